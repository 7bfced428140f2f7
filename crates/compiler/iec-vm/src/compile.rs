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

use petriplc_iec_sema::ir::{self, Expr, Place, PouId, PouKind, Project};
use petriplc_iec_sema::types::{Elem, Type, TypeId};
use petriplc_iec_sema::value::{self, Value};
use petriplc_iec_sema::Overflow;
use petriplc_iec_syntax::source::Span;

use crate::ext::{self, ExtOp, Kind};
use crate::layout::{FrameLayout, Sizes};
use crate::op::{ArrayInfo, Op};

mod builtin;
mod call;
mod expression;
mod fused;
mod link;
mod place;
mod statement;
#[cfg(test)]
mod tests;
mod unit;
mod vararray;

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
    /// The busy flags ([`ExtOp::Enter`]) of absolute units: cleared when a run faults, so
    /// that a POU left by the fault can be entered again.
    pub guards: Vec<u32>,
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
    /// What integer overflow does: chosen by the instructions compiled ([`Op::ArNW`]…), and
    /// read by the slower operations ([`crate::ext::exec`]).
    pub overflow: Overflow,
    /// The byte image of every referenced type (`REF`, `ADR`), for pointer views.
    pub shapes: crate::pointer::Shapes,
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
    /// A part of the value there: its lowest bit and width (1 for a bit).
    bit: Option<(u8, u8)>,
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
        // In bytes: a WSTRING's units are two bytes each (ext::read_units).
        Type::Str { len, wide } => len.saturating_mul(if *wide { 2 } else { 1 }),
        _ => 0,
    }
}

/// Whether values of the type are one slot.
fn scalar(p: &Project, ty: TypeId) -> bool {
    matches!(
        p.types.get(ty),
        Type::Elem(_)
            | Type::Enum { .. }
            | Type::Subrange { .. }
            | Type::IntLit
            | Type::RealLit
            | Type::Ref { .. }
            | Type::Null
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
    if p.types.is_wstring(ty) {
        Kind::W
    } else if is_string(p, ty) {
        Kind::S
    } else {
        ext::kind_of(elem_or_dint(p, ty))
    }
}

/// The raw slot of a constant scalar.
fn raw_const(p: &Project, v: &Value, ty: TypeId) -> u64 {
    ext::put_value(v, elem_or_dint(p, ty))
}

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
    /// The busy flag of a guarded POU (`Project::guarded`), cleared before each return.
    guard: Option<u32>,
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
            guard: None,
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

    /// A return, releasing the POU's busy flag first when it has one.
    fn ret(&mut self, span: Span) {
        if let Some(s) = self.guard {
            self.ext(ExtOp::Leave { s }, span);
        }
        self.emit(Op::Ret, span);
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
}

#[allow(dead_code)]
fn _uses(_: &value::Value) {}
