//! Calls of vendor library functions (`crate::vendor`): typed when their library is loaded,
//! refused naming the library otherwise (E180), so that a CODESYS or PCWorx program says
//! what to load instead of "unknown function".

use petriplc_iec_syntax::ast::{self, BinaryOp};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Builtin, Expr, ExprKind};
use crate::types::{ids, Elem, Type, TypeTable};
use crate::value::Value;
use crate::vendor;

use super::err;

impl<'a> Checker<'a> {
    /// Whether `lib`'s functions may be called; if not, E180 at `span` naming it.
    fn vendor_loaded(&mut self, what: &str, lib: &str, span: Span) -> bool {
        if vendor::provides(&self.libs, lib) {
            return true;
        }
        self.error(
            diag::VENDOR_NOT_LOADED,
            span,
            format!(
                "{what} is a {} function: add --lib {lib} (`libs = {lib}` on `module NAME iec`), or declare a FUNCTION of that name",
                vendor::title(lib)
            ),
        );
        false
    }

    /// A call of a vendor function, or `None` when `name` is not one.
    pub(super) fn vendor_call(
        &mut self,
        name: &ast::Ident,
        call: &ast::Call,
        cx: &mut Cx,
    ) -> Option<Expr> {
        let key = name.key();
        let lib = vendor::provider(&key)?;
        let span = call.span;
        if !self.vendor_loaded(&key, lib, name.span) {
            return Some(err(span));
        }
        Some(match key.as_str() {
            "TIME" => {
                if let Some(a) = call.args.first() {
                    self.error(
                        diag::BAD_ARGUMENTS,
                        a.span,
                        "TIME() takes no argument: it gives the time since the PLC started",
                    );
                    return Some(err(span));
                }
                Expr {
                    kind: ExprKind::Builtin(Builtin::Time, Vec::new()),
                    ty: TypeTable::elem_id(Elem::Time),
                    span,
                }
            }
            "GET_CHAR" => self.get_char(call, cx),
            "F_TOASC" => {
                // TwinCAT's Tc2_System: the first character's code, 0 for ''.
                let Some(args) = self.std_args("F_ToASC", call, &["STR"], 1, false) else {
                    return Some(err(span));
                };
                let s = self.expr(args[0].expr, cx, Some(ids::STRING));
                if s.ty == ids::ERROR {
                    return Some(err(span));
                }
                if !matches!(self.types.get(s.ty), Type::Str { wide: false, .. }) {
                    let t = self.types.name(s.ty);
                    self.error(
                        diag::TYPE_MISMATCH,
                        args[0].span,
                        format!("F_ToASC reads a STRING, not {t}"),
                    );
                    return Some(err(span));
                }
                let first = Expr {
                    kind: ExprKind::Const(Value::Int(1)),
                    ty: ids::DINT,
                    span,
                };
                Expr {
                    kind: ExprKind::Builtin(Builtin::GetChar, vec![s, first]),
                    ty: ids::BYTE,
                    span,
                }
            }
            "F_TOCHR" => {
                let Some(args) = self.std_args("F_ToCHR", call, &["C"], 1, false) else {
                    return Some(err(span));
                };
                let c = self.expr(args[0].expr, cx, Some(ids::BYTE));
                let c = self.coerce(c, ids::BYTE, "F_ToCHR's code");
                if c.ty == ids::ERROR {
                    return Some(err(span));
                }
                Expr {
                    kind: ExprKind::Builtin(Builtin::Chr, vec![c]),
                    ty: ids::STRING,
                    span,
                }
            }
            "MUL_T_AI" | "DIV_T_AI" => {
                let op = if key == "MUL_T_AI" {
                    BinaryOp::Mul
                } else {
                    BinaryOp::Div
                };
                let Some(args) = self.std_args(&key, call, &["IN1", "IN2"], 2, false) else {
                    return Some(err(span));
                };
                let t = self.expr(args[0].expr, cx, Some(TypeTable::elem_id(Elem::Time)));
                let n = self.expr(args[1].expr, cx, Some(ids::DINT));
                if t.ty == ids::ERROR || n.ty == ids::ERROR {
                    return Some(err(span));
                }
                let int = n.ty == ids::INT_LIT || self.types.elem(n.ty).is_some_and(|e| e.is_int());
                if self.types.elem(t.ty) != Some(Elem::Time) || !int {
                    let (a, b) = (self.types.name(t.ty), self.types.name(n.ty));
                    self.error(
                        diag::TYPE_MISMATCH,
                        span,
                        format!("{key} takes a TIME and an integer, not {a} and {b}"),
                    );
                    return Some(err(span));
                }
                let mut x = self.binary_checked(op, t, n, span);
                x.span = span;
                x
            }
            _ => return None,
        })
    }

    /// PCWorx `GET_CHAR(string, position)`: the code of the character at `position` (1 is
    /// the first) as INT; 0 past either end.
    fn get_char(&mut self, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let Some(args) = self.std_args("GET_CHAR", call, &["STR", "POS"], 2, false) else {
            return err(span);
        };
        let s = self.expr(args[0].expr, cx, Some(ids::STRING));
        let p = self.expr(args[1].expr, cx, Some(ids::DINT));
        if s.ty == ids::ERROR || p.ty == ids::ERROR {
            return err(span);
        }
        if !matches!(self.types.get(s.ty), Type::Str { wide: false, .. }) {
            let t = self.types.name(s.ty);
            self.error(
                diag::TYPE_MISMATCH,
                args[0].span,
                format!("GET_CHAR reads a STRING, not {t}"),
            );
            return err(span);
        }
        let p = if p.ty == ids::INT_LIT {
            self.coerce(p, ids::DINT, "GET_CHAR's position")
        } else {
            p
        };
        if !self.types.elem(p.ty).is_some_and(|e| e.is_int()) {
            let t = self.types.name(p.ty);
            self.error(
                diag::TYPE_MISMATCH,
                args[1].span,
                format!("GET_CHAR's position is an integer, not {t}"),
            );
            return err(span);
        }
        Expr {
            kind: ExprKind::Builtin(Builtin::GetChar, vec![s, p]),
            ty: ids::INT,
            span,
        }
    }

    /// PCWorx `X_TO_STRING(value, format)` (two arguments; one is the standard's
    /// conversion): `None` when this is not that form, so the standard one checks it.
    pub(super) fn vendor_format(
        &mut self,
        name: &ast::Ident,
        call: &ast::Call,
        cx: &mut Cx,
        from: Option<&str>,
        to: &str,
    ) -> Option<Expr> {
        if to != "STRING" || call.args.len() != 2 {
            return None;
        }
        let from_ty = match from {
            Some(f) => Some(TypeTable::elem_id(Elem::from_name(f)?)),
            None => None,
        };
        let span = call.span;
        let what = format!("{}(value, format)", name.name);
        // `__FORMAT(value, format)`: the same, for the vendor libraries' own ST (twincat's
        // FB_FormatString), in every dialect.
        if !name.is("__FORMAT") && !self.vendor_loaded(&what, "pcworx", name.span) {
            return Some(err(span));
        }
        let f = name.key();
        let args = match self.std_args(&f, call, &["IN", "FORMAT"], 2, false) {
            Some(a) => a,
            None => return Some(err(span)),
        };
        let x = self.expr(args[0].expr, cx, from_ty);
        let fmt = self.expr(args[1].expr, cx, Some(ids::STRING));
        if x.ty == ids::ERROR || fmt.ty == ids::ERROR {
            return Some(err(span));
        }
        let x = match (from_ty, self.types.get(x.ty)) {
            (Some(ft), _) => {
                if self.base_type(x.ty) != ft
                    && !matches!(self.types.get(x.ty), Type::IntLit | Type::RealLit)
                    && !self.assignable(x.ty, ft)
                {
                    let (a, b) = (self.types.name(x.ty), self.types.name(ft));
                    self.error(
                        diag::TYPE_MISMATCH,
                        args[0].span,
                        format!("{} converts {b}, and this argument is {a}", name.name),
                    );
                    return Some(err(span));
                }
                self.coerce(x, ft, &format!("the argument of {}", name.name))
            }
            (None, Type::IntLit) => self.coerce(x, ids::LINT, "the argument"),
            (None, Type::RealLit) => self.coerce(x, ids::LREAL, "the argument"),
            _ => x,
        };
        if x.ty == ids::ERROR {
            return Some(err(span));
        }
        if self.types.elem(x.ty).is_none() && !matches!(self.types.get(x.ty), Type::Enum { .. }) {
            let t = self.types.name(x.ty);
            self.error(
                diag::VENDOR_ARGUMENT,
                args[0].span,
                format!("{what} writes an elementary value, not {t}"),
            );
            return Some(err(span));
        }
        if !matches!(self.types.get(fmt.ty), Type::Str { wide: false, .. }) {
            let t = self.types.name(fmt.ty);
            self.error(
                diag::VENDOR_ARGUMENT,
                args[1].span,
                format!(
                    "the format of {what} is a STRING (a C printf format such as '%02X'), not {t}"
                ),
            );
            return Some(err(span));
        }
        Some(Expr {
            kind: ExprKind::Builtin(Builtin::Format, vec![x, fmt]),
            ty: ids::STRING,
            span,
        })
    }
}
