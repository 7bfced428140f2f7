//! Runs the analyses found, as scan steps (and plant moves), and as the input timeline that
//! `petriplc sim` replays: one row per controller scan at k × period.

use std::fmt::Write as _;
use std::time::Duration;

use petriplc_net::time::format_seconds;
use petriplc_net::{Marking, Net, Scanner, SignalId, TransitionId};

use crate::plc::Plc;

/// One controller scan of a run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ScanStep {
    /// The controller's input values, in the order of `Net::inputs`.
    pub inputs: Vec<i64>,
    /// Delayed transitions the abstraction assumed had waited long enough (see
    /// docs/analysis-plc.md); empty for nets without delays.
    pub elapsed: Vec<TransitionId>,
    /// Transitions fired, in firing order.
    pub fired: Vec<TransitionId>,
    /// The controller's marking after the scan (input places shown as 0).
    pub marking: Marking,
}

/// One step of a closed-loop run.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Move {
    /// The controller scans, its inputs read from the plant's outputs (and free inputs).
    Scan(ScanStep),
    /// One plant transition fires.
    Plant {
        transition: TransitionId,
        /// Values of plant inputs nothing drives that let it fire (empty when none is read).
        free_inputs: Vec<(SignalId, i64)>,
        /// The plant's marking after the move (input places shown as 0).
        marking: Marking,
    },
}

impl Move {
    /// One line for people, e.g. `scan 3: B1=1 N1=0 → fires B1` or `plant: fill_dry_V1`.
    pub fn describe(&self, controller: &Net, plant: &Net, scan_index: usize) -> String {
        match self {
            Move::Scan(s) => format!("scan {scan_index}: {}", s.describe(controller)),
            Move::Plant {
                transition,
                free_inputs,
                ..
            } => {
                let mut out = format!("plant fires {}", plant.transition_label(*transition));
                if !free_inputs.is_empty() {
                    let _ = write!(out, " (with {})", values(plant, free_inputs));
                }
                out
            }
        }
    }
}

impl ScanStep {
    /// `B1=1 N1=0 → fires B1` (and the delays assumed elapsed, if any).
    pub fn describe(&self, net: &Net) -> String {
        let inputs: Vec<(SignalId, i64)> = net.inputs().zip(self.inputs.clone()).collect();
        let mut parts = Vec::new();
        if !inputs.is_empty() {
            parts.push(values(net, &inputs));
        }
        if !self.elapsed.is_empty() {
            parts.push(format!("delays of {} elapsed", names(net, &self.elapsed)));
        }
        let fired = if self.fired.is_empty() {
            "nothing".to_string()
        } else {
            names(net, &self.fired)
        };
        if parts.is_empty() {
            format!("→ fires {fired}")
        } else {
            format!("{} → fires {fired}", parts.join(", "))
        }
    }
}

/// A run of the controller alone from its initial marking.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Witness {
    pub steps: Vec<ScanStep>,
    /// The inputs as a timeline (`time,IN1,...`), one row per scan at k × period.
    pub timeline_csv: String,
    /// Whether the real scanner, with real timers at the analysis period and these inputs,
    /// goes through exactly these markings. Always true without delays; false when the run
    /// needs a delay to elapse sooner than it can at this period.
    pub replays: bool,
}

impl Witness {
    pub(crate) fn new(
        plc: &Plc<'_>,
        period: Duration,
        steps: Vec<ScanStep>,
        about: &[String],
    ) -> Self {
        let rows: Vec<Row<'_>> = steps.iter().map(Row::Scan).collect();
        let timeline_csv = timeline(plc.net, period, &rows, about);
        let replays = replays(plc, period, steps.iter());
        Witness {
            steps,
            timeline_csv,
            replays,
        }
    }
}

pub(crate) enum Row<'a> {
    Scan(&'a ScanStep),
    Comment(String),
}

pub(crate) fn names(net: &Net, ts: &[TransitionId]) -> String {
    ts.iter()
        .map(|&t| net.transition_label(t))
        .collect::<Vec<_>>()
        .join(", ")
}

pub(crate) fn values(net: &Net, vs: &[(SignalId, i64)]) -> String {
    vs.iter()
        .map(|(s, v)| format!("{}={v}", net.signal(*s).name))
        .collect::<Vec<_>>()
        .join(" ")
}

/// The time of scan k: exactly k × period, as the simulation schedules it.
pub(crate) fn scan_time(period: Duration, k: usize) -> Duration {
    let nanos = period.as_nanos().saturating_mul(k as u128);
    let secs = u64::try_from(nanos / 1_000_000_000).unwrap_or(u64::MAX);
    Duration::new(secs, (nanos % 1_000_000_000) as u32)
}

/// The timeline text: `about` as leading comments, then the header and one row per scan,
/// comments where the rows say.
pub(crate) fn timeline(net: &Net, period: Duration, rows: &[Row<'_>], about: &[String]) -> String {
    let mut out = String::new();
    for line in about {
        let _ = writeln!(out, "# {line}");
    }
    let inputs: Vec<SignalId> = net.inputs().collect();
    if inputs.is_empty() {
        out.push_str("# the controller has no inputs: replay it without --inputs\n");
    } else {
        out.push_str("time");
        for &s in &inputs {
            let _ = write!(out, ",{}", net.signal(s).name);
        }
        out.push('\n');
    }
    let mut k = 0;
    for row in rows {
        match row {
            Row::Comment(c) => {
                let _ = writeln!(out, "# {c}");
            }
            Row::Scan(step) => {
                if !step.elapsed.is_empty() {
                    let _ = writeln!(
                        out,
                        "# scan {k} assumes the delays of {} elapsed",
                        names(net, &step.elapsed)
                    );
                }
                if !inputs.is_empty() {
                    out.push_str(&format_seconds(scan_time(period, k)));
                    for v in &step.inputs {
                        let _ = write!(out, ",{v}");
                    }
                    out.push('\n');
                }
                k += 1;
            }
        }
    }
    out
}

/// Whether the real scanner (real timers, scan k at k × period) follows `steps` exactly.
pub(crate) fn replays<'s>(
    plc: &Plc<'_>,
    period: Duration,
    steps: impl Iterator<Item = &'s ScanStep>,
) -> bool {
    let net = plc.net;
    let mut scanner = Scanner::new(net, plc.options);
    let mut signals = vec![0; net.signals().len()];
    for (k, step) in steps.enumerate() {
        for (s, v) in net.inputs().zip(&step.inputs) {
            signals[s.index()] = *v;
        }
        if scanner.scan(scan_time(period, k), &mut signals).is_err() {
            return false;
        }
        let mut m = scanner.marking().clone();
        plc.normalize(&mut m);
        if m != step.marking {
            return false;
        }
    }
    true
}
