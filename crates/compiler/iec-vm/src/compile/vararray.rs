//! ARRAY[*] in-outs: the descriptor a caller writes after the address (per dimension the
//! lower bound, the upper bound and the stride in slots, `layout::in_out_slots`), the
//! subscripts checked against it when the program runs, and LOWER_BOUND/UPPER_BOUND read
//! from it.

use petriplc_iec_sema::ir::{Expr, Place, Root, Step, VarClass};
use petriplc_iec_sema::types::{FbRef, Type, TypeId};
use petriplc_iec_syntax::source::Span;

use crate::op::Op;

use super::{CompileError, Fx, Loc, FRAME, R};

impl<'c, 'p> Fx<'c, 'p> {
    /// Where the ARRAY[*] in-out `p` keeps its address; its descriptor follows. The checker
    /// gives that type only to in-outs, so `p` is one of this POU's or an instance's member.
    pub(super) fn var_array_slot(&mut self, p: &Place) -> R<Loc> {
        let unsupported = || CompileError::Unsupported("this use of an ARRAY[*] in-out".into());
        match (p.root, p.path.split_last()) {
            (Root::Var(v), None) if self.glue_of.is_none() => {
                let var = &self.c.p.pou(self.pou).vars[v as usize];
                if var.class != VarClass::InOut {
                    return Err(unsupported());
                }
                let off = self.layout.offsets[v as usize].unwrap_or(0);
                Ok(Loc::Slot(FRAME | off))
            }
            (_, Some((Step::Member(i), rest))) => {
                let prefix = Place {
                    root: p.root,
                    path: rest.to_vec(),
                    ty: p.ty,
                    span: p.span,
                };
                let inst_ty = self.place_ty(&prefix);
                let Type::Fb(FbRef::User(q)) = *self.c.p.types.get(inst_ty) else {
                    return Err(unsupported());
                };
                let off = self.c.layout(q).offsets[*i as usize].unwrap_or(0);
                let loc = self.place_loc(&prefix)?.loc;
                Ok(self.offset(loc, off))
            }
            _ => Err(unsupported()),
        }
    }

    /// The type of a place's value, from its root through its steps.
    fn place_ty(&self, p: &Place) -> TypeId {
        let mut ty = self.root_ty(p.root);
        for s in &p.path {
            ty = self.step_ty(ty, s);
        }
        ty
    }

    /// The element of the ARRAY[*] in-out whose address slot is `desc` (its address in
    /// `ptr`), at subscripts `subs`: each checked against its dimension's bounds.
    pub(super) fn var_array_index(&mut self, ptr: u32, desc: Loc, subs: &[Expr]) -> R<Loc> {
        let mut ptr = ptr;
        for (k, s) in subs.iter().enumerate() {
            let i = self.expr(s, None)?;
            let i = self.pinned_copy(i, s.span);
            let b = self.temp(3);
            for j in 0..3u32 {
                let at = self.offset(desc, 1 + 3 * k as u32 + j);
                let x = self.load_loc(at, s.span)?;
                self.emit(Op::Mov { d: b + j, s: x }, s.span);
            }
            let d = self.temp(1);
            self.emit(Op::IndexV { d, p: ptr, i, b }, s.span);
            ptr = d;
        }
        Ok(Loc::Ind(ptr, 0))
    }

    /// A copy of slot `x` in a temporary (loading the descriptor must not overwrite it).
    fn pinned_copy(&mut self, x: u32, span: Span) -> u32 {
        let t = self.temp(1);
        self.emit(Op::Mov { d: t, s: x }, span);
        t
    }

    /// `LOWER_BOUND(a, dim)` / `UPPER_BOUND(a, dim)` of an ARRAY[*] in-out (`ir::Builtin::Bound`).
    pub(super) fn var_array_bound(
        &mut self,
        args: &[Expr],
        want: Option<u32>,
        span: Span,
    ) -> R<u32> {
        let unsupported = || CompileError::Unsupported("LOWER_BOUND of this expression".into());
        let [a, dim, upper] = args else {
            return Err(unsupported());
        };
        let petriplc_iec_sema::ir::ExprKind::Load(p) = &a.kind else {
            return Err(unsupported());
        };
        let (Some(dim), Some(upper)) = (dim.const_int(), upper.const_int()) else {
            return Err(unsupported());
        };
        let desc = self.var_array_slot(p)?;
        let at = self.offset(desc, 1 + 3 * (dim as u32 - 1) + u32::from(upper != 0));
        let x = self.load_loc(at, span)?;
        let d = want.unwrap_or_else(|| self.temp(1));
        self.emit(Op::Mov { d, s: x }, span);
        Ok(d)
    }

    /// The descriptor values of the array `place` passed to an ARRAY[*] in-out: constants
    /// for an array of fixed bounds, the caller's own descriptor for an ARRAY[*] it has.
    pub(super) fn var_array_desc(&mut self, place: &Place, span: Span) -> R<Vec<u32>> {
        let mut out = Vec::new();
        match self.c.p.types.get(place.ty).clone() {
            Type::Array { dims, elem } => {
                let es = self.size(elem);
                let mut strides = vec![es; dims.len()];
                for k in (0..dims.len().saturating_sub(1)).rev() {
                    let len = (dims[k + 1].1 - dims[k + 1].0 + 1) as u32;
                    strides[k] = strides[k + 1] * len;
                }
                for (k, (lo, hi)) in dims.iter().enumerate() {
                    for v in [*lo as u64, *hi as u64, u64::from(strides[k])] {
                        out.push(self.konst(v));
                    }
                }
            }
            Type::VarArray { dims, .. } => {
                let desc = self.var_array_slot(place)?;
                for j in 0..3 * dims {
                    let at = self.offset(desc, 1 + j);
                    let x = self.load_loc(at, span)?;
                    out.push(self.pinned_copy(x, span));
                }
            }
            _ => {
                return Err(CompileError::Unsupported(
                    "an ARRAY[*] in-out given something other than an array".into(),
                ))
            }
        }
        Ok(out)
    }
}
