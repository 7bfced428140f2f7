//! CODESYS's and TwinCAT's `__QUERYINTERFACE(source, dest)` (docs/iec.md, "Interfaces";
//! `__ISVALIDREF`, in expr/reference.rs, takes an interface too). The query is a FUNCTION the checker writes per destination
//! interface (`__QUERYINTERFACE I_X`): its source an input (an interface's handle, or an
//! instance's), its destination an in-out; a CASE over the source's block type sets the
//! destination and returns TRUE for every block implementing I_X, else sets it to 0 and
//! returns FALSE.

use petriplc_iec_syntax::ast::{self, PouKind};
use petriplc_iec_syntax::diag;

use crate::check::{Checker, Cx, Shape, State};
use crate::expr::err;
use crate::ir::{
    self, Builtin, CaseArm, Expr, ExprKind, FnCall, Place, PouId, Root, Stmt, StmtKind, Var,
    VarClass,
};
use crate::types::{ids, FbRef, Type};
use crate::value::Value;

impl<'a> Checker<'a> {
    /// After the members are collected: the query function of every interface.
    pub(crate) fn collect_queries(&mut self) {
        for itf in 0..self.pou_asts.len() as PouId {
            if !self.is_interface(itf) {
                continue;
            }
            let ast = self.pou_asts[itf as usize];
            let span = ast.name.span;
            let ty = self.itf_type(itf);
            let var = |name: &str, ty, class| Var {
                name: name.into(),
                ty,
                class,
                init: None,
                constant: false,
                retain: false,
                location: None,
                span,
            };
            let id = self.pou_asts.len() as PouId;
            self.pou_asts.push(ast);
            self.pous.push(ir::Pou {
                name: format!("__QUERYINTERFACE {}", ast.name.name),
                kind: PouKind::Function,
                vars: vec![
                    var("__QUERYINTERFACE", ids::BOOL, VarClass::Result),
                    var("SOURCE", ty, VarClass::Input),
                    var("DEST", ty, VarClass::InOut),
                ],
                result: Some(0),
                body: Vec::new(),
                span,
                runnable: true,
            });
            self.pou_state.push(State::Done);
            self.fb_shapes.push(Shape { depth: 0, slots: 3 });
            self.oop.queries.insert(itf, id);
            self.oop.query_of.insert(id, itf);
        }
    }

    /// The body of a query function (`true`); `false` for any other POU.
    pub(crate) fn query_body(&mut self, p: PouId) -> bool {
        let Some(&itf) = self.oop.query_of.get(&p) else {
            return false;
        };
        let span = self.pous[p as usize].span;
        let ty = self.itf_type(itf);
        let place = |v: u32, ty| Place {
            root: Root::Var(v),
            path: Vec::new(),
            ty,
            span,
        };
        let konst = |v: Value, ty| Expr {
            kind: ExprKind::Const(v),
            ty,
            span,
        };
        let source = Expr {
            kind: ExprKind::Load(place(1, ty)),
            ty,
            span,
        };
        let set = |value: Expr, ok: bool| {
            vec![
                Stmt {
                    kind: StmtKind::Assign {
                        target: place(2, ty),
                        value,
                    },
                    span,
                },
                Stmt {
                    kind: StmtKind::Assign {
                        target: place(0, ids::BOOL),
                        value: konst(Value::Int(i128::from(ok)), ids::BOOL),
                    },
                    span,
                },
            ]
        };
        let mut arms = Vec::new();
        for k in self.implementers(itf) {
            let tid = i128::from(self.types.fb(FbRef::User(k)));
            arms.push(CaseArm {
                ranges: vec![(tid, tid)],
                body: set(source.clone(), true),
            });
        }
        let selector = Expr {
            kind: ExprKind::Builtin(Builtin::ItfType, vec![source.clone()]),
            ty: ids::DINT,
            span,
        };
        self.pous[p as usize].body = vec![Stmt {
            kind: StmtKind::Case {
                selector,
                arms,
                else_body: set(konst(Value::Int(0), ty), false),
            },
            span,
        }];
        true
    }

    /// `__QUERYINTERFACE(source, dest)`: BOOL, `dest` set to the source's instance as
    /// `dest`'s interface when the instance implements it, else to 0.
    pub(crate) fn query_interface(&mut self, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let args: Vec<&ast::Expr> = call
            .args
            .iter()
            .filter(|a| a.name.is_none() && !a.output)
            .filter_map(|a| a.value.as_ref())
            .collect();
        let [src, dest] = args[..] else {
            self.error(
                diag::BAD_ARGUMENTS,
                span,
                "__QUERYINTERFACE takes two operands: __QUERYINTERFACE(source, dest), the source an interface or a function block instance, dest an interface variable",
            );
            return err(span);
        };
        let Some(dplace) = self.place(dest, cx, true) else {
            return err(span);
        };
        let Some(itf) = self.itf_of_type(dplace.ty) else {
            if dplace.ty != ids::ERROR {
                let t = self.types.name(dplace.ty);
                self.error(
                    diag::ITF_MISUSE,
                    dest.span,
                    format!("the second operand of __QUERYINTERFACE is an interface variable, the one to set; this is {t}"),
                );
            }
            return err(span);
        };
        if !self.writable(&dplace, cx, dest.span) {
            return err(span);
        }
        let dty = dplace.ty;
        let x = self.expr(src, cx, None);
        let source = match (self.types.get(x.ty), &x.kind) {
            (Type::Fb(FbRef::User(_)), ExprKind::Load(p)) => Expr {
                kind: ExprKind::Ref(p.clone()),
                ty: dty,
                span: x.span,
            },
            _ if self.itf_of_type(x.ty).is_some() => Expr { ty: dty, ..x },
            _ => {
                if x.ty != ids::ERROR {
                    let t = self.types.name(x.ty);
                    self.error(
                        diag::ITF_MISUSE,
                        src.span,
                        format!("the first operand of __QUERYINTERFACE is an interface or an instance of a FUNCTION_BLOCK; this is {t}"),
                    );
                }
                return err(span);
            }
        };
        let q = self.oop.queries[&itf];
        Expr {
            kind: ExprKind::Call(FnCall {
                pou: q,
                inputs: vec![(1, source)],
                in_outs: vec![(2, dplace)],
                outputs: Vec::new(),
            }),
            ty: ids::BOOL,
            span,
        }
    }
}
