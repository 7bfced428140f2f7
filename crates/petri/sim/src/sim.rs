//! The closed-loop driver: at every scan time it applies the timeline, steps the plant, scans
//! the controller and records the result, with signals wired between them by name.

use std::time::Duration;

use petriplc_net::{Net, ScanOptions, Scanner, SignalDirection, SignalId, SignalType};

use crate::plant::Plant;
use crate::timeline::{CursorState, Timeline};
use crate::trace::{Trace, TraceRow};
use crate::wiring::{Controller, Port, Source};

/// Kept at its old path `sim::SimError` for callers.
pub use crate::error::SimError;

/// How a simulation runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SimOptions {
    /// Time between scans; scans happen at k·period exactly.
    pub period: Duration,
    /// The last time a scan may happen (inclusive).
    pub until: Duration,
    /// The controller's scan options.
    pub scan: ScanOptions,
}

impl SimOptions {
    /// `period` and `until` with the scan options the net asks for.
    pub fn new(net: &Net, period: Duration, until: Duration) -> Self {
        SimOptions {
            period,
            until,
            scan: ScanOptions::of(net),
        }
    }
}

struct PlantWiring<'n> {
    plant: Box<dyn Plant + 'n>,
    input_names: Vec<String>,
    sources: Vec<Source<SignalId>>,
    /// Plant output index → controller input it drives.
    drives: Vec<(usize, SignalId)>,
    /// Plant outputs that drive nothing, recorded in the trace for the plot.
    observed: Vec<usize>,
    inputs: Vec<i64>,
    outputs: Vec<i64>,
    forced: Vec<Option<i64>>,
}

/// A controller net in a closed loop with an optional timeline and plant, run scan by scan.
pub struct Simulation<'n> {
    net: &'n Net,
    opts: SimOptions,
    scanner: Scanner<'n>,
    signals: Vec<i64>,
    timeline: Option<Timeline>,
    cursor: CursorState,
    /// Timeline column → controller input it drives.
    timeline_inputs: Vec<(usize, SignalId)>,
    /// Per timeline column: the controller input it drives.
    column_input: Vec<Option<SignalId>>,
    plant: Option<PlantWiring<'n>>,
    /// Per controller signal: a value set by hand, overriding timeline and plant.
    forced: Vec<Option<i64>>,
    /// The signals in `forced`, in the order they were first set.
    forced_list: Vec<SignalId>,
    /// An input was set by hand since the last scan.
    set_by_hand: bool,
    input_ids: Vec<SignalId>,
    output_ids: Vec<SignalId>,
    warnings: Vec<String>,
    /// Index of the next scan.
    next: u64,
    /// Its time, `next`·period (kept by adding the period: exact, and no division per scan).
    next_at: Duration,
    now: Duration,
    finished: bool,
    current: TraceRow,
    trace: Trace,
}

impl<'n> Simulation<'n> {
    /// Wires the timeline and plant to the controller by signal name and checks the wiring.
    pub fn new(
        controller: &'n Net,
        opts: SimOptions,
        timeline: Option<Timeline>,
        plant: Option<Box<dyn Plant + 'n>>,
    ) -> Result<Self, SimError> {
        if opts.period.is_zero() {
            return Err(SimError::ZeroPeriod);
        }
        let net = controller;
        let wiring = crate::wiring::wire(net, timeline.as_ref(), plant.as_deref())?;
        let timeline_inputs: Vec<(usize, SignalId)> = wiring
            .timeline_inputs
            .iter()
            .map(|(c, p)| (*c, p.signal))
            .collect();
        let first: Vec<String> = wiring
            .first_inputs()
            .iter()
            .map(|p| p.name.clone())
            .collect();
        let warnings = wiring.warnings;
        let plant = plant.map(|plant| {
            let input_names = plant.inputs();
            let n_outputs = plant.outputs().len();
            PlantWiring {
                plant,
                sources: wiring.plant_sources,
                drives: wiring.drives.iter().map(|(i, p)| (*i, p.signal)).collect(),
                observed: wiring.observed,
                inputs: vec![0; input_names.len()],
                outputs: vec![0; n_outputs],
                forced: vec![None; input_names.len()],
                input_names,
            }
        });

        // The trace lists inputs in the user's order: the timeline's columns, then what the
        // plant drives, then the rest as the net declares them.
        let mut trace = Trace::new(net);
        trace.period = opts.period;
        let first: Vec<&str> = first.iter().map(String::as_str).collect();
        let declared: Vec<SignalId> = net.inputs().collect();
        let input_ids = trace
            .order_inputs(&first)
            .into_iter()
            .map(|i| declared[i])
            .collect();

        let cursor = timeline.as_ref().map(CursorState::new).unwrap_or_default();
        if let Some(pw) = &plant {
            let names = pw.plant.outputs();
            trace.plant = pw.observed.iter().map(|&i| names[i].clone()).collect();
        }
        let mut column_input = vec![None; timeline.as_ref().map_or(0, |t| t.columns().len())];
        for &(c, s) in &timeline_inputs {
            column_input[c] = Some(s);
        }
        Ok(Simulation {
            net,
            opts,
            scanner: Scanner::incremental(net, opts.scan),
            column_input,
            forced_list: Vec::new(),
            set_by_hand: false,
            signals: vec![0; net.signals().len()],
            timeline,
            cursor,
            timeline_inputs,
            plant,
            forced: vec![None; net.signals().len()],
            input_ids,
            output_ids: net.outputs().collect(),
            warnings,
            next: 0,
            next_at: Duration::ZERO,
            now: Duration::ZERO,
            finished: false,
            current: TraceRow::default(),
            trace,
        })
    }

    /// Scans the controller with the reference evaluator ([`Scanner::new`], every transition
    /// every pass) instead of the incremental one, which gives the same scans: for tests that
    /// hold the two to each other. Call it before the first step.
    pub fn use_reference_evaluator(&mut self) {
        debug_assert_eq!(self.next, 0, "switch evaluators before the first scan");
        self.scanner = Scanner::new(self.net, self.opts.scan);
    }

    /// Wiring remarks that do not stop the run, e.g. inputs nothing drives.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    /// The time of scan `k`: exactly k·period, saturating at [`Duration::MAX`].
    fn time_of(&self, k: u64) -> Duration {
        let nanos = self.opts.period.as_nanos().saturating_mul(u128::from(k));
        match u64::try_from(nanos / 1_000_000_000) {
            Ok(secs) => Duration::new(secs, (nanos % 1_000_000_000) as u32),
            Err(_) => Duration::MAX,
        }
    }

    /// The time of the next scan (past `until` once the run is over).
    pub fn next_time(&self) -> Duration {
        debug_assert_eq!(self.next_at, self.time_of(self.next));
        self.next_at
    }

    /// Whether the run is over: past `until`, or stopped by an error.
    pub fn is_over(&self) -> bool {
        self.finished || self.next_time() > self.opts.until
    }

    /// Makes one scan at the next time k·period and returns its row (recorded in the trace
    /// only when something changed); `Ok(None)` once past `until`. After an error the run is
    /// over and further steps return `Ok(None)`.
    pub fn step(&mut self) -> Result<Option<&TraceRow>, SimError> {
        if self.is_over() {
            self.finished = true;
            return Ok(None);
        }
        let t = self.next_time();
        if let Err(e) = self.scan_at(t) {
            self.finished = true;
            return Err(e);
        }
        self.next += 1;
        self.next_at = self
            .next_at
            .checked_add(self.opts.period)
            .unwrap_or(Duration::MAX);
        self.now = t;
        Ok(Some(&self.current))
    }

    fn scan_at(&mut self, t: Duration) -> Result<(), SimError> {
        // (1) The timeline's values at t: only the columns that changed are written (the
        // others hold their values from earlier scans).
        let mut inputs_changed = self.next == 0 || std::mem::take(&mut self.set_by_hand);
        if let Some(tl) = &self.timeline {
            self.cursor.seek(tl, t);
        }
        let values = self.cursor.values();
        for &col in &self.cursor.changed {
            if let (Some(s), Some(v)) = (self.column_input[col], values[col]) {
                let slot = &mut self.signals[s.index()];
                inputs_changed |= *slot != v;
                *slot = v;
            }
        }
        // (2) The plant, seeing the controller's outputs from the previous scan.
        if let Some(pw) = &mut self.plant {
            for (i, src) in pw.sources.iter().enumerate() {
                let v = match *src {
                    Source::Controller(s) => Some(self.signals[s.index()]),
                    Source::Timeline(col) => values[col],
                    Source::Unwired => None,
                };
                if let Some(v) = pw.forced[i].or(v) {
                    pw.inputs[i] = v;
                }
            }
            pw.plant
                .step(t, &pw.inputs, &mut pw.outputs)
                .map_err(|source| SimError::Plant { time: t, source })?;
            for &(i, s) in &pw.drives {
                let slot = &mut self.signals[s.index()];
                inputs_changed |= *slot != pw.outputs[i];
                *slot = pw.outputs[i];
            }
        }
        for &s in &self.forced_list {
            if let Some(f) = self.forced[s.index()] {
                let slot = &mut self.signals[s.index()];
                inputs_changed |= *slot != f;
                *slot = f;
            }
        }
        // (3) The controller.
        self.scanner
            .scan(t, &mut self.signals)
            .map_err(|source| SimError::Scan { time: t, source })?;
        // (4) The record. A scan where nothing changed and nothing fired repeats the last
        // row kept (every scan's row equals the last kept one or is kept), so it is only
        // counted.
        // Plant outputs the controller does not read (kept for the plot) count as changes too:
        // `current` holds the last row built, which equals the last row kept.
        let plant_changed = self.plant.as_ref().is_some_and(|pw| {
            pw.observed.len() != self.current.plant.len()
                || pw
                    .observed
                    .iter()
                    .zip(&self.current.plant)
                    .any(|(&i, &v)| pw.outputs[i] != v)
        });
        let row = &mut self.current;
        row.time = t;
        if !inputs_changed
            && !plant_changed
            && self.scanner.fired().is_empty()
            && !self.scanner.marking_changed()
            && !self.scanner.outputs_changed()
        {
            row.fired.clear();
            self.trace.count(t);
            return Ok(());
        }
        row.inputs.clear();
        row.inputs
            .extend(self.input_ids.iter().map(|s| self.signals[s.index()]));
        row.outputs.clear();
        row.outputs
            .extend(self.output_ids.iter().map(|s| self.signals[s.index()]));
        row.marking.clear();
        row.marking.extend_from_slice(&self.scanner.marking().0);
        row.plant.clear();
        if let Some(pw) = &self.plant {
            row.plant.extend(pw.observed.iter().map(|&i| pw.outputs[i]));
        }
        row.fired.clear();
        row.fired.extend(
            self.scanner
                .fired()
                .iter()
                .map(|&t| self.net.transition_label(t).to_string()),
        );
        self.trace.record(row);
        Ok(())
    }

    /// Sets an input by hand from the next scan on, overriding the timeline and the plant for
    /// it (stepwise simulation). `name` is a controller input or a plant input fed by the
    /// timeline.
    pub fn set_input(&mut self, name: &str, value: i64) -> Result<(), SimError> {
        let net = self.net;
        let mut found = false;
        if let Some(s) = net.signal_by_name(name) {
            let sig = net.signal(s);
            if sig.direction == SignalDirection::Output {
                return Err(SimError::SetOutput {
                    name: name.to_string(),
                });
            }
            if sig.ty == SignalType::Bool && value != 0 && value != 1 {
                return Err(SimError::NotBooleanValue {
                    name: name.to_string(),
                    value,
                });
            }
            if self.forced[s.index()].is_none() {
                self.forced_list.push(s);
            }
            self.forced[s.index()] = Some(value);
            self.signals[s.index()] = value;
            self.set_by_hand = true;
            found = true;
        }
        if let Some(pw) = &mut self.plant {
            for (i, n) in pw.input_names.iter().enumerate() {
                if n == name && matches!(pw.sources[i], Source::Timeline(_)) {
                    pw.forced[i] = Some(value);
                    found = true;
                }
            }
        }
        if found {
            Ok(())
        } else {
            Err(SimError::UnknownInput {
                name: name.to_string(),
                known: self.settable_inputs(),
            })
        }
    }

    /// The controller's signals as the next scan will find them before the plant steps: the
    /// timeline's values at [`Simulation::next_time`] and inputs set by hand applied; inputs
    /// the plant drives keep their current values. For showing what could fire next.
    pub fn preview_signals(&self) -> Vec<i64> {
        let mut signals = self.signals.clone();
        if let Some(tl) = &self.timeline {
            let t = self.next_time();
            for &(col, s) in &self.timeline_inputs {
                if let Some(v) = tl.value_at(col, t) {
                    signals[s.index()] = v;
                }
            }
        }
        for (v, f) in signals.iter_mut().zip(&self.forced) {
            if let Some(f) = f {
                *v = *f;
            }
        }
        signals
    }

    /// The value input `name` will have at the next scan as far as known now (see
    /// [`Simulation::preview_signals`]); `None` for a name [`Simulation::set_input`] rejects.
    pub fn pending_input(&self, name: &str) -> Option<i64> {
        if let Some(s) = self.net.signal_by_name(name) {
            let is_input = self.net.signal(s).direction == SignalDirection::Input;
            return is_input.then(|| self.preview_signals()[s.index()]);
        }
        let pw = self.plant.as_ref()?;
        let i = pw.input_names.iter().position(|n| n == name)?;
        let Source::Timeline(col) = pw.sources[i] else {
            return None;
        };
        let timeline_value = self
            .timeline
            .as_ref()
            .and_then(|tl| tl.value_at(col, self.next_time()));
        Some(pw.forced[i].or(timeline_value).unwrap_or(pw.inputs[i]))
    }

    /// Names [`Simulation::set_input`] accepts: controller inputs, then plant inputs fed by
    /// the timeline.
    pub fn settable_inputs(&self) -> Vec<String> {
        let mut names: Vec<String> = self
            .net
            .inputs()
            .map(|s| self.net.signal(s).name.clone())
            .collect();
        if let Some(pw) = &self.plant {
            for (n, src) in pw.input_names.iter().zip(&pw.sources) {
                if matches!(src, Source::Timeline(_)) && !names.contains(n) {
                    names.push(n.clone());
                }
            }
        }
        names
    }

    /// The time of the last scan made (zero before the first).
    pub fn now(&self) -> Duration {
        self.now
    }
    /// The number of scans made.
    pub fn scans(&self) -> u64 {
        self.next
    }
    pub fn options(&self) -> &SimOptions {
        &self.opts
    }
    pub fn net(&self) -> &'n Net {
        self.net
    }
    pub fn scanner(&self) -> &Scanner<'n> {
        &self.scanner
    }
    /// The controller's signal values, indexed by [`SignalId`].
    pub fn signals(&self) -> &[i64] {
        &self.signals
    }
    /// The value of a controller signal by name.
    pub fn signal(&self, name: &str) -> Option<i64> {
        self.net
            .signal_by_name(name)
            .map(|s| self.signals[s.index()])
    }
    /// Tokens in the place with this label ([`Net::place_label`]).
    pub fn tokens(&self, label: &str) -> Option<u32> {
        let p = self
            .net
            .place_ids()
            .find(|&p| self.net.place_label(p) == label)?;
        Some(self.scanner.marking()[p])
    }
    pub fn timeline(&self) -> Option<&Timeline> {
        self.timeline.as_ref()
    }
    pub fn plant(&self) -> Option<&(dyn Plant + 'n)> {
        self.plant.as_ref().map(|p| p.plant.as_ref())
    }
    /// The plant's one-line state report.
    pub fn plant_summary(&self) -> Option<String> {
        self.plant.as_ref().map(|p| p.plant.summary())
    }
    /// The rows recorded so far.
    pub fn trace(&self) -> &Trace {
        &self.trace
    }
    pub fn into_trace(self) -> Trace {
        self.trace
    }

    /// Steps until `until` (keeping the simulation, e.g. for its plant summary).
    pub fn finish(&mut self) -> Result<(), SimError> {
        while self.step()?.is_some() {}
        Ok(())
    }

    /// Steps until `until` and returns the trace.
    pub fn run(mut self) -> Result<Trace, SimError> {
        self.finish()?;
        Ok(self.trace)
    }
}

/// A net's inputs and outputs by exact name; an input nothing drives stays 0 (FALSE).
impl Controller for Net {
    type Signal = SignalId;

    fn inputs(&self) -> Vec<Port<SignalId>> {
        self.inputs().map(|s| net_port(self, s)).collect()
    }

    fn outputs(&self) -> Vec<Port<SignalId>> {
        self.outputs().map(|s| net_port(self, s)).collect()
    }
}

fn net_port(net: &Net, s: SignalId) -> Port<SignalId> {
    let boolean = net.signal(s).ty == SignalType::Bool;
    Port {
        name: net.signal(s).name.clone(),
        signal: s,
        boolean,
        initial: if boolean { "FALSE" } else { "0" }.to_string(),
        optional: false,
    }
}

#[cfg(test)]
mod tests;
