//! Places: where a variable, element or field lives, loads, stores, copies and conversions
//! between slots.

use petriplc_iec_sema::ir::{self, Expr, Place, Root, Step, VarClass};
use petriplc_iec_sema::types::{Elem, FbRef, RefKind, Type, TypeId};
use petriplc_iec_syntax::source::Span;

use crate::ext::ExtOp;
use crate::op::{ArrayInfo, Op};

use super::{
    elem_or_dint, is_string, scalar, str_cap, Fx, Loc, PlaceLoc, Region, FRAME, R, SYM, TAG,
};

/// An elementary access through a pointer (see `view_of`).
pub(super) struct ViewAt {
    h: u32,
    idx: Option<(u32, i64)>,
    e: Elem,
    what: String,
    /// A whole STRING or WSTRING (a union's member): its capacity and width.
    text: Option<(u32, bool)>,
}

impl<'c, 'p> Fx<'c, 'p> {
    pub(super) fn place_loc(&mut self, p: &Place) -> R<PlaceLoc> {
        let mut loc = match p.root {
            Root::Var(v) => {
                if let Some((prog, layout)) = self.glue_of.clone() {
                    // Configuration glue names the instance's variables absolutely.
                    let off = layout.offsets[v as usize].unwrap_or(0);
                    self.region_loc(Region::Unit(prog), off)
                } else {
                    let var = &self.c.p.pou(self.pou).vars[v as usize];
                    let off = self.layout.offsets[v as usize].unwrap_or(0);
                    if var.class == VarClass::InOut {
                        Loc::Ind(FRAME | off, 0)
                    } else {
                        Loc::Slot(FRAME | off)
                    }
                }
            }
            Root::Global(g) => self.region_loc(Region::Global(g), 0),
            // The instance's variables start at the frame's base.
            Root::This => Loc::Slot(FRAME),
            // Set by the path's first step, `Step::Value`.
            Root::Value => Loc::Slot(0),
        };
        let mut ty = match p.root {
            Root::Var(v) => {
                if let Some((_, _)) = &self.glue_of {
                    // The instance's POU is the glue's program.
                    self.glue_var_ty(v)
                } else {
                    self.c.p.pou(self.pou).vars[v as usize].ty
                }
            }
            Root::Global(g) => self.c.p.globals[g as usize].ty,
            Root::This => self.this_ty(),
            Root::Value => petriplc_iec_sema::types::ids::ERROR,
        };
        let mut bit = None;
        // The slot of the ARRAY[*] in-out reached so far (its descriptor follows it).
        let mut var_array = match p.root {
            Root::Var(v) if self.glue_of.is_none() && self.c.p.types.is_var_array(ty) => {
                let off = self.layout.offsets[v as usize].unwrap_or(0);
                Some(Loc::Slot(FRAME | off))
            }
            _ => None,
        };
        for step in &p.path {
            match step {
                Step::Field(i) => {
                    let offs = self.c.sizes.field_offsets(self.c.p, ty);
                    loc = self.offset(loc, offs[*i as usize]);
                    if let Type::Struct { fields, .. } = self.c.p.types.get(ty) {
                        ty = fields[*i as usize].ty;
                    }
                }
                Step::Member(i) => match *self.c.p.types.get(ty) {
                    Type::Fb(FbRef::User(q)) => {
                        let layout = self.c.layout(q);
                        let off = layout.offsets[*i as usize].unwrap_or(0);
                        let var = &self.c.p.pou(q).vars[*i as usize];
                        loc = self.offset(loc, off);
                        ty = var.ty;
                        if var.class == VarClass::InOut {
                            var_array = self.c.p.types.is_var_array(ty).then_some(loc);
                            loc = self.deref(loc, p.span)?;
                        }
                    }
                    Type::Fb(FbRef::Native(k)) => {
                        loc = self.offset(loc, *i);
                        ty = petriplc_iec_sema::types::TypeTable::elem_id(
                            self.c.p.natives[k as usize].vars[*i as usize].ty,
                        );
                    }
                    _ => {}
                },
                Step::Index(subs) => {
                    if let (Type::VarArray { elem, .. }, Some(desc)) =
                        (self.c.p.types.get(ty).clone(), var_array.take())
                    {
                        let ptr = self.addr_of(loc, p.span)?;
                        loc = self.var_array_index(ptr, desc, subs)?;
                        ty = elem;
                        continue;
                    }
                    let Type::Array { dims, elem } = self.c.p.types.get(ty).clone() else {
                        continue;
                    };
                    let es = self.size(elem);
                    // Strides, innermost last.
                    let mut strides = vec![es; dims.len()];
                    for k in (0..dims.len().saturating_sub(1)).rev() {
                        let len = (dims[k + 1].1 - dims[k + 1].0 + 1) as u32;
                        strides[k] = strides[k + 1] * len;
                    }
                    let consts: Vec<Option<i128>> = subs.iter().map(|s| s.const_int()).collect();
                    if consts.iter().all(Option::is_some) {
                        let mut off = 0u32;
                        for (k, c) in consts.iter().enumerate() {
                            off += ((c.unwrap_or(0) - dims[k].0 as i128) as u32) * strides[k];
                        }
                        loc = self.offset(loc, off);
                    } else {
                        let mut ptr = self.addr_of(loc, p.span)?;
                        for (k, s) in subs.iter().enumerate() {
                            let i = self.expr(s, None)?;
                            let a = self.c.units[self.unit].arrays.len() as u32;
                            self.c.units[self.unit].arrays.push(ArrayInfo {
                                lo: dims[k].0,
                                hi: dims[k].1,
                                stride: strides[k],
                            });
                            let d = self.temp(1);
                            self.emit(Op::Index { d, p: ptr, i, a }, s.span);
                            ptr = d;
                        }
                        loc = Loc::Ind(ptr, 0);
                    }
                    ty = elem;
                }
                Step::Bit(n) => bit = Some((*n as u8, 1)),
                Step::Bits(lo, w) => bit = Some((*lo as u8, *w as u8)),
                Step::Value(e) => {
                    loc = Loc::Slot(self.expr(e, None)?);
                    ty = e.ty;
                }
                Step::Deref => {
                    let Some(target) = self.c.p.types.ref_target(ty) else {
                        continue;
                    };
                    let h = self.load_loc(loc, p.span)?;
                    let d = self.temp(1);
                    let what = self.c.p.types.name(ty);
                    let n = self.size(target);
                    self.ext(
                        ExtOp::Deref {
                            d,
                            p: h,
                            ty: target,
                            n,
                            what,
                        },
                        p.span,
                    );
                    loc = Loc::Ind(d, 0);
                    ty = target;
                }
                // The checker lets a union's member be only read or assigned, which
                // `view_of` compiles.
                Step::Overlay { .. } => {
                    return Err(crate::compile::CompileError::Unsupported(
                        "a union's member used as a variable with an address of its own".into(),
                    ))
                }
            }
        }
        Ok(PlaceLoc { loc, bit })
    }

    /// An elementary value reached through a CODESYS pointer (`p^`, `p^[i]` of a 1-dimension
    /// array): read and written through the designated variable's byte image
    /// ([`crate::pointer::View`]), so a pointer of another type than the variable's works
    /// as in CODESYS. The handle's slot, the subscript and its lower bound, the type.
    ///
    /// A union's member (`Step::Overlay`) is the same view, through a handle of the union
    /// made on the spot.
    pub(super) fn view_of(&mut self, p: &Place) -> R<Option<ViewAt>> {
        let Some(k) = p
            .path
            .iter()
            .rposition(|s| matches!(s, Step::Deref | Step::Overlay { .. }))
        else {
            return Ok(None);
        };
        if let Step::Overlay { ty: target, .. } = p.path[k] {
            return self.overlay_view(p, k, target).map(Some);
        }
        let Some(e) = self.c.p.types.elem(p.ty) else {
            return Ok(None);
        };
        if matches!(self.c.p.types.get(p.ty), Type::Subrange { .. }) {
            return Ok(None);
        }
        let mut ty = self.root_ty(p.root);
        for s in &p.path[..k] {
            ty = self.step_ty(ty, s);
        }
        let Type::Ref {
            kind: RefKind::PointerTo,
            target,
        } = *self.c.p.types.get(ty)
        else {
            return Ok(None);
        };
        let rest = &p.path[k + 1..];
        let idx = match rest {
            [] => None,
            [Step::Index(subs)] if subs.len() == 1 => match self.c.p.types.get(target) {
                Type::Array { dims, .. } if dims.len() == 1 => Some((&subs[0], dims[0].0)),
                _ => return Ok(None),
            },
            _ => return Ok(None),
        };
        let prefix = Place {
            root: p.root,
            path: p.path[..k].to_vec(),
            ty,
            span: p.span,
        };
        let pl = self.place_loc(&prefix)?;
        let h = self.load_place(&pl, p.span)?;
        let idx = match idx {
            Some((x, lo)) => Some((self.expr(x, None)?, lo)),
            None => None,
        };
        Ok(Some(ViewAt {
            h,
            idx,
            e,
            what: self.c.p.types.name(ty),
            text: None,
        }))
    }

    /// The view of union member `p.path[k]` (of type `target`; the checker allowed only an
    /// elementary value in it: `memory::overlay_path`).
    fn overlay_view(&mut self, p: &Place, k: usize, target: TypeId) -> R<ViewAt> {
        let mut uty = self.root_ty(p.root);
        for s in &p.path[..k] {
            uty = self.step_ty(uty, s);
        }
        let unsupported = |what: &str| crate::compile::CompileError::Unsupported(what.into());
        let types = &self.c.p.types;
        let Some((off, idx, last)) =
            petriplc_iec_sema::memory::overlay_path(types, target, &p.path[k + 1..])
        else {
            return Err(unsupported("this use of a union's member"));
        };
        let text = match types.get(last) {
            Type::Str { len, wide } => Some((*len, *wide)),
            _ => None,
        };
        let Some(e) = types.elem(last).or(text.map(|_| Elem::Byte)) else {
            return Err(unsupported("this use of a union's member"));
        };
        if uty > crate::pointer::MAX_TAGGED_TYPE {
            return Err(unsupported("a union beyond the first types of a project"));
        }
        let prefix = Place {
            root: p.root,
            path: p.path[..k].to_vec(),
            ty: uty,
            span: p.span,
        };
        let pl = self.place_loc(&prefix)?;
        let a = self.addr_of(pl.loc, p.span)?;
        let h = self.temp(1);
        self.ext(
            ExtOp::MakeRef {
                d: h,
                s: a,
                ty: uty,
            },
            p.span,
        );
        let h = if off > 0 {
            // A field or a constant element inside the member: the handle moved there.
            let n = self.konst(off);
            let d = self.temp(1);
            self.ext(
                ExtOp::PtrAdd {
                    d,
                    p: h,
                    n,
                    sub: false,
                },
                p.span,
            );
            d
        } else {
            h
        };
        let idx = match idx {
            Some((x, (lo, hi))) => {
                // The member's own bounds, checked as an array element's are (the view
                // checks only the union's): the element's number from 0, `i - lo`.
                let i = self.expr(x, None)?;
                let zero = self.konst(0);
                let a = self.c.units[self.unit].arrays.len() as u32;
                self.c.units[self.unit]
                    .arrays
                    .push(ArrayInfo { lo, hi, stride: 1 });
                let d = self.temp(1);
                self.emit(Op::Index { d, p: zero, i, a }, x.span);
                Some((d, 0))
            }
            None => None,
        };
        Ok(ViewAt {
            h,
            idx,
            e,
            what: format!("member of {}", self.c.p.types.name(uty)),
            text,
        })
    }

    pub(super) fn view_load(&mut self, v: ViewAt, d: u32, span: Span) {
        if let Some((cap, wide)) = v.text {
            // `d` gets the address of a copy of the string.
            let slots = crate::layout::string_slots(cap.saturating_mul(1 + u32::from(wide)));
            let buf = self.temp(slots);
            self.emit(Op::Lea { d, s: buf }, span);
            self.ext(
                ExtOp::ViewStr {
                    s: d,
                    p: v.h,
                    cap,
                    wide,
                    load: true,
                    what: v.what,
                },
                span,
            );
            return;
        }
        self.ext(
            ExtOp::ViewLoad {
                d,
                p: v.h,
                idx: v.idx,
                e: v.e,
                what: v.what,
            },
            span,
        );
    }

    pub(super) fn view_store(&mut self, v: ViewAt, s: u32, span: Span) {
        if let Some((cap, wide)) = v.text {
            self.ext(
                ExtOp::ViewStr {
                    s,
                    p: v.h,
                    cap,
                    wide,
                    load: false,
                    what: v.what,
                },
                span,
            );
            return;
        }
        self.ext(
            ExtOp::ViewStore {
                s,
                p: v.h,
                idx: v.idx,
                e: v.e,
                what: v.what,
            },
            span,
        );
    }

    pub(super) fn root_ty(&self, root: Root) -> TypeId {
        match root {
            Root::Var(v) => {
                if self.glue_of.is_some() {
                    self.glue_var_ty(v)
                } else {
                    self.c.p.pou(self.pou).vars[v as usize].ty
                }
            }
            Root::Global(g) => self.c.p.globals[g as usize].ty,
            Root::This => self.this_ty(),
            // The path's first step (`Step::Value`) gives the type.
            Root::Value => petriplc_iec_sema::types::ids::ERROR,
        }
    }

    /// The type of the instance whose body is compiled (the checker made it the type of the
    /// THIS of the methods that take it).
    fn this_ty(&self) -> TypeId {
        self.c
            .p
            .types
            .fb_id(FbRef::User(self.pou))
            .unwrap_or(petriplc_iec_sema::types::ids::ERROR)
    }

    /// The type a step of a path leads to from `ty`.
    pub(super) fn step_ty(&self, ty: TypeId, s: &Step) -> TypeId {
        let types = &self.c.p.types;
        match (s, types.get(ty)) {
            (Step::Field(i), Type::Struct { fields, .. }) => fields[*i as usize].ty,
            (Step::Member(i), Type::Fb(FbRef::User(q))) => self.c.p.pou(*q).vars[*i as usize].ty,
            (Step::Member(i), Type::Fb(FbRef::Native(k))) => {
                petriplc_iec_sema::types::TypeTable::elem_id(
                    self.c.p.natives[*k as usize].vars[*i as usize].ty,
                )
            }
            (Step::Index(_), Type::Array { elem, .. } | Type::VarArray { elem, .. }) => *elem,
            (Step::Bit(_), _) => petriplc_iec_sema::types::ids::BOOL,
            (Step::Bits(_, 8), _) => petriplc_iec_sema::types::ids::BYTE,
            (Step::Bits(_, 16), _) => petriplc_iec_sema::types::ids::WORD,
            (Step::Bits(..), _) => petriplc_iec_sema::types::ids::DWORD,
            (Step::Deref, Type::Ref { target, .. }) => *target,
            (Step::Overlay { ty, .. }, _) => *ty,
            (Step::Value(e), _) => e.ty,
            _ => ty,
        }
    }

    fn glue_var_ty(&self, v: ir::VarId) -> TypeId {
        let (prog, _) = self.glue_of.as_ref().map(|x| (x.0, ())).unwrap_or((0, ()));
        let pou = self.c.units[prog].pou.unwrap_or(0);
        self.c.p.pou(pou).vars[v as usize].ty
    }

    pub(super) fn offset(&mut self, loc: Loc, k: u32) -> Loc {
        if k == 0 {
            return loc;
        }
        match loc {
            Loc::Slot(x) if x & TAG == SYM => {
                let (r, off) = self.c.syms[(x & !TAG) as usize];
                let s = self.c.sym(r, off + k);
                Loc::Slot(SYM | s)
            }
            Loc::Slot(x) => Loc::Slot(x + k),
            Loc::Abs(r, off) => Loc::Abs(r, off + k),
            Loc::Ind(p, off) => Loc::Ind(p, off + k),
        }
    }

    /// The pointer a slot holds (an in-out), as a place.
    fn deref(&mut self, loc: Loc, span: Span) -> R<Loc> {
        let p = self.load_loc(loc, span)?;
        let t = self.temp(1);
        self.emit(Op::Mov { d: t, s: p }, span);
        Ok(Loc::Ind(t, 0))
    }

    /// A temporary holding the absolute address of a place.
    pub(super) fn addr_of(&mut self, loc: Loc, span: Span) -> R<u32> {
        let d = self.temp(1);
        match loc {
            Loc::Slot(x) => {
                self.emit(Op::Lea { d, s: x }, span);
            }
            Loc::Abs(r, off) => {
                let s = self.c.sym(r, off);
                self.emit(Op::LeaG { d, g: SYM | s }, span);
            }
            Loc::Ind(p, off) => {
                if off == 0 {
                    return Ok(p);
                }
                self.emit(Op::AddrK { d, p, off }, span);
            }
        }
        Ok(d)
    }

    /// A slot holding the scalar at `loc` (the place itself when it is a slot).
    pub(super) fn load_loc(&mut self, loc: Loc, span: Span) -> R<u32> {
        Ok(match loc {
            Loc::Slot(x) => x,
            Loc::Abs(r, off) => {
                let d = self.temp(1);
                let s = self.c.sym(r, off);
                self.emit(Op::LdG { d, g: SYM | s }, span);
                d
            }
            Loc::Ind(p, off) => {
                let d = self.temp(1);
                self.emit(Op::LdI { d, p, off }, span);
                d
            }
        })
    }

    pub(super) fn store_loc(&mut self, loc: Loc, s: u32, span: Span) {
        match loc {
            Loc::Slot(x) => {
                if x != s {
                    self.emit(Op::Mov { d: x, s }, span);
                }
            }
            Loc::Abs(r, off) => {
                let g = self.c.sym(r, off);
                self.emit(Op::StG { g: SYM | g, s }, span);
            }
            Loc::Ind(p, off) => {
                self.emit(Op::StI { p, off, s }, span);
            }
        }
    }

    pub(super) fn load_place(&mut self, pl: &PlaceLoc, span: Span) -> R<u32> {
        let w = self.load_loc(pl.loc, span)?;
        match pl.bit {
            None => Ok(w),
            Some((n, width)) => {
                let d = self.temp(1);
                self.emit(
                    Op::GetBit {
                        d,
                        s: w,
                        n,
                        w: width,
                    },
                    span,
                );
                Ok(d)
            }
        }
    }

    /// Stores a scalar value into a place (a bit: read, set, write back).
    pub(super) fn store_place(&mut self, pl: &PlaceLoc, s: u32, span: Span) -> R<()> {
        match pl.bit {
            None => self.store_loc(pl.loc, s, span),
            Some((n, width)) => {
                let w = self.load_loc(pl.loc, span)?;
                let t = self.temp(1);
                self.emit(
                    Op::SetBit {
                        d: t,
                        s: w,
                        n,
                        w: width,
                        v: s,
                    },
                    span,
                );
                self.store_loc(pl.loc, t, span);
            }
        }
        Ok(())
    }

    /// `place := e`, computing straight into the place when it is a slot.
    pub(super) fn store_expr(&mut self, dst: &PlaceLoc, ty: TypeId, e: &Expr) -> R<()> {
        if scalar(self.p(), ty) {
            if let (Loc::Slot(d), None) = (dst.loc, dst.bit) {
                let v = self.expr(e, Some(d))?;
                if v != d {
                    self.emit(Op::Mov { d, s: v }, e.span);
                }
                return Ok(());
            }
            let v = self.expr(e, None)?;
            return self.store_place(dst, v, e.span);
        }
        // Aggregates: copy through pointers.
        let src = self.expr(e, None)?;
        let dp = self.addr_of(dst.loc, e.span)?;
        if is_string(self.p(), ty) {
            let cap = str_cap(self.p(), ty);
            self.emit(Op::StrCopyI { dp, sp: src, cap }, e.span);
        } else {
            let n = self.size(ty);
            self.emit(Op::CopyI { dp, sp: src, n }, e.span);
        }
        Ok(())
    }

    /// Copies a value of `ty` at `src` into the place `dst` of type `dty` (widening scalars).
    pub(super) fn copy_loc(
        &mut self,
        src: Loc,
        ty: TypeId,
        dst: &PlaceLoc,
        dty: TypeId,
        span: Span,
    ) -> R<()> {
        if scalar(self.p(), ty) {
            let v = self.load_loc(src, span)?;
            let v = self.convert_slot(v, ty, dty, span)?;
            return self.store_place(dst, v, span);
        }
        let sp = self.addr_of(src, span)?;
        let dp = self.addr_of(dst.loc, span)?;
        if is_string(self.p(), ty) {
            let cap = str_cap(self.p(), dty);
            self.emit(Op::StrCopyI { dp, sp, cap }, span);
        } else {
            let n = self.size(ty);
            self.emit(Op::CopyI { dp, sp, n }, span);
        }
        Ok(())
    }

    /// An implicit conversion of a scalar slot (widening; REAL to LREAL is exact).
    fn convert_slot(&mut self, v: u32, from: TypeId, to: TypeId, span: Span) -> R<u32> {
        let (fe, te) = (elem_or_dint(self.p(), from), elem_or_dint(self.p(), to));
        if fe == te
            || (fe.is_integral()
                && te.is_integral()
                && !matches!(self.p().types.get(to), Type::Subrange { .. }))
        {
            return Ok(v);
        }
        let d = self.temp(1);
        if let Type::Subrange { lo, hi, .. } = *self.p().types.get(to) {
            self.ext(
                ExtOp::Check {
                    d,
                    s: v,
                    lo: lo as i64,
                    hi: hi as i64,
                },
                span,
            );
            return Ok(d);
        }
        self.ext(
            ExtOp::Conv {
                d,
                s: v,
                from: fe,
                to: te,
            },
            span,
        );
        Ok(d)
    }
}
