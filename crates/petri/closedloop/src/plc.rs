//! One PLC scan from any marking, computed by `petriplc-net`'s `Scanner`, with time abstracted
//! by a choice of which delayed transitions have waited long enough.
//!
//! # The time abstraction
//!
//! A delayed arc holds in a pass iff its timer, sampled at the start of the pass at the scan's
//! time `now`, has run for at least its delay (T1, T2). So in every pass each transition's
//! delays are either all elapsed or not, fixed for the whole pass; and they can be elapsed only
//! if every delayed arc's token condition holds at that sample (otherwise its timer is off).
//! Whether they are depends on how long the tokens have been there, i.e. on the scan period and
//! on when inputs changed, which the analysis leaves open:
//!
//! - **At the start of a scan**, every transition whose delayed arcs (with a delay > 0) all
//!   have their tokens is *eligible*, and the analysis tries both "elapsed" and "not yet" for
//!   each eligible transition independently (2^k scans for k eligible transitions).
//! - **Within a scan** `now` is fixed, so timers follow T2 exactly: a transition stays elapsed
//!   while all its delayed arcs keep their tokens at every pass start; once one loses them,
//!   its timer restarts at `now` and cannot elapse again in this scan. An arc with delay 0
//!   holds at every pass start where its tokens are there.
//!
//! Every real run, whatever the period and input timing, makes at each scan one of the choices
//! tried, so every marking it reaches is reached by the abstraction: the abstraction
//! over-approximates real timing, and a property that holds in it (a place never marked, a
//! place never above one token, conflicting outputs never both on) holds for every timing. The
//! converse fails: a run the abstraction finds may need a timing the delays forbid (e.g. a
//! 2 s delay elapsed one scan after its token came); witnesses say whether they replay with
//! real timers at the chosen period ([`Witness::replays`](crate::Witness::replays)).
//!
//! The `Scanner` cannot take per-transition delay choices, so the passes run on a copy of the
//! net whose delays are replaced by one boolean input per delayed transition, conjoined with
//! its guard: S3 and S4 test "guard and delays hold" together, so the copy fires exactly what
//! the original fires with those delay outcomes. Nets without delays are scanned as they are.

use std::collections::HashMap;
use std::convert::Infallible;
use std::time::Duration;

use petriplc_net::guard::Expr;
use petriplc_net::{
    ArcDirection, ArcSpec, Evolution, Marking, Net, NetBuilder, PlaceId, PlaceSpec, ScanError,
    ScanOptions, Scanner, SignalDirection, SignalId, SignalType, TransitionId, TransitionSpec,
};

use crate::{ClosedLoopError, MAX_DELAY_CHOICES};

/// A transition with delayed arcs.
#[derive(Clone, Debug)]
pub(crate) struct Timed {
    pub t: TransitionId,
    /// The input bit standing for "its delays hold" in the copy.
    aux: SignalId,
    /// Each delayed arc: (place, weight, delay > 0).
    arcs: Vec<(PlaceId, u32, bool)>,
}

/// A controller net prepared for scans from any state.
#[derive(Clone, Debug)]
pub(crate) struct Plc<'n> {
    pub net: &'n Net,
    pub options: ScanOptions,
    /// The copy without delays, when `net` has any.
    derived: Option<Net>,
    pub timed: Vec<Timed>,
    input_places: Vec<(PlaceId, SignalId)>,
}

impl<'n> Plc<'n> {
    pub(crate) fn new(net: &'n Net, options: ScanOptions) -> Result<Self, ClosedLoopError> {
        let (derived, timed) = match derive(net)? {
            Some((d, t)) => (Some(d), t),
            None => (None, Vec::new()),
        };
        Ok(Plc {
            net,
            options,
            derived,
            timed,
            input_places: net
                .place_ids()
                .filter_map(|p| net.place(p).input.map(|s| (p, s)))
                .collect(),
        })
    }

    /// The net the passes run on.
    fn pass_net(&self) -> &Net {
        self.derived.as_ref().unwrap_or(self.net)
    }

    /// Whether `p` is an input place (its tokens are the input's value, rewritten every scan).
    pub(crate) fn is_input_place(&self, p: PlaceId) -> bool {
        self.input_places.iter().any(|&(q, _)| q == p)
    }

    /// States keep input places at 0: S1 overwrites them before anything reads them.
    pub(crate) fn normalize(&self, m: &mut Marking) {
        for &(p, _) in &self.input_places {
            m[p] = 0;
        }
    }

    /// `m` with input places as S1 sets them from `signals`.
    fn sampled(&self, m: &Marking, signals: &[i64]) -> Marking {
        let mut m = m.clone();
        set_input_places(self.net, &mut m, signals);
        m
    }

    /// The delayed transitions (indices into `timed`) that may have waited long enough at the
    /// start of a scan from `m` with these inputs: those whose delayed arcs (delay > 0) all
    /// have their tokens. Fails beyond [`MAX_DELAY_CHOICES`].
    pub(crate) fn eligible(
        &self,
        m: &Marking,
        signals: &[i64],
    ) -> Result<Vec<usize>, ClosedLoopError> {
        if self.timed.is_empty() {
            return Ok(Vec::new());
        }
        let m = self.sampled(m, signals);
        let out: Vec<usize> = self
            .timed
            .iter()
            .enumerate()
            .filter(|(_, tt)| {
                tt.arcs.iter().any(|a| a.2) && tt.arcs.iter().all(|&(p, w, _)| m[p] >= w)
            })
            .map(|(k, _)| k)
            .collect();
        if out.len() > MAX_DELAY_CHOICES {
            return Err(ClosedLoopError::TooManyDelayChoices {
                net: self.net.id.clone(),
                count: out.len(),
                limit: MAX_DELAY_CHOICES,
                transitions: out
                    .iter()
                    .map(|&k| self.net.transition_label(self.timed[k].t).to_string())
                    .collect(),
            });
        }
        Ok(out)
    }
}

/// S1: an input place takes `max(min(value, capacity), 0)` of its signal.
pub(crate) fn set_input_places(net: &Net, m: &mut Marking, signals: &[i64]) {
    for p in net.place_ids() {
        if let Some(s) = net.place(p).input {
            m[p] = signals[s.index()].clamp(0, i64::from(net.capacity(p))) as u32;
        }
    }
}

/// S6: a boolean output is TRUE iff one of its places is marked; an integer output is its
/// place's marking. Written into `signals` (indexed by [`SignalId`]).
pub(crate) fn write_outputs(net: &Net, m: &Marking, signals: &mut [i64]) {
    for s in net.outputs() {
        let mut places = net.place_ids().filter(|&p| net.place(p).output == Some(s));
        signals[s.index()] = match net.signal(s).ty {
            SignalType::Bool => i64::from(places.any(|p| m[p] > 0)),
            SignalType::Int => places.next().map_or(0, |p| i64::from(m[p])),
        };
    }
}

/// What one scan did.
#[derive(Clone, Debug)]
pub(crate) struct Outcome {
    /// The marking after the scan, input places at 0.
    pub marking: Marking,
    /// Transitions fired, in firing order over all passes.
    pub fired: Vec<TransitionId>,
    /// The delayed transitions assumed elapsed at the start of the scan.
    pub elapsed: Vec<TransitionId>,
}

/// How passes under constant inputs end (the SIPN stability check).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) enum Settle {
    Stable,
    /// A marking (with the same delay state) came back: passes repeat forever.
    Cycle {
        /// The transitions fired in the repeating part, in priority order.
        cycle: Vec<TransitionId>,
        /// The markings of the repeating part (input places at 0), for recognising the same
        /// cycle reached from elsewhere.
        markings: Vec<Marking>,
    },
    /// Still firing after the pass limit with no marking repeated (tokens keep growing).
    Endless {
        firing: Vec<TransitionId>,
    },
}

/// Scans a [`Plc`] from any marking; owns the scanners and their signal buffer.
pub(crate) struct Stepper<'a> {
    plc: &'a Plc<'a>,
    /// The real scanner on the real net, for nets without delays.
    full: Scanner<'a>,
    /// One-pass scanner on the pass net.
    pass: Scanner<'a>,
    signals: Vec<i64>,
}

impl<'a> Stepper<'a> {
    pub(crate) fn new(plc: &'a Plc<'a>) -> Self {
        let one_pass = ScanOptions {
            evolve: Evolution::OnePass,
            ..plc.options
        };
        Stepper {
            plc,
            full: Scanner::new(plc.net, plc.options),
            pass: Scanner::new(plc.pass_net(), one_pass),
            signals: vec![0; plc.pass_net().signals().len()],
        }
    }

    /// One scan from `m` (input places ignored) with `signals` giving the inputs (indexed by
    /// the net's [`SignalId`]s) and the eligible delayed transitions whose bit is set in
    /// `choice` assumed elapsed. Errors are the scanner's (`Unstable`, `Overflow`).
    pub(crate) fn scan(
        &mut self,
        m: &Marking,
        signals: &[i64],
        eligible: &[usize],
        choice: u32,
    ) -> Result<Outcome, ScanError> {
        let old = self.initial_delays(eligible, choice);
        self.scan_from(m, signals, old, None)
    }

    /// One scan from `m` with `elapsed[k]` saying whether the delays of `timed[k]` have
    /// elapsed at the scan's first pass (only those with all their delayed tokens may be
    /// true). With `samples`, the marking each pass starts from (input places set) is
    /// pushed there: the moments the timers sample (T2).
    pub(crate) fn scan_from(
        &mut self,
        m: &Marking,
        signals: &[i64],
        elapsed: Vec<bool>,
        mut samples: Option<&mut Vec<Marking>>,
    ) -> Result<Outcome, ScanError> {
        let plc = self.plc;
        let n = plc.net.signals().len();
        if plc.timed.is_empty() {
            self.signals[..n].copy_from_slice(&signals[..n]);
            self.full.set_marking(m);
            self.full.scan(Duration::ZERO, &mut self.signals)?;
            let mut marking = self.full.marking().clone();
            plc.normalize(&mut marking);
            return Ok(Outcome {
                marking,
                fired: self.full.fired().to_vec(),
                elapsed: Vec::new(),
            });
        }
        let initial = elapsed;
        let mut old = initial.clone();
        let mut cur = plc.sampled(m, signals);
        self.signals[..n].copy_from_slice(&signals[..n]);
        let until_stable = plc.options.evolve == Evolution::UntilStable;
        let max = plc.options.max_passes;
        let (mut fired, mut passes, mut second_half) = (Vec::new(), 0u32, 0usize);
        loop {
            // The scanner's own loop (S5, X1), pass by pass so that delay bits can follow T2.
            if until_stable && passes == max {
                let mut ids = fired[second_half..].to_vec();
                ids.sort();
                ids.dedup();
                return Err(ScanError::Unstable {
                    time: Duration::ZERO,
                    passes,
                    transitions: ids
                        .iter()
                        .map(|&t| plc.net.transition_label(t).to_string())
                        .collect(),
                });
            }
            if passes == max / 2 {
                second_half = fired.len();
            }
            let before = fired.len();
            if let Some(samples) = samples.as_deref_mut() {
                samples.push(cur.clone());
            }
            cur = self.pass_once(&cur, &mut old, &mut fired)?;
            passes += 1;
            if !until_stable || fired.len() == before {
                break;
            }
        }
        plc.normalize(&mut cur);
        Ok(Outcome {
            marking: cur,
            fired,
            elapsed: initial
                .iter()
                .zip(&plc.timed)
                .filter(|(e, _)| **e)
                .map(|(_, tt)| tt.t)
                .collect(),
        })
    }

    /// Passes under constant inputs from `m` until one fires nothing, a state repeats, or
    /// `limit` passes: exactly the passes an `until-stable` scan makes.
    pub(crate) fn settle(
        &mut self,
        m: &Marking,
        signals: &[i64],
        eligible: &[usize],
        choice: u32,
        limit: u32,
    ) -> Result<Settle, ScanError> {
        let plc = self.plc;
        let n = plc.net.signals().len();
        self.signals[..n].copy_from_slice(&signals[..n]);
        let mut old = self.initial_delays(eligible, choice);
        let mut cur = plc.sampled(m, signals);
        // (marking, delay state) → pass index; per pass, where its firings start.
        let mut seen: HashMap<(Marking, Vec<bool>), usize> = HashMap::new();
        let mut starts = Vec::new();
        let mut markings = Vec::new();
        let mut fired = Vec::new();
        for pass in 0..limit as usize {
            if let Some(&first) = seen.get(&(cur.clone(), old.clone())) {
                let mut cycle = fired[starts[first]..].to_vec();
                cycle.sort();
                cycle.dedup();
                let mut ms: Vec<Marking> = markings[first..].to_vec();
                for m in &mut ms {
                    plc.normalize(m);
                }
                return Ok(Settle::Cycle {
                    cycle,
                    markings: ms,
                });
            }
            seen.insert((cur.clone(), old.clone()), pass);
            starts.push(fired.len());
            markings.push(cur.clone());
            let before = fired.len();
            cur = self.pass_once(&cur, &mut old, &mut fired)?;
            if fired.len() == before {
                return Ok(Settle::Stable);
            }
        }
        let half = starts.get(limit as usize / 2).copied().unwrap_or(0);
        let mut firing = fired[half..].to_vec();
        firing.sort();
        firing.dedup();
        Ok(Settle::Endless { firing })
    }

    fn initial_delays(&self, eligible: &[usize], choice: u32) -> Vec<bool> {
        let mut old = vec![false; self.plc.timed.len()];
        for (i, &k) in eligible.iter().enumerate() {
            old[k] = choice >> i & 1 == 1;
        }
        old
    }

    /// One pass from `cur` (input places set): samples the delays (T2) into the copy's delay
    /// bits, then runs one one-pass scan.
    fn pass_once(
        &mut self,
        cur: &Marking,
        old: &mut [bool],
        fired: &mut Vec<TransitionId>,
    ) -> Result<Marking, ScanError> {
        for (k, tt) in self.plc.timed.iter().enumerate() {
            let holds = |&(p, w, _): &(PlaceId, u32, bool)| cur[p] >= w;
            // A timer that finds its tokens gone restarts and cannot elapse again at this `now`.
            old[k] = old[k] && tt.arcs.iter().filter(|a| a.2).all(holds);
            let elapsed = tt.arcs.iter().all(|a| holds(a) && (!a.2 || old[k]));
            self.signals[tt.aux.index()] = i64::from(elapsed);
        }
        self.pass.set_marking(cur);
        self.pass.scan(Duration::ZERO, &mut self.signals)?;
        fired.extend_from_slice(self.pass.fired());
        Ok(self.pass.marking().clone())
    }
}

/// The copy of `net` whose delays are input bits, with the delayed transitions; `None` when
/// `net` has no delays.
fn derive(net: &Net) -> Result<Option<(Net, Vec<Timed>)>, ClosedLoopError> {
    let timed_ts: Vec<TransitionId> = net
        .transition_ids()
        .filter(|&t| !net.arcs_of(t).timed.is_empty())
        .collect();
    if timed_ts.is_empty() {
        return Ok(None);
    }
    let internal = |message: String| ClosedLoopError::Internal {
        net: net.id.clone(),
        message,
    };
    let mut b = NetBuilder::new(net.id.clone(), net.name.clone());
    b.step(net.step);
    b.evolve(net.evolve);
    // Declared first, in order: the copy's signal ids are the original's, then the bits.
    for s in net.signals() {
        b.signal(s.name.clone(), s.direction, s.ty);
    }
    let mut aux_names = Vec::new();
    for &t in &timed_ts {
        let mut name = format!("__delays_of_{}", t.index());
        while net.signal_by_name(&name).is_some() {
            name.push('_');
        }
        b.signal(name.clone(), SignalDirection::Input, SignalType::Bool);
        aux_names.push(name);
    }
    let sig = |s: &SignalId| Ok::<_, Infallible>(net.signal(*s).name.clone());
    for p in net.places() {
        b.place(PlaceSpec {
            id: p.id.clone(),
            name: p.name.clone(),
            initial: p.initial,
            capacity: p.capacity,
            output: p.output.map(|s| net.signal(s).name.clone()),
            input: p.input.map(|s| net.signal(s).name.clone()),
        });
    }
    for t in net.transition_ids() {
        let tr = net.transition(t);
        let Ok(mut guard) = tr.guard.0.try_map(&mut sig.clone());
        if let Some(k) = timed_ts.iter().position(|&u| u == t) {
            let bit = Expr::Signal(aux_names[k].clone());
            guard = if tr.guard.is_true() {
                bit
            } else {
                Expr::And(Box::new(guard), Box::new(bit))
            };
        }
        b.transition(TransitionSpec {
            id: tr.id.clone(),
            name: tr.name.clone(),
            guard,
        });
    }
    for a in net.arcs() {
        let (place, tr) = (&net.place(a.place).id, &net.transition(a.transition).id);
        let (source, target) = match a.direction {
            ArcDirection::PlaceToTransition => (place.clone(), tr.clone()),
            ArcDirection::TransitionToPlace => (tr.clone(), place.clone()),
        };
        b.arc(ArcSpec {
            id: a.id.clone(),
            source,
            target,
            kind: a.kind,
            weight: a.weight,
            delay: None,
        });
    }
    let derived = b.build().map_err(|errors| {
        internal(
            errors
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join("; "),
        )
    })?;
    let n = net.signals().len();
    let same = derived.signals()[..n] == *net.signals()
        && derived.places().len() == net.places().len()
        && derived.transitions().len() == net.transitions().len();
    if !same {
        return Err(internal("the copy's signals or elements differ".into()));
    }
    let timed = timed_ts
        .iter()
        .enumerate()
        .map(|(k, &t)| Timed {
            t,
            aux: SignalId::from(n + k),
            arcs: net
                .arcs_of(t)
                .timed
                .iter()
                .map(|&i| {
                    let ta = net.timed_arcs()[i];
                    (ta.place, ta.weight, !ta.delay.is_zero())
                })
                .collect(),
        })
        .collect();
    Ok(Some((derived, timed)))
}

#[cfg(test)]
mod tests {
    //! Scans with delay choices against the real scanner's timers.

    use super::*;
    use petriplc_testnet::net;

    /// Scans once from the initial marking with input vector `inputs` and every choice of the
    /// eligible delays; lists "choice: fired → marked places".
    fn check(text: &str, inputs: &[i64], expect: &[&str]) {
        let n = net(text);
        let plc = Plc::new(&n, ScanOptions::of(&n)).unwrap();
        let mut st = Stepper::new(&plc);
        let mut signals = vec![0; n.signals().len()];
        for (s, v) in n.inputs().zip(inputs) {
            signals[s.index()] = *v;
        }
        let m0 = n.initial_marking();
        let el = plc.eligible(&m0, &signals).unwrap();
        let mut got = Vec::new();
        for c in 0..1u32 << el.len() {
            let line = match st.scan(&m0, &signals, &el, c) {
                Ok(o) => {
                    let name = |t: &TransitionId| n.transition_label(*t).to_string();
                    let marked: Vec<String> = n
                        .place_ids()
                        .filter(|&p| o.marking[p] > 0)
                        .map(|p| format!("{}:{}", n.place_label(p), o.marking[p]))
                        .collect();
                    let fired = o.fired.iter().map(name).collect::<Vec<_>>().join(",");
                    format!(
                        "[{}] {} -> {}",
                        o.elapsed.iter().map(name).collect::<Vec<_>>().join(","),
                        if fired.is_empty() { "nothing" } else { &fired },
                        marked.join(" ")
                    )
                }
                Err(e) => format!("error: {e}"),
            };
            got.push(line);
        }
        assert_eq!(got, expect);
    }

    #[test]
    fn a_delay_is_tried_elapsed_and_not() {
        check(
            "p a 1\np b 0\nt t a@1s -> b",
            &[],
            &["[] nothing -> a:1", "[t] t -> b:1"],
        );
    }

    #[test]
    fn only_transitions_with_their_tokens_are_eligible() {
        // u's delayed arc has no token: u is not eligible, whatever the choice.
        check(
            "p a 1\np b 0\np c 0\nt t a@1s -> b\nt u c@1s -> a",
            &[],
            &["[] nothing -> a:1", "[t] t -> b:1"],
        );
    }

    #[test]
    fn within_a_scan_a_timer_that_loses_its_tokens_restarts() {
        // until-stable: t (delayed on a) fires, back puts the token back at once, but t's timer
        // restarted in the pass that found `a` empty, so the scan settles in `a`.
        check(
            "evolve until-stable\np a 1\np b 0\nt t a@1s -> b\nt back b -> a",
            &[],
            &["[] nothing -> a:1", "[t] t,back -> a:1"],
        );
        // A read arc keeps its tokens: the timer keeps running and t fires in every pass
        // until `b` is full.
        check(
            "evolve until-stable\np a 1\np b 0 cap=3\nt t ?a@1s -> b",
            &[],
            &["[] nothing -> a:1", "[t] t,t,t -> a:1 b:3"],
        );
    }

    #[test]
    fn delay_zero_holds_at_every_pass_start_with_tokens() {
        check(
            "evolve until-stable\np a 1\np b 0\nt t a@0s -> b\nt back b -> a",
            &[],
            &[
                "error: the net is unstable at t=0s: still firing after 1000 passes of one scan \
               (transitions cycling: t, back); break the cycle with a guard or an inhibitor \
               arc, or use --evolve one-pass",
            ],
        );
    }

    #[test]
    fn debounced_inputs_count_only_when_the_input_is_on() {
        check(
            "s X in bool\np x 0 <X\np a 1\np b 0\nt t a ?x@1s -> b",
            &[0],
            &["[] nothing -> a:1"],
        );
        check(
            "s X in bool\np x 0 <X\np a 1\np b 0\nt t a ?x@1s -> b",
            &[1],
            &["[] nothing -> a:1", "[t] t -> b:1"],
        );
    }

    /// With the delays elapsed long ago, the real scanner does what the "elapsed" choice does.
    #[test]
    fn elapsed_choice_matches_real_timers() {
        let n = net("p a 1\np b 0\np c 0\nt t a@1s -> b\nt u b -> c");
        let mut real = Scanner::new(&n, ScanOptions::of(&n));
        real.scan(Duration::ZERO, &mut []).unwrap();
        real.scan(Duration::from_secs(1), &mut []).unwrap();
        let plc = Plc::new(&n, ScanOptions::of(&n)).unwrap();
        let mut st = Stepper::new(&plc);
        let m0 = n.initial_marking();
        let el = plc.eligible(&m0, &[]).unwrap();
        let o = st.scan(&m0, &[], &el, 1).unwrap();
        assert_eq!(&o.marking, real.marking());
    }

    #[test]
    fn s6_matches_the_scanner() {
        let n = net("s Q out int\np a 2 >Q\np b 0 >B\np c 1 >B\nt t a -> b");
        let mut real = Scanner::new(&n, ScanOptions::of(&n));
        let mut signals = vec![0; n.signals().len()];
        real.scan(Duration::ZERO, &mut signals).unwrap();
        let mut mine = vec![0; n.signals().len()];
        write_outputs(&n, real.marking(), &mut mine);
        assert_eq!(mine, signals);
    }
}
