//! `iec`: an IEC 61131-3 program (Structured Text, or a PLCopen XML project) run on the
//! engine once per PLC scan, its variables bound to plc points.
//!
//! ```text
//! [chaser]
//! program = chaser.st        # or project = plc.xml (relative to the configuration file); a
//!                            # folder of sources or a TwinCAT .plcproj is one project
//! pou = main                 # a PROGRAM to run; default: the CONFIGURATION's programs
//! task = fast                # only the programs of this TASK of the configuration
//! max_iterations = 10000000  # loop iterations one scan may make before it fails
//! watchdog = T#100ms         # wall-clock limit of one scan (default: none)
//! dialect = codesys          # iec, codesys, twincat, pcworx (default: detected, else iec)
//! overflow = fault           # integer overflow a fault (default: wrap, as other PLCs)
//! libs = codesys, pcworx      # vendor libraries to load (default: none; docs/iec.md)
//! map lights L               # variable lights (a global, or instance.var) is point L
//! ```
//!
//! Bindings: a global located `AT %NAME` where NAME is a point is that point (MatPLC's
//! convention); `map VARIABLE POINT` rows bind any variable (a global, `instance.var`, or a
//! variable of the only program); a PROGRAM run without configuration binds its VAR_INPUTs
//! and VAR_OUTPUTs to points of the same name. A point the module owns is written after each
//! scan; any other is read before it. Types must match the points' sizes (BOOL: 1 bit,
//! SINT/USINT/BYTE: 8, INT/UINT/WORD: 16, DINT/UDINT/DWORD: 32, REAL: f32, TIME: i32 in ms).
//! The scan period, when the section sets none, is the configuration's task interval.
//! A run-time fault (division by zero, index out of range, an endless loop; overflow with
//! `overflow = fault`) fails the module with the POU, line and values; `on_failure` decides
//! what follows.

use std::sync::Arc;
use std::time::{Duration, Instant};

use petriplc_config::{ModuleDecl, PointKind};
use petriplc_iec::sema::ir::VarClass;
use petriplc_iec::sema::types::{Elem, Type};
use petriplc_iec::sema::Overflow;
use petriplc_iec::vm::{Engine, FaultKind, Machine, VarRef};
use petriplc_iec::{Dialect, Natives, Select, Sources};
use petriplc_runtime::image::{Handle, ModuleMap};
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};

use crate::common::{self, error};
use crate::iec_retain;

const KIND: &str = "iec";
const SETTINGS: &[&str] = &[
    "program",
    "project",
    "pou",
    "task",
    "max_iterations",
    "watchdog",
    "dialect",
    "overflow",
    "libs",
];

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(IecModule::new(decl)?))
}

/// How a variable maps to a point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Conv {
    Bool,
    Unsigned,
    Signed,
    Real,
    /// TIME in an i32 point, in milliseconds.
    TimeMs,
}

#[derive(Clone, Debug)]
struct Binding {
    var: String,
    point: String,
    at: VarRef,
    handle: Handle,
    conv: Conv,
}

impl Binding {
    /// The point's value as the variable's memory slot.
    fn read(&self, map: &ModuleMap) -> u64 {
        let h = &self.handle;
        match self.conv {
            Conv::Bool => u64::from(map.get_bool(h)),
            Conv::Unsigned => u64::from(map.get_u32(h)),
            Conv::Signed => map.get_i32(h) as i64 as u64,
            Conv::Real => (map.get_f32(h) as f64).to_bits(),
            Conv::TimeMs => (map.get_i32(h) as i64 * 1_000_000) as u64,
        }
    }
}

/// The `iec` module.
pub struct IecModule {
    name: String,
    file: String,
    project: bool,
    select: Select,
    task: Option<String>,
    iterations: u64,
    watchdog: Option<Duration>,
    /// `dialect = …`; `None`: detected from the files (docs/iec.md, "Dialects and vendor code").
    dialect: Option<Dialect>,
    overflow: Overflow,
    /// The program declares RETAIN variables (see [`iec_retain::declares_retain`]).
    retains: bool,
    /// Vendor libraries loaded (`libs = codesys, pcworx`).
    libs: Vec<String>,
    run: Option<Run>,
}

struct Run {
    engine: Arc<Engine>,
    machine: Machine,
    inputs: Vec<Binding>,
    outputs: Vec<Binding>,
    period: Option<Duration>,
    scans: u64,
    kept: Vec<iec_retain::Kept>,
}

impl IecModule {
    pub fn new(decl: &ModuleDecl) -> Result<IecModule, ModuleError> {
        common::check_decl(decl, KIND, SETTINGS)?;
        let (file, project) = match (common::setting(decl, "program"), common::setting(decl, "project")) {
            (Some(f), None) => (f.to_string(), false),
            (None, Some(f)) => (f.to_string(), true),
            (Some(_), Some(_)) => {
                return Err(error(&decl.name, "give either `program = FILE.st|FILE.il` or `project = FILE.xml`, not both"))
            }
            (None, None) => {
                return Err(error(
                    &decl.name,
                    format!("no program: add `program = FILE.st` (Structured Text; FILE.il: Instruction List; a FOLDER of sources; a TwinCAT FILE.plcproj) or `project = FILE.xml` (PLCopen XML) to section [{}]", decl.name),
                ))
            }
        };
        let select = match common::setting(decl, "pou") {
            Some(p) => Select::Pou(p.to_string()),
            None => Select::Auto,
        };
        let task = common::setting(decl, "task").map(str::to_string);
        let dialect = common::setting(decl, "dialect")
            .map(|d| {
                d.parse::<Dialect>()
                    .map_err(|e| error(&decl.name, format!("`dialect = {d}`: {e}")))
            })
            .transpose()?;
        if task.is_some() && matches!(select, Select::Pou(_)) {
            return Err(error(&decl.name, "`pou` runs one PROGRAM, `task` the programs of a configuration's task: give one of them"));
        }
        let iterations = match common::setting(decl, "max_iterations") {
            None => petriplc_iec::vm::DEFAULT_ITERATIONS,
            Some(v) => v.parse::<u64>().ok().filter(|n| *n > 0).ok_or_else(|| {
                error(
                    &decl.name,
                    format!("`max_iterations = {v}`: give a whole number above 0"),
                )
            })?,
        };
        let overflow = match common::setting(decl, "overflow") {
            None => Overflow::default(),
            Some(v) => Overflow::parse(v).ok_or_else(|| {
                error(
                    &decl.name,
                    format!("`overflow = {v}`: give `wrap` (an integer result outside its type keeps its low bits, as CODESYS, TwinCAT, matiec and OpenPLC) or `fault` (it stops the module)"),
                )
            })?,
        };
        let libs: Vec<String> = common::setting(decl, "libs")
            .unwrap_or_default()
            .split(|c: char| c == ',' || c.is_whitespace())
            .filter(|l| !l.is_empty())
            .map(str::to_string)
            .collect();
        petriplc_iec::sema::vendor::check_names(&libs)
            .map_err(|m| error(&decl.name, format!("`libs`: {m}")))?;
        // Read by the configuration (C060 when it is not a duration): the runner's watchdog
        // and the engine's check are the same limit.
        let watchdog = decl.watchdog;
        Ok(IecModule {
            name: decl.name.clone(),
            file,
            project,
            select,
            task,
            iterations,
            watchdog,
            dialect,
            overflow,
            retains: decl
                .settings
                .get(if project { "project" } else { "program" })
                .is_some_and(|s| iec_retain::declares_retain(&s.origin.file, &s.value)),
            libs,
            run: None,
        })
    }

    fn bind_one(
        &self,
        ctx: &InitContext<'_>,
        engine: &Engine,
        var: &str,
        at: VarRef,
        point: &str,
        problems: &mut Vec<String>,
    ) -> Option<(Binding, bool)> {
        let module = &self.name;
        let handle = match ctx.map.handle(point) {
            Ok(h) => h,
            Err(e) => {
                problems.push(format!(
                    "variable `{var}` needs point `{point}`: {e}; declare `point {point} \"...\" OWNER` in [PLC], or bind the variable to another point with `map {var} POINT` in [{module}]"
                ));
                return None;
            }
        };
        let ty_name = engine.project.types.name(at.ty);
        let (kind, bits) = (handle.kind(), handle.bits());
        let point_desc = format!(
            "point `{point}` ({} {bits} bit{})",
            common::kind_name(kind),
            if bits == 1 { "" } else { "s" }
        );
        let elem = match engine.project.types.get(at.ty) {
            Type::Elem(e) | Type::Subrange { base: e, .. } => Some(*e),
            Type::Enum { .. } => Some(Elem::Dint),
            _ => None,
        };
        let want = match elem {
            Some(Elem::Bool) => Some((Conv::Bool, 1, None)),
            Some(Elem::Sint) => Some((Conv::Signed, 8, Some(PointKind::Signed))),
            Some(Elem::Usint | Elem::Byte) => Some((Conv::Unsigned, 8, Some(PointKind::Unsigned))),
            Some(Elem::Int) => Some((Conv::Signed, 16, Some(PointKind::Signed))),
            Some(Elem::Uint | Elem::Word) => Some((Conv::Unsigned, 16, Some(PointKind::Unsigned))),
            Some(Elem::Dint) => Some((Conv::Signed, 32, Some(PointKind::Signed))),
            Some(Elem::Udint | Elem::Dword) => {
                Some((Conv::Unsigned, 32, Some(PointKind::Unsigned)))
            }
            Some(Elem::Real) => Some((Conv::Real, 32, Some(PointKind::Float))),
            Some(Elem::Time) => Some((Conv::TimeMs, 32, Some(PointKind::Signed))),
            _ => None,
        };
        let Some((conv, need_bits, need_kind)) = want else {
            problems.push(format!(
                "variable `{var}` is {ty_name}, which no point can hold (points are 1 to 32 bits: BOOL, SINT…DINT, USINT…UDINT, BYTE…DWORD, REAL, TIME in ms); bind a variable of one of these types to {point_desc}"
            ));
            return None;
        };
        let enum_ok = matches!(engine.project.types.get(at.ty), Type::Enum { .. })
            && kind != PointKind::Float;
        let ok = enum_ok
            || (bits == need_bits
                && match need_kind {
                    None => kind != PointKind::Float,
                    Some(k) => kind == k,
                });
        if !ok {
            let fix = match conv {
                Conv::Bool => format!("declare `{point}` with 1 bit (`u1`), or make `{var}` an integer of {bits} bits"),
                Conv::Real => format!("declare `{point}` as `f32`"),
                _ => format!(
                    "declare `{point}` as `{}{need_bits}`, or give `{var}` the type of the point",
                    if need_kind == Some(PointKind::Signed) { "i" } else { "u" }
                ),
            };
            problems.push(format!(
                "variable `{var}` is {ty_name} but it is bound to {point_desc}; {fix}"
            ));
            return None;
        }
        let output = ctx.map.owns(&handle);
        Some((
            Binding {
                var: var.to_string(),
                point: point.to_string(),
                at,
                handle,
                conv,
            },
            output,
        ))
    }
}

impl Module for IecModule {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let path = ctx.path(&self.file);
        let mut sources = Sources::new();
        sources.dialect = self.dialect;
        sources.overflow = self.overflow;
        sources.libs = self.libs.clone();
        sources.add_path(&path).map_err(|e| error(&self.name, e))?;
        if self.project
            && !petriplc_iec::project::is_project(&path)
            && !petriplc_iec::syntax::plcopen::is_plcopen(
                &petriplc_files::read_to_string(&path, petriplc_files::IEC_SOURCE)
                    .unwrap_or_default(),
            )
        {
            return Err(error(&self.name, format!("`project = {}` is not a PLCopen XML project; for Structured Text write `program = {}`", self.file, self.file)));
        }
        let checked =
            petriplc_iec::check_to_run(&sources, &Natives::default().with_libs(&sources.libs()))
                .map_err(|e| error(&self.name, format!("{} does not compile:\n{e}", self.file)))?;
        for w in &checked.warnings {
            log::warn!("{}: {w}", self.name);
        }
        let mut specs = petriplc_iec::instances(&checked.project, &self.select, &sources.map)
            .map_err(|e| error(&self.name, e))?;
        if let Some(task) = &self.task {
            let tasks = checked
                .project
                .configuration
                .as_ref()
                .map(|c| c.tasks.iter().map(|t| t.name.clone()).collect::<Vec<_>>())
                .unwrap_or_default();
            let Some(t) = tasks.iter().position(|n| n.eq_ignore_ascii_case(task)) else {
                return Err(error(
                    &self.name,
                    format!(
                        "`task = {task}`: the configuration has no such task (its tasks: {})",
                        if tasks.is_empty() {
                            "none".into()
                        } else {
                            tasks.join(", ")
                        }
                    ),
                ));
            };
            specs.retain(|s| s.task == Some(t as u32));
        }
        let engine = Engine::new(
            checked.project,
            &specs,
            Natives::default()
                .in_dialect(sources.dialect())
                .with_libs(&sources.libs())
                .fbs,
            &sources.map,
        )
        .map_err(|e| error(&self.name, e))?;
        let mut machine = Machine::new(engine.clone());
        machine.iterations = self.iterations;
        let kept = iec_retain::restore(&self.name, ctx, &engine, &mut machine)?;

        // Bindings: map rows, located globals, and a lone program's inputs and outputs.
        let mut problems = Vec::new();
        let mut wanted: Vec<(String, VarRef, String)> = Vec::new();
        for row in common::rows(ctx, KIND, &["map"])? {
            match row.cells.as_slice() {
                [var, point] => {
                    let found = engine.lookup(var).or_else(|| {
                        (engine.instances().len() == 1)
                            .then(|| {
                                engine.lookup(&format!("{}.{var}", engine.instances()[0].name))
                            })
                            .flatten()
                    });
                    match found {
                        Some(r) => wanted.push((var.clone(), r, point.clone())),
                        None => problems.push(format!("{}: `map {var} {point}`: the program has no variable `{var}` (write a global's name, or instance.variable)", row.origin)),
                    }
                }
                _ => problems.push(format!("{}: a map row is `map VARIABLE POINT`", row.origin)),
            }
        }
        let mapped = |name: &str, w: &[(String, VarRef, String)]| {
            w.iter().any(|(v, _, _)| v.eq_ignore_ascii_case(name))
        };
        for g in &engine.project.globals {
            let Some(loc) = &g.location else { continue };
            if mapped(&g.name, &wanted) {
                continue;
            }
            let Some(r) = engine.lookup(&g.name) else {
                continue;
            };
            if ctx.map.handle(loc).is_ok() {
                wanted.push((g.name.clone(), r, loc.clone()));
            } else {
                problems.push(format!(
                    "global `{}` is located at %{loc}, which is not a point of this PLC; name a point (`{} AT %POINT`) or add `map {} POINT` to [{}]",
                    g.name, g.name, g.name, self.name
                ));
            }
        }
        let lone = engine.project.configuration.is_none() || matches!(self.select, Select::Pou(_));
        if lone {
            for (k, inst) in engine.instances().iter().enumerate() {
                for (name, class, _) in engine.instance_vars(k) {
                    if !matches!(class, VarClass::Input | VarClass::Output)
                        || mapped(&name, &wanted)
                    {
                        continue;
                    }
                    if let Some(r) = engine.lookup(&format!("{}.{name}", inst.name)) {
                        wanted.push((name.clone(), r, name.clone()));
                    }
                }
            }
        }
        let mut inputs = Vec::new();
        let mut outputs = Vec::new();
        for (var, r, point) in wanted {
            if let Some((b, output)) = self.bind_one(ctx, &engine, &var, r, &point, &mut problems) {
                if output {
                    outputs.push(b);
                } else {
                    inputs.push(b);
                }
            }
        }
        if !problems.is_empty() {
            return Err(error(&self.name, problems.join("\n")));
        }
        // A retentive point the program drives goes on from its stored value: it is loaded
        // into the variable before the first scan, which would otherwise write the
        // variable's initial value over it. A RETAIN variable given back from the retain
        // file keeps its own value.
        for b in &outputs {
            if ctx.restored(&b.handle) && !kept.iter().any(|k| k.restored_at(b.at.addr)) {
                machine.set_slot(b.at.addr, b.read(ctx.map));
                log::debug!(
                    "{}: `{}` goes on from retentive point `{}`",
                    self.name,
                    b.var,
                    b.point
                );
            }
        }
        let period = engine
            .task_period()
            .and_then(|ns| u64::try_from(ns).ok())
            .map(Duration::from_nanos);
        self.run = Some(Run {
            engine,
            machine,
            inputs,
            outputs,
            period,
            scans: 0,
            kept,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        for b in &run.inputs {
            run.machine.set_slot(b.at.addr, b.read(ctx.map));
        }
        let started = Instant::now();
        let limit = self.watchdog;
        let mut check = || limit.is_none_or(|l| started.elapsed() < l);
        run.machine
            .scan(ctx.now.as_nanos() as i64, &mut check)
            .map_err(|f| {
                let limit = match (&f.kind, limit) {
                    (FaultKind::Watchdog, Some(l)) => {
                        format!(" (watchdog = {})", petriplc_net::time::format_iec(l))
                    }
                    _ => String::new(),
                };
                error(&self.name, format!("{}: {f}{limit}", common::at(ctx.now)))
            })?;
        for b in &run.outputs {
            let raw = run.machine.slot(b.at.addr);
            let r = match b.conv {
                Conv::Bool => ctx
                    .map
                    .set_bool(&b.handle, raw != 0)
                    .map_err(|e| e.to_string()),
                Conv::Unsigned => ctx
                    .map
                    .set_u32(&b.handle, raw as u32)
                    .map_err(|e| e.to_string()),
                Conv::Signed => ctx
                    .map
                    .set_i32(&b.handle, raw as i64 as i32)
                    .map_err(|e| e.to_string()),
                Conv::Real => ctx
                    .map
                    .set_f32(&b.handle, f64::from_bits(raw) as f32)
                    .map_err(|e| e.to_string()),
                Conv::TimeMs => {
                    let ms = raw as i64 / 1_000_000;
                    common::write_int(ctx.map, &b.handle, &b.point, ms)
                }
            };
            r.map_err(|e| {
                error(
                    &self.name,
                    format!(
                        "{}: variable `{}` → point `{}`: {e}",
                        common::at(ctx.now),
                        b.var,
                        b.point
                    ),
                )
            })?;
        }
        iec_retain::stage(&mut run.kept, &run.machine);
        run.scans += 1;
        Ok(Control::Continue)
    }

    fn status(&self) -> String {
        match &self.run {
            Some(run) => {
                let names: Vec<&str> = run
                    .engine
                    .instances()
                    .iter()
                    .map(|i| i.name.as_str())
                    .collect();
                format!(
                    "{} ({}): {} scans, {} inputs, {} outputs",
                    self.file,
                    names.join(", "),
                    run.scans,
                    run.inputs.len(),
                    run.outputs.len()
                )
            }
            None => String::new(),
        }
    }

    fn retains_data(&self) -> bool {
        self.retains
    }

    /// The engine checks `watchdog` in its loops and fails the scan with the file and line
    /// it was stuck at: the runner waits a little longer before it abandons the scan.
    fn watchdog_grace(&self) -> Duration {
        self.watchdog.map_or(Duration::ZERO, |limit| {
            (limit / 2).clamp(Duration::from_millis(20), Duration::from_millis(500))
        })
    }

    fn default_scan_period(&self) -> Option<Duration> {
        Some(
            self.run
                .as_ref()
                .and_then(|r| r.period)
                .unwrap_or(common::DEFAULT_PERIOD),
        )
    }
}
