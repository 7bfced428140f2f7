//! The current result: taken by an instruction, converted, kept in a hidden variable where it
//! must survive, joined at labels.

use petriplc_iec_syntax::ast::{self, IlCond};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::Checker;
use crate::expr::err;
use crate::ir::{Expr, ExprKind, Place, Root, Stmt, StmtKind, UnaryOp, Var, VarId};
use crate::types::{ids, Type, TypeId};
use crate::value::Value;

use super::{cond_name, load, reads, var_place, Cr, Il, FOLD_DEPTH};

impl Checker<'_> {
    /// The current result for an instruction that needs it (reported when there is none).
    pub(super) fn il_take(&mut self, il: &mut Il<'_>, what: &str, span: Span) -> Option<Expr> {
        self.il_take_as(il, what, span, None)
    }

    /// The current result, typed as `expected` when it is still a literal function.
    pub(super) fn il_take_as(
        &mut self,
        il: &mut Il<'_>,
        what: &str,
        span: Span,
        expected: Option<TypeId>,
    ) -> Option<Expr> {
        match &il.cr {
            Cr::Value(x) => Some(x.clone()),
            Cr::Pending(e) => {
                let e = e.clone();
                Some(self.expr(&e, il.cx, expected))
            }
            Cr::None(why) => {
                let why = *why;
                self.error(
                    diag::IL_NO_RESULT,
                    span,
                    format!("{what} needs the current result, but there is none here ({why}); load one first: LD x"),
                );
                // One report per missing value.
                il.cr = Cr::Value(err(span));
                None
            }
        }
    }

    /// The current result as a BOOL condition.
    pub(super) fn il_bool(&mut self, il: &mut Il<'_>, what: &str, span: Span) -> Option<Expr> {
        let x = self.il_take(il, what, span)?;
        if x.ty == ids::ERROR {
            return None;
        }
        if x.ty != ids::BOOL {
            let t = self.types.name(x.ty);
            self.error(
                diag::NOT_BOOL,
                span,
                format!(
                    "{what} needs a BOOL current result, not {t}; compare it first (e.g. GT 0)"
                ),
            );
            return None;
        }
        Some(x)
    }

    /// `NOT x` on BOOL and bit strings.
    pub(super) fn il_not(&mut self, x: Expr, span: Span) -> Expr {
        if x.ty == ids::ERROR {
            return x;
        }
        let ok = self.types.elem(x.ty).is_some_and(|e| e.is_bit());
        if !ok {
            let t = self.types.name(x.ty);
            let hint = if x.ty == ids::INT_LIT {
                " (give the literal a type: WORD#16#0F)"
            } else {
                ""
            };
            self.error(
                diag::OPERAND_TYPE,
                span,
                format!("NOT and the N modifier apply to BOOL and bit strings, not {t}{hint}"),
            );
            return err(span);
        }
        let ty = self.base_type(x.ty);
        self.fold(Expr {
            kind: ExprKind::Unary(UnaryOp::Not, Box::new(x)),
            ty,
            span,
        })
    }

    /// Runs `body` always, when the current result is TRUE (`C`) or FALSE (`CN`).
    pub(super) fn il_conditional(
        &mut self,
        il: &mut Il<'_>,
        cond: IlCond,
        base: &str,
        span: Span,
        body: impl FnOnce(&mut Self, &mut Il<'_>) -> Vec<Stmt>,
    ) {
        let Some(flag) = cond else {
            let b = body(self, il);
            il.out.extend(b);
            return;
        };
        let name = cond_name(base, cond);
        let Some(c) = self.il_bool(il, &name, span) else {
            return;
        };
        let c = if flag {
            c
        } else {
            Expr {
                kind: ExprKind::Unary(UnaryOp::Not, Box::new(c)),
                ty: ids::BOOL,
                span,
            }
        };
        let b = body(self, il);
        il.out.push(Stmt {
            kind: StmtKind::If {
                branches: vec![(c, b)],
                else_body: Vec::new(),
            },
            span,
        });
    }

    /// Before a store into `root` (or a call, `None`: anything may change), holds the current
    /// results saved by open `OP(` that read what changes, so they keep their values.
    pub(super) fn il_protect(&mut self, il: &mut Il<'_>, root: Option<Root>, span: Span) {
        for i in 0..il.open.len() {
            let Cr::Value(e) = &il.open[i].saved else {
                continue;
            };
            if matches!(e.kind, ExprKind::Const(_)) {
                continue;
            }
            let mut r = Vec::new();
            let pure = reads(e, &mut r);
            if !pure || root.is_none_or(|x| r.contains(&x)) {
                let e = e.clone();
                let held = self.il_materialise(il, e, span);
                il.open[i].saved = Cr::Value(held);
            }
        }
    }

    /// A current result just folded, stored in a hidden variable when it has grown deeper than
    /// [`FOLD_DEPTH`].
    pub(super) fn il_bounded(&mut self, il: &mut Il<'_>, x: Expr, span: Span) -> Expr {
        if x.depth() > FOLD_DEPTH {
            self.il_materialise(il, x, span)
        } else {
            x
        }
    }

    /// A new hidden variable of the POU.
    fn il_var(&mut self, il: &mut Il<'_>, ty: TypeId, span: Span) -> VarId {
        let id = il.cx.vars.len() as VarId;
        let name = format!("$il{id}");
        il.cx.vars.push(Var::hidden(name.clone(), ty, span));
        // Reachable by name from the syntax trees this front end builds (`$` starts no
        // identifier a source can spell).
        il.cx.names.insert(name.to_ascii_uppercase(), id);
        id
    }

    /// Stores the current result in a hidden variable; returns the load of it.
    pub(super) fn il_materialise(&mut self, il: &mut Il<'_>, x: Expr, span: Span) -> Expr {
        if x.ty == ids::ERROR || matches!(x.kind, ExprKind::Const(_)) {
            return x;
        }
        let ty = self.settle_type(x.ty, None);
        let x = self.coerce(x, ty, "the current result");
        let v = self.il_var(il, ty, span);
        let p = var_place(v, ty, span);
        il.out.push(Stmt {
            kind: StmtKind::Assign {
                target: p.clone(),
                value: x,
            },
            span,
        });
        load(p)
    }

    /// Stores the current result for a label whose code uses it.
    pub(super) fn il_join(&mut self, il: &mut Il<'_>, key: &str, x: Expr, span: Span) {
        if x.ty == ids::ERROR {
            if let Some(l) = il.labels.get_mut(key) {
                l.poisoned = true;
            }
            return;
        }
        let var = match il.labels.get(key).and_then(|l| l.var) {
            Some(v) => v,
            None => {
                let target = il.labels.get(key).and_then(|l| l.target.clone());
                let wanted = match target {
                    Some(t) if x.ty == ids::INT_LIT || x.ty == ids::REAL_LIT => {
                        let mut quiet = std::mem::take(&mut self.diags);
                        let p = self.place(&t, il.cx, false);
                        std::mem::swap(&mut quiet, &mut self.diags);
                        p.map(|p| p.ty)
                            .filter(|t| self.types.elem(*t).is_some_and(|e| e.is_num()))
                    }
                    _ => None,
                };
                let ty = self.settle_type(x.ty, wanted);
                let v = self.il_var(il, ty, span);
                if let Some(l) = il.labels.get_mut(key) {
                    l.var = Some(v);
                }
                v
            }
        };
        let ty = il.cx.vars[var as usize].ty;
        let x = self.coerce(x, ty, "the current result carried to the label");
        if x.ty == ids::ERROR {
            return;
        }
        il.out.push(Stmt {
            kind: StmtKind::Assign {
                target: var_place(var, ty, span),
                value: x,
            },
            span,
        });
    }

    /// The current result as a syntax tree (for calls checked from syntax): a literal or a
    /// variable's name as they are, anything else through a hidden variable.
    pub(super) fn il_as_ast(&mut self, il: &mut Il<'_>, x: Expr, span: Span) -> ast::Expr {
        if x.ty == ids::ERROR {
            return ast::Expr {
                kind: ast::ExprKind::Error,
                span,
            };
        }
        let lit = match (&x.kind, self.types.get(x.ty)) {
            (ExprKind::Const(Value::Int(v)), Type::IntLit) => Some(ast::Literal::Int {
                value: *v,
                ty: None,
            }),
            (ExprKind::Const(Value::Real(v)), Type::RealLit) => Some(ast::Literal::Real {
                value: *v,
                ty: None,
            }),
            (ExprKind::Const(Value::Int(v)), _) if x.ty == ids::BOOL => Some(ast::Literal::Bool {
                value: *v != 0,
                ty: None,
            }),
            _ => None,
        };
        if let Some(l) = lit {
            return ast::Expr {
                kind: ast::ExprKind::Literal(l),
                span,
            };
        }
        let held = match &x.kind {
            ExprKind::Load(p) if p.path.is_empty() && matches!(p.root, Root::Var(_)) => x,
            ExprKind::Const(_) => {
                // A typed constant (BYTE#1): held like any other value.
                let v = self.il_var(il, x.ty, span);
                let p = var_place(v, x.ty, span);
                il.out.push(Stmt {
                    kind: StmtKind::Assign {
                        target: p.clone(),
                        value: x,
                    },
                    span,
                });
                load(p)
            }
            _ => self.il_materialise(il, x, span),
        };
        let ExprKind::Load(Place {
            root: Root::Var(v), ..
        }) = held.kind
        else {
            return ast::Expr {
                kind: ast::ExprKind::Error,
                span,
            };
        };
        let name = il.cx.vars[v as usize].name.clone();
        il.cx.names.entry(name.to_ascii_uppercase()).or_insert(v);
        ast::Expr {
            kind: ast::ExprKind::Name(ast::Ident::new(name, span)),
            span,
        }
    }
}
