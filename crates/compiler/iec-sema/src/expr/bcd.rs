//! The BCD conversions of the standard (`WORD_BCD_TO_INT`, `BCD_TO_INT`, `INT_TO_BCD_WORD`,
//! `INT_TO_BCD`): bit strings holding decimal digits, four bits each, and integers.

use petriplc_iec_syntax::ast;
use petriplc_iec_syntax::diag;

use crate::check::{Checker, Cx};
use crate::ir::{Builtin, Expr, ExprKind};
use crate::stdlib::BcdName;
use crate::types::{ids, Elem, Type, TypeId, TypeTable};

use super::err;

impl<'a> Checker<'a> {
    /// A BCD conversion: decoding takes a bit string and gives the named integer type;
    /// encoding takes an integer and gives the named bit string, or, unnamed, the one the
    /// context wants, else the one as wide as the integer (INT → WORD, as matiec pairs them).
    pub(super) fn bcd(
        &mut self,
        name: &ast::Ident,
        call: &ast::Call,
        cx: &mut Cx,
        bcd: BcdName,
        expected: Option<TypeId>,
    ) -> Expr {
        let span = call.span;
        let f = name.key();
        let bits = |e: Elem| e.is_bitstring();
        let ints = |e: Elem| e.is_int();
        let (from_ok, to_ok): (&dyn Fn(Elem) -> bool, &dyn Fn(Elem) -> bool) = if bcd.decode {
            (&bits, &ints)
        } else {
            (&ints, &bits)
        };
        let named = |n: &Option<String>, ok: &dyn Fn(Elem) -> bool| match n {
            None => Ok(None),
            Some(n) => match Elem::from_name(n).filter(|e| ok(*e)) {
                Some(e) => Ok(Some(e)),
                None => Err(n.clone()),
            },
        };
        let (from, to) = match (named(&bcd.from, from_ok), named(&bcd.to, to_ok)) {
            (Ok(a), Ok(b)) => (a, b),
            (Err(bad), _) | (_, Err(bad)) => {
                self.error(
                    diag::UNKNOWN_POU,
                    name.span,
                    format!(
                        "unknown function `{}`: {bad} has no place here; a BCD conversion goes from a bit string to an integer type (WORD_BCD_TO_INT, BCD_TO_INT) or from an integer type to a bit string (INT_TO_BCD_WORD, INT_TO_BCD)",
                        name.name
                    ),
                );
                return err(span);
            }
        };
        let Some(args) = self.std_args(&f, call, &["IN"], 1, false) else {
            return err(span);
        };
        let from_ty = from.map(TypeTable::elem_id);
        let x = self.expr(args[0].expr, cx, from_ty);
        let x = match (from_ty, self.types.get(x.ty)) {
            _ if x.ty == ids::ERROR => return x,
            (Some(t), _) => self.coerce(x, t, &format!("the argument of {}", name.name)),
            (None, Type::IntLit) => {
                let t = if bcd.decode { ids::LWORD } else { ids::LINT };
                self.coerce(x, t, &format!("the argument of {}", name.name))
            }
            (None, _) => x,
        };
        if x.ty == ids::ERROR {
            return x;
        }
        let Some(xe) = self
            .types
            .elem(self.base_type(x.ty))
            .filter(|e| from_ok(*e))
        else {
            let t = self.types.name(x.ty);
            let want = if bcd.decode {
                "a bit string (BYTE, WORD, DWORD, LWORD) of BCD digits"
            } else {
                "an integer"
            };
            self.error(
                diag::TYPE_MISMATCH,
                args[0].span,
                format!("{} takes {want}, not {t}", name.name),
            );
            return err(span);
        };
        let to = to.unwrap_or_else(|| {
            let wanted = expected
                .and_then(|t| self.types.elem(t))
                .filter(|e| bits(*e));
            wanted.unwrap_or(match xe {
                Elem::Sint | Elem::Usint => Elem::Byte,
                Elem::Int | Elem::Uint => Elem::Word,
                Elem::Dint | Elem::Udint => Elem::Dword,
                _ => Elem::Lword,
            })
        });
        let b = if bcd.decode {
            Builtin::BcdToInt
        } else {
            Builtin::IntToBcd
        };
        self.fold(Expr {
            kind: ExprKind::Builtin(b, vec![x]),
            ty: TypeTable::elem_id(to),
            span,
        })
    }
}
