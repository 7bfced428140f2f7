//! The checked form compiled to bytecode.
//!
//! Each function block type is compiled once, addressing its instance relative to a base
//! (so arrays of instances work); programs (one unit per program instance), functions (one
//! static frame each: IEC forbids recursion) and the configuration's glue are compiled with
//! absolute addresses, so they read globals directly. A unit's frame is its variables, then
//! its temporaries, then its constants. Operands are tagged while compiling (own variable,
//! temporary, constant, absolute symbol) and relocated when the units are linked, after the
//! memory is laid out.

use std::collections::HashMap;

use petriplc_iec_sema::ir::{
    self, BinaryOp, Builtin, Expr, ExprKind, FbCall, FnCall, Place, PouId, PouKind, Project, Root,
    Step, Stmt, StmtKind, UnaryOp, VarClass,
};
use petriplc_iec_sema::types::{Elem, FbRef, Type, TypeId};
use petriplc_iec_sema::value::{self, Value};
use petriplc_iec_syntax::source::Span;

use crate::ext::{self, ExtOp, Kind};
use crate::layout::{self, FrameLayout, Sizes};
use crate::op::{int_class, Arith, ArrayInfo, Cmp, IntClass, Op};

const TAG: u32 = 0xC000_0000;
const FRAME: u32 = 0x0000_0000;
const TEMP: u32 = 0x4000_0000;
const CONST: u32 = 0x8000_0000;
const SYM: u32 = 0xC000_0000;
const MAX_OFF: u32 = 0x3FFF_FFFF;

/// Why a project could not be compiled (limits the checker does not know).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CompileError {
    #[error("the program needs more than {MAX_OFF} memory slots")]
    TooLarge,
    #[error("{0}")]
    Unsupported(String),
}

/// A program instance to run: from the configuration, or one made for a chosen PROGRAM.
#[derive(Clone, Debug)]
pub struct InstanceSpec {
    pub name: String,
    pub pou: PouId,
    pub task: Option<u32>,
    pub inputs: Vec<(ir::VarId, Expr)>,
    pub outputs: Vec<(ir::VarId, Place)>,
}

/// A linked program: bytecode, side tables, the memory's layout and initial image.
#[derive(Debug)]
pub struct Code {
    pub ops: Vec<Op>,
    pub ext: Vec<ExtOp>,
    /// Literals of [`Op::AndLits`] / [`Op::OrLits`]: (slot, 1 to negate).
    pub lits: Vec<(u32, u64)>,
    /// Stores of [`Op::CondStore`]: (slot, value).
    pub stores: Vec<(u32, u64)>,
    pub arrays: Vec<ArrayInfo>,
    /// `(first pc, POU index or u32::MAX for configuration code, line)`, sorted by pc.
    pub lines: Vec<(u32, u32, u32)>,
    pub init: Vec<u64>,
    pub sizes: Sizes,
    /// Per POU: where its variables sit in its frame.
    pub layouts: Vec<FrameLayout>,
    pub global_addr: Vec<u32>,
    pub instances: Vec<InstanceRt>,
    /// Slots of each native function block's instance.
    pub native_sizes: Vec<u32>,
}

/// A program instance in memory.
#[derive(Clone, Debug)]
pub struct InstanceRt {
    pub name: String,
    pub pou: PouId,
    pub task: Option<u32>,
    /// Address of the instance's frame.
    pub frame: u32,
    /// Entry of the glue that sets its inputs, runs it and copies its outputs.
    pub entry: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Region {
    Global(u32),
    Unit(usize),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Target {
    Unit(usize),
}

#[derive(Debug, Default)]
struct Unit {
    ops: Vec<Op>,
    ext: Vec<ExtOp>,
    lits: Vec<(u32, u64)>,
    stores: Vec<(u32, u64)>,
    arrays: Vec<ArrayInfo>,
    lines: Vec<(u32, u32)>,
    vars: u32,
    temps: u32,
    consts: Vec<u64>,
    rel: bool,
    /// `(op index, callee)` to resolve when linking.
    calls: Vec<(usize, Target)>,
    pou: Option<PouId>,
    /// Program instance frame: the instance's POU.
    frame_pou: Option<PouId>,
}

impl Unit {
    fn size(&self) -> u32 {
        self.vars + self.temps + self.consts.len() as u32
    }
}

/// Where a value lives while compiling.
#[derive(Clone, Copy, Debug)]
enum Loc {
    /// A slot operand of the unit (tagged).
    Slot(u32),
    /// An absolute place the unit cannot name directly (relative code reading a global).
    Abs(Region, u32),
    /// Through a pointer slot, plus an offset.
    Ind(u32, u32),
}

struct PlaceLoc {
    loc: Loc,
    bit: Option<u8>,
}

pub struct Compiler<'p> {
    p: &'p Project,
    line_of: &'p dyn Fn(Span) -> u32,
    sizes: Sizes,
    layouts: Vec<Option<FrameLayout>>,
    units: Vec<Unit>,
    syms: Vec<(Region, u32)>,
    sym_index: HashMap<(Region, u32), u32>,
    pou_unit: Vec<Option<usize>>,
    fb_templates: HashMap<PouId, Vec<u64>>,
}

/// Compiles a checked project for the given program instances.
pub fn compile(
    p: &Project,
    instances: &[InstanceSpec],
    line_of: &dyn Fn(Span) -> u32,
) -> Result<Code, CompileError> {
    let mut c = Compiler {
        p,
        line_of,
        sizes: Sizes {
            fb: vec![None; p.pous.len()],
        },
        layouts: vec![None; p.pous.len()],
        units: Vec::new(),
        syms: Vec::new(),
        sym_index: HashMap::new(),
        pou_unit: vec![None; p.pous.len()],
        fb_templates: HashMap::new(),
    };
    // Functions get their units first (any code may call them), then function blocks are
    // compiled, contained ones before their containers, then functions and programs.
    let mut functions = Vec::new();
    for (i, pou) in p.pous.iter().enumerate() {
        if pou.kind == PouKind::Function && pou.runnable {
            let u = c.units.len();
            c.units.push(Unit {
                pou: Some(i as PouId),
                frame_pou: Some(i as PouId),
                ..Unit::default()
            });
            c.pou_unit[i] = Some(u);
            functions.push((i as PouId, u));
        }
    }
    let order = c.fb_order();
    for fb in order {
        if p.pou(fb).runnable {
            c.compile_pou(fb, None, None)?;
        }
    }
    for (f, u) in functions {
        c.compile_pou(f, None, Some(u))?;
    }
    let mut prog_units = Vec::new();
    for inst in instances {
        let u = c.compile_pou(inst.pou, Some(inst), None)?;
        prog_units.push(u);
    }
    let mut glue_units = Vec::new();
    for (i, inst) in instances.iter().enumerate() {
        glue_units.push(c.compile_glue(inst, prog_units[i])?);
    }
    c.link(instances, &prog_units, &glue_units)
}

fn elem_of(p: &Project, ty: TypeId) -> Option<Elem> {
    p.types.elem(ty)
}

fn is_string(p: &Project, ty: TypeId) -> bool {
    matches!(p.types.get(ty), Type::Str { .. })
}

fn str_cap(p: &Project, ty: TypeId) -> u32 {
    match p.types.get(ty) {
        Type::Str { len } => *len,
        _ => 0,
    }
}

/// Whether values of the type are one slot.
fn scalar(p: &Project, ty: TypeId) -> bool {
    matches!(
        p.types.get(ty),
        Type::Elem(_) | Type::Enum { .. } | Type::Subrange { .. } | Type::IntLit | Type::RealLit
    )
}

/// How an elementary (or enumeration) value computes.
fn elem_or_dint(p: &Project, ty: TypeId) -> Elem {
    match p.types.get(ty) {
        Type::Elem(e) | Type::Subrange { base: e, .. } => *e,
        Type::RealLit => Elem::Lreal,
        _ => Elem::Lint,
    }
}

fn kind(p: &Project, ty: TypeId) -> Kind {
    if is_string(p, ty) {
        Kind::S
    } else {
        ext::kind_of(elem_or_dint(p, ty))
    }
}

/// The raw slot of a constant scalar.
fn raw_const(p: &Project, v: &Value, ty: TypeId) -> u64 {
    ext::put_value(v, elem_or_dint(p, ty))
}

impl<'p> Compiler<'p> {
    /// Function blocks ordered so that every contained FB comes first.
    fn fb_order(&self) -> Vec<PouId> {
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

    fn layout(&mut self, pou: PouId) -> FrameLayout {
        if let Some(l) = &self.layouts[pou as usize] {
            return l.clone();
        }
        let l = layout::frame_layout(self.p, &self.sizes, pou);
        self.layouts[pou as usize] = Some(l.clone());
        l
    }

    fn sym(&mut self, r: Region, off: u32) -> u32 {
        let key = (r, off);
        if let Some(&i) = self.sym_index.get(&key) {
            return i;
        }
        let i = self.syms.len() as u32;
        self.syms.push(key);
        self.sym_index.insert(key, i);
        i
    }

    fn compile_pou(
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
        fx.emit(Op::Ret, p.span);
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
    fn compile_glue(
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
    fn frame_template(&mut self, pou: PouId, unit: usize) -> Vec<u64> {
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
    fn write_init(&mut self, mem: &mut [u64], at: usize, ty: TypeId, init: Option<&Value>) {
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
            Type::Str { len } => {
                if let Some(Value::Str(s)) = init {
                    ext::write_str(mem, at, s, len);
                }
            }
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

    fn link(
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
                ext_all.push(x);
            }
            arrays.extend(u.arrays.iter().copied());
            let pou = u.pou.unwrap_or(u32::MAX);
            for (pc, line) in &u.lines {
                lines.push((start + pc, pou, *line));
            }
        }
        // Initial image.
        let mut init = vec![0u64; addr as usize];
        for (g, v) in self.p.globals.iter().enumerate() {
            let a = global_addr[g] as usize;
            self.write_init(&mut init, a, v.ty, v.init.as_ref());
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
        })
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

/// A condition literal (slot, negated) and the constant stores it guards.
type CondStores = ((u32, bool), Vec<(u32, u64)>);

struct LoopCx {
    exits: Vec<usize>,
    continues: Vec<usize>,
}

/// The compilation of one unit.
struct Fx<'c, 'p> {
    c: &'c mut Compiler<'p>,
    unit: usize,
    pou: PouId,
    layout: FrameLayout,
    rel: bool,
    temp_top: u32,
    consts: HashMap<u64, u32>,
    loops: Vec<LoopCx>,
    /// Where each label of the body is (IL, SFC).
    labels: HashMap<u32, u32>,
    /// Forward jumps waiting for their label: (instruction, label).
    gotos: Vec<(usize, u32)>,
    line: u32,
    /// For configuration glue: the program instance's unit and layout.
    glue_of: Option<(usize, FrameLayout)>,
}

type R<T> = Result<T, CompileError>;

impl<'c, 'p> Fx<'c, 'p> {
    fn new(c: &'c mut Compiler<'p>, unit: usize, pou: PouId, layout: FrameLayout) -> Self {
        let rel = c.units[unit].rel;
        Fx {
            c,
            unit,
            pou,
            layout,
            rel,
            temp_top: 0,
            consts: HashMap::new(),
            loops: Vec::new(),
            labels: HashMap::new(),
            gotos: Vec::new(),
            line: 0,
            glue_of: None,
        }
    }

    fn unit(&mut self) -> &mut Unit {
        &mut self.c.units[self.unit]
    }

    fn p(&self) -> &'p Project {
        self.c.p
    }

    /// Points the forward jumps at their labels.
    fn finish(&mut self) -> R<()> {
        let _ = self.pou;
        for (at, label) in std::mem::take(&mut self.gotos) {
            let Some(&t) = self.labels.get(&label) else {
                return Err(CompileError::Unsupported(format!(
                    "a jump to label {label}, which the body does not have"
                )));
            };
            self.patch(at, t);
        }
        Ok(())
    }

    fn emit(&mut self, op: Op, span: Span) -> usize {
        let line = (self.c.line_of)(span);
        let u = &mut self.c.units[self.unit];
        let pc = u.ops.len();
        if line != self.line || u.lines.is_empty() {
            u.lines.push((pc as u32, line));
            self.line = line;
        }
        u.ops.push(op);
        pc
    }

    fn ext(&mut self, x: ExtOp, span: Span) {
        let u = &mut self.c.units[self.unit];
        let i = u.ext.len() as u32;
        u.ext.push(x);
        self.emit(Op::Ext { x: i }, span);
    }

    fn pc(&self) -> u32 {
        self.c.units[self.unit].ops.len() as u32
    }

    fn patch(&mut self, at: usize, target: u32) {
        match &mut self.c.units[self.unit].ops[at] {
            Op::Jmp { t }
            | Op::JmpF { t, .. }
            | Op::JmpT { t, .. }
            | Op::Loop { t }
            | Op::ForNext { t, .. } => *t = target,
            _ => {}
        }
    }

    fn temp(&mut self, n: u32) -> u32 {
        let t = self.temp_top;
        self.temp_top += n.max(1);
        let u = &mut self.c.units[self.unit];
        u.temps = u.temps.max(self.temp_top);
        TEMP | t
    }

    fn konst(&mut self, raw: u64) -> u32 {
        if let Some(&c) = self.consts.get(&raw) {
            return CONST | c;
        }
        let u = &mut self.c.units[self.unit];
        let c = u.consts.len() as u32;
        u.consts.push(raw);
        self.consts.insert(raw, c);
        CONST | c
    }

    /// A constant block (a string) in the constant area; returns its first operand.
    fn const_block(&mut self, slots: &[u64]) -> u32 {
        let u = &mut self.c.units[self.unit];
        let c = u.consts.len() as u32;
        u.consts.extend_from_slice(slots);
        CONST | c
    }

    fn region_loc(&mut self, r: Region, off: u32) -> Loc {
        if self.rel {
            Loc::Abs(r, off)
        } else {
            let s = self.c.sym(r, off);
            Loc::Slot(SYM | s)
        }
    }

    fn size(&self, ty: TypeId) -> u32 {
        self.c.sizes.of(self.c.p, ty).unwrap_or(1)
    }

    // ---- statements ----

    fn stmts(&mut self, stmts: &[Stmt]) -> R<()> {
        let mut i = 0;
        while i < stmts.len() {
            let mark = self.temp_top;
            let used = self.fused(&stmts[i..])?;
            if used == 0 {
                self.stmt(&stmts[i])?;
                i += 1;
            } else {
                i += used;
            }
            self.temp_top = mark;
        }
        Ok(())
    }

    /// A BOOL variable held in a slot of this unit, possibly negated: `x` or `NOT x`.
    fn bool_literal(&mut self, e: &Expr) -> R<Option<(u32, bool)>> {
        let (inner, neg) = match &e.kind {
            ExprKind::Unary(UnaryOp::Not, x) => (&**x, true),
            _ => (e, false),
        };
        if inner.ty != petriplc_iec_sema::types::ids::BOOL {
            return Ok(None);
        }
        if let ExprKind::Load(p) = &inner.kind {
            if p.path
                .iter()
                .all(|s| matches!(s, Step::Field(_) | Step::Member(_)))
            {
                let pl = self.place_loc(p)?;
                if let (Loc::Slot(x), None) = (pl.loc, pl.bit) {
                    return Ok(Some((x, neg)));
                }
            }
        }
        Ok(None)
    }

    /// Compiles a run of statements that fuse into one instruction; returns how many it
    /// took (0: none fuse).
    fn fused(&mut self, stmts: &[Stmt]) -> R<usize> {
        // IF c THEN x := k; … END_IF, repeated with the same c: one CondStore.
        let cond_stores = |me: &mut Self, s: &Stmt| -> R<Option<CondStores>> {
            let StmtKind::If {
                branches,
                else_body,
            } = &s.kind
            else {
                return Ok(None);
            };
            if branches.len() != 1 || !else_body.is_empty() || branches[0].1.is_empty() {
                return Ok(None);
            }
            let Some(lit) = me.bool_literal(&branches[0].0)? else {
                return Ok(None);
            };
            let mut stores = Vec::new();
            for b in &branches[0].1 {
                let StmtKind::Assign { target, value } = &b.kind else {
                    return Ok(None);
                };
                let ExprKind::Const(v) = &value.kind else {
                    return Ok(None);
                };
                if !scalar(me.p(), target.ty)
                    || target
                        .path
                        .iter()
                        .any(|s| matches!(s, Step::Index(_) | Step::Bit(_)))
                {
                    return Ok(None);
                }
                let pl = me.place_loc(target)?;
                let Loc::Slot(d) = pl.loc else {
                    return Ok(None);
                };
                if pl.bit.is_some() {
                    return Ok(None);
                }
                stores.push((d, raw_const(me.p(), v, target.ty)));
            }
            Ok(Some((lit, stores)))
        };
        if let Some((lit, mut stores)) = cond_stores(self, &stmts[0])? {
            let mut used = 1;
            // A store to the condition ends the group (later IFs must see it).
            if !stores.iter().any(|(d, _)| *d == lit.0) {
                while used < stmts.len() {
                    match cond_stores(self, &stmts[used])? {
                        Some((l2, more)) if l2 == lit => {
                            let stop = more.iter().any(|(d, _)| *d == lit.0);
                            stores.extend(more);
                            used += 1;
                            if stop {
                                break;
                            }
                        }
                        _ => break,
                    }
                }
            }
            let span = stmts[0].span;
            if stores.len() == 1 {
                let (d, k) = stores[0];
                let op = if lit.1 {
                    Op::CondNotMovK { c: lit.0, d, k }
                } else {
                    Op::CondMovK { c: lit.0, d, k }
                };
                self.emit(op, span);
            } else {
                let u = &mut self.c.units[self.unit];
                let start = u.stores.len() as u32;
                u.stores.extend(stores.iter().copied());
                let len = stores.len() as u32;
                self.emit(
                    Op::CondStore {
                        c: lit.0,
                        neg: lit.1,
                        start,
                        len,
                    },
                    span,
                );
            }
            return Ok(used);
        }
        // x1 := y1; x2 := y2; … with consecutive slots on both sides: one MovN.
        let plain_move = |me: &mut Self, s: &Stmt| -> R<Option<(u32, u32)>> {
            let StmtKind::Assign { target, value } = &s.kind else {
                return Ok(None);
            };
            let ExprKind::Load(src) = &value.kind else {
                return Ok(None);
            };
            if target.ty != src.ty
                || !scalar(me.p(), target.ty)
                || matches!(me.p().types.get(target.ty), Type::Subrange { .. })
            {
                return Ok(None);
            }
            let no_index = |p: &Place| {
                p.path
                    .iter()
                    .all(|s| matches!(s, Step::Field(_) | Step::Member(_)))
            };
            if !no_index(target) || !no_index(src) {
                return Ok(None);
            }
            let (d, sl) = (me.place_loc(target)?, me.place_loc(src)?);
            match (d.loc, d.bit, sl.loc, sl.bit) {
                (Loc::Slot(d), None, Loc::Slot(s), None)
                    if d & TAG == FRAME && s & TAG == FRAME =>
                {
                    Ok(Some((d, s)))
                }
                _ => Ok(None),
            }
        };
        if let Some((d0, s0)) = plain_move(self, &stmts[0])? {
            let mut n = 1u32;
            while (n as usize) < stmts.len() {
                match plain_move(self, &stmts[n as usize])? {
                    Some((d, s)) if d == d0 + n && s == s0 + n => n += 1,
                    _ => break,
                }
            }
            // Overlapping ranges would change what sequential assignments do.
            let overlap = d0 < s0 + n && s0 < d0 + n;
            if n >= 3 && !overlap {
                self.emit(Op::MovN { d: d0, s: s0, n }, stmts[0].span);
                return Ok(n as usize);
            }
        }
        Ok(0)
    }

    fn stmt(&mut self, s: &Stmt) -> R<()> {
        let span = s.span;
        match &s.kind {
            StmtKind::Assign { target, value } => {
                let dst = self.place_loc(target)?;
                self.store_expr(&dst, target.ty, value)?;
            }
            StmtKind::CallFb(call) => self.call_fb(call, span)?,
            StmtKind::Eval(e) => {
                self.expr(e, None)?;
            }
            StmtKind::If {
                branches,
                else_body,
            } => self.if_stmt(branches, else_body, span)?,
            StmtKind::Case {
                selector,
                arms,
                else_body,
            } => self.case(selector, arms, else_body, span)?,
            StmtKind::For(f) => self.for_loop(&f.var, &f.from, &f.to, &f.by, &f.body, span)?,
            StmtKind::While { cond, body } => {
                let top = self.pc();
                let c = self.expr(cond, None)?;
                let exit = self.emit(Op::JmpF { c, t: 0 }, span);
                self.loops.push(LoopCx {
                    exits: vec![exit],
                    continues: Vec::new(),
                });
                self.stmts(body)?;
                self.emit(Op::Loop { t: top }, span);
                let l = self.loops.pop().unwrap_or(LoopCx {
                    exits: vec![],
                    continues: vec![],
                });
                let end = self.pc();
                for e in l.exits {
                    self.patch(e, end);
                }
                for c in l.continues {
                    self.patch(c, top);
                }
            }
            StmtKind::Repeat { body, until } => {
                let top = self.pc();
                self.loops.push(LoopCx {
                    exits: Vec::new(),
                    continues: Vec::new(),
                });
                self.stmts(body)?;
                let cond_pc = self.pc();
                let c = self.expr(until, None)?;
                let done = self.emit(Op::JmpT { c, t: 0 }, span);
                self.emit(Op::Loop { t: top }, span);
                let l = self.loops.pop().unwrap_or(LoopCx {
                    exits: vec![],
                    continues: vec![],
                });
                let end = self.pc();
                self.patch(done, end);
                for e in l.exits {
                    self.patch(e, end);
                }
                for c in l.continues {
                    self.patch(c, cond_pc);
                }
            }
            StmtKind::Exit => {
                let at = self.emit(Op::Jmp { t: 0 }, span);
                if let Some(l) = self.loops.last_mut() {
                    l.exits.push(at);
                }
            }
            StmtKind::Continue => {
                let at = self.emit(Op::Jmp { t: 0 }, span);
                if let Some(l) = self.loops.last_mut() {
                    l.continues.push(at);
                }
            }
            StmtKind::Return => {
                self.emit(Op::Ret, span);
            }
            StmtKind::Label(l) => {
                let here = self.pc();
                self.labels.insert(*l, here);
            }
            StmtKind::Goto { label, cond } => self.goto(*label, cond.as_ref(), span)?,
        }
        Ok(())
    }

    fn if_stmt(&mut self, branches: &[(Expr, Vec<Stmt>)], else_body: &[Stmt], span: Span) -> R<()> {
        // IF c THEN x := constant; END_IF → one instruction.
        if branches.len() == 1 && else_body.is_empty() && branches[0].1.len() == 1 {
            if let StmtKind::Assign { target, value } = &branches[0].1[0].kind {
                if let (ExprKind::Const(v), true) = (&value.kind, scalar(self.p(), target.ty)) {
                    let dst = self.place_loc(target)?;
                    if let (Loc::Slot(d), None) = (dst.loc, dst.bit) {
                        let k = raw_const(self.p(), v, target.ty);
                        let k = self.store_raw_for(target.ty, k);
                        let (c, negated) = self.cond_operand(&branches[0].0)?;
                        let op = if negated {
                            Op::CondNotMovK { c, d, k }
                        } else {
                            Op::CondMovK { c, d, k }
                        };
                        self.emit(op, branches[0].1[0].span);
                        return Ok(());
                    }
                }
            }
        }
        let mut ends = Vec::new();
        for (i, (cond, body)) in branches.iter().enumerate() {
            let mark = self.temp_top;
            let (c, negated) = self.cond_operand(cond)?;
            self.temp_top = mark;
            let skip = if negated {
                self.emit(Op::JmpT { c, t: 0 }, cond.span)
            } else {
                self.emit(Op::JmpF { c, t: 0 }, cond.span)
            };
            self.stmts(body)?;
            let last = i + 1 == branches.len() && else_body.is_empty();
            if !last {
                ends.push(self.emit(Op::Jmp { t: 0 }, span));
            }
            let here = self.pc();
            self.patch(skip, here);
        }
        self.stmts(else_body)?;
        let end = self.pc();
        for e in ends {
            self.patch(e, end);
        }
        Ok(())
    }

    /// A jump to a label. A jump back (a loop) spends the scan's iteration budget, so a body
    /// that jumps back for ever faults like an endless WHILE.
    fn goto(&mut self, label: u32, cond: Option<&(Expr, bool)>, span: Span) -> R<()> {
        let back = self.labels.get(&label).copied();
        let mark = self.temp_top;
        let test = match cond {
            Some((c, flag)) => {
                let (slot, negated) = self.cond_operand(c)?;
                Some((slot, *flag != negated))
            }
            None => None,
        };
        self.temp_top = mark;
        match (back, test) {
            (Some(t), None) => {
                self.emit(Op::Loop { t }, span);
            }
            (Some(t), Some((c, when))) => {
                let skip = if when {
                    self.emit(Op::JmpF { c, t: 0 }, span)
                } else {
                    self.emit(Op::JmpT { c, t: 0 }, span)
                };
                self.emit(Op::Loop { t }, span);
                let here = self.pc();
                self.patch(skip, here);
            }
            (None, None) => {
                let at = self.emit(Op::Jmp { t: 0 }, span);
                self.gotos.push((at, label));
            }
            (None, Some((c, when))) => {
                let at = if when {
                    self.emit(Op::JmpT { c, t: 0 }, span)
                } else {
                    self.emit(Op::JmpF { c, t: 0 }, span)
                };
                self.gotos.push((at, label));
            }
        }
        Ok(())
    }

    /// A condition's slot, and whether it is negated (`NOT x` tests x).
    fn cond_operand(&mut self, cond: &Expr) -> R<(u32, bool)> {
        if let ExprKind::Unary(UnaryOp::Not, inner) = &cond.kind {
            if inner.ty == petriplc_iec_sema::types::ids::BOOL {
                return Ok((self.expr(inner, None)?, true));
            }
        }
        Ok((self.expr(cond, None)?, false))
    }

    /// The raw slot stored for a constant of `ty` (REAL constants already rounded).
    fn store_raw_for(&self, _ty: TypeId, raw: u64) -> u64 {
        raw
    }

    fn case(
        &mut self,
        selector: &Expr,
        arms: &[ir::CaseArm],
        else_body: &[Stmt],
        span: Span,
    ) -> R<()> {
        let sel = self.expr(selector, None)?;
        let sel = if matches!(self.temp_tag(sel), Some(TEMP)) {
            sel
        } else {
            // Keep the selector's value even if a branch changes it.
            let t = self.temp(1);
            self.emit(Op::Mov { d: t, s: sel }, span);
            t
        };
        let unsigned = matches!(
            elem_of(self.p(), selector.ty),
            Some(Elem::Ulint | Elem::Lword)
        );
        let cmp = |op: Cmp, d: u32, a: u32, b: u32| {
            if unsigned {
                Op::CmpU { op, d, a, b }
            } else {
                Op::CmpI { op, d, a, b }
            }
        };
        let t = self.temp(1);
        let t2 = self.temp(1);
        let mut arm_jumps: Vec<Vec<usize>> = Vec::new();
        for arm in arms {
            let mut jumps = Vec::new();
            for (lo, hi) in &arm.ranges {
                let klo = self.konst(*lo as i64 as u64);
                if lo == hi {
                    self.emit(cmp(Cmp::Eq, t, sel, klo), span);
                } else {
                    let khi = self.konst(*hi as i64 as u64);
                    self.emit(cmp(Cmp::Ge, t, sel, klo), span);
                    self.emit(cmp(Cmp::Le, t2, sel, khi), span);
                    self.emit(Op::And { d: t, a: t, b: t2 }, span);
                }
                jumps.push(self.emit(Op::JmpT { c: t, t: 0 }, span));
            }
            arm_jumps.push(jumps);
        }
        let mut ends = Vec::new();
        self.stmts(else_body)?;
        ends.push(self.emit(Op::Jmp { t: 0 }, span));
        for (arm, jumps) in arms.iter().zip(arm_jumps) {
            let here = self.pc();
            for j in jumps {
                self.patch(j, here);
            }
            self.stmts(&arm.body)?;
            ends.push(self.emit(Op::Jmp { t: 0 }, span));
        }
        let end = self.pc();
        for e in ends {
            self.patch(e, end);
        }
        Ok(())
    }

    fn temp_tag(&self, x: u32) -> Option<u32> {
        Some(x & TAG)
    }

    fn for_loop(
        &mut self,
        var: &Place,
        from: &Expr,
        to: &Expr,
        by: &Expr,
        body: &[Stmt],
        span: Span,
    ) -> R<()> {
        let v = self.place_loc(var)?;
        let Loc::Slot(vs) = v.loc else {
            return Err(CompileError::Unsupported(
                "a FOR control variable must be a variable of the POU itself".into(),
            ));
        };
        let e = elem_or_dint(self.p(), var.ty);
        // Bounds and step are evaluated once, before the first iteration.
        let x = self.expr(from, None)?;
        let t_from = self.temp(1);
        self.emit(Op::Mov { d: t_from, s: x }, span);
        let t_to = self.temp(1);
        let x = self.expr(to, Some(t_to))?;
        if x != t_to {
            self.emit(Op::Mov { d: t_to, s: x }, span);
        }
        let t_by = self.temp(1);
        let x = self.expr(by, Some(t_by))?;
        if x != t_by {
            self.emit(Op::Mov { d: t_by, s: x }, span);
        }
        self.emit(Op::Mov { d: vs, s: t_from }, span);
        if by.const_int().is_none() {
            self.ext(ExtOp::NonZeroStep { s: t_by }, by.span);
        }
        let (r, u) = match int_class(e) {
            IntClass::Narrow(r) => (r, false),
            IntClass::Long => (7, false),
            IntClass::ULong => (8, true),
        };
        // Entry test: by > 0 ? v <= to : v >= to.
        let cmp = |op: Cmp, d: u32, a: u32, b: u32| {
            if u {
                Op::CmpU { op, d, a, b }
            } else {
                Op::CmpI { op, d, a, b }
            }
        };
        let t_c = self.temp(1);
        let negative = by.const_int().map(|k| k < 0);
        match negative {
            Some(false) => {
                self.emit(cmp(Cmp::Le, t_c, vs, t_to), span);
            }
            Some(true) => {
                self.emit(cmp(Cmp::Ge, t_c, vs, t_to), span);
            }
            None => {
                let zero = self.konst(0);
                let t_pos = self.temp(1);
                let t_a = self.temp(1);
                self.emit(
                    Op::CmpI {
                        op: Cmp::Gt,
                        d: t_pos,
                        a: t_by,
                        b: zero,
                    },
                    span,
                );
                self.emit(cmp(Cmp::Le, t_a, vs, t_to), span);
                self.emit(
                    Op::And {
                        d: t_a,
                        a: t_a,
                        b: t_pos,
                    },
                    span,
                );
                self.emit(cmp(Cmp::Ge, t_c, vs, t_to), span);
                self.emit(
                    Op::AndN {
                        d: t_c,
                        a: t_c,
                        b: t_pos,
                    },
                    span,
                );
                self.emit(
                    Op::Or {
                        d: t_c,
                        a: t_c,
                        b: t_a,
                    },
                    span,
                );
            }
        }
        let exit = self.emit(Op::JmpF { c: t_c, t: 0 }, span);
        let body_start = self.pc();
        self.loops.push(LoopCx {
            exits: vec![exit],
            continues: Vec::new(),
        });
        self.stmts(body)?;
        let cont = self.pc();
        self.emit(
            Op::ForNext {
                v: vs,
                to: t_to,
                by: t_by,
                t: body_start,
                r,
                u,
            },
            span,
        );
        let l = self.loops.pop().unwrap_or(LoopCx {
            exits: vec![],
            continues: vec![],
        });
        let end = self.pc();
        for x in l.exits {
            self.patch(x, end);
        }
        for c in l.continues {
            self.patch(c, cont);
        }
        Ok(())
    }

    // ---- places ----

    fn place_loc(&mut self, p: &Place) -> R<PlaceLoc> {
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
        };
        let mut bit = None;
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
                Step::Bit(n) => bit = Some(*n as u8),
            }
        }
        Ok(PlaceLoc { loc, bit })
    }

    fn glue_var_ty(&self, v: ir::VarId) -> TypeId {
        let (prog, _) = self.glue_of.as_ref().map(|x| (x.0, ())).unwrap_or((0, ()));
        let pou = self.c.units[prog].pou.unwrap_or(0);
        self.c.p.pou(pou).vars[v as usize].ty
    }

    fn offset(&mut self, loc: Loc, k: u32) -> Loc {
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
    fn addr_of(&mut self, loc: Loc, span: Span) -> R<u32> {
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
    fn load_loc(&mut self, loc: Loc, span: Span) -> R<u32> {
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

    fn store_loc(&mut self, loc: Loc, s: u32, span: Span) {
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

    fn load_place(&mut self, pl: &PlaceLoc, span: Span) -> R<u32> {
        let w = self.load_loc(pl.loc, span)?;
        match pl.bit {
            None => Ok(w),
            Some(n) => {
                let d = self.temp(1);
                self.emit(Op::GetBit { d, s: w, n }, span);
                Ok(d)
            }
        }
    }

    /// Stores a scalar value into a place (a bit: read, set, write back).
    fn store_place(&mut self, pl: &PlaceLoc, s: u32, span: Span) -> R<()> {
        match pl.bit {
            None => self.store_loc(pl.loc, s, span),
            Some(n) => {
                let w = self.load_loc(pl.loc, span)?;
                let t = self.temp(1);
                self.emit(
                    Op::SetBit {
                        d: t,
                        s: w,
                        n,
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
    fn store_expr(&mut self, dst: &PlaceLoc, ty: TypeId, e: &Expr) -> R<()> {
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
    fn copy_loc(&mut self, src: Loc, ty: TypeId, dst: &PlaceLoc, dty: TypeId, span: Span) -> R<()> {
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

    // ---- expressions ----

    /// Computes `e`; returns the slot holding its value (a pointer for strings and other
    /// aggregates). With `want`, the last instruction writes there when it can.
    fn expr(&mut self, e: &Expr, want: Option<u32>) -> R<u32> {
        let span = e.span;
        let p = self.p();
        match &e.kind {
            ExprKind::Const(v) => {
                if let Value::Str(s) = v {
                    let mut slots =
                        vec![0u64; layout::string_slots(s.len().max(1) as u32) as usize];
                    ext::write_str(&mut slots, 0, s, s.len() as u32);
                    let c = self.const_block(&slots);
                    let d = self.temp(1);
                    self.emit(Op::Lea { d, s: c }, span);
                    return Ok(d);
                }
                if !scalar(p, e.ty) {
                    // An aggregate constant (never produced by the checker for expressions).
                    return Err(CompileError::Unsupported("aggregate constant".into()));
                }
                let raw = raw_const(p, v, e.ty);
                match want {
                    Some(d) => {
                        self.emit(Op::MovK { d, k: raw }, span);
                        Ok(d)
                    }
                    None => Ok(self.konst(raw)),
                }
            }
            ExprKind::Load(place) => {
                let pl = self.place_loc(place)?;
                if scalar(p, place.ty) {
                    if let (Some(d), None, Loc::Abs(..) | Loc::Ind(..)) = (want, pl.bit, pl.loc) {
                        // Load straight into the destination.
                        match pl.loc {
                            Loc::Abs(r, off) => {
                                let s = self.c.sym(r, off);
                                self.emit(Op::LdG { d, g: SYM | s }, span);
                            }
                            Loc::Ind(pp, off) => {
                                self.emit(Op::LdI { d, p: pp, off }, span);
                            }
                            Loc::Slot(_) => {}
                        }
                        return Ok(d);
                    }
                    if let (Some(d), Some(n)) = (want, pl.bit) {
                        let w = self.load_loc(pl.loc, span)?;
                        self.emit(Op::GetBit { d, s: w, n }, span);
                        return Ok(d);
                    }
                    self.load_place(&pl, span)
                } else {
                    self.addr_of(pl.loc, span)
                }
            }
            ExprKind::Unary(op, x) => {
                let a = self.expr(x, None)?;
                let d = want.unwrap_or_else(|| self.temp(1));
                let el = elem_or_dint(p, x.ty);
                match op {
                    UnaryOp::Plus => {
                        if d != a {
                            self.emit(Op::Mov { d, s: a }, span);
                        }
                    }
                    UnaryOp::Not => {
                        if el == Elem::Bool {
                            self.emit(Op::Not { d, s: a }, span);
                        } else {
                            self.emit(
                                Op::BNot {
                                    d,
                                    s: a,
                                    bits: el.bits() as u8,
                                },
                                span,
                            );
                        }
                    }
                    UnaryOp::Neg => {
                        if el.is_real() {
                            self.emit(Op::NegF { d, s: a }, span);
                        } else {
                            match int_class(el) {
                                IntClass::Narrow(r) => self.emit(Op::NegN { d, s: a, r }, span),
                                _ => self.emit(Op::NegL { d, s: a }, span),
                            };
                        }
                    }
                }
                Ok(d)
            }
            ExprKind::Binary(op, a, b) => self.binary(*op, a, b, e.ty, want, span),
            ExprKind::Convert(x) => self.convert(x, e.ty, want, span),
            ExprKind::Trunc(x) => {
                let s = self.expr(x, None)?;
                let d = want.unwrap_or_else(|| self.temp(1));
                let to = elem_or_dint(p, e.ty);
                self.ext(ExtOp::Trunc { d, s, to }, span);
                Ok(d)
            }
            ExprKind::Call(call) => self.call_fn(call, e.ty, want, span),
            ExprKind::Builtin(b, args) => self.builtin(*b, args, e.ty, want, span),
        }
    }

    /// The operands of a chain `a op b op c …` (left-nested).
    fn chain<'e>(e: &'e Expr, op: BinaryOp, out: &mut Vec<&'e Expr>) {
        match &e.kind {
            ExprKind::Binary(o, a, b)
                if *o == op && e.ty == petriplc_iec_sema::types::ids::BOOL =>
            {
                Self::chain(a, op, out);
                Self::chain(b, op, out);
            }
            _ => out.push(e),
        }
    }

    fn binary(
        &mut self,
        op: BinaryOp,
        a: &Expr,
        b: &Expr,
        ty: TypeId,
        want: Option<u32>,
        span: Span,
    ) -> R<u32> {
        let p = self.p();
        let (ae, be) = (elem_or_dint(p, a.ty), elem_or_dint(p, b.ty));
        // Chains of three or more BOOL terms: one instruction over their literals.
        if matches!(op, BinaryOp::And | BinaryOp::Or) && ae == Elem::Bool {
            let mut terms = Vec::new();
            Self::chain(a, op, &mut terms);
            Self::chain(b, op, &mut terms);
            if terms.len() >= 3 {
                let mut lits = Vec::with_capacity(terms.len());
                for t in terms {
                    let lit = match self.bool_literal(t)? {
                        Some(l) => l,
                        None => {
                            // Computed first (all terms are evaluated, as IEC does).
                            let x = self.expr(t, None)?;
                            (x, false)
                        }
                    };
                    lits.push((lit.0, lit.1 as u64));
                }
                let d = want.unwrap_or_else(|| self.temp(1));
                let u = &mut self.c.units[self.unit];
                let start = u.lits.len() as u32;
                let len = lits.len() as u32;
                u.lits.extend(lits);
                let o = if op == BinaryOp::And {
                    Op::AndLits { d, start, len }
                } else {
                    Op::OrLits { d, start, len }
                };
                self.emit(o, span);
                return Ok(d);
            }
        }
        // a AND NOT b, a OR NOT b on BOOL.
        if matches!(op, BinaryOp::And | BinaryOp::Or) && ae == Elem::Bool {
            if let ExprKind::Unary(UnaryOp::Not, inner) = &b.kind {
                let x = self.expr(a, None)?;
                let y = self.expr(inner, None)?;
                let d = want.unwrap_or_else(|| self.temp(1));
                let o = if op == BinaryOp::And {
                    Op::AndN { d, a: x, b: y }
                } else {
                    Op::OrN { d, a: x, b: y }
                };
                self.emit(o, span);
                return Ok(d);
            }
            if let ExprKind::Unary(UnaryOp::Not, inner) = &a.kind {
                let y = self.expr(inner, None)?;
                let x = self.expr(b, None)?;
                let d = want.unwrap_or_else(|| self.temp(1));
                let o = if op == BinaryOp::And {
                    Op::AndN { d, a: x, b: y }
                } else {
                    Op::OrN { d, a: x, b: y }
                };
                self.emit(o, span);
                return Ok(d);
            }
        }
        let x = self.expr(a, None)?;
        let y = self.expr(b, None)?;
        let d = want.unwrap_or_else(|| self.temp(1));
        let re = elem_or_dint(p, ty);
        // Durations and dates of one type: LINT arithmetic, but an overflow is told in T#…
        if ae == be
            && (ae.is_duration() || ae.is_date())
            && matches!(op, BinaryOp::Add | BinaryOp::Sub)
        {
            self.ext(
                ExtOp::TimeAdd {
                    d,
                    a: x,
                    b: y,
                    sub: op == BinaryOp::Sub,
                    of: ae,
                    to: re,
                },
                span,
            );
            return Ok(d);
        }
        // Time arithmetic with mixed types.
        if ae != be && (ae.is_duration() || ae.is_date()) {
            match (op, ae, be) {
                (BinaryOp::Mul | BinaryOp::Div, _, _) => {
                    self.ext(
                        ExtOp::TimeScale {
                            d,
                            a: x,
                            b: y,
                            div: op == BinaryOp::Div,
                            real: be.is_real(),
                        },
                        span,
                    );
                }
                (_, Elem::Tod, Elem::Time | Elem::Ltime) if re == Elem::Tod => {
                    self.ext(
                        ExtOp::TodAdd {
                            d,
                            a: x,
                            b: y,
                            sub: op == BinaryOp::Sub,
                        },
                        span,
                    );
                }
                _ => {
                    let ar = if op == BinaryOp::Add {
                        Arith::Add
                    } else {
                        Arith::Sub
                    };
                    self.emit(
                        Op::ArL {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        },
                        span,
                    );
                }
            }
            return Ok(d);
        }
        if op == BinaryOp::Power {
            self.ext(
                ExtOp::Pow {
                    d,
                    a: x,
                    b: y,
                    e: re,
                    int_exp: !be.is_real(),
                },
                span,
            );
            return Ok(d);
        }
        if ae == Elem::Tod && re == Elem::Tod {
            self.ext(
                ExtOp::TodAdd {
                    d,
                    a: x,
                    b: y,
                    sub: op == BinaryOp::Sub,
                },
                span,
            );
            return Ok(d);
        }
        let cmp = match op {
            BinaryOp::Eq => Some(Cmp::Eq),
            BinaryOp::Ne => Some(Cmp::Ne),
            BinaryOp::Lt => Some(Cmp::Lt),
            BinaryOp::Le => Some(Cmp::Le),
            BinaryOp::Gt => Some(Cmp::Gt),
            BinaryOp::Ge => Some(Cmp::Ge),
            _ => None,
        };
        if let Some(c) = cmp {
            let o = match kind(p, a.ty) {
                Kind::S => Op::CmpS {
                    op: c,
                    d,
                    a: x,
                    b: y,
                },
                Kind::F => Op::CmpF {
                    op: c,
                    d,
                    a: x,
                    b: y,
                },
                Kind::U => Op::CmpU {
                    op: c,
                    d,
                    a: x,
                    b: y,
                },
                Kind::I => Op::CmpI {
                    op: c,
                    d,
                    a: x,
                    b: y,
                },
            };
            self.emit(o, span);
            return Ok(d);
        }
        let o = match op {
            BinaryOp::And => Op::And { d, a: x, b: y },
            BinaryOp::Or => Op::Or { d, a: x, b: y },
            BinaryOp::Xor => Op::Xor { d, a: x, b: y },
            _ => {
                let ar = match op {
                    BinaryOp::Add => Arith::Add,
                    BinaryOp::Sub => Arith::Sub,
                    BinaryOp::Mul => Arith::Mul,
                    BinaryOp::Div => Arith::Div,
                    _ => Arith::Mod,
                };
                if re.is_real() {
                    Op::ArF {
                        op: ar,
                        d,
                        a: x,
                        b: y,
                        single: re == Elem::Real,
                    }
                } else {
                    match int_class(re) {
                        IntClass::Narrow(r) => Op::ArN {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                            r,
                        },
                        IntClass::Long => Op::ArL {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        },
                        IntClass::ULong => Op::ArU {
                            op: ar,
                            d,
                            a: x,
                            b: y,
                        },
                    }
                }
            }
        };
        self.emit(o, span);
        Ok(d)
    }

    fn convert(&mut self, x: &Expr, to: TypeId, want: Option<u32>, span: Span) -> R<u32> {
        let p = self.p();
        let from = x.ty;
        if is_string(p, to) {
            if is_string(p, from) {
                // Truncation happens where the string is stored.
                return self.expr(x, None);
            }
            let s = self.expr(x, None)?;
            let cap = str_cap(p, to);
            let buf = self.temp(layout::string_slots(cap));
            let dp = self.temp(1);
            self.emit(Op::Lea { d: dp, s: buf }, span);
            let fe = elem_or_dint(p, from);
            self.ext(
                ExtOp::ToStr {
                    dp,
                    s,
                    from: fe,
                    cap,
                },
                span,
            );
            return Ok(dp);
        }
        if is_string(p, from) {
            let sp = self.expr(x, None)?;
            let d = want.unwrap_or_else(|| self.temp(1));
            self.ext(
                ExtOp::FromStr {
                    d,
                    sp,
                    to: elem_or_dint(p, to),
                },
                span,
            );
            return Ok(d);
        }
        let s = self.expr(x, None)?;
        let (fe, te) = (elem_or_dint(p, from), elem_or_dint(p, to));
        if let Type::Subrange { lo, hi, base } = *p.types.get(to) {
            let d = want.unwrap_or_else(|| self.temp(1));
            let v = if fe == base || (fe.is_int() && fe.widens_to(base)) {
                s
            } else {
                let t = self.temp(1);
                self.ext(
                    ExtOp::Conv {
                        d: t,
                        s,
                        from: fe,
                        to: base,
                    },
                    span,
                );
                t
            };
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
        if fe == te
            || (fe.is_int() && te.is_int() && fe.widens_to(te))
            || (fe.is_bitstring() && te.is_bitstring() && fe.widens_to(te))
            || (fe == Elem::Time && te == Elem::Ltime)
        {
            if let Some(d) = want {
                if d != s {
                    self.emit(Op::Mov { d, s }, span);
                }
                return Ok(d);
            }
            return Ok(s);
        }
        let d = want.unwrap_or_else(|| self.temp(1));
        self.ext(
            ExtOp::Conv {
                d,
                s,
                from: fe,
                to: te,
            },
            span,
        );
        Ok(d)
    }

    /// A string buffer for a result of `ty`; returns the pointer slot.
    fn string_buffer(&mut self, ty: TypeId, span: Span) -> u32 {
        let cap = str_cap(self.p(), ty);
        let buf = self.temp(layout::string_slots(cap));
        let dp = self.temp(1);
        self.emit(Op::Lea { d: dp, s: buf }, span);
        dp
    }

    fn builtin(
        &mut self,
        b: Builtin,
        args: &[Expr],
        ty: TypeId,
        want: Option<u32>,
        span: Span,
    ) -> R<u32> {
        let p = self.p();
        let mut xs = Vec::with_capacity(args.len());
        for a in args {
            xs.push(self.expr(a, None)?);
        }
        let k = kind(p, ty);
        let re = elem_or_dint(p, ty);
        let cap = str_cap(p, ty);
        let out = |me: &mut Self| -> u32 {
            if k == Kind::S {
                me.string_buffer(ty, span)
            } else {
                want.unwrap_or_else(|| me.temp(1))
            }
        };
        let d = match b {
            Builtin::Abs => {
                let d = out(self);
                if re.is_real() {
                    self.ext(
                        ExtOp::Math {
                            f: Builtin::Abs,
                            d,
                            s: xs[0],
                            e: re,
                        },
                        span,
                    );
                } else {
                    self.ext(ExtOp::AbsI { d, s: xs[0], e: re }, span);
                }
                d
            }
            Builtin::Sqrt
            | Builtin::Ln
            | Builtin::Log
            | Builtin::Exp
            | Builtin::Sin
            | Builtin::Cos
            | Builtin::Tan
            | Builtin::Asin
            | Builtin::Acos
            | Builtin::Atan => {
                let d = out(self);
                self.ext(
                    ExtOp::Math {
                        f: b,
                        d,
                        s: xs[0],
                        e: re,
                    },
                    span,
                );
                d
            }
            Builtin::Atan2 => {
                let d = out(self);
                self.ext(
                    ExtOp::Atan2 {
                        d,
                        y: xs[0],
                        x: xs[1],
                        e: re,
                    },
                    span,
                );
                d
            }
            Builtin::Max | Builtin::Min => {
                let d = out(self);
                self.ext(
                    ExtOp::MinMax {
                        max: b == Builtin::Max,
                        d,
                        args: xs,
                        kind: k,
                        cap,
                    },
                    span,
                );
                d
            }
            Builtin::Limit => {
                let d = out(self);
                self.ext(
                    ExtOp::Limit {
                        d,
                        mn: xs[0],
                        x: xs[1],
                        mx: xs[2],
                        kind: k,
                        cap,
                    },
                    span,
                );
                d
            }
            Builtin::Sel | Builtin::Mux => {
                let d = out(self);
                let kk = xs[0];
                self.ext(
                    ExtOp::Select {
                        mux: b == Builtin::Mux,
                        d,
                        k: kk,
                        args: xs[1..].to_vec(),
                        kind: k,
                        cap,
                    },
                    span,
                );
                d
            }
            Builtin::Shl | Builtin::Shr | Builtin::Rol | Builtin::Ror => {
                let d = out(self);
                self.ext(
                    ExtOp::Shift {
                        f: b,
                        d,
                        s: xs[0],
                        n: xs[1],
                        e: re,
                    },
                    span,
                );
                d
            }
            Builtin::Len | Builtin::Find => {
                let d = want.unwrap_or_else(|| self.temp(1));
                self.ext(
                    ExtOp::Str {
                        f: b,
                        d,
                        args: xs,
                        cap: 0,
                    },
                    span,
                );
                d
            }
            Builtin::Left
            | Builtin::Right
            | Builtin::Mid
            | Builtin::Concat
            | Builtin::Insert
            | Builtin::Delete
            | Builtin::Replace => {
                let d = self.string_buffer(ty, span);
                self.ext(
                    ExtOp::Str {
                        f: b,
                        d,
                        args: xs,
                        cap,
                    },
                    span,
                );
                d
            }
            Builtin::ConcatDateTod => {
                let d = out(self);
                self.ext(
                    ExtOp::ConcatDateTod {
                        d,
                        a: xs[0],
                        b: xs[1],
                    },
                    span,
                );
                d
            }
            Builtin::DtToTod | Builtin::DtToDate | Builtin::Expt => {
                return Err(CompileError::Unsupported(format!(
                    "{} as a builtin",
                    b.name()
                )));
            }
        };
        Ok(d)
    }

    // ---- calls ----

    fn call_fn(&mut self, call: &FnCall, ty: TypeId, want: Option<u32>, span: Span) -> R<u32> {
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

    fn call_fb(&mut self, call: &FbCall, span: Span) -> R<()> {
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

    fn pinned(&self) -> u32 {
        0
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
            | ExtOp::AbsI { d, s, .. } => {
                g(d);
                g(s);
            }
            ExtOp::ToStr { dp, s, .. } => {
                g(dp);
                g(s);
            }
            ExtOp::FromStr { d, sp, .. } => {
                g(d);
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
        }
    }
}

#[allow(dead_code)]
fn _uses(_: &value::Value) {}
