//! `petriplc sim PROGRAM.st`: an IEC program scanned offline, every `period`, against a
//! timeline of inputs and an optional plant, with the trace format of nets (`time`, an
//! `in:NAME` column per input, then one column per output value; a row for the first scan
//! and for every scan where something changed).
//!
//! Timeline columns and plant outputs drive the program's VAR_INPUTs by name
//! (case-insensitive; `instance.input` when a configuration runs several programs; global
//! variables too, the configuration's I/O); plant inputs read VAR_OUTPUTs and globals. The
//! trace's inputs are the VAR_INPUTs and the globals the timeline or plant drives (in the
//! timeline's column order, then the plant's, then declaration order, as for nets); then a
//! column per VAR_OUTPUT (and, for a configuration, per other global variable), and with
//! `vars` the programs' other variables. Time is exact: the same program and inputs give the
//! same trace.
//!
//! Values crossing to the integer world of timelines and plants: BOOL 0/1, integers as they
//! are, REAL rounded, TIME in milliseconds.

use std::io::{self, Write};
use std::sync::Arc;
use std::time::Duration;

use petriplc_iec_sema::ir::VarClass;
use petriplc_iec_sema::types::{Elem, Type, TypeId};
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::{display, Engine, Machine, VarRef};
use petriplc_net::time::format_seconds;
use petriplc_sim::wiring::{Controller, Port, Source};
use petriplc_sim::{Plant, SimError, Timeline};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimOptions {
    pub period: Duration,
    /// The last time a scan may happen (inclusive).
    pub until: Duration,
    /// Trace the programs' other variables too.
    pub vars: bool,
}

/// A variable the simulation reads or writes.
#[derive(Clone, Debug)]
struct Var {
    name: String,
    var: VarRef,
}

struct PlantWiring<'p> {
    plant: Box<dyn Plant + 'p>,
    sources: Vec<Source<VarRef>>,
    drives: Vec<(usize, VarRef, String)>,
    inputs: Vec<i64>,
    outputs: Vec<i64>,
}

/// The record of a run.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IecTrace {
    /// What ran (the plot's title): the program, or the configuration.
    pub name: String,
    pub period: Duration,
    /// The first `inputs` columns are inputs (written `in:NAME`).
    pub inputs: usize,
    pub columns: Vec<String>,
    /// Whether each column is BOOL (plotted as a step line of 0/1).
    pub boolean: Vec<bool>,
    /// Time and displayed values of the first scan and of every scan with a change.
    pub rows: Vec<(Duration, Vec<String>)>,
    /// The same rows as integers (BOOL 0/1, REAL rounded, TIME in ms, STRING its length),
    /// for plots.
    pub numbers: Vec<Vec<i64>>,
    pub scans: u64,
    /// The time of the last scan made.
    pub end: Duration,
}

impl IecTrace {
    /// `time,in:<input>…,<column>…`, one line per row, CSV fields quoted where needed.
    pub fn write_csv(&self, mut w: impl Write) -> io::Result<()> {
        let mut line = String::from("time");
        for (i, c) in self.columns.iter().enumerate() {
            if i < self.inputs {
                push_field(&mut line, &format!("in:{c}"));
            } else {
                push_field(&mut line, c);
            }
        }
        line.push('\n');
        w.write_all(line.as_bytes())?;
        for (t, vals) in &self.rows {
            line.clear();
            line.push_str(&format_seconds(*t));
            for v in vals {
                push_field(&mut line, v);
            }
            line.push('\n');
            w.write_all(line.as_bytes())?;
        }
        w.flush()
    }

    pub fn to_csv(&self) -> String {
        let mut out = Vec::new();
        let _ = self.write_csv(&mut out);
        String::from_utf8_lossy(&out).into_owned()
    }

    /// How many data lines [`IecTrace::write_csv`] writes.
    pub fn csv_rows(&self) -> usize {
        self.rows.len()
    }

    /// The trace in the form the SVG plot draws (inputs and outputs, no places).
    pub fn to_plot_trace(&self) -> petriplc_sim::Trace {
        use petriplc_net::SignalType;
        let ty = |b: &bool| {
            if *b {
                SignalType::Bool
            } else {
                SignalType::Int
            }
        };
        let k = self.inputs.min(self.columns.len());
        petriplc_sim::Trace {
            net: self.name.clone(),
            period: self.period,
            inputs: self.columns[..k].to_vec(),
            input_types: self.boolean[..k].iter().map(ty).collect(),
            outputs: self.columns[k..].to_vec(),
            output_types: self.boolean[k..].iter().map(ty).collect(),
            output_places: vec![Vec::new(); self.columns.len() - k],
            rows: self
                .rows
                .iter()
                .zip(&self.numbers)
                .map(|((t, _), n)| petriplc_sim::TraceRow {
                    time: *t,
                    inputs: n[..k].to_vec(),
                    outputs: n[k..].to_vec(),
                    ..Default::default()
                })
                .collect(),
            end: self.end,
            scans: self.scans,
            ..Default::default()
        }
    }
}

fn push_field(line: &mut String, field: &str) {
    line.push(',');
    if field.contains([',', '"', '\n', '\r']) {
        line.push('"');
        line.push_str(&field.replace('"', "\"\""));
        line.push('"');
    } else {
        line.push_str(field);
    }
}

/// A program (or a configuration's programs) in a closed loop with a timeline and a plant.
pub struct IecSimulation<'p> {
    engine: Arc<Engine>,
    machine: Machine,
    opts: SimOptions,
    timeline: Option<Timeline>,
    timeline_inputs: Vec<(usize, Var)>,
    plant: Option<PlantWiring<'p>>,
    columns: Vec<Var>,
    warnings: Vec<String>,
    next: u64,
    now: Duration,
    finished: bool,
    trace: IecTrace,
    last: Option<Vec<String>>,
}

impl<'p> IecSimulation<'p> {
    pub fn new(
        engine: Arc<Engine>,
        opts: SimOptions,
        timeline: Option<Timeline>,
        plant: Option<Box<dyn Plant + 'p>>,
    ) -> Result<Self, SimError> {
        if opts.period.is_zero() {
            return Err(SimError::ZeroPeriod);
        }
        let machine = Machine::new(engine.clone());
        let several = engine.instances().len() > 1;
        let configured = engine.project.configuration.is_some()
            && engine.instances().iter().any(|i| i.task.is_some());
        // Inputs and outputs of every program instance, and the globals.
        let mut inputs: Vec<Var> = Vec::new();
        let mut outputs: Vec<Var> = Vec::new();
        let mut others: Vec<Var> = Vec::new();
        for (k, inst) in engine.instances().iter().enumerate() {
            for (name, class, ty) in engine.instance_vars(k) {
                // What the LD/SFC lowering adds (`__…`) is not the program's; an SFC step is
                // shown by its flag `S.X`.
                if name.starts_with("__") {
                    continue;
                }
                let step = matches!(
                    engine.project.types.get(ty),
                    petriplc_iec_sema::types::Type::Struct { name, .. } if name == "__SFC_STEP"
                );
                let name = if step { format!("{name}.X") } else { name };
                if !step && !traceable(&engine, ty) {
                    continue;
                }
                let Some(var) = engine.lookup(&format!("{}.{name}", inst.name)) else {
                    continue;
                };
                let shown = if several {
                    format!("{}.{name}", inst.name)
                } else {
                    name.clone()
                };
                let v = Var { name: shown, var };
                match class {
                    VarClass::Input => inputs.push(v),
                    VarClass::Output => outputs.push(v),
                    VarClass::Local => others.push(v),
                    _ => {}
                }
            }
        }
        let mut globals: Vec<Var> = Vec::new();
        for g in &engine.project.globals {
            // A vendor library's own globals (TwinCAT's task index) are not the project's I/O.
            if g.constant
                || !traceable(&engine, g.ty)
                || petriplc_iec_syntax::builtin::is_builtin(g.span.file)
            {
                continue;
            }
            if let Some(var) = engine.lookup(&g.name) {
                globals.push(Var {
                    name: g.name.clone(),
                    var,
                });
            }
        }
        let wiring = {
            let controller = Vars {
                engine: &engine,
                machine: &machine,
                inputs: &inputs,
                outputs: &outputs,
                globals: &globals,
            };
            petriplc_sim::wire(&controller, timeline.as_ref(), plant.as_deref())?
        };
        let var = |p: &Port<VarRef>| Var {
            name: p.name.clone(),
            var: p.signal,
        };
        let timeline_inputs: Vec<(usize, Var)> = wiring
            .timeline_inputs
            .iter()
            .map(|(c, p)| (*c, var(p)))
            .collect();
        let first: Vec<Var> = wiring.first_inputs().into_iter().map(var).collect();
        let warnings = wiring.warnings;
        let plant = plant.map(|plant| PlantWiring {
            inputs: vec![0; plant.inputs().len()],
            outputs: vec![0; plant.outputs().len()],
            plant,
            sources: wiring.plant_sources,
            drives: wiring
                .drives
                .iter()
                .map(|(i, p)| (*i, p.signal, p.name.clone()))
                .collect(),
        });
        // Inputs as nets order them: the timeline's columns, then what the plant drives, then
        // the other VAR_INPUTs in declaration order.
        let mut columns: Vec<Var> = Vec::new();
        let push = |columns: &mut Vec<Var>, v: &Var| {
            if !columns.iter().any(|c| c.var.addr == v.var.addr) {
                columns.push(v.clone());
            }
        };
        for v in &first {
            push(&mut columns, v);
        }
        for v in &inputs {
            push(&mut columns, v);
        }
        let n_inputs = columns.len();
        for v in &outputs {
            push(&mut columns, v);
        }
        // A configuration's globals are its I/O (located variables): traced like outputs.
        if configured || engine.project.configuration.is_some() || opts.vars {
            for v in &globals {
                push(&mut columns, v);
            }
        }
        if opts.vars {
            for v in &others {
                push(&mut columns, v);
            }
        }
        let name = match engine.project.configuration.as_ref() {
            Some(c) if configured => format!("CONFIGURATION {}", c.name),
            _ => engine
                .instances()
                .iter()
                .map(|i| i.name.clone())
                .collect::<Vec<_>>()
                .join(", "),
        };
        let trace = IecTrace {
            name,
            period: opts.period,
            inputs: n_inputs,
            columns: columns.iter().map(|c| c.name.clone()).collect(),
            boolean: columns
                .iter()
                .map(|c| matches!(engine.project.types.get(c.var.ty), Type::Elem(Elem::Bool)))
                .collect(),
            ..IecTrace::default()
        };
        Ok(IecSimulation {
            engine,
            machine,
            opts,
            timeline,
            timeline_inputs,
            plant,
            columns,
            warnings,
            next: 0,
            now: Duration::ZERO,
            finished: false,
            trace,
            last: None,
        })
    }

    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    pub fn machine(&mut self) -> &mut Machine {
        &mut self.machine
    }

    fn time_of(&self, k: u64) -> Duration {
        let nanos = self.opts.period.as_nanos().saturating_mul(u128::from(k));
        match u64::try_from(nanos / 1_000_000_000) {
            Ok(secs) => Duration::new(secs, (nanos % 1_000_000_000) as u32),
            Err(_) => Duration::MAX,
        }
    }

    /// Runs every scan until `until`; returns the trace (or the first failure).
    pub fn run(mut self) -> Result<IecTrace, SimError> {
        while self.step()? {}
        Ok(self.trace)
    }

    /// Makes one scan at the next time k·period; `Ok(false)` once past `until`. After an
    /// error the run is over and further steps return `Ok(false)`.
    pub fn step(&mut self) -> Result<bool, SimError> {
        let t = self.time_of(self.next);
        if self.finished || t > self.opts.until {
            self.finished = true;
            return Ok(false);
        }
        if let Err(e) = self.scan_at(t) {
            self.finished = true;
            return Err(e);
        }
        self.next += 1;
        self.now = t;
        Ok(true)
    }

    /// The time of the last scan made.
    pub fn now(&self) -> Duration {
        self.now
    }

    /// How many scans were made.
    pub fn scans(&self) -> u64 {
        self.trace.scans
    }

    pub fn options(&self) -> &SimOptions {
        &self.opts
    }

    pub fn trace(&self) -> &IecTrace {
        &self.trace
    }

    pub fn into_trace(self) -> IecTrace {
        self.trace
    }

    fn set_input(&mut self, v: VarRef, name: &str, raw: i64, t: Duration) -> Result<(), SimError> {
        let p = &self.engine.project;
        let bad = |why: String| SimError::BadValue {
            time: t,
            name: name.to_string(),
            value: raw,
            why,
        };
        let value = match p.types.get(v.ty) {
            Type::Elem(Elem::Bool) => {
                if raw != 0 && raw != 1 {
                    return Err(bad("a BOOL input takes 0/1 or TRUE/FALSE".into()));
                }
                Value::Int(raw as i128)
            }
            Type::Elem(e) if e.is_real() => Value::Real(raw as f64),
            Type::Elem(e) if e.is_duration() => Value::Int(raw as i128 * 1_000_000),
            _ => Value::Int(raw as i128),
        };
        self.machine.set(v, &value).map_err(bad)
    }

    fn scan_at(&mut self, t: Duration) -> Result<(), SimError> {
        let values: Vec<Option<i64>> = match &self.timeline {
            Some(tl) => (0..tl.columns().len()).map(|c| tl.value_at(c, t)).collect(),
            None => Vec::new(),
        };
        let inputs = self.timeline_inputs.clone();
        for (col, v) in &inputs {
            if let Some(x) = values.get(*col).copied().flatten() {
                self.set_input(v.var, &v.name, x, t)?;
            }
        }
        // The plant steps first, seeing the program's outputs of the previous scan.
        if let Some(mut pw) = self.plant.take() {
            for (i, src) in pw.sources.iter().enumerate() {
                let v = match src {
                    Source::Controller(v) => Some(to_i64(&self.engine, &self.machine, *v)),
                    Source::Timeline(c) => values.get(*c).copied().flatten(),
                    Source::Unwired => None,
                };
                if let Some(v) = v {
                    pw.inputs[i] = v;
                }
            }
            let r = pw.plant.step(t, &pw.inputs, &mut pw.outputs);
            if let Err(source) = r {
                return Err(SimError::Plant { time: t, source });
            }
            let drives = pw.drives.clone();
            let outs = pw.outputs.clone();
            self.plant = Some(pw);
            for (i, v, name) in drives {
                self.set_input(v, &name, outs[i], t)?;
            }
        }
        self.machine
            .scan(t.as_nanos() as i64, &mut || true)
            .map_err(|fault| SimError::Fault {
                time: t,
                fault: Arc::new(fault),
            })?;
        let row: Vec<String> = self
            .columns
            .iter()
            .map(|c| {
                self.machine
                    .get(c.var)
                    .map_or_else(String::new, |v| display(&self.engine.project, c.var.ty, &v))
            })
            .collect();
        self.trace.scans += 1;
        self.trace.end = t;
        if self.last.as_ref() != Some(&row) {
            let numbers = self
                .columns
                .iter()
                .map(|c| to_i64(&self.engine, &self.machine, c.var))
                .collect();
            self.trace.rows.push((t, row.clone()));
            self.trace.numbers.push(numbers);
            self.last = Some(row);
        }
        Ok(())
    }

    /// The plant's one-line state report.
    pub fn plant_summary(&self) -> Option<String> {
        self.plant.as_ref().map(|p| p.plant.summary())
    }
}

/// A program's variables as the closed loop's wiring sees them: VAR_INPUTs and globals may be
/// driven, VAR_OUTPUTs and globals read; names ignore case, as IEC 61131-3 identifiers do.
struct Vars<'a> {
    engine: &'a Engine,
    machine: &'a Machine,
    inputs: &'a [Var],
    outputs: &'a [Var],
    globals: &'a [Var],
}

impl Vars<'_> {
    fn port(&self, v: &Var, optional: bool) -> Port<VarRef> {
        let boolean = matches!(
            self.engine.project.types.get(v.var.ty),
            Type::Elem(Elem::Bool)
        );
        let value = self.machine.get(v.var);
        let initial = match (&value, boolean) {
            (Some(Value::Int(0)), true) => "FALSE".to_string(),
            (Some(Value::Int(_)), true) => "TRUE".to_string(),
            (Some(x), false) => display(&self.engine.project, v.var.ty, x),
            _ => "its initial value".to_string(),
        };
        Port {
            name: v.name.clone(),
            signal: v.var,
            boolean,
            initial,
            optional,
        }
    }
}

impl Controller for Vars<'_> {
    type Signal = VarRef;

    fn inputs(&self) -> Vec<Port<VarRef>> {
        let inputs = self.inputs.iter().map(|v| self.port(v, false));
        // A configuration's globals are its I/O: driven when a column names one, set by the
        // programs otherwise.
        inputs
            .chain(self.globals.iter().map(|v| self.port(v, true)))
            .collect()
    }

    fn outputs(&self) -> Vec<Port<VarRef>> {
        let outputs = self.outputs.iter().map(|v| self.port(v, false));
        outputs
            .chain(self.globals.iter().map(|v| self.port(v, true)))
            .collect()
    }

    fn same_name(&self, a: &str, b: &str) -> bool {
        a.eq_ignore_ascii_case(b)
    }
}

/// Whether a variable's values fit one trace column (elementary, enumerations, strings).
fn traceable(engine: &Engine, ty: TypeId) -> bool {
    matches!(
        engine.project.types.get(ty),
        Type::Elem(_) | Type::Enum { .. } | Type::Subrange { .. } | Type::Str { .. }
    )
}

/// A program value for the integer world of plants: BOOL 0/1, integers, REAL rounded, TIME
/// in milliseconds.
fn to_i64(engine: &Engine, m: &Machine, v: VarRef) -> i64 {
    let ty = engine.project.types.get(v.ty);
    match (m.get(v), ty) {
        (Some(Value::Real(f)), _) => f.round() as i64,
        (Some(Value::Int(i)), Type::Elem(e)) if e.is_duration() => (i / 1_000_000) as i64,
        (Some(Value::Int(i)), _) => i as i64,
        (Some(Value::Str(s)), _) => s.len() as i64,
        (Some(Value::WStr(w)), _) => w.len() as i64,
        _ => 0,
    }
}
