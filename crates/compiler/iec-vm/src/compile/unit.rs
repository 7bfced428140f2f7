//! Units: function blocks in dependency order, each POU and the configuration's glue compiled,
//! frame templates and initial values.

use petriplc_iec_sema::ir::{PouId, PouKind, VarClass};
use petriplc_iec_sema::types::{FbRef, Type, TypeId};
use petriplc_iec_sema::value::Value;

use crate::ext::{self, ExtOp};
use crate::layout::{self, FrameLayout};
use crate::op::Op;

use super::{
    CompileError, Compiler, Fx, InstanceSpec, PlaceLoc, Region, Target, Unit, FRAME, MAX_OFF,
};

impl<'p> Compiler<'p> {
    /// Function blocks ordered so that every contained FB comes first.
    pub(super) fn fb_order(&self) -> Vec<PouId> {
        let mut out = Vec::new();
        let mut state = vec![0u8; self.p.pous.len()];
        for start in 0..self.p.pous.len() {
            if self.p.pous[start].kind != PouKind::FunctionBlock {
                continue;
            }
            let mut stack = vec![(start, false)];
            while let Some((n, done)) = stack.pop() {
                if done {
                    if state[n] != 2 {
                        state[n] = 2;
                        out.push(n as PouId);
                    }
                    continue;
                }
                if state[n] != 0 {
                    continue;
                }
                state[n] = 1;
                stack.push((n, true));
                for v in &self.p.pous[n].vars {
                    let mut t = v.ty;
                    while let Type::Array { elem, .. } = self.p.types.get(t) {
                        t = *elem;
                    }
                    for q in self.fbs_in(t) {
                        if state[q as usize] == 0 {
                            stack.push((q as usize, false));
                        }
                    }
                }
            }
        }
        out
    }

    /// User function blocks inside a type (through arrays and structures).
    fn fbs_in(&self, ty: TypeId) -> Vec<PouId> {
        match self.p.types.get(ty) {
            Type::Fb(FbRef::User(q)) => vec![*q],
            Type::Array { elem, .. } => self.fbs_in(*elem),
            Type::Struct { fields, .. } => fields.iter().flat_map(|f| self.fbs_in(f.ty)).collect(),
            _ => Vec::new(),
        }
    }

    pub(super) fn layout(&mut self, pou: PouId) -> FrameLayout {
        if let Some(l) = &self.layouts[pou as usize] {
            return l.clone();
        }
        let l = layout::frame_layout(self.p, &self.sizes, pou);
        self.layouts[pou as usize] = Some(l.clone());
        l
    }

    pub(super) fn sym(&mut self, r: Region, off: u32) -> u32 {
        let key = (r, off);
        if let Some(&i) = self.sym_index.get(&key) {
            return i;
        }
        let i = self.syms.len() as u32;
        self.syms.push(key);
        self.sym_index.insert(key, i);
        i
    }

    pub(super) fn compile_pou(
        &mut self,
        pou: PouId,
        inst: Option<&InstanceSpec>,
        reserved: Option<usize>,
    ) -> Result<usize, CompileError> {
        let p = self.p.pou(pou);
        // The checker bounds every type; instances of function blocks whose frames hold
        // temporaries and constants besides can still add up past what slots can address.
        if layout::frame_slots(self.p, &self.sizes, pou) > u64::from(MAX_OFF) {
            return Err(CompileError::TooLarge);
        }
        let layout = self.layout(pou);
        let rel = p.kind == PouKind::FunctionBlock;
        let unit = Unit {
            vars: layout.vars,
            rel,
            pou: Some(pou),
            frame_pou: Some(pou),
            ..Unit::default()
        };
        let unit_id = match reserved {
            Some(u) => {
                self.units[u] = unit;
                u
            }
            None => {
                self.units.push(unit);
                self.units.len() - 1
            }
        };
        if inst.is_none() {
            self.pou_unit[pou as usize] = Some(unit_id);
        }
        let mut fx = Fx::new(self, unit_id, pou, layout);
        // A POU a call through an interface may enter again: its busy flag, a temporary that
        // no statement reuses (statements free only the temporaries they take).
        if fx.c.p.guarded.contains(&pou) {
            let flag = fx.temp(1);
            fx.guard = Some(flag);
            fx.ext(
                ExtOp::Enter {
                    s: flag,
                    pou: p.name.clone(),
                },
                p.span,
            );
        }
        // VAR_TEMP (and a function's non-inputs) start from their initial values each call.
        let reinit: Vec<(u32, u32)> = {
            let mut v = Vec::new();
            for (i, var) in p.vars.iter().enumerate() {
                let again = match p.kind {
                    PouKind::Function => !matches!(
                        var.class,
                        VarClass::Input | VarClass::InOut | VarClass::External(_)
                    ),
                    _ => var.class == VarClass::Temp,
                };
                if again {
                    if let Some(off) = fx.layout.offsets[i] {
                        let n = fx.c.sizes.of(fx.c.p, var.ty).unwrap_or(1);
                        v.push((off, n));
                    }
                }
            }
            v
        };
        for (off, n) in merge_ranges(reinit) {
            fx.emit(Op::Init { s: FRAME | off, n }, p.span);
        }
        fx.stmts(&p.body)?;
        fx.ret(p.span);
        fx.finish()?;
        if rel {
            let size = self.units[unit_id].size();
            self.sizes.fb[pou as usize] = Some(size);
            let tmpl = self.frame_template(pou, unit_id);
            self.fb_templates.insert(pou, tmpl);
        }
        Ok(unit_id)
    }

    /// The glue of a program instance: inputs from globals, the run, outputs to globals.
    pub(super) fn compile_glue(
        &mut self,
        inst: &InstanceSpec,
        prog_unit: usize,
    ) -> Result<usize, CompileError> {
        let unit_id = self.units.len();
        self.units.push(Unit {
            vars: 0,
            rel: false,
            ..Unit::default()
        });
        let layout = self.layout(inst.pou);
        let span = self.p.pou(inst.pou).span;
        let mut fx = Fx::new(self, unit_id, u32::MAX, FrameLayout::default());
        fx.glue_of = Some((prog_unit, layout.clone()));
        for (v, e) in &inst.inputs {
            let ty = fx.c.p.pou(inst.pou).vars[*v as usize].ty;
            let off = layout.offsets[*v as usize].unwrap_or(0);
            let dst = PlaceLoc {
                loc: fx.region_loc(Region::Unit(prog_unit), off),
                bit: None,
            };
            fx.store_expr(&dst, ty, e)?;
        }
        let at = fx.unit().ops.len();
        fx.emit(Op::CallAbs { entry: 0 }, span);
        fx.unit().calls.push((at, Target::Unit(prog_unit)));
        for (v, place) in &inst.outputs {
            let ty = fx.c.p.pou(inst.pou).vars[*v as usize].ty;
            let off = layout.offsets[*v as usize].unwrap_or(0);
            let src = fx.region_loc(Region::Unit(prog_unit), off);
            let dst = fx.place_loc(place)?;
            fx.copy_loc(src, ty, &dst, place.ty, place.span)?;
        }
        fx.emit(Op::Halt, span);
        fx.finish()?;
        Ok(unit_id)
    }

    /// Initial slots of a unit's frame (its variables, then zeros, then its constants).
    pub(super) fn frame_template(&mut self, pou: PouId, unit: usize) -> Vec<u64> {
        let size = self.units[unit].size() as usize;
        let mut mem = vec![0u64; size];
        let layout = self.layout(pou);
        let vars = self.p.pou(pou).vars.clone();
        for (i, v) in vars.iter().enumerate() {
            if let (Some(off), false) = (layout.offsets[i], v.class == VarClass::InOut) {
                self.write_init(&mut mem, off as usize, v.ty, v.init.as_ref());
            }
        }
        let u = &self.units[unit];
        let cbase = (u.vars + u.temps) as usize;
        for (k, c) in u.consts.iter().enumerate() {
            mem[cbase + k] = *c;
        }
        mem
    }

    /// Writes the initial value of a `ty` at `at` (the type's default where `init` is None).
    pub(super) fn write_init(
        &mut self,
        mem: &mut [u64],
        at: usize,
        ty: TypeId,
        init: Option<&Value>,
    ) {
        let p = self.p;
        match p.types.get(ty).clone() {
            Type::Elem(e) => {
                let v = init.cloned().unwrap_or(if e.is_real() {
                    Value::Real(0.0)
                } else {
                    Value::Int(0)
                });
                mem[at] = ext::put_value(&v, e);
            }
            Type::Enum { values, .. } => {
                let v = init
                    .and_then(Value::as_int)
                    .unwrap_or(values.first().map_or(0, |v| v.1 as i128));
                mem[at] = v as i64 as u64;
            }
            Type::Subrange { lo, base, .. } => {
                let v = init.cloned().unwrap_or(Value::Int(lo));
                mem[at] = ext::put_value(&v, base);
            }
            Type::Str { len, wide } => match init {
                Some(Value::Str(s)) if !wide => ext::write_str(mem, at, s, len),
                Some(Value::WStr(w)) if wide => ext::write_units(mem, at, w, len.saturating_mul(2)),
                _ => {}
            },
            Type::Array { elem, .. } => {
                let n = p.types.element_count(ty) as usize;
                let es = self.sizes.of(p, elem).unwrap_or(1) as usize;
                let items = match init {
                    Some(Value::Array(items)) => Some(items),
                    _ => None,
                };
                for k in 0..n {
                    let item = items.and_then(|it| it.get(k));
                    self.write_init(mem, at + k * es, elem, item);
                }
            }
            Type::Struct { fields, .. } => {
                let offs = self.sizes.field_offsets(p, ty);
                for (k, f) in fields.iter().enumerate() {
                    let given = match init {
                        Some(Value::Fields(fs)) => {
                            fs.iter().find(|(i, _)| *i == k as u32).map(|(_, v)| v)
                        }
                        _ => None,
                    };
                    let v = given.or(f.init.as_ref()).cloned();
                    self.write_init(mem, at + offs[k] as usize, f.ty, v.as_ref());
                }
            }
            Type::Fb(FbRef::User(q)) => {
                if let Some(t) = self.fb_templates.get(&q) {
                    mem[at..at + t.len()].copy_from_slice(t);
                }
                if let Some(Value::Fields(fs)) = init {
                    let layout = self.layout(q);
                    for (i, v) in fs {
                        let vty = p.pou(q).vars[*i as usize].ty;
                        if let Some(off) = layout.offsets[*i as usize] {
                            self.write_init(mem, at + off as usize, vty, Some(v));
                        }
                    }
                }
            }
            Type::Fb(FbRef::Native(k)) => {
                let sig = &p.natives[k as usize];
                for (i, s) in crate::native::initial_slots(sig).into_iter().enumerate() {
                    mem[at + i] = s;
                }
                if let Some(Value::Fields(fs)) = init {
                    for (i, v) in fs {
                        mem[at + *i as usize] = ext::put_value(v, sig.vars[*i as usize].ty);
                    }
                }
            }
            _ => {}
        }
    }
}

fn merge_ranges(mut v: Vec<(u32, u32)>) -> Vec<(u32, u32)> {
    v.sort();
    let mut out: Vec<(u32, u32)> = Vec::new();
    for (o, n) in v {
        if let Some(last) = out.last_mut() {
            if last.0 + last.1 == o {
                last.1 += n;
                continue;
            }
        }
        out.push((o, n));
    }
    out
}
