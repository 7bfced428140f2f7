//! Analysis of petriplc nets under the PLC-scan semantics they run with: the state space of a
//! controller whose inputs are free, Frey's SIPN checks on it, and the closed loop of a
//! controller with a plant net, where `--never PLACE` proves an error place unreachable or
//! returns a counterexample timeline that `petriplc sim` replays.
//!
//! Every scan is computed by `petriplc-net`'s [`Scanner`](petriplc_net::Scanner) (the one
//! semantics, docs/semantics.md); this crate adds only what analysis needs around it:
//!
//! - **inputs** — each scan is tried with every combination of the input values that matter
//!   (`domain.rs`: the reduction is exact, the argument is there);
//! - **time** — delays are abstracted by a nondeterministic choice of which delayed
//!   transitions have waited long enough (`plc.rs`), an over-approximation of every real
//!   timing, so "never reachable" is proved for every scan period and every input timing;
//!   or, for a closed loop at one scan period ([`PlcOptions::timed`]), counted in scans: the
//!   controller's timers exact, the plant's arc delays and deadlines as the bounds of its
//!   timing (`closed.rs`);
//! - **plant** — a plant net moves one transition at a time (interleaving, seed 004's process
//!   model) between controller scans, its guards and input places reading the controller's
//!   outputs (`closed.rs`).
//!
//! docs/analysis-plc.md explains the abstractions with a worked example.

mod closed;
mod domain;
mod plc;
mod sipn;
mod space;
mod witness;

use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use petriplc_net::{Net, ScanError, ScanOptions, TokenOverflow};

pub use closed::{closed_loop, never, never_all, ClosedLoop, NeverReport, NeverResult, Target};
pub use sipn::{sipn_checks, ConflictingOutputs, SipnReport, Unsafe, Unstable};
pub use space::{explore_controller, PlcSpace};
pub use witness::{Move, ScanStep, Witness};

/// At most this many input combinations are tried per scan (per state); beyond, the analysis
/// refuses with [`ClosedLoopError::TooManyInputCombinations`] rather than running for days.
pub const MAX_INPUT_COMBINATIONS: u64 = 1 << 16;

/// At most this many delayed transitions may be waiting at once; each doubles the scans tried.
pub const MAX_DELAY_CHOICES: usize = 12;

/// How the PLC-scan analyses run.
#[derive(Clone, Debug)]
pub struct PlcOptions {
    /// The controller's step rule, evolution mode and pass limit.
    pub scan: ScanOptions,
    /// Exploration stops (with `complete == false`) once this many states are known.
    pub max_states: u64,
    /// Set to `true` (e.g. by a Ctrl-C handler) to stop an exploration early, with
    /// `complete == false`.
    pub cancel: Option<Arc<AtomicBool>>,
    /// The scan period counterexample timelines are written for: scan k at k × period; in
    /// timed mode also the period the closed loop is analysed at.
    pub period: Duration,
    /// Closed loop only: analyse at exactly `period` — controller timers exact, plant delays
    /// as lower and plant deadlines as upper bounds of the plant's timing (`closed.rs`).
    /// Off: every timing (delays may elapse at any scan, plant timing ignored).
    pub timed: bool,
}

impl PlcOptions {
    pub const DEFAULT_MAX_STATES: u64 = 1_000_000;
    pub const DEFAULT_PERIOD: Duration = Duration::from_millis(10);

    /// The scan options `net` asks for, 1 000 000 states, no cancel flag, a 10 ms period.
    pub fn of(net: &Net) -> Self {
        PlcOptions {
            scan: ScanOptions::of(net),
            max_states: Self::DEFAULT_MAX_STATES,
            cancel: None,
            period: Self::DEFAULT_PERIOD,
            timed: false,
        }
    }

    fn cancelled(&self) -> bool {
        self.cancel
            .as_ref()
            .is_some_and(|c| c.load(std::sync::atomic::Ordering::Relaxed))
    }
}

/// Why an analysis could not run, or stopped.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ClosedLoopError {
    #[error(
        "net `{net}`: its inputs take {combinations} combinations of the values that matter \
         ({}), more than the {limit} the PLC-scan analysis tries per state; \
         split the net or drive some inputs from a plant",
        .inputs.iter().map(|(n, k)| format!("{n}: {k}")).collect::<Vec<_>>().join(", ")
    )]
    TooManyInputCombinations {
        net: String,
        /// The product of the per-input counts (saturating).
        combinations: u64,
        limit: u64,
        /// Each free input with the number of its values that matter.
        inputs: Vec<(String, u64)>,
    },
    #[error(
        "net `{net}`: {count} delayed transitions ({}) can be waiting at once; the analysis \
         tries each elapsed and not (2^{count} scans per input combination) and allows at most \
         {limit}",
        .transitions.join(", ")
    )]
    TooManyDelayChoices {
        net: String,
        count: usize,
        limit: usize,
        transitions: Vec<String>,
    },
    #[error("`{signal}` is an output of both the controller and the plant; a signal has one driver, rename one of them")]
    DrivenTwice { signal: String },
    #[error("no place `{name}` in {where_}; places: {}", .known.join(", "))]
    UnknownPlace {
        name: String,
        where_: String,
        known: Vec<String>,
    },
    #[error("`{name}` names a place of the controller and of the plant; write `controller:{name}` or `plant:{name}`")]
    AmbiguousPlace { name: String },
    #[error("`{name}` is an input place (it mirrors signal `{signal}`); name the place that drives `{signal}` instead, or add an observer place")]
    InputPlace { name: String, signal: String },
    #[error(
        "`{signal}` is not an output of net `{net}`; conflicting outputs are pairs of outputs"
    )]
    NotAnOutput { net: String, signal: String },
    #[error("a scan of `{net}` failed")]
    Scan {
        net: String,
        #[source]
        source: ScanError,
    },
    #[error("a move of plant `{net}` failed")]
    PlantOverflow {
        net: String,
        #[source]
        source: TokenOverflow,
    },
    #[error("the scan period is 0; a timed analysis needs a period greater than 0 (e.g. 10ms)")]
    ZeroPeriod,
    #[error("plant `{net}`: transition `{transition}` has a deadline but reads `{signal}`, an input nothing drives; a deadline on a move that depends on a free input cannot be kept in a timed analysis — drive `{signal}` from the controller or drop the deadline")]
    DeadlineReadsFreeInput {
        net: String,
        transition: String,
        signal: String,
    },
    /// A bug: rebuilding the net without its delays failed.
    #[error("internal error: cannot abstract the delays of net `{net}`: {message}")]
    Internal { net: String, message: String },
}

#[cfg(test)]
mod tests {
    //! The crate's public surface as the CLI uses it, on the shipped examples.

    use std::path::{Path, PathBuf};

    use petriplc_net::Net;
    use petriplc_pnml::{Naming, ReadOptions};

    use super::*;

    pub(crate) fn example(rel: &str, naming: Naming) -> Net {
        let path: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../examples")
            .join(rel);
        petriplc_pnml::read_file(&path, &ReadOptions { naming })
            .unwrap_or_else(|e| panic!("{rel}: {e}"))
            .net
    }

    /// One line per example: states, completeness, unsafe places, unstable cycles.
    fn check(rel: &str, naming: Naming, expect: &str) {
        let net = example(rel, naming);
        let opts = PlcOptions::of(&net);
        let space = explore_controller(&net, &opts).unwrap();
        let report = sipn_checks(&space, &[]).unwrap();
        let unsafe_: Vec<String> = report
            .unsafe_places
            .iter()
            .map(|u| net.place_label(u.place).to_string())
            .collect();
        let got = format!(
            "states={} complete={} unsafe=[{}] unstable={}",
            space.states(),
            space.complete(),
            unsafe_.join(","),
            report.unstable_total
        );
        assert_eq!(got, expect, "{rel}");
    }

    #[test]
    fn examples() {
        check(
            "mixer/mixer.pnml",
            Naming::Sipn,
            "states=4 complete=true unsafe=[] unstable=1",
        );
        check(
            "blink/blink.pnml",
            Naming::Plain,
            "states=4 complete=true unsafe=[] unstable=0",
        );
        check(
            "philosophers/philosophers.pnml",
            Naming::Plain,
            "states=11 complete=true unsafe=[] unstable=0",
        );
        check(
            "busy-beaver/busy-beaver.pnml",
            Naming::Plain,
            "states=10 complete=true unsafe=[] unstable=2",
        );
        // The plant of the mixer, analysed as a controller of its valves.
        check(
            "mixer/tank.pnml",
            Naming::Plain,
            "states=5 complete=true unsafe=[] unstable=0",
        );
    }
}
