//! The engine's public face: an [`Engine`] (a compiled project, shared between threads) and
//! [`Machine`]s running it (memory, tasks, faults), with access to variables by name and the
//! snapshot and restore of retentive variables.

use std::fmt;
use std::sync::{Arc, OnceLock};

use petriplc_iec_sema::ir::{PouKind, Project, VarClass};
use petriplc_iec_sema::ops;
use petriplc_iec_sema::types::{Elem, FbRef, Type, TypeId};
use petriplc_iec_sema::value::Value;
use petriplc_iec_syntax::source::SourceMap;

use crate::compile::{self, Code, CompileError, InstanceSpec};
use crate::exec::{self, Budget, FaultKind, RawFault};
use crate::ext;
use crate::native::{self, NativeFb};
use crate::vars::{split_path, RetainImage, Retained, Segment, VarRef};

/// A run-time fault, located: the POU, its file and line, what happened with which values.
#[derive(Clone, Debug, PartialEq)]
pub struct Fault {
    pub pou: String,
    pub file: String,
    pub line: u32,
    pub kind: FaultKind,
    /// What happened, with the values involved.
    pub message: String,
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}:{}: in {}: {}",
            self.file, self.line, self.pou, self.message
        )
    }
}

impl std::error::Error for Fault {}

/// A compiled project with the native function blocks it uses.
pub struct Engine {
    pub project: Project,
    pub code: Code,
    natives: Vec<Box<dyn NativeFb>>,
    pou_files: Vec<String>,
    /// Tasks by priority, then declaration order.
    task_order: Vec<usize>,
    /// Whether some program instance runs in a task (else every instance runs every scan).
    tasked: bool,
    /// The instances in the order a scan runs them when every task is due.
    scan_order: Vec<u32>,
    /// Per task: whether some program instance runs in it.
    task_used: Vec<bool>,
    /// Per task: the slot of its SINGLE variable (an event task), if it has one.
    singles: Vec<Option<u32>>,
    /// TwinCAT's task information, when the project has it (the `twincat` library).
    task_info: Option<TaskInfo>,
    /// Machine code for the instances, made when the first machine is ([`Engine::compiled`]),
    /// so that checking a program does not pay for it.
    compiled: OnceLock<Option<Box<dyn Compiled>>>,
    compiler: Option<Compiler>,
}

/// Makes machine code for an engine (`None` when it cannot).
pub type Compiler = Box<dyn Fn(&Engine) -> Option<Box<dyn Compiled>> + Send + Sync>;

/// Machine code for an engine's program instances (the `petriplc-iec-jit` crate makes it),
/// run in place of the instruction loop with the same memory, faults and budget.
pub trait Compiled: Send + Sync {
    /// Runs program instance `instance` once at `now` on `mem` (the machine's memory),
    /// spending `budget`; [`Ran::NotCompiled`] when that instance has no compiled form (the
    /// VM runs it). It must not unwind: a panic inside (a bug) is [`Ran::Panic`], reported
    /// as the VM reports its own.
    fn run(
        &self,
        engine: &Engine,
        instance: usize,
        mem: &mut [u64],
        now: i64,
        budget: &mut Budget<'_>,
    ) -> Ran;

    /// What runs whole scans of one machine of `engine` (the engine this code was made
    /// for), when there is such a fast path: `None` by default (the machine then runs each
    /// instance through [`Compiled::run`]).
    fn scanner(&self, engine: &Arc<Engine>) -> Option<Box<dyn Scanner>> {
        let _ = engine;
        None
    }
}

/// Whole scans of one machine on compiled code: every program instance once, in
/// [`Engine::scan_order`], each with a budget of `iterations`, as [`Machine::scan`] runs
/// them when every task is due (always, when no instance has a task). Made once per
/// machine ([`Compiled::scanner`]), so that what a scan needs is prepared once, not per
/// scan.
pub trait Scanner: Send + Sync {
    /// One scan of `mem` at `now`; `check` is the watchdog's. [`Ran::NotCompiled`] when
    /// `mem` is not a memory of this engine (nothing has run).
    fn scan(
        &mut self,
        mem: &mut [u64],
        now: i64,
        iterations: u64,
        check: &mut dyn FnMut() -> bool,
    ) -> Ran;

    /// The instance the last scan ended in (for the message of [`Ran::Panic`]).
    fn instance(&self) -> usize;
}

/// How a run of compiled code ended (small, so the scan's fast path stays in registers).
#[derive(Debug)]
pub enum Ran {
    Done,
    Fault(Box<RawFault>),
    Panic,
    NotCompiled,
}

/// What runs a machine's programs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Backend {
    /// The engine's machine code where it has some ([`Engine::set_compiled`]), else the VM.
    #[default]
    Compiled,
    /// The bytecode VM only.
    Vm,
}

impl fmt::Debug for Engine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Engine")
            .field("ops", &self.code.ops.len())
            .field("memory", &self.code.init.len())
            .finish()
    }
}

/// The iteration budget of one scan when none is set: a loop still going after this many
/// iterations in one scan is stopped as endless.
pub const DEFAULT_ITERATIONS: u64 = 10_000_000;

impl Engine {
    /// Compiles `project` for `instances`. `natives` implements `project.natives` in order
    /// (the standard function blocks first: [`native::standard`]).
    pub fn new(
        project: Project,
        instances: &[InstanceSpec],
        natives: Vec<Box<dyn NativeFb>>,
        sources: &SourceMap,
    ) -> Result<Arc<Engine>, CompileError> {
        if !native::matches(&natives, &project.natives) {
            return Err(CompileError::Unsupported(
                "the native function blocks do not match the ones the project was checked with"
                    .into(),
            ));
        }
        let line_of = |span| sources.line(span);
        let mut code = compile::compile(&project, instances, &line_of)?;
        code.native_sizes = project
            .natives
            .iter()
            .map(|n| n.vars.len() as u32)
            .collect();
        let pou_files = project
            .pous
            .iter()
            .map(|p| {
                sources
                    .get(p.span.file)
                    .map_or_else(String::new, |f| f.name.clone())
            })
            .collect();
        let mut task_order: Vec<usize> =
            (0..project.configuration.as_ref().map_or(0, |c| c.tasks.len())).collect();
        if let Some(c) = &project.configuration {
            task_order.sort_by_key(|&t| (c.tasks[t].priority, t));
        }
        let tasked =
            code.instances.iter().any(|i| i.task.is_some()) && project.configuration.is_some();
        let in_task = |t: Option<u32>| -> Vec<u32> {
            (0..code.instances.len() as u32)
                .filter(|&i| code.instances[i as usize].task == t)
                .collect()
        };
        let scan_order = if tasked {
            let mut order: Vec<u32> = Vec::new();
            for &t in &task_order {
                order.extend(in_task(Some(t as u32)));
            }
            order.extend(in_task(None));
            order
        } else {
            (0..code.instances.len() as u32).collect()
        };
        let task_used: Vec<bool> = (0..task_order.len())
            .map(|t| code.instances.iter().any(|i| i.task == Some(t as u32)))
            .collect();
        // An event task's programs run when its variable rose: a scan with one in use takes
        // the task path, which looks at the variable (machine code still runs each instance).
        let singles: Vec<Option<u32>> = project.configuration.as_ref().map_or_else(Vec::new, |c| {
            c.tasks
                .iter()
                .map(|t| t.single.map(|g| code.global_addr[g as usize]))
                .collect()
        });
        let mut engine = Engine {
            project,
            code,
            natives,
            pou_files,
            task_order,
            tasked,
            scan_order,
            task_used,
            singles,
            task_info: None,
            compiled: OnceLock::new(),
            compiler: None,
        };
        engine.apply_var_config();
        engine.task_info = TaskInfo::find(&engine);
        Ok(Arc::new(engine))
    }

    /// VAR_CONFIG's values into the instances' initial memory (the checker resolved each
    /// path to an elementary, enumeration, subrange or string variable of an instance).
    fn apply_var_config(&mut self) {
        let Some(c) = &self.project.configuration else {
            return;
        };
        let items: Vec<(String, Value)> = c
            .var_config
            .iter()
            .map(|v| (v.path.clone(), v.value.clone()))
            .collect();
        for (path, value) in items {
            let Some(v) = self.lookup(&path) else {
                continue;
            };
            let at = v.addr as usize;
            let slot = match self.project.types.get(v.ty).clone() {
                Type::Elem(e) => ext::put_value(&value, e),
                Type::Subrange { base, .. } => ext::put_value(&value, base),
                Type::Enum { .. } => value.as_int().unwrap_or(0) as i64 as u64,
                Type::Str { len, wide } => {
                    match &value {
                        Value::Str(s) if !wide => ext::write_str(&mut self.code.init, at, s, len),
                        Value::WStr(w) if wide => {
                            ext::write_units(&mut self.code.init, at, w, len.saturating_mul(2))
                        }
                        _ => {}
                    }
                    continue;
                }
                _ => continue,
            };
            self.code.init[at] = slot;
        }
    }

    /// Sets what makes the machine code, run once when the first machine is made (before
    /// machines are made: `Arc::get_mut`).
    pub fn set_compiler(&mut self, compiler: Compiler) {
        self.compiler = Some(compiler);
    }

    /// The machine code, made now if it was not yet.
    pub fn compiled(&self) -> Option<&dyn Compiled> {
        self.compiled
            .get_or_init(|| self.compiler.as_ref().and_then(|c| c(self)))
            .as_deref()
    }

    /// Whether there is machine code (made now if it was not yet).
    pub fn is_compiled(&self) -> bool {
        self.compiled().is_some()
    }

    /// The program instances in the order a scan runs them when every task is due (all of
    /// them every scan when no instance has a task): by task priority, then declaration
    /// order, the instances without a task last.
    pub fn scan_order(&self) -> &[u32] {
        &self.scan_order
    }

    /// The native function blocks, in the order of `project.natives`.
    pub fn natives(&self) -> &[Box<dyn NativeFb>] {
        &self.natives
    }

    /// The program instances: those of the configuration, or one of `pou` named after it.
    pub fn instances(&self) -> &[compile::InstanceRt] {
        &self.code.instances
    }

    #[cold]
    fn locate(&self, f: RawFault) -> Fault {
        let i = self.code.lines.partition_point(|(pc, _, _)| *pc <= f.pc);
        let (pou, line) = match i.checked_sub(1).map(|k| self.code.lines[k]) {
            Some((_, p, l)) => (p, l),
            None => (u32::MAX, 0),
        };
        let (name, file) = if pou == u32::MAX {
            let c = self
                .project
                .configuration
                .as_ref()
                .map_or("the configuration".to_string(), |c| {
                    format!("CONFIGURATION {}", c.name)
                });
            (c, String::new())
        } else {
            let p = self.project.pou(pou);
            (
                format!("{} {}", p.kind.keyword(), p.name),
                self.pou_files
                    .get(pou as usize)
                    .cloned()
                    .unwrap_or_default(),
            )
        };
        let what = match &f.error {
            FaultKind::Op(e) => e.to_string(),
            FaultKind::IndexOutOfRange => "array index out of range".into(),
            FaultKind::Watchdog => "watchdog".into(),
            FaultKind::Native => "function block failed".into(),
            FaultKind::Internal => "internal limit".into(),
        };
        Fault {
            pou: name,
            file,
            line,
            kind: f.error,
            message: format!("{what}: {}", f.detail),
        }
    }

    /// The scan period the configuration's tasks ask for: the greatest common divisor of
    /// their intervals (nanoseconds), if any task has one.
    pub fn task_period(&self) -> Option<i64> {
        let c = self.project.configuration.as_ref()?;
        let used: Vec<i64> = self
            .code
            .instances
            .iter()
            .filter_map(|i| i.task)
            .filter_map(|t| c.tasks[t as usize].interval)
            .collect();
        used.into_iter().reduce(gcd)
    }

    /// Resolves `name`, `instance.var`, `var.field[3].x` to a variable.
    pub fn lookup(&self, path: &str) -> Option<VarRef> {
        let mut parts = split_path(path)?.into_iter();
        let first = parts.next()?;
        let Segment::Name(first) = first else {
            return None;
        };
        let p = &self.project;
        let (mut addr, mut ty, mut class) = if let Some(g) = p.global_by_name(&first) {
            (
                self.code.global_addr[g as usize],
                p.globals[g as usize].ty,
                VarClass::Global,
            )
        } else if let Some(inst) = self
            .code
            .instances
            .iter()
            .find(|i| i.name.eq_ignore_ascii_case(&first))
        {
            let Some(Segment::Name(v)) = parts.next() else {
                return None;
            };
            return self.member(inst.frame, inst.pou, &v, parts.collect());
        } else {
            return None;
        };
        for seg in parts {
            let (a, t, c) = self.step(addr, ty, seg)?;
            addr = a;
            ty = t;
            class = c;
        }
        Some(VarRef { addr, ty, class })
    }

    fn member(&self, frame: u32, pou: u32, var: &str, rest: Vec<Segment>) -> Option<VarRef> {
        let p = self.project.pou(pou);
        let v = p.var_by_name(var)?;
        let decl = &p.vars[v as usize];
        let (mut addr, ty) = match decl.class {
            VarClass::External(g) => (self.code.global_addr[g as usize], decl.ty),
            VarClass::InOut | VarClass::Hidden => return None,
            _ => (
                frame + self.code.layouts[pou as usize].offsets[v as usize]?,
                decl.ty,
            ),
        };
        let mut ty = ty;
        let mut class = decl.class;
        for seg in rest {
            let (a, t, c) = self.step(addr, ty, seg)?;
            addr = a;
            ty = t;
            class = c;
        }
        Some(VarRef { addr, ty, class })
    }

    fn step(&self, addr: u32, ty: TypeId, seg: Segment) -> Option<(u32, TypeId, VarClass)> {
        let p = &self.project;
        match (p.types.get(ty), seg) {
            (Type::Struct { fields, .. }, Segment::Name(n)) => {
                let i = fields
                    .iter()
                    .position(|f| f.name.eq_ignore_ascii_case(&n))?;
                let offs = self.code.sizes.field_offsets(p, ty);
                Some((addr + offs[i], fields[i].ty, VarClass::Local))
            }
            (Type::Fb(FbRef::User(q)), Segment::Name(n)) => {
                let r = self.member(addr, *q, &n, Vec::new())?;
                Some((r.addr, r.ty, r.class))
            }
            (Type::Fb(FbRef::Native(k)), Segment::Name(n)) => {
                let sig = &p.natives[*k as usize];
                let i = sig.var_by_name(&n)?;
                Some((
                    addr + i,
                    petriplc_iec_sema::types::TypeTable::elem_id(sig.vars[i as usize].ty),
                    VarClass::Local,
                ))
            }
            (Type::Array { dims, elem }, Segment::Index(idx)) => {
                if idx.len() != dims.len() {
                    return None;
                }
                let es = self.code.sizes.of(p, *elem)?;
                let mut lin: u64 = 0;
                for (k, (i, (lo, hi))) in idx.iter().zip(dims).enumerate() {
                    if i < lo || i > hi {
                        return None;
                    }
                    let _ = k;
                    lin = lin * (hi - lo + 1) as u64 + (i - lo) as u64;
                }
                Some((addr + (lin * es as u64) as u32, *elem, VarClass::Local))
            }
            _ => None,
        }
    }

    /// The variables of a program instance, in declaration order (name, class, type).
    pub fn instance_vars(&self, instance: usize) -> Vec<(String, VarClass, TypeId)> {
        let Some(inst) = self.code.instances.get(instance) else {
            return Vec::new();
        };
        self.project
            .pou(inst.pou)
            .vars
            .iter()
            .filter(|v| v.class != VarClass::Hidden)
            .map(|v| (v.name.clone(), v.class, v.ty))
            .collect()
    }

    /// Every retentive variable: RETAIN globals, RETAIN variables of program instances
    /// (and everything inside an instance declared RETAIN), by path.
    pub fn retained(&self) -> Vec<Retained> {
        let mut out = Vec::new();
        let p = &self.project;
        for (g, v) in p.globals.iter().enumerate() {
            if v.retain {
                out.push(self.retained_var(v.name.clone(), self.code.global_addr[g], v.ty));
            }
        }
        for inst in &self.code.instances {
            self.retained_in(&inst.name, inst.frame, inst.pou, false, &mut out);
        }
        out
    }

    fn retained_in(&self, path: &str, frame: u32, pou: u32, all: bool, out: &mut Vec<Retained>) {
        let p = self.project.pou(pou);
        let layout = &self.code.layouts[pou as usize];
        for (i, v) in p.vars.iter().enumerate() {
            let Some(off) = layout.offsets[i] else {
                continue;
            };
            if matches!(
                v.class,
                VarClass::InOut | VarClass::Temp | VarClass::External(_)
            ) {
                continue;
            }
            let name = format!("{path}.{}", v.name);
            if (v.retain || all) && self.holds_reference(v.ty) {
                // An address of this build means nothing after a restart (E202): the
                // references of a retained instance start NULL again, its other variables
                // are kept.
                if let Type::Fb(FbRef::User(q)) = self.project.types.get(v.ty) {
                    self.retained_in(&name, frame + off, *q, true, out);
                }
            } else if v.retain || all {
                out.push(self.retained_var(name, frame + off, v.ty));
            } else if let Type::Fb(FbRef::User(q)) = self.project.types.get(v.ty) {
                // RETAIN variables inside a non-retained instance.
                self.retained_in(&name, frame + off, *q, false, out);
            }
        }
    }

    /// Whether a value of `ty` holds a reference, in a function block instance too.
    fn holds_reference(&self, ty: TypeId) -> bool {
        let types = &self.project.types;
        match types.get(ty) {
            Type::Fb(FbRef::User(q)) => {
                self.project.pou(*q).vars.iter().any(|v| {
                    !matches!(v.class, VarClass::External(_)) && self.holds_reference(v.ty)
                })
            }
            Type::Array { elem, .. } => self.holds_reference(*elem),
            _ => types.holds_reference(ty),
        }
    }

    fn retained_var(&self, path: String, addr: u32, ty: TypeId) -> Retained {
        Retained {
            path,
            addr,
            len: self.code.sizes.of(&self.project, ty).unwrap_or(1),
            type_name: self.project.types.name(ty),
        }
    }

    pub fn pou_kind(&self, name: &str) -> Option<PouKind> {
        self.project
            .pou_by_name(name)
            .map(|p| self.project.pou(p).kind)
    }
}

/// Runs one program instance; a panic inside (a bug in the engine) becomes a fault.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn run_one(
    engine: &Engine,
    backend: Backend,
    mem: &mut [u64],
    stack: &mut Vec<(u32, u32)>,
    iterations: u64,
    instance: usize,
    now: i64,
    check: &mut dyn FnMut() -> bool,
) -> Result<(), Fault> {
    let r = run_one_inner(
        engine, backend, mem, stack, iterations, instance, now, check,
    );
    if r.is_err() {
        release_guards(engine, mem);
    }
    r
}

/// The busy flags of the POUs a fault left (`Code::guards`): the next scan may enter them.
#[cold]
fn release_guards(engine: &Engine, mem: &mut [u64]) {
    for &g in &engine.code.guards {
        if let Some(flag) = mem.get_mut(g as usize) {
            *flag = 0;
        }
    }
}

#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn run_one_inner(
    engine: &Engine,
    backend: Backend,
    mem: &mut [u64],
    stack: &mut Vec<(u32, u32)>,
    iterations: u64,
    instance: usize,
    now: i64,
    check: &mut dyn FnMut() -> bool,
) -> Result<(), Fault> {
    let Some(inst) = engine.code.instances.get(instance) else {
        return Ok(());
    };
    let mut budget = Budget {
        iterations: iterations.max(1),
        check,
    };
    if let (Backend::Compiled, Some(c)) = (backend, engine.compiled()) {
        // Compiled code catches its own panics: no unwinding boundary on the fast path.
        match c.run(engine, instance, mem, now, &mut budget) {
            Ran::Done => return Ok(()),
            Ran::Fault(f) => return Err(engine.locate(*f)),
            Ran::Panic => return Err(internal(inst)),
            Ran::NotCompiled => {}
        }
    }
    run_vm(engine, inst, mem, stack, now, &mut budget)
}

/// Runs one program instance on the VM.
#[inline(never)]
fn run_vm(
    engine: &Engine,
    inst: &compile::InstanceRt,
    mem: &mut [u64],
    stack: &mut Vec<(u32, u32)>,
    now: i64,
    budget: &mut Budget<'_>,
) -> Result<(), Fault> {
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        exec::run(
            &engine.code,
            &engine.natives,
            mem,
            inst.entry,
            now,
            budget,
            stack,
        )
        .map_err(Box::new)
    }));
    match r {
        Ok(Ok(())) => Ok(()),
        Ok(Err(f)) => Err(engine.locate(*f)),
        Err(_) => Err(internal(inst)),
    }
}

/// The fault of a bug in the engine (a panic caught).
#[cold]
fn internal(inst: &compile::InstanceRt) -> Fault {
    Fault {
        pou: format!("PROGRAM instance {}", inst.name),
        file: String::new(),
        line: 0,
        kind: FaultKind::Internal,
        message: "internal error in the IEC engine (please report it)".into(),
    }
}

/// Whether task `t` is due at `now`, and its clock after running it: the next multiple of
/// its interval after `now` (missed ones are skipped).
#[inline(always)]
fn task_due(interval: Option<i64>, next_due: Option<i64>, now: i64) -> (bool, Option<i64>) {
    match interval {
        None => (true, next_due),
        Some(iv) => {
            let next = next_due.unwrap_or(now);
            if now >= next {
                let late = now - next;
                let k = if late < iv { 1 } else { late / iv + 1 };
                (true, Some(next + k * iv))
            } else {
                (false, next_due)
            }
        }
    }
}

/// When every task that runs an instance is due at `now`: advances every due task's clock
/// (the old ones kept in `saved`) and returns true. Else changes nothing.
#[inline]
fn all_due(
    engine: &Engine,
    next_due: &mut [Option<i64>],
    saved: &mut [Option<i64>],
    now: i64,
) -> bool {
    let Some(c) = engine.project.configuration.as_ref() else {
        return true;
    };
    // One pass, element by element (no call to memcpy for a slice of one or two clocks);
    // undone in the rare scan where a task that runs an instance is not due.
    let mut all = true;
    for (t, (d, s)) in next_due.iter_mut().zip(saved.iter_mut()).enumerate() {
        let (due, next) = task_due(c.tasks[t].interval, *d, now);
        *s = *d;
        *d = next;
        all &= due || !engine.task_used[t];
    }
    if !all {
        for (d, s) in next_due.iter_mut().zip(saved.iter()) {
            *d = *s;
        }
    }
    all
}

fn gcd(a: i64, b: i64) -> i64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// A running copy of an engine: its memory and task clocks.
pub struct Machine {
    engine: Arc<Engine>,
    backend: Backend,
    mem: Vec<u64>,
    stack: Vec<(u32, u32)>,
    /// Loop iterations one scan may make before it fails as endless.
    pub iterations: u64,
    next_due: Vec<Option<i64>>,
    /// The task clocks before the last whole scan on machine code (to undo the advance of
    /// the tasks it did not reach when it stopped on a fault).
    saved_due: Vec<Option<i64>>,
    /// Whole scans on machine code (every instance in [`Engine::scan_order`]), when the
    /// engine has some.
    scanner: Option<Box<dyn Scanner>>,
    /// The engine's `tasked`, kept here: the fast path reads nothing of the engine.
    tasked: bool,
    /// Whether a whole scan may run on machine code at once: not when an event task
    /// (SINGLE) runs programs, whose variable the task path reads first.
    whole: bool,
    /// Per task: its SINGLE variable at the last scan (FALSE before the first).
    single_was: Vec<bool>,
}

impl fmt::Debug for Machine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Machine")
            .field("engine", &self.engine)
            .finish()
    }
}

impl Machine {
    /// A machine in its initial state (a cold start).
    pub fn new(engine: Arc<Engine>) -> Self {
        let tasks = engine
            .project
            .configuration
            .as_ref()
            .map_or(0, |c| c.tasks.len());
        // Machine code is made now, not in the first scan.
        let scanner = match engine.compiled() {
            Some(c) => c.scanner(&engine),
            None => None,
        };
        // Task information is written between tasks: the task path runs them.
        let whole = engine.task_info.is_none()
            && !engine
                .singles
                .iter()
                .zip(&engine.task_used)
                .any(|(s, &used)| s.is_some() && used);
        Machine {
            scanner,
            tasked: engine.tasked,
            whole,
            single_was: vec![false; tasks],
            backend: Backend::default(),
            mem: engine.code.init.clone(),
            engine,
            stack: Vec::with_capacity(16),
            iterations: DEFAULT_ITERATIONS,
            next_due: vec![None; tasks],
            saved_due: vec![None; tasks],
        }
    }

    pub fn engine(&self) -> &Arc<Engine> {
        &self.engine
    }

    /// Chooses what runs the programs (the engine's machine code by default).
    pub fn set_backend(&mut self, backend: Backend) {
        self.backend = backend;
    }

    /// What runs the programs: [`Backend::Vm`] when asked for, or when the engine has no
    /// machine code.
    pub fn backend(&self) -> Backend {
        match self.backend {
            Backend::Compiled if self.engine.is_compiled() => Backend::Compiled,
            _ => Backend::Vm,
        }
    }

    /// Back to the initial values (retained ones included: restore them afterwards).
    pub fn reset(&mut self) {
        self.mem.copy_from_slice(&self.engine.code.init);
        self.next_due.iter_mut().for_each(|d| *d = None);
        self.single_was.iter_mut().for_each(|w| *w = false);
    }

    /// A new epoch of the dynamic memory: what the last run deleted may be reused, since no
    /// call that could still use its slots is running ([`crate::heap`]).
    #[inline(always)]
    fn heap_tick(&mut self) {
        if let Some(h) = self.engine.code.shapes.heap {
            h.tick(&mut self.mem);
        }
    }

    /// Runs one program instance once at time `now` (nanoseconds).
    pub fn run_instance(&mut self, instance: usize, now: i64) -> Result<(), Fault> {
        self.heap_tick();
        let Machine {
            engine,
            backend,
            mem,
            stack,
            iterations,
            ..
        } = self;
        run_one(
            engine,
            *backend,
            mem,
            stack,
            *iterations,
            instance,
            now,
            &mut || true,
        )
    }

    /// One scan at `now` (nanoseconds): every task whose interval has come, by priority (then
    /// declaration order), runs its program instances; instances without a task run every
    /// scan, after the tasks. `check` is called every 65 536 loop iterations and stops the
    /// scan (a watchdog fault) when it returns false (pass `&mut || true` for none).
    #[inline]
    pub fn scan(&mut self, now: i64, check: &mut dyn FnMut() -> bool) -> Result<(), Fault> {
        self.heap_tick();
        // The fast path: machine code, and every task due (always, when no instance has a
        // task): one call into the scanner made for this machine, which runs every instance
        // in the order the task path would.
        if let (Backend::Compiled, Some(s), true) =
            (self.backend, self.scanner.as_deref_mut(), self.whole)
        {
            let tasked = self.tasked;
            if !tasked || all_due(&self.engine, &mut self.next_due, &mut self.saved_due, now) {
                match s.scan(&mut self.mem, now, self.iterations.max(1), &mut *check) {
                    Ran::Done => return Ok(()),
                    Ran::NotCompiled if tasked => {
                        // Nothing ran: the clocks go back, the task path runs the scan.
                        self.next_due.copy_from_slice(&self.saved_due);
                    }
                    Ran::NotCompiled => {}
                    r => return Err(self.scan_stopped(r)),
                }
            }
        }
        self.scan_tasks(now, check)
    }

    /// The fault a whole scan on machine code stopped with.
    /// On a task path the clocks of the tasks after the instance's are left where they were
    /// (they would not have been reached), as [`Machine::scan_tasks`] does.
    #[cold]
    #[inline(never)]
    fn scan_stopped(&mut self, r: Ran) -> Fault {
        release_guards(&self.engine, &mut self.mem);
        let instances = &self.engine.code.instances;
        let i = self.scanner.as_ref().map_or(0, |s| s.instance());
        if let Some(t) = instances.get(i).and_then(|inst| inst.task) {
            let order = &self.engine.task_order;
            if let Some(p) = order.iter().position(|&x| x == t as usize) {
                for &later in &order[p + 1..] {
                    self.next_due[later] = self.saved_due[later];
                }
            }
        }
        match (r, instances.get(i).or(instances.first())) {
            (Ran::Fault(f), _) => self.engine.locate(*f),
            (_, Some(inst)) => internal(inst),
            (_, None) => Fault {
                pou: String::new(),
                file: String::new(),
                line: 0,
                kind: FaultKind::Internal,
                message: "internal error in the IEC engine (please report it)".into(),
            },
        }
    }

    /// A scan with tasks, or on the VM.
    #[inline(never)]
    fn scan_tasks(&mut self, now: i64, check: &mut dyn FnMut() -> bool) -> Result<(), Fault> {
        let Machine {
            engine,
            backend,
            mem,
            stack,
            iterations,
            next_due,
            single_was,
            ..
        } = self;
        let engine: &Engine = engine;
        let backend = *backend;
        let instances = &engine.code.instances;
        let info = engine.task_info.as_ref();
        let tasks = match engine.project.configuration.as_ref() {
            Some(c) if engine.tasked => &c.tasks,
            _ => {
                if let Some(info) = info {
                    info.starts(mem, 1);
                }
                for i in 0..instances.len() {
                    run_one(
                        engine,
                        backend,
                        mem,
                        stack,
                        *iterations,
                        i,
                        now,
                        &mut *check,
                    )?;
                }
                return Ok(());
            }
        };
        for &t in &engine.task_order {
            let due = match engine.singles[t] {
                // SINGLE: once, in the scan that sees its variable TRUE after FALSE.
                Some(slot) => {
                    let v = mem[slot as usize] != 0;
                    let rose = v && !single_was[t];
                    single_was[t] = v;
                    rose
                }
                None => {
                    let (due, next) = task_due(tasks[t].interval, next_due[t], now);
                    next_due[t] = next;
                    due
                }
            };
            if !due {
                continue;
            }
            if let Some(info) = info {
                info.starts(mem, t + 1);
            }
            for (i, inst) in instances.iter().enumerate() {
                if inst.task == Some(t as u32) {
                    run_one(
                        engine,
                        backend,
                        mem,
                        stack,
                        *iterations,
                        i,
                        now,
                        &mut *check,
                    )?;
                }
            }
        }
        if let Some(info) = info.filter(|_| instances.iter().any(|i| i.task.is_none())) {
            // The programs without a task are one task more, after the configured ones.
            info.starts(mem, tasks.len() + 1);
        }
        for (i, inst) in instances.iter().enumerate() {
            if inst.task.is_none() {
                run_one(
                    engine,
                    backend,
                    mem,
                    stack,
                    *iterations,
                    i,
                    now,
                    &mut *check,
                )?;
            }
        }
        Ok(())
    }

    /// The value of a scalar or string variable (`None` for aggregates).
    pub fn get(&self, v: VarRef) -> Option<Value> {
        let p = &self.engine.project;
        let raw = *self.mem.get(v.addr as usize)?;
        Some(match p.types.get(v.ty) {
            Type::Elem(e) | Type::Subrange { base: e, .. } => ext::get_value(raw, *e),
            Type::Enum { .. } => Value::Int(raw as i64 as i128),
            Type::Str { wide: false, .. } => Value::Str(ext::read_str(&self.mem, v.addr as usize)),
            Type::Str { wide: true, .. } => {
                Value::WStr(ext::read_units(&self.mem, v.addr as usize))
            }
            _ => return None,
        })
    }

    /// Sets a scalar or string variable; the value is converted to its type (integers kept
    /// in range, BOOL from 0/1).
    pub fn set(&mut self, v: VarRef, value: &Value) -> Result<(), String> {
        let p = &self.engine.project;
        match p.types.get(v.ty).clone() {
            Type::Elem(e) => {
                let from = match value {
                    Value::Real(_) => Elem::Lreal,
                    Value::Str(s) => {
                        let r = ops::from_text(s, e).map_err(|_| {
                            format!("`{}` is not a {}", String::from_utf8_lossy(s), e.name())
                        })?;
                        self.mem[v.addr as usize] = ext::put_value(&r, e);
                        return Ok(());
                    }
                    _ => Elem::Lint,
                };
                let r = match (value, e) {
                    (Value::Int(i), _) if e.is_integral() && !(e.is_duration() || e.is_date()) => {
                        if !petriplc_iec_sema::types::fits(*i, e) {
                            return Err(format!("{i} does not fit {}", e.name()));
                        }
                        Value::Int(*i)
                    }
                    (Value::Int(i), _) if e.is_duration() || e.is_date() => Value::Int(*i),
                    // A value from outside that does not fit is refused, whatever the
                    // program's overflow rule: it is the sender's mistake, not arithmetic.
                    _ => ops::convert_elem(value, from, e, ops::Overflow::Fault)
                        .map_err(|er| er.to_string())?,
                };
                self.mem[v.addr as usize] = ext::put_value(&r, e);
                Ok(())
            }
            Type::Subrange { base, lo, hi } => {
                let i = value.as_int().ok_or("a subrange takes an integer")?;
                if i < lo || i > hi {
                    return Err(format!("{i} is outside {lo}..{hi}"));
                }
                self.mem[v.addr as usize] = ext::put_value(&Value::Int(i), base);
                Ok(())
            }
            Type::Enum { values, .. } => {
                let i = value
                    .as_int()
                    .ok_or("an enumeration takes its value's number")?;
                if !values.iter().any(|(_, x)| *x as i128 == i) {
                    return Err(format!("{i} is not a value of the enumeration"));
                }
                self.mem[v.addr as usize] = i as i64 as u64;
                Ok(())
            }
            Type::Str { len, wide: false } => match value {
                Value::Str(s) => {
                    ext::write_str(&mut self.mem, v.addr as usize, s, len);
                    Ok(())
                }
                Value::WStr(w) => {
                    ext::write_str(&mut self.mem, v.addr as usize, &ops::narrow(w), len);
                    Ok(())
                }
                _ => Err("a STRING takes text".into()),
            },
            Type::Str { len, wide: true } => {
                let w = match value {
                    Value::WStr(w) => w.clone(),
                    // Text from outside (a point, a command line) in its characters.
                    Value::Str(s) => String::from_utf8_lossy(s).encode_utf16().collect(),
                    _ => return Err("a WSTRING takes text".into()),
                };
                ext::write_units(&mut self.mem, v.addr as usize, &w, len.saturating_mul(2));
                Ok(())
            }
            _ => Err("only elementary variables and strings can be set".into()),
        }
    }

    /// Raw slots (for bindings that copy words).
    pub fn slot(&self, addr: u32) -> u64 {
        self.mem.get(addr as usize).copied().unwrap_or(0)
    }

    pub fn set_slot(&mut self, addr: u32, raw: u64) {
        if let Some(s) = self.mem.get_mut(addr as usize) {
            *s = raw;
        }
    }

    /// The current values of every retentive variable.
    pub fn snapshot_retain(&self) -> RetainImage {
        RetainImage {
            entries: self
                .engine
                .retained()
                .into_iter()
                .map(|r| {
                    let a = r.addr as usize;
                    (
                        r.path,
                        r.type_name,
                        self.mem[a..a + r.len as usize].to_vec(),
                    )
                })
                .collect(),
        }
    }

    /// Restores retentive variables saved by [`Machine::snapshot_retain`], matched by path
    /// and type; returns the paths skipped (no longer there, or of another type).
    pub fn restore_retain(&mut self, image: &RetainImage) -> Vec<String> {
        let here = self.engine.retained();
        let mut skipped = Vec::new();
        for (path, ty, slots) in &image.entries {
            match here.iter().find(|r| r.path.eq_ignore_ascii_case(path)) {
                Some(r) if &r.type_name == ty && r.len as usize == slots.len() => {
                    let a = r.addr as usize;
                    self.mem[a..a + slots.len()].copy_from_slice(slots);
                }
                _ => skipped.push(path.clone()),
            }
        }
        skipped
    }
}

/// TwinCAT's `TwinCAT_SystemInfoVarList._TaskInfo[n].CycleCount` and `.FirstCycle`, and the
/// index GETCURTASKINDEX gives (`__CURTASKINDEX`), as the `twincat` library declares them:
/// written when a task starts its cycle. Task n is the configuration's n-th; the programs
/// without a task (all of them, without a configuration) are the task after the last.
#[derive(Debug)]
struct TaskInfo {
    index: u32,
    /// Per task index from 1: the slots of its cycle count and first-cycle flag.
    tasks: Vec<(u32, u32)>,
}

impl TaskInfo {
    fn find(engine: &Engine) -> Option<TaskInfo> {
        let index = engine.lookup("__CURTASKINDEX")?.addr;
        let mut tasks = Vec::new();
        for n in 1.. {
            let (Some(c), Some(f)) = (
                engine.lookup(&format!("_TaskInfo[{n}].CycleCount")),
                engine.lookup(&format!("_TaskInfo[{n}].FirstCycle")),
            ) else {
                break;
            };
            tasks.push((c.addr, f.addr));
        }
        Some(TaskInfo { index, tasks })
    }

    /// Task `n` (from 1) starts a cycle.
    fn starts(&self, mem: &mut [u64], n: usize) {
        mem[self.index as usize] = n as u64;
        if let Some(&(c, f)) = self.tasks.get(n.wrapping_sub(1)) {
            // A UDINT counter, wrapping as TwinCAT's does.
            let count = (mem[c as usize] as u32).wrapping_add(1);
            mem[c as usize] = u64::from(count);
            mem[f as usize] = u64::from(count == 1);
        }
    }
}
