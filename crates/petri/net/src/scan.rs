//! PLC-scan semantics: read inputs, evolve the net, compute outputs, with time passed in by
//! the caller. docs/semantics.md states each rule and the seed it comes from.
//!
//! Two evaluators give the same scans. [`Scanner::new`] evaluates every transition in every
//! pass, as the rules are written: the reference. [`Scanner::incremental`] evaluates only what
//! can have changed: it keeps the set of transitions enabled in the current marking (arcs,
//! delays and guard; the maximal step's own reductions aside) and asks a transition again only
//! when a place its rule reads, a signal its guard reads or one of its delays changed; a timer
//! queue says when a delay runs out; outputs are written when their places change. A pass then
//! visits the transitions in that set plus, in a maximal step, those a firing earlier in the
//! pass took tokens from or added tokens to; each visit is the same rule
//! ([`TransitionArcs::allow`](crate::TransitionArcs::allow), the delays, the guard) on the
//! same values the reference sees.

use std::fmt;
use std::time::Duration;

use crate::ids::{PlaceId, SignalId, TransitionId};
use crate::model::{Evolution, Marking, Net, SignalType, StepRule, TokenOverflow};
use crate::time::format_seconds;

mod incremental;

use incremental::Incremental;

/// How a scan evolves the net; [`ScanOptions::of`] takes the net's own choices.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScanOptions {
    pub step: StepRule,
    pub evolve: Evolution,
    /// With `until-stable`, the most passes one scan may make before the net is declared
    /// unstable.
    pub max_passes: u32,
}

impl ScanOptions {
    pub const DEFAULT_MAX_PASSES: u32 = 1000;

    pub fn of(net: &Net) -> Self {
        ScanOptions {
            step: net.step,
            evolve: net.evolve,
            max_passes: Self::DEFAULT_MAX_PASSES,
        }
    }
}

/// Why a scan failed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ScanError {
    #[error(
        "the net is unstable at t={}s: still firing after {passes} passes of one scan \
         (transitions cycling: {}); break the cycle with a guard or an inhibitor arc, \
         or use --evolve one-pass",
        format_seconds(*time),
        transitions.join(", ")
    )]
    Unstable {
        time: Duration,
        passes: u32,
        transitions: Vec<String>,
    },
    #[error("at t={}s: {overflow}", format_seconds(*time))]
    Overflow {
        time: Duration,
        overflow: TokenOverflow,
    },
    #[error("time went backwards: a scan at {}s after one at {}s", format_seconds(*now), format_seconds(*previous))]
    TimeWentBackwards { previous: Duration, now: Duration },
}

/// Why a transition cannot fire now (for stepwise simulation).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Blocker {
    /// The guard is false under the current inputs.
    Guard { guard: String },
    /// A normal or read arc needs more tokens.
    Tokens { place: String, has: u32, needs: u32 },
    /// An inhibitor arc's place holds too many tokens.
    Inhibited { place: String, has: u32, limit: u32 },
    /// Firing would overfill a place.
    Capacity {
        place: String,
        would_hold: u64,
        capacity: u32,
    },
    /// A delayed arc's place has not held its tokens long enough.
    Waiting { place: String, remaining: Duration },
}

impl fmt::Display for Blocker {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Blocker::Guard { guard } => write!(f, "guard `{guard}` is false"),
            Blocker::Tokens { place, has, needs } => {
                write!(f, "{place} holds {has}, needs {needs}")
            }
            Blocker::Inhibited { place, has, limit } => {
                write!(
                    f,
                    "{place} holds {has}, inhibitor allows fewer than {limit}"
                )
            }
            Blocker::Capacity {
                place,
                would_hold,
                capacity,
            } => {
                write!(f, "{place} would hold {would_hold}, capacity {capacity}")
            }
            Blocker::Waiting { place, remaining } => {
                write!(
                    f,
                    "{place} must hold its tokens {}s longer",
                    format_seconds(*remaining)
                )
            }
        }
    }
}

/// Runs a net scan by scan. Owns the marking and the timers of delayed arcs.
#[derive(Clone, Debug)]
pub struct Scanner<'n> {
    net: &'n Net,
    options: ScanOptions,
    marking: Marking,
    /// Per place: the clamp for an input place's signal.
    capacity: Vec<u32>,
    /// Per place: the capacity the firing rule checks, `u64::MAX` for an unbounded place
    /// (whose only limit is the token counter: exceeding it is [`ScanError::Overflow`]).
    limit: Vec<u64>,
    /// Input places and the signal each mirrors.
    input_places: Vec<(PlaceId, SignalId)>,
    /// Each output signal, its type and the places bound to it.
    outputs: Vec<(SignalId, SignalType, Vec<PlaceId>)>,
    /// Per delayed arc: since when its place has held the arc's weight, if it does.
    since: Vec<Option<Duration>>,
    last_time: Option<Duration>,
    /// When set, every delayed arc holds (`true`) or none does (`false`), whatever the timers
    /// say: state-space exploration abstracts time this way.
    assume_delays: Option<bool>,
    fired: Vec<TransitionId>,
    passes: u32,
    avail: Vec<u32>,
    /// Tokens produced so far in a maximal step; `u64` so that an overflow of a place is
    /// found when the step is applied instead of wrapping.
    produced: Vec<u64>,
    /// Whether the last scan changed a place's tokens, and an output's value.
    marking_changed: bool,
    outputs_changed: bool,
    /// The incremental evaluator's tables and state ([`Scanner::incremental`]).
    incr: Option<Box<Incremental>>,
}

impl<'n> Scanner<'n> {
    /// A scanner at the initial marking, no scan made yet.
    pub fn new(net: &'n Net, options: ScanOptions) -> Self {
        let capacity = net.place_ids().map(|p| net.capacity(p)).collect();
        let limit = net
            .place_ids()
            .map(|p| net.bound(p).map_or(u64::MAX, u64::from))
            .collect();
        let input_places = net
            .place_ids()
            .filter_map(|p| net.place(p).input.map(|s| (p, s)))
            .collect();
        let outputs = net
            .outputs()
            .map(|s| {
                let places = net
                    .place_ids()
                    .filter(|&p| net.place(p).output == Some(s))
                    .collect();
                (s, net.signal(s).ty, places)
            })
            .collect();
        Scanner {
            net,
            options,
            marking: net.initial_marking(),
            capacity,
            limit,
            input_places,
            outputs,
            since: vec![None; net.timed_arcs().len()],
            last_time: None,
            assume_delays: None,
            fired: Vec::new(),
            passes: 0,
            avail: vec![0; net.places().len()],
            produced: vec![0; net.places().len()],
            marking_changed: false,
            outputs_changed: false,
            incr: None,
        }
    }

    /// A scanner that evaluates only what can have changed since the last scan (see the
    /// module documentation); its scans are exactly those of [`Scanner::new`]. It writes an
    /// output signal only when the output changes (every output on the first scan and after
    /// [`Scanner::set_marking`]), so pass the same `signals` to every scan and leave the
    /// outputs in it as the scanner wrote them.
    pub fn incremental(net: &'n Net, options: ScanOptions) -> Self {
        let mut s = Scanner::new(net, options);
        s.avail.copy_from_slice(&s.marking.0);
        s.incr = Some(Box::new(Incremental::new(net, &s.outputs)));
        s
    }

    /// Whether this scanner is [`Scanner::incremental`].
    pub fn is_incremental(&self) -> bool {
        self.incr.is_some()
    }

    /// Whether the last scan changed the tokens of some place (input places included).
    pub fn marking_changed(&self) -> bool {
        self.marking_changed
    }

    /// Whether the last scan changed the value of some output signal.
    pub fn outputs_changed(&self) -> bool {
        self.outputs_changed
    }

    pub fn net(&self) -> &'n Net {
        self.net
    }
    pub fn options(&self) -> ScanOptions {
        self.options
    }
    pub fn marking(&self) -> &Marking {
        &self.marking
    }
    /// The transitions fired by the last scan, in firing order (repeated when a transition
    /// fired in several passes).
    pub fn fired(&self) -> &[TransitionId] {
        &self.fired
    }
    /// The number of passes the last scan made.
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// Puts the net in marking `m` (timers restart), for exploring scans from any state.
    pub fn set_marking(&mut self, m: &Marking) {
        self.marking.0.copy_from_slice(&m.0);
        self.since.iter_mut().for_each(|s| *s = None);
        if let Some(inc) = &mut self.incr {
            self.avail.copy_from_slice(&self.marking.0);
            inc.valid = false;
        }
    }

    /// Makes every delayed arc hold (`Some(true)`) or never hold (`Some(false)`) as soon as
    /// its token condition does, instead of timing it; `None` restores real timers. State-space
    /// exploration uses it to abstract time away.
    pub fn assume_delays(&mut self, elapsed: Option<bool>) {
        self.assume_delays = elapsed;
        if let Some(inc) = &mut self.incr {
            inc.valid = false;
        }
    }

    /// One PLC scan at time `now`: input places take the values of their input signals,
    /// the net evolves by the step rule and evolution mode, then output signals are written.
    /// `signals` is indexed by [`SignalId`]; only outputs are written.
    pub fn scan(&mut self, now: Duration, signals: &mut [i64]) -> Result<(), ScanError> {
        if let Some(previous) = self.last_time.filter(|&t| now < t) {
            return Err(ScanError::TimeWentBackwards { previous, now });
        }
        self.last_time = Some(now);
        if let Some(mut inc) = self.incr.take() {
            self.marking_changed = false;
            self.outputs_changed = false;
            self.fired.clear();
            self.read_changes(&mut inc, signals);
            if self.quiet(&inc, now) {
                // Nothing changed, no delay ran out, nothing is enabled: the scan is one
                // pass that fires nothing (most scans of a controller waiting for inputs).
                self.passes = 1;
                self.incr = Some(inc);
                return Ok(());
            }
            let r = self.scan_incremental(&mut inc, now, signals);
            if r.is_err() {
                // Whatever the error left half done is rebuilt by the next scan.
                inc.valid = false;
                self.avail.copy_from_slice(&self.marking.0);
                self.produced.iter_mut().for_each(|x| *x = 0);
            }
            self.incr = Some(inc);
            return r;
        }
        let start = self.marking.clone();
        self.read_inputs(signals);
        self.fired.clear();
        self.passes = 0;
        // Where in `fired` the second half of the allowed passes starts: what fires there is
        // what keeps the net from settling (see `unstable`).
        let mut second_half = 0;
        loop {
            if self.options.evolve == Evolution::UntilStable
                && self.passes == self.options.max_passes
            {
                return Err(self.unstable(now, second_half));
            }
            if self.passes == self.options.max_passes / 2 {
                second_half = self.fired.len();
            }
            self.sample_timers(now);
            let before = self.fired.len();
            match self.options.step {
                StepRule::MaximalStep => self.maximal_step(now, signals)?,
                StepRule::Sequential => self.sequential(now, signals)?,
            }
            self.passes += 1;
            if self.options.evolve == Evolution::OnePass || self.fired.len() == before {
                break;
            }
        }
        self.marking_changed = self.marking != start;
        self.write_outputs(signals);
        Ok(())
    }

    /// Names the transitions that fired in the second half of the allowed passes: transients
    /// of the first passes are left out, and every transition of a cycle up to half the bound
    /// long is named (a look-back counted in firings missed parts of long cycles).
    fn unstable(&self, now: Duration, second_half: usize) -> ScanError {
        let mut ids: Vec<TransitionId> = self.fired[second_half..].to_vec();
        ids.sort();
        ids.dedup();
        ScanError::Unstable {
            time: now,
            passes: self.passes,
            transitions: ids
                .iter()
                .map(|&t| self.net.transition_label(t).to_string())
                .collect(),
        }
    }

    fn read_inputs(&mut self, signals: &[i64]) {
        for &(p, s) in &self.input_places {
            let cap = i64::from(self.capacity[p.index()]);
            self.marking[p] = signals[s.index()].clamp(0, cap) as u32;
        }
    }

    fn write_outputs(&mut self, signals: &mut [i64]) {
        self.outputs_changed = false;
        for o in 0..self.outputs.len() {
            self.write_output(o, signals);
        }
    }

    /// Writes output `o` (an index into `outputs`) from the marking.
    fn write_output(&mut self, o: usize, signals: &mut [i64]) {
        let (s, ty, places) = &self.outputs[o];
        let v = match ty {
            SignalType::Bool => i64::from(places.iter().any(|&p| self.marking[p] > 0)),
            SignalType::Int => places.first().map_or(0, |&p| i64::from(self.marking[p])),
        };
        let slot = &mut signals[s.index()];
        self.outputs_changed |= *slot != v;
        *slot = v;
    }

    /// Timers of delayed arcs look at the marking at the start of every pass.
    fn sample_timers(&mut self, now: Duration) {
        for (since, ta) in self.since.iter_mut().zip(self.net.timed_arcs()) {
            if self.marking[ta.place] >= ta.weight {
                since.get_or_insert(now);
            } else {
                *since = None;
            }
        }
    }

    fn delays_elapsed(&self, t: TransitionId, now: Duration) -> bool {
        if let Some(assumed) = self.assume_delays {
            return assumed || self.net.arcs_of(t).timed.is_empty();
        }
        self.net.arcs_of(t).timed.iter().all(|&i| {
            self.since[i].is_some_and(|s| now.saturating_sub(s) >= self.net.timed_arcs()[i].delay)
        })
    }

    /// Seed 003's `filter_possible_firings`, extended to read, inhibitor and capacity arcs.
    fn maximal_step(&mut self, now: Duration, signals: &[i64]) -> Result<(), ScanError> {
        let net = self.net;
        self.avail.copy_from_slice(&self.marking.0);
        self.produced.iter_mut().for_each(|x| *x = 0);
        for t in net.transition_ids() {
            let a = net.arcs_of(t);
            let (avail, produced, marking, limit) =
                (&self.avail, &self.produced, &self.marking, &self.limit);
            // Preset, read and inhibitor arcs see the tokens left by higher-priority members of
            // the step; capacities count the start marking plus everything produced so far.
            let enabled = a.allow(
                |p| avail[p.index()],
                |p| u64::from(marking[p]).saturating_add(produced[p.index()]),
                |p| limit[p.index()],
                |_| false,
            ) && self.delays_elapsed(t, now)
                && net.transition(t).guard.eval(signals);
            if enabled {
                for &(p, w) in &a.consume {
                    self.avail[p.index()] -= w;
                }
                for &(p, w) in &a.produce {
                    // Saturating: a sum past u32::MAX is reported as an overflow below anyway.
                    self.produced[p.index()] =
                        self.produced[p.index()].saturating_add(u64::from(w));
                }
                self.fired.push(t);
            }
        }
        // Check every place before writing any, so an error leaves the pass's start marking.
        let overflow = (0..self.avail.len()).find(|&i| {
            u64::from(self.avail[i]).saturating_add(self.produced[i]) > u64::from(u32::MAX)
        });
        if let Some(i) = overflow {
            return Err(ScanError::Overflow {
                time: now,
                overflow: TokenOverflow {
                    place: net.place_label(PlaceId::from(i)).to_string(),
                },
            });
        }
        for (i, m) in self.marking.0.iter_mut().enumerate() {
            // In range: checked just above.
            *m = (u64::from(self.avail[i]) + self.produced[i]) as u32;
        }
        Ok(())
    }

    /// Seed 004's generated code: in priority order, each enabled transition fires at once.
    fn sequential(&mut self, now: Duration, signals: &[i64]) -> Result<(), ScanError> {
        let net = self.net;
        for t in net.transition_ids() {
            if self.enabled_now(t, now, signals) {
                net.fire(&mut self.marking, t)
                    .map_err(|overflow| ScanError::Overflow {
                        time: now,
                        overflow,
                    })?;
                self.fired.push(t);
            }
        }
        Ok(())
    }

    fn enabled_now(&self, t: TransitionId, now: Duration, signals: &[i64]) -> bool {
        let m = &self.marking;
        self.net.arcs_of(t).allow(
            |p| m[p],
            |p| u64::from(m[p]),
            |p| self.limit[p.index()],
            |_| false,
        ) && self.delays_elapsed(t, now)
            && self.net.transition(t).guard.eval(signals)
    }

    /// Why `t` could not fire alone in the current marking at time `now` with these inputs
    /// (empty when it could). Delays are judged from the timers as last sampled.
    pub fn blockers(&self, t: TransitionId, now: Duration, signals: &[i64]) -> Vec<Blocker> {
        let net = self.net;
        let a = net.arcs_of(t);
        let m = &self.marking;
        let label = |p: PlaceId| net.place_label(p).to_string();
        let mut out = Vec::new();
        if !net.transition(t).guard.eval(signals) {
            out.push(Blocker::Guard {
                guard: net.guard_text(t),
            });
        }
        for &(p, w) in a.consume.iter().chain(&a.read) {
            if m[p] < w {
                out.push(Blocker::Tokens {
                    place: label(p),
                    has: m[p],
                    needs: w,
                });
            }
        }
        for &(p, w) in &a.inhibit {
            if m[p] >= w {
                out.push(Blocker::Inhibited {
                    place: label(p),
                    has: m[p],
                    limit: w,
                });
            }
        }
        for &(p, w) in &a.produce {
            let Some(capacity) = net.bound(p) else {
                continue;
            };
            let own = a.consumed_from(p);
            let would_hold = u64::from(m[p]) + u64::from(w) - u64::from(own.min(m[p]));
            if would_hold > u64::from(capacity) {
                out.push(Blocker::Capacity {
                    place: label(p),
                    would_hold,
                    capacity,
                });
            }
        }
        for &i in &a.timed {
            let ta = net.timed_arcs()[i];
            if m[ta.place] >= ta.weight {
                let held = self.since[i].map_or(Duration::ZERO, |s| now.saturating_sub(s));
                if held < ta.delay {
                    out.push(Blocker::Waiting {
                        place: label(ta.place),
                        remaining: ta.delay - held,
                    });
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    //! The hooks state-space exploration uses: placing the scanner at a marking and assuming
    //! delays elapsed or not.

    use super::*;
    use crate::guard::parse;
    use crate::model::{ArcKind, ArcSpec, NetBuilder, PlaceSpec, TransitionSpec};

    /// p1 --(delay 1 s)--> t --> p2
    fn delayed() -> Net {
        let mut b = NetBuilder::new("n", "n");
        b.place(PlaceSpec {
            id: "p1".into(),
            name: "p1".into(),
            initial: 1,
            ..Default::default()
        });
        b.place(PlaceSpec {
            id: "p2".into(),
            name: "p2".into(),
            ..Default::default()
        });
        b.transition(TransitionSpec {
            id: "t".into(),
            name: "t".into(),
            guard: parse("").unwrap(),
        });
        let arc = |id: &str, s: &str, t: &str, delay| ArcSpec {
            id: id.into(),
            source: s.into(),
            target: t.into(),
            kind: ArcKind::Normal,
            weight: 1,
            delay,
        };
        b.arc(arc("a1", "p1", "t", Some(Duration::from_secs(1))));
        b.arc(arc("a2", "t", "p2", None));
        b.build().unwrap()
    }

    fn check(assume: Option<bool>, expect: &[u32]) {
        let net = delayed();
        let mut s = Scanner::new(&net, ScanOptions::of(&net));
        s.assume_delays(assume);
        s.scan(Duration::ZERO, &mut []).unwrap();
        assert_eq!(s.marking().0, expect, "assume_delays({assume:?})");
    }

    #[test]
    fn delays_can_be_assumed_elapsed_or_not() {
        check(None, &[1, 0]);
        check(Some(true), &[0, 1]);
        check(Some(false), &[1, 0]);
    }

    #[test]
    fn set_marking_restarts_from_any_state() {
        let net = delayed();
        let mut s = Scanner::new(&net, ScanOptions::of(&net));
        s.scan(Duration::ZERO, &mut []).unwrap();
        s.set_marking(&Marking(vec![0, 5]));
        s.scan(Duration::from_secs(2), &mut []).unwrap();
        assert_eq!(s.marking().0, vec![0, 5]);
        s.set_marking(&Marking(vec![1, 0]));
        // Timers restarted: the token must wait its second again.
        s.scan(Duration::from_secs(2), &mut []).unwrap();
        assert_eq!(s.marking().0, vec![1, 0]);
        s.scan(Duration::from_secs(3), &mut []).unwrap();
        assert_eq!(s.marking().0, vec![0, 1]);
    }
}
