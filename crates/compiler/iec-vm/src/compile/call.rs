//! Calls: user functions through their static frame, function block instances through their base.

use petriplc_iec_sema::ir::{FbCall, FnCall};
use petriplc_iec_sema::types::{FbRef, TypeId};
use petriplc_iec_syntax::source::Span;

use crate::op::Op;

use super::{
    is_string, scalar, str_cap, CompileError, Fx, Loc, PlaceLoc, Region, Target, R, SYM, TAG,
};

impl<'c, 'p> Fx<'c, 'p> {
    pub(super) fn call_fn(
        &mut self,
        call: &FnCall,
        ty: TypeId,
        want: Option<u32>,
        span: Span,
    ) -> R<u32> {
        let Some(unit) = self.c.pou_unit[call.pou as usize] else {
            return Err(CompileError::Unsupported(format!(
                "function {} is not compiled",
                self.c.p.pou(call.pou).name
            )));
        };
        let layout = self.c.layout(call.pou);
        let callee = self.c.p.pou(call.pou);
        // Arguments are computed before any is stored (an argument may call the same function).
        let mut vals = Vec::new();
        for (v, e) in &call.inputs {
            let vty = callee.vars[*v as usize].ty;
            let x = self.expr(e, None)?;
            let x = if scalar(self.p(), vty) {
                let t = self.temp(1);
                self.emit(Op::Mov { d: t, s: x }, e.span);
                t
            } else {
                x
            };
            vals.push((*v, vty, x));
        }
        let mut ptrs = Vec::new();
        for (v, place) in &call.in_outs {
            let pl = self.place_loc(place)?;
            let a = self.addr_of(pl.loc, place.span)?;
            ptrs.push((*v, a));
        }
        let descs = self.var_array_descs(&callee.vars, &call.in_outs)?;
        for (v, vty, x) in vals {
            let off = layout.offsets[v as usize].unwrap_or(0);
            let dst = self.region_loc(Region::Unit(unit), off);
            if scalar(self.p(), vty) {
                self.store_loc(dst, x, span);
            } else {
                let dp = self.addr_of(dst, span)?;
                if is_string(self.p(), vty) {
                    let cap = str_cap(self.p(), vty);
                    self.emit(Op::StrCopyI { dp, sp: x, cap }, span);
                } else {
                    let n = self.size(vty);
                    self.emit(Op::CopyI { dp, sp: x, n }, span);
                }
            }
        }
        for (v, a) in ptrs {
            let off = layout.offsets[v as usize].unwrap_or(0);
            let dst = self.region_loc(Region::Unit(unit), off);
            self.store_loc(dst, a, span);
        }
        for (v, xs) in descs {
            let off = layout.offsets[v as usize].unwrap_or(0);
            for (j, x) in xs.into_iter().enumerate() {
                let dst = self.region_loc(Region::Unit(unit), off + 1 + j as u32);
                self.store_loc(dst, x, span);
            }
        }
        let at = self.emit(Op::CallAbs { entry: 0 }, span);
        self.unit().calls.push((at, Target::Unit(unit)));
        for (v, place) in &call.outputs {
            let vty = callee.vars[*v as usize].ty;
            let off = layout.offsets[*v as usize].unwrap_or(0);
            let src = self.region_loc(Region::Unit(unit), off);
            let dst = self.place_loc(place)?;
            self.copy_loc(src, vty, &dst, place.ty, span)?;
        }
        let Some(r) = callee.result else {
            return Ok(want.unwrap_or_else(|| self.temp(1)));
        };
        let roff = layout.offsets[r as usize].unwrap_or(0);
        let src = self.region_loc(Region::Unit(unit), roff);
        if scalar(self.p(), ty) {
            // Copied out: the next call of the same function overwrites its frame.
            let d = want.unwrap_or_else(|| self.temp(1));
            match src {
                Loc::Slot(x) => {
                    self.emit(Op::Mov { d, s: x }, span);
                }
                Loc::Abs(r2, off) => {
                    let s = self.c.sym(r2, off);
                    self.emit(Op::LdG { d, g: SYM | s }, span);
                }
                Loc::Ind(pp, off) => {
                    self.emit(Op::LdI { d, p: pp, off }, span);
                }
            }
            Ok(d)
        } else {
            let n = self.size(ty);
            let buf = self.temp(n);
            let dp = self.temp(1);
            self.emit(Op::Lea { d: dp, s: buf }, span);
            let sp = self.addr_of(src, span)?;
            self.emit(Op::CopyI { dp, sp, n }, span);
            Ok(dp)
        }
    }

    pub(super) fn call_fb(&mut self, call: &FbCall, span: Span) -> R<()> {
        let inst = self.place_loc(&call.instance)?.loc;
        let (vars_ty, offsets, natives): (Vec<TypeId>, Vec<Option<u32>>, Option<u32>) =
            match call.fb {
                FbRef::User(q) => {
                    let layout = self.c.layout(q);
                    let tys = self.c.p.pou(q).vars.iter().map(|v| v.ty).collect();
                    (tys, layout.offsets, None)
                }
                FbRef::Native(k) => {
                    let sig = &self.c.p.natives[k as usize];
                    let tys = sig
                        .vars
                        .iter()
                        .map(|v| petriplc_iec_sema::types::TypeTable::elem_id(v.ty))
                        .collect();
                    let offs = (0..sig.vars.len() as u32).map(Some).collect();
                    (tys, offs, Some(k))
                }
            };
        // Inputs.
        for (v, e) in &call.inputs {
            let off = offsets[*v as usize].unwrap_or(0);
            let dst = PlaceLoc {
                loc: self.offset(inst, off),
                bit: None,
            };
            let mark = self.temp_top;
            self.store_expr(&dst, vars_ty[*v as usize], e)?;
            self.temp_top = mark.max(self.pinned());
        }
        for (v, place) in &call.in_outs {
            let pl = self.place_loc(place)?;
            let a = self.addr_of(pl.loc, place.span)?;
            let off = offsets[*v as usize].unwrap_or(0);
            let dst = self.offset(inst, off);
            self.store_loc(dst, a, span);
            if self.c.p.types.is_var_array(vars_ty[*v as usize]) {
                for (j, x) in self.var_array_desc(place, span)?.into_iter().enumerate() {
                    let dst = self.offset(inst, off + 1 + j as u32);
                    self.store_loc(dst, x, span);
                }
            }
        }
        // The call.
        match (natives, inst) {
            (Some(k), Loc::Slot(x)) if x & TAG != SYM || !self.rel => {
                self.emit(Op::CallNative { k, inst: x }, span);
            }
            (Some(k), loc) => {
                let p = self.addr_of(loc, span)?;
                self.emit(Op::CallNativeI { k, p }, span);
            }
            (None, Loc::Slot(x)) => {
                let at = self.emit(Op::CallFb { entry: 0, inst: x }, span);
                if let FbRef::User(q) = call.fb {
                    let u = self.c.pou_unit[q as usize].unwrap_or(0);
                    self.unit().calls.push((at, Target::Unit(u)));
                }
            }
            (None, loc) => {
                let p = self.addr_of(loc, span)?;
                let at = self.emit(Op::CallFbI { entry: 0, p }, span);
                if let FbRef::User(q) = call.fb {
                    let u = self.c.pou_unit[q as usize].unwrap_or(0);
                    self.unit().calls.push((at, Target::Unit(u)));
                }
            }
        }
        // Outputs.
        for (v, place, negated) in &call.outputs {
            let off = offsets[*v as usize].unwrap_or(0);
            let src = self.offset(inst, off);
            let vty = vars_ty[*v as usize];
            let dst = self.place_loc(place)?;
            if *negated {
                let x = self.load_loc(src, span)?;
                let t = self.temp(1);
                self.emit(Op::Not { d: t, s: x }, span);
                self.store_place(&dst, t, span)?;
            } else {
                self.copy_loc(src, vty, &dst, place.ty, span)?;
            }
        }
        Ok(())
    }

    /// The descriptors of a function call's ARRAY[*] in-outs, computed before any argument
    /// is stored, as the arguments are.
    fn var_array_descs(
        &mut self,
        vars: &[petriplc_iec_sema::ir::Var],
        in_outs: &[(petriplc_iec_sema::ir::VarId, petriplc_iec_sema::ir::Place)],
    ) -> R<Vec<(u32, Vec<u32>)>> {
        let mut out = Vec::new();
        for (v, place) in in_outs {
            if self.c.p.types.is_var_array(vars[*v as usize].ty) {
                out.push((*v, self.var_array_desc(place, place.span)?));
            }
        }
        Ok(out)
    }

    fn pinned(&self) -> u32 {
        0
    }
}
