//! TwinCAT's and CODESYS's dynamic memory: `__NEW(T)`, `__NEW(T, n)`,
//! `__NEW(POINTER TO T, n)`, `__DELETE(p)` (with the block's `FB_exit`), and Tc2_System's
//! `F_CheckMemoryArea` (docs/iec.md, "Dynamic memory"). The objects live in the engine's
//! checked heap: a pointer to a deleted object is a fault when it is used, never a read of
//! another object.

use petriplc_iec_syntax::ast::{self, BinaryOp, ExprKind as A, RefKind, VarKind};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Builtin, Expr, ExprKind, Stmt, StmtKind};
use crate::types::{ids, FbRef, Type, TypeId};

use super::err;

/// The name the parser gives `POINTER TO` in `__NEW(POINTER TO T, n)`.
const POINTER_TO: &str = "POINTER TO";

impl<'a> Checker<'a> {
    /// `__NEW(T)` (one value) or `__NEW(T, n)` (an array of `n`): a POINTER TO T designating
    /// a new object holding T's initial value, or 0 when the dynamic memory is full.
    pub(super) fn heap_new(&mut self, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let usage = "__NEW takes a type and, for an array, a count: __NEW(T), __NEW(T, n) or __NEW(POINTER TO T, n)";
        let args: Vec<&ast::Expr> = call
            .args
            .iter()
            .filter(|a| a.name.is_none() && !a.output)
            .filter_map(|a| a.value.as_ref())
            .collect();
        if args.is_empty() || args.len() > 2 || args.len() != call.args.len() {
            self.error(diag::BAD_ARGUMENTS, span, usage);
            return err(span);
        }
        let Some(ty) = self.new_type(args[0]) else {
            return err(span);
        };
        let mut xs = Vec::new();
        if let Some(n) = args.get(1) {
            let x = self.expr(n, cx, Some(ids::UDINT));
            if x.ty == ids::ERROR {
                return err(span);
            }
            if !self.is_integral(x.ty) {
                let t = self.types.name(x.ty);
                self.error(
                    diag::TYPE_MISMATCH,
                    n.span,
                    format!("__NEW: the count of an array is an integer; this is {t}"),
                );
                return err(span);
            }
            xs.push(self.convert(x, ids::UDINT));
        }
        Expr {
            kind: ExprKind::Builtin(Builtin::New, xs),
            ty: self.types.reference(RefKind::PointerTo, ty),
            span,
        }
    }

    /// The type `__NEW` makes a value of, from its first argument (reported when it is none).
    fn new_type(&mut self, e: &ast::Expr) -> Option<TypeId> {
        let ty = match &e.kind {
            A::Name(id) => self.type_by_name(id).0,
            A::Call(c) => match (&c.callee.kind, c.args.as_slice()) {
                (A::Name(n), [a]) if n.name == POINTER_TO && a.value.is_some() => {
                    let inner = self.new_type(a.value.as_ref()?)?;
                    return Some(self.types.reference(RefKind::PointerTo, inner));
                }
                (A::Name(n), _) if n.name.ends_with(" TO") => {
                    self.error(
                        diag::BAD_ARGUMENTS,
                        e.span,
                        "__NEW makes values and pointers, not references: __NEW(POINTER TO T, n)",
                    );
                    return None;
                }
                _ => {
                    self.error(
                        diag::BAD_ARGUMENTS,
                        e.span,
                        "__NEW(T(…)) passes arguments to FB_init, which petriplc does only on the right of an assignment: write `p := __NEW(T(…));`",
                    );
                    return None;
                }
            },
            _ => {
                self.error(
                    diag::BAD_ARGUMENTS,
                    e.span,
                    "__NEW takes a type's name: __NEW(T), __NEW(T, n)",
                );
                return None;
            }
        };
        if ty == ids::ERROR {
            return None;
        }
        if matches!(
            self.types.get(ty),
            Type::Ref {
                kind: RefKind::Interface,
                ..
            }
        ) {
            self.error(
                diag::BAD_ARGUMENTS,
                e.span,
                "__NEW makes an instance of a FUNCTION_BLOCK, not of an INTERFACE: __NEW(FB_Impl), then give the pointer's target to the interface variable",
            );
            return None;
        }
        if self.types.is_var_array(ty) {
            self.error(
                diag::BAD_ARGUMENTS,
                e.span,
                "__NEW needs a size: ARRAY[*] has none; give the count, __NEW(T, n)",
            );
            return None;
        }
        Some(ty)
    }

    /// `__DELETE(p);`: the block's FB_exit when the object is a function block instance,
    /// then the object freed and `p` set to 0 (nothing at all when `p` is 0).
    pub(crate) fn delete_stmt(&mut self, call: &ast::Call, cx: &mut Cx) -> Option<Stmt> {
        let span = call.span;
        let arg = self.sole_argument(call, "__DELETE takes the pointer __NEW gave: __DELETE(p)")?;
        let mut x = self.expr(arg, cx, None);
        if x.ty == ids::ERROR {
            return None;
        }
        // `__DELETE(THIS)`: the instance's own address (never NULL).
        let this = matches!(&arg.kind, A::Name(n) if n.is("THIS"))
            && matches!(self.types.get(x.ty), Type::Fb(_));
        if this {
            let ptr = self.types.reference(RefKind::PointerTo, x.ty);
            x = self.expr(arg, cx, Some(ptr));
        }
        let target = match self.types.get(x.ty) {
            Type::Ref {
                kind: RefKind::PointerTo,
                target,
            } => *target,
            _ => {
                let t = self.types.name(x.ty);
                self.error(
                    diag::TYPE_MISMATCH,
                    arg.span,
                    format!("__DELETE takes a POINTER TO the object __NEW made; this is {t}"),
                );
                return None;
            }
        };
        let mut body = Vec::new();
        if let Type::Fb(FbRef::User(fb)) = *self.types.get(target) {
            if let Some(exit) = self.fb_exit_call(fb, arg, span, cx) {
                body.push(exit);
            }
        }
        body.push(Stmt {
            kind: StmtKind::Eval(Expr {
                kind: ExprKind::Builtin(Builtin::Free, vec![x]),
                ty: ids::VOID,
                span,
            }),
            span,
        });
        // Nothing happens to NULL (THIS never is).
        let cond = if this {
            super::konst(crate::value::Value::Int(1), ids::BOOL, span)
        } else {
            self.expr(&not_null(arg, span), cx, Some(ids::BOOL))
        };
        if cond.ty == ids::ERROR {
            return None;
        }
        Some(Stmt {
            kind: StmtKind::If {
                branches: vec![(cond, body)],
                else_body: Vec::new(),
            },
            span,
        })
    }

    /// `p^.FB_exit(bInCopyCode := FALSE);` when block `fb` has an FB_exit method.
    fn fb_exit_call(
        &mut self,
        fb: crate::ir::PouId,
        p: &ast::Expr,
        span: Span,
        cx: &mut Cx,
    ) -> Option<Stmt> {
        let m = *self.oop.methods.get(&(fb, "FB_EXIT".to_string()))?;
        let takes_flag = self.blocks_of(m).iter().any(|b| {
            b.kind == VarKind::Input
                && b.vars
                    .iter()
                    .any(|d| d.names.iter().any(|n| n.is("bInCopyCode")))
        });
        let ident = |name: &str| ast::Ident {
            name: name.into(),
            span,
        };
        let args = if takes_flag {
            vec![ast::Arg {
                name: Some(ident("bInCopyCode")),
                output: false,
                negated: false,
                value: Some(ast::Expr {
                    kind: A::Literal(ast::Literal::Bool {
                        value: false,
                        ty: None,
                    }),
                    span,
                }),
                span,
            }]
        } else {
            Vec::new()
        };
        let call = ast::Call {
            callee: Box::new(ast::Expr {
                kind: A::Field(
                    Box::new(ast::Expr {
                        kind: A::Deref(Box::new(p.clone())),
                        span,
                    }),
                    ident("FB_exit"),
                ),
                span,
            }),
            args,
            span,
        };
        self.call_stmt(&call, cx)
    }

    /// TwinCAT's `F_CheckMemoryArea(pData, nSize)`: E_TcMemoryArea's Unknown (0, NULL or a
    /// deleted object), Static (1) or Dynamic (2, an object of `__NEW`), as a UDINT.
    pub(super) fn memory_area(&mut self, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let Some(arg) = self.sole_argument(call, "__MEMORYAREA takes a pointer: __MEMORYAREA(p)")
        else {
            return err(span);
        };
        let x = self.expr(arg, cx, None);
        if x.ty == ids::ERROR {
            return err(span);
        }
        if !matches!(
            self.types.get(x.ty),
            Type::Ref {
                kind: RefKind::PointerTo,
                ..
            }
        ) {
            let t = self.types.name(x.ty);
            self.error(
                diag::TYPE_MISMATCH,
                arg.span,
                format!("__MEMORYAREA takes a POINTER TO; this is {t}"),
            );
            return err(span);
        }
        Expr {
            kind: ExprKind::Builtin(Builtin::MemArea, vec![x]),
            ty: ids::UDINT,
            span,
        }
    }
}

/// `p <> 0`.
fn not_null(p: &ast::Expr, span: Span) -> ast::Expr {
    ast::Expr {
        kind: A::Binary(
            BinaryOp::Ne,
            Box::new(p.clone()),
            Box::new(ast::Expr {
                kind: A::Literal(ast::Literal::Int { value: 0, ty: None }),
                span,
            }),
        ),
        span,
    }
}
