//! LOWER_BOUND and UPPER_BOUND (IEC 61131-3 3rd edition), and the one refusal of an
//! ARRAY[*] in-out used as a whole value.

use petriplc_iec_syntax::ast;
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Builtin, Expr, ExprKind};
use crate::types::{ids, Type};
use crate::value::Value;

use super::{err, konst};

impl<'a> Checker<'a> {
    /// `LOWER_BOUND(arr, dim)`, `UPPER_BOUND(arr, dim)` as DINT: a constant for an array of
    /// fixed bounds; for an ARRAY[*] in-out, [`Builtin::Bound`] reads the bounds the caller
    /// passed with it (its arguments: the array, the dimension from 1, 1 for the upper bound).
    pub(super) fn array_bound(&mut self, name: &ast::Ident, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let upper = name.is("UPPER_BOUND");
        let fname = if upper { "UPPER_BOUND" } else { "LOWER_BOUND" };
        let usage =
            format!("{fname} takes an array variable and a constant dimension: {fname}(arr, 1)");
        let args: Vec<&ast::Expr> = call.args.iter().filter_map(|a| a.value.as_ref()).collect();
        if args.len() != 2 || call.args.len() != 2 || call.args.iter().any(|a| a.output) {
            self.error(diag::ARRAY_BOUND, span, usage);
            return err(span);
        }
        let Some(place) = self.place(args[0], cx, false) else {
            return err(span);
        };
        if place.ty == ids::ERROR {
            return err(span);
        }
        let Some((dims, _)) = self.types.array_shape(place.ty) else {
            let t = self.types.name(place.ty);
            self.error(
                diag::ARRAY_BOUND,
                args[0].span,
                format!("{fname} gives an array's bound; this is {t}"),
            );
            return err(span);
        };
        let Some(dim) = self.const_int(args[1], cx) else {
            return err(span);
        };
        if !(1..=i128::from(dims)).contains(&dim) {
            let t = self.types.name(place.ty);
            self.error(
                diag::ARRAY_BOUND,
                args[1].span,
                format!("{fname}: {t} has dimensions 1 to {dims}, not {dim}"),
            );
            return err(span);
        }
        if let Type::Array { dims, .. } = self.types.get(place.ty) {
            let (lo, hi) = dims[dim as usize - 1];
            let v = if upper { hi } else { lo };
            return konst(Value::Int(i128::from(v)), ids::DINT, span);
        }
        let arr = Expr {
            ty: place.ty,
            span: args[0].span,
            kind: ExprKind::Load(place),
        };
        Expr {
            kind: ExprKind::Builtin(
                Builtin::Bound,
                vec![
                    arr,
                    konst(Value::Int(dim), ids::DINT, span),
                    konst(Value::Int(i128::from(upper)), ids::DINT, span),
                ],
            ),
            ty: ids::DINT,
            span,
        }
    }

    /// The error of an ARRAY[*] in-out used as one value (read, assigned, ADR, REF).
    pub(crate) fn var_array_whole(&mut self, span: Span) -> Expr {
        self.error(
            diag::ARRAY_STAR_WHOLE,
            span,
            "an ARRAY[*] in-out is used element by element (a[i]), with LOWER_BOUND and UPPER_BOUND, or passed on to another ARRAY[*] in-out; it is not read, assigned or referenced as a whole",
        );
        err(span)
    }
}
