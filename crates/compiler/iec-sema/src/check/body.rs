//! POU bodies: statements checked and lowered, edge-triggered inputs prepended.

use petriplc_iec_syntax::ast;
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::ir::{self, PouId, VarClass, VarId};
use crate::types::ids;

use super::{Checker, Cx};

impl<'a> Checker<'a> {
    pub(super) fn body(&mut self, p: PouId) {
        if self.itf_dispatch(p) || self.query_body(p) {
            return;
        }
        let ast = self.pou_asts[p as usize];
        let this = self.this_of(p);
        // A member is FUNCTION-like whatever its syntax tree (an action's is its block's).
        let kind = self.pous[p as usize].kind;
        match self.body_of(p) {
            ast::Body::St(stmts) => {
                let mut cx = Cx::global();
                cx.pou = Some(p);
                cx.kind = Some(kind);
                cx.this = this;
                cx.vars = self.pous[p as usize].vars.clone();
                cx.names = cx
                    .vars
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.class != VarClass::Hidden)
                    .map(|(i, v)| (v.name.to_ascii_uppercase(), i as VarId))
                    .collect();
                let mut body = self.en_prologue(p, ast.name.span);
                body.extend(self.edge_prologue(p, ast.name.span));
                body.extend(self.any_prologue(p, ast.name.span));
                body.extend(self.stmts(stmts, &mut cx));
                // Results of calls given EN inside an expression are variables of the POU.
                self.pous[p as usize].vars = cx.vars;
                self.escape_todo.push((p, kind));
                self.pous[p as usize].body = body;
            }
            ast::Body::Il { code, .. } => {
                let mut cx = Cx::global();
                cx.pou = Some(p);
                cx.kind = Some(kind);
                cx.this = this;
                cx.vars = self.pous[p as usize].vars.clone();
                cx.names = cx
                    .vars
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.class != VarClass::Hidden)
                    .map(|(i, v)| (v.name.to_ascii_uppercase(), i as VarId))
                    .collect();
                let mut body = self.en_prologue(p, ast.name.span);
                body.extend(self.edge_prologue(p, ast.name.span));
                body.extend(self.any_prologue(p, ast.name.span));
                body.extend(self.il_body(code, &mut cx));
                // The accumulator's temporaries are variables of the POU.
                self.pous[p as usize].vars = cx.vars;
                self.escape_todo.push((p, kind));
                self.pous[p as usize].body = body;
            }
            ast::Body::Graphical { language, span, .. } => {
                self.diags.warning(
                    diag::NOT_CHECKED,
                    *span,
                    format!("{} {} is written in {}, which the engine does not run yet; it cannot be called or instantiated", ast.kind.keyword(), ast.name.name, language.name()),
                );
            }
            ast::Body::Missing(span) => {
                self.error(
                    diag::PLCOPEN_STRUCTURE,
                    *span,
                    format!("{} {} has no body", ast.kind.keyword(), ast.name.name),
                );
            }
        }
    }

    /// For every R_EDGE input: `x$raw := x; x := x AND NOT x$prev; x$prev := x$raw;`
    /// (F_EDGE: `NOT x AND x$prev`).
    fn edge_prologue(&mut self, p: PouId, span: Span) -> Vec<ir::Stmt> {
        let edges = self.edges.get(&p).cloned().unwrap_or_default();
        let mut out = Vec::new();
        let vars = &self.pous[p as usize].vars;
        let find = |n: String| vars.iter().position(|x| x.name == n);
        for (v, edge) in edges {
            let base = &vars[v as usize].name;
            let (Some(prev), Some(raw)) =
                (find(format!("{base}$prev")), find(format!("{base}$raw")))
            else {
                continue;
            };
            let place = |id: usize| ir::Place {
                root: ir::Root::Var(id as VarId),
                path: Vec::new(),
                ty: ids::BOOL,
                span,
            };
            let load = |id: usize| ir::Expr {
                kind: ir::ExprKind::Load(place(id)),
                ty: ids::BOOL,
                span,
            };
            let not = |e: ir::Expr| ir::Expr {
                kind: ir::ExprKind::Unary(ir::UnaryOp::Not, Box::new(e)),
                ty: ids::BOOL,
                span,
            };
            let and = |a: ir::Expr, b: ir::Expr| ir::Expr {
                kind: ir::ExprKind::Binary(ir::BinaryOp::And, Box::new(a), Box::new(b)),
                ty: ids::BOOL,
                span,
            };
            let assign = |target: usize, value: ir::Expr| ir::Stmt {
                kind: ir::StmtKind::Assign {
                    target: place(target),
                    value,
                },
                span,
            };
            let v = v as usize;
            out.push(assign(raw, load(v)));
            let edge_value = match edge {
                ast::Edge::Rising => and(load(v), not(load(prev))),
                ast::Edge::Falling => and(not(load(v)), load(prev)),
            };
            out.push(assign(v, edge_value));
            out.push(assign(prev, load(raw)));
        }
        out
    }
}
