//! Linking: memory laid out, the units' tagged operands relocated to absolute slots, instances
//! placed.

use crate::ext::ExtOp;
use crate::op::Op;

use super::{
    Code, CompileError, Compiler, InstanceRt, InstanceSpec, Region, Target, CONST, FRAME, MAX_OFF,
    TAG, TEMP,
};

impl<'p> Compiler<'p> {
    pub(super) fn link(
        mut self,
        instances: &[InstanceSpec],
        prog_units: &[usize],
        glue_units: &[usize],
    ) -> Result<Code, CompileError> {
        // Memory: globals, then the frames of absolute units.
        let mut addr: u64 = 0;
        let mut global_addr = Vec::new();
        for g in &self.p.globals {
            global_addr.push(addr as u32);
            addr = addr.saturating_add(self.sizes.of_wide(self.p, g.ty));
            if addr > MAX_OFF as u64 {
                return Err(CompileError::TooLarge);
            }
        }
        let mut frame_addr = vec![0u32; self.units.len()];
        for (i, u) in self.units.iter().enumerate() {
            if !u.rel {
                frame_addr[i] = addr.min(MAX_OFF as u64) as u32;
                addr = addr.saturating_add(u.size() as u64);
            }
        }
        if addr > MAX_OFF as u64 {
            return Err(CompileError::TooLarge);
        }
        let resolve =
            |syms: &[(Region, u32)], s: u32, global_addr: &[u32], frame_addr: &[u32]| -> u32 {
                let (r, off) = syms[s as usize];
                match r {
                    Region::Global(g) => global_addr[g as usize] + off,
                    Region::Unit(u) => frame_addr[u] + off,
                }
            };
        // Code.
        let mut ops = Vec::new();
        let mut ext_all = Vec::new();
        let mut lits_all: Vec<(u32, u64)> = Vec::new();
        let mut stores_all: Vec<(u32, u64)> = Vec::new();
        let mut arrays = Vec::new();
        let mut lines = Vec::new();
        let mut guards = Vec::new();
        let mut starts = Vec::new();
        for u in &self.units {
            starts.push(ops.len() as u32);
            let _ = u;
            let n: usize = u.ops.len();
            ops.reserve(n);
            ops.extend(std::iter::repeat_n(Op::Halt, n));
        }
        for (ui, u) in self.units.iter_mut().enumerate() {
            let start = starts[ui];
            let ext_off = ext_all.len() as u32;
            let arr_off = arrays.len() as u32;
            let lit_off = lits_all.len() as u32;
            let store_off = stores_all.len() as u32;
            let (vars, temps) = (u.vars, u.temps);
            let base = if u.rel { 0 } else { frame_addr[ui] };
            let syms = &self.syms;
            let reloc = |x: u32| -> u32 {
                let off = x & !TAG;
                match x & TAG {
                    FRAME => base + off,
                    TEMP => base + vars + off,
                    CONST => base + vars + temps + off,
                    _ => resolve(syms, off, &global_addr, &frame_addr),
                }
            };
            for (k, op) in u.ops.iter().enumerate() {
                let mut op = *op;
                op.map_slots(reloc);
                match &mut op {
                    Op::Jmp { t }
                    | Op::JmpF { t, .. }
                    | Op::JmpT { t, .. }
                    | Op::Loop { t }
                    | Op::ForNext { t, .. } => *t += start,
                    Op::Ext { x } => *x += ext_off,
                    Op::Index { a, .. } => *a += arr_off,
                    Op::AndLits { start, .. } | Op::OrLits { start, .. } => *start += lit_off,
                    Op::CondStore { start, .. } => *start += store_off,
                    _ => {}
                }
                ops[start as usize + k] = op;
            }
            lits_all.extend(u.lits.iter().map(|&(s, n)| (reloc(s), n)));
            stores_all.extend(u.stores.iter().map(|&(s, k)| (reloc(s), k)));
            for (k, tgt) in &u.calls {
                let Target::Unit(t) = tgt;
                match &mut ops[start as usize + *k] {
                    Op::CallFb { entry, .. }
                    | Op::CallFbI { entry, .. }
                    | Op::CallAbs { entry } => {
                        *entry = starts[*t];
                    }
                    _ => {}
                }
            }
            for x in &u.ext {
                let mut x = x.clone();
                x.map_slots(reloc);
                if let (ExtOp::Enter { s, .. }, false) = (&x, u.rel) {
                    guards.push(*s);
                }
                ext_all.push(x);
            }
            arrays.extend(u.arrays.iter().copied());
            let pou = u.pou.unwrap_or(u32::MAX);
            for (pc, line) in &u.lines {
                lines.push((start + pc, pou, *line));
            }
        }
        // Dynamic memory, when the program has `__NEW`: the prototypes of the types it
        // makes (their initial values, copied into each new object), then the region.
        let mut protos: Vec<(u32, u64)> = Vec::new();
        for x in &mut ext_all {
            if let ExtOp::New {
                ty, slots, proto, ..
            } = x
            {
                // Every block's size is known now that all units are compiled.
                *slots = self.sizes.of(self.p, *ty).unwrap_or(1);
                let at = match protos.iter().find(|(t, _)| t == ty) {
                    Some(&(_, a)) => a,
                    None => {
                        let a = addr;
                        protos.push((*ty, a));
                        addr += u64::from(*slots);
                        a
                    }
                };
                *proto = u32::try_from(at).map_err(|_| {
                    CompileError::Unsupported("a program of more than 2^32 slots".into())
                })?;
            }
        }
        let heap = (!protos.is_empty()).then(|| {
            let h = crate::heap::Layout { at: addr };
            addr += crate::heap::Layout::slots();
            h
        });
        // Initial image.
        let mut init = vec![0u64; addr as usize];
        for (g, v) in self.p.globals.iter().enumerate() {
            let a = global_addr[g] as usize;
            self.write_init(&mut init, a, v.ty, v.init.as_ref());
        }
        for &(ty, at) in &protos {
            self.write_init(&mut init, at as usize, ty, None);
        }
        for (i, &fa) in frame_addr.iter().enumerate() {
            if self.units[i].rel {
                continue;
            }
            let fa = fa as usize;
            if let Some(pou) = self.units[i].frame_pou {
                let t = self.frame_template(pou, i);
                init[fa..fa + t.len()].copy_from_slice(&t);
            } else {
                let u = &self.units[i];
                let cbase = fa + (u.vars + u.temps) as usize;
                for (k, c) in u.consts.iter().enumerate() {
                    init[cbase + k] = *c;
                }
            }
        }
        let layouts = (0..self.p.pous.len() as u32)
            .map(|p| self.layout(p))
            .collect();
        let inst_rt = instances
            .iter()
            .enumerate()
            .map(|(i, s)| InstanceRt {
                name: s.name.clone(),
                pou: s.pou,
                task: s.task,
                frame: frame_addr[prog_units[i]],
                // Without connections the program runs straight (its RET ends the run).
                entry: if s.inputs.is_empty() && s.outputs.is_empty() {
                    starts[prog_units[i]]
                } else {
                    starts[glue_units[i]]
                },
            })
            .collect();
        let mut shapes = crate::pointer::Shapes {
            heap,
            ..Default::default()
        };
        for x in &ext_all {
            if let ExtOp::MakeRef { ty, .. } | ExtOp::New { ty, .. } = x {
                shapes
                    .images
                    .entry(*ty)
                    .or_insert_with(|| crate::pointer::image_of(self.p, &self.sizes, *ty));
            }
        }
        Ok(Code {
            ops,
            ext: ext_all,
            lits: lits_all,
            stores: stores_all,
            arrays,
            lines,
            init,
            sizes: self.sizes,
            layouts,
            global_addr,
            instances: inst_rt,
            native_sizes: self.p.natives.iter().map(|n| n.vars.len() as u32).collect(),
            overflow: self.p.overflow,
            shapes,
            guards,
        })
    }
}

impl Op {
    /// Applies `f` to every slot operand.
    pub fn map_slots(&mut self, mut f: impl FnMut(u32) -> u32) {
        match self {
            Op::Halt
            | Op::Ret
            | Op::Jmp { .. }
            | Op::Loop { .. }
            | Op::CallAbs { .. }
            | Op::Ext { .. } => {}
            Op::Mov { d, s }
            | Op::Lea { d, s }
            | Op::Not { d, s }
            | Op::BNot { d, s, .. }
            | Op::NegN { d, s, .. }
            | Op::NegL { d, s }
            | Op::NegNW { d, s, .. }
            | Op::NegLW { d, s }
            | Op::NegF { d, s }
            | Op::GetBit { d, s, .. } => {
                *d = f(*d);
                *s = f(*s);
            }
            Op::MovK { d, .. } => *d = f(*d),
            Op::AndLits { d, .. } | Op::OrLits { d, .. } => *d = f(*d),
            Op::CondStore { c, .. } => *c = f(*c),
            Op::MovN { d, s, .. } => {
                *d = f(*d);
                *s = f(*s);
            }
            Op::CondMovK { c, d, .. } | Op::CondNotMovK { c, d, .. } => {
                *c = f(*c);
                *d = f(*d);
            }
            Op::LdG { d, g } | Op::LeaG { d, g } => {
                *d = f(*d);
                *g = f(*g);
            }
            Op::StG { g, s } => {
                *g = f(*g);
                *s = f(*s);
            }
            Op::LdI { d, p, .. } | Op::AddrK { d, p, .. } => {
                *d = f(*d);
                *p = f(*p);
            }
            Op::StI { p, s, .. } => {
                *p = f(*p);
                *s = f(*s);
            }
            Op::Index { d, p, i, .. } => {
                *d = f(*d);
                *p = f(*p);
                *i = f(*i);
            }
            Op::IndexV { d, p, i, b } => {
                *d = f(*d);
                *p = f(*p);
                *i = f(*i);
                *b = f(*b);
            }
            Op::CopyI { dp, sp, .. } | Op::StrCopyI { dp, sp, .. } => {
                *dp = f(*dp);
                *sp = f(*sp);
            }
            Op::Init { s, .. } => *s = f(*s),
            Op::And { d, a, b }
            | Op::AndN { d, a, b }
            | Op::Or { d, a, b }
            | Op::OrN { d, a, b }
            | Op::Xor { d, a, b }
            | Op::CmpI { d, a, b, .. }
            | Op::CmpU { d, a, b, .. }
            | Op::CmpF { d, a, b, .. }
            | Op::CmpS { d, a, b, .. }
            | Op::ArN { d, a, b, .. }
            | Op::ArL { d, a, b, .. }
            | Op::ArU { d, a, b, .. }
            | Op::ArNW { d, a, b, .. }
            | Op::ArLW { d, a, b, .. }
            | Op::ArUW { d, a, b, .. }
            | Op::ArF { d, a, b, .. } => {
                *d = f(*d);
                *a = f(*a);
                *b = f(*b);
            }
            Op::SetBit { d, s, v, .. } => {
                *d = f(*d);
                *s = f(*s);
                *v = f(*v);
            }
            Op::JmpF { c, .. } | Op::JmpT { c, .. } => *c = f(*c),
            Op::ForNext { v, to, by, .. } => {
                *v = f(*v);
                *to = f(*to);
                *by = f(*by);
            }
            Op::CallFb { inst, .. } | Op::CallNative { inst, .. } => *inst = f(*inst),
            Op::CallFbI { p, .. } | Op::CallNativeI { p, .. } => *p = f(*p),
        }
    }
}

impl ExtOp {
    pub fn map_slots(&mut self, mut f: impl FnMut(u32) -> u32) {
        let mut g = |x: &mut u32| *x = f(*x);
        match self {
            ExtOp::Conv { d, s, .. }
            | ExtOp::Trunc { d, s, .. }
            | ExtOp::Check { d, s, .. }
            | ExtOp::Math { d, s, .. }
            | ExtOp::AbsI { d, s, .. }
            | ExtOp::Bcd { d, s, .. }
            | ExtOp::MakeRef { d, s, .. }
            | ExtOp::ItfCheck { d, s }
            | ExtOp::ItfType { d, s } => {
                g(d);
                g(s);
            }
            ExtOp::New { d, n, .. } => {
                g(d);
                if let Some(n) = n {
                    g(n);
                }
            }
            ExtOp::Free { p, .. } => g(p),
            ExtOp::Area { d, p } => {
                g(d);
                g(p);
            }
            ExtOp::Deref { d, p, .. } => {
                g(d);
                g(p);
            }
            ExtOp::Mem { d, a, b, n, .. } => {
                g(d);
                g(a);
                g(b);
                g(n);
            }
            ExtOp::PtrAdd { d, p, n, .. } => {
                g(d);
                g(p);
                g(n);
            }
            ExtOp::ViewLoad { d: s, p, idx, .. } | ExtOp::ViewStore { s, p, idx, .. } => {
                g(s);
                g(p);
                if let Some((i, _)) = idx {
                    g(i);
                }
            }
            ExtOp::ViewStr { s, p, .. } => {
                g(s);
                g(p);
            }
            ExtOp::ToStr { dp, s, .. } => {
                g(dp);
                g(s);
            }
            ExtOp::FromStr { d, sp, .. } => {
                g(d);
                g(sp);
            }
            ExtOp::Recode { dp, sp, .. } => {
                g(dp);
                g(sp);
            }
            ExtOp::Pow { d, a, b, .. }
            | ExtOp::TimeScale { d, a, b, .. }
            | ExtOp::TodAdd { d, a, b, .. }
            | ExtOp::TimeAdd { d, a, b, .. }
            | ExtOp::ConcatDateTod { d, a, b } => {
                g(d);
                g(a);
                g(b);
            }
            ExtOp::Atan2 { d, y, x, .. } => {
                g(d);
                g(y);
                g(x);
            }
            ExtOp::MinMax { d, args, .. } | ExtOp::Str { d, args, .. } => {
                g(d);
                args.iter_mut().for_each(g);
            }
            ExtOp::Limit { d, mn, x, mx, .. } => {
                g(d);
                g(mn);
                g(x);
                g(mx);
            }
            ExtOp::Select { d, k, args, .. } => {
                g(d);
                g(k);
                args.iter_mut().for_each(g);
            }
            ExtOp::Shift { d, s, n, .. } => {
                g(d);
                g(s);
                g(n);
            }
            ExtOp::NonZeroStep { s } => g(s),
            ExtOp::Now { d } => g(d),
            ExtOp::Enter { s, .. } | ExtOp::Leave { s } => g(s),
            ExtOp::Chr { d, s, .. } => {
                g(d);
                g(s);
            }
            ExtOp::GetChar { d, s, p } => {
                g(d);
                g(s);
                g(p);
            }
            ExtOp::Format { d, s, fmt, .. } => {
                g(d);
                g(s);
                g(fmt);
            }
        }
    }
}
