//! The closed loop: a controller net under its PLC-scan semantics and a plant net (seed 004's
//! process model) wired by signal name, and `never PLACE…`, which proves places are never
//! marked or finds, for each one that can be, a shortest run that marks it.
//!
//! # Composition
//!
//! - A plant output feeds the controller input of the same name; a controller output feeds the
//!   plant input of the same name. A name that is an output of both is an error
//!   ([`ClosedLoopError::DrivenTwice`]).
//! - An input nothing drives is **free**: it may take any value at any move (the values that
//!   matter, `domain.rs`). This is the sound choice — a button the operator presses (`B1` of
//!   the mixer) is an input of the controller that no plant drives, and "stays 0" would hide
//!   every run that presses it. A name both nets read and nothing drives is free for each
//!   independently, since a controller scan and a plant move happen at different instants.
//! - Before the controller's first scan its outputs are 0 (as in `petriplc sim` and on a PLC
//!   at power-up); afterwards they are S6 of its marking.
//!
//! # Moves
//!
//! A state is (controller marking, plant marking, whether the controller has scanned, and in
//! timed mode the clocks below). From a state, either
//!
//! - **the controller scans**: its inputs are the plant's outputs (S6 of the plant marking:
//!   a boolean output is on iff one of its places is marked, an integer output is its place's
//!   marking) and every combination of its free inputs; the scan is the `Scanner`'s, with the
//!   delay choices of `plc.rs` (untimed) or its exact timers (timed); or
//! - **one plant transition fires** under the interleaving rule (I1, I2) — except that inputs
//!   are not abstracted as I1 does: its guard reads the controller's current outputs, and its
//!   input places mirror them, clamped to their capacity (S1).
//!
//! Any number of plant moves may happen between two scans and any number of scans between two
//! plant moves.
//!
//! # Untimed (every timing)
//!
//! Plant delays and deadlines are ignored: a plant move may happen whenever its token
//! conditions hold, and the controller's delays may elapse at any scan (`plc.rs`). A run of
//! `petriplc sim` with the same nets is one of these runs when the plant has no inhibitor
//! arcs: the simulated plant fires maximal steps, each of which is a sequence of interleaved
//! moves in priority order (semantics.md §8), and its timers only restrict when moves happen.
//! So when no state marks the place, it is never marked by the closed loop for any scan
//! period, any plant timing and any behaviour of the free inputs: **proved** means exactly
//! that. A run found may be one that timing rules out (the plant filling faster than its
//! delays allow); the run lists every move so that can be judged.
//!
//! # Timed (at a scan period P)
//!
//! Time passes only with the controller's scans, exactly P apart; plant moves happen between
//! them, at any instants that keep the plant's timing. Time is counted in scans (a
//! digitisation in the sense of real-time model checking), which needs no zones and keeps
//! states finite:
//!
//! - **controller delays** are exact: an arc's timer starts at the first scan whose pass start
//!   sees its tokens and has elapsed at the first scan at least `ceil(d / P)` scans later
//!   (T1, T2 at scan k taking place at k × P). The clock is the timer's age in scans.
//! - **plant arc delays are lower bounds**: a plant move whose arc has delay d needs the arc's
//!   tokens to have been there for d. In any interval of length d at least `ceil(d / P) - 1`
//!   scans start strictly inside it (scans are P apart), so the arc may hold once its timer has
//!   seen that many scans. The clock counts scans since the tokens came (a plant move, a scan
//!   that switched the mirrored output on, or the initial marking).
//! - **plant deadlines are upper bounds** ([`Transition::deadline`](petriplc_net::Transition)):
//!   a transition enabled for D fires. A closed interval of length D holds at most
//!   `floor(D / P) + 1` scan instants, so once a transition has been enabled through that
//!   many scans, no further scan may happen before it fires (or is disabled); when a scan
//!   enabled it (switching a mirrored output), the scans after it number at most
//!   `floor(D / P)`. Enabling follows the intermediate semantics of time Petri nets: a
//!   transition is newly enabled when it was not enabled, or when the move's own consumption
//!   disabled it (or it is the one that fired).
//!
//! Every real run — scans every P, plant moves at real instants within their delays and
//! deadlines, any free inputs — is a run of this abstraction, so "proved" holds for all of
//! them. Plant delays on the input places of free inputs and deadlines are refused or ignored
//! as [`ClosedLoopError::DeadlineReadsFreeInput`] says.

use indexmap::IndexSet;
use petriplc_net::{Marking, Net, PlaceId, ScanError, SignalDirection, SignalId, TransitionId};

use crate::domain::{Combos, Reduction};
use crate::plc::{set_input_places, write_outputs, Plc, Stepper};
use crate::witness::{self, values, Move, Row, ScanStep};
use crate::{ClosedLoopError, PlcOptions};

/// A controller and a plant wired together, ready for [`never`].
#[derive(Debug)]
pub struct ClosedLoop<'n> {
    controller: Plc<'n>,
    plant: &'n Net,
    options: PlcOptions,
    controller_reduction: Reduction,
    plant_reduction: Reduction,
    /// (controller input, plant output driving it).
    controller_from_plant: Vec<(SignalId, SignalId)>,
    /// (plant input, controller output driving it).
    plant_from_controller: Vec<(SignalId, SignalId)>,
    plant_input_places: Vec<PlaceId>,
    clocks: Clocks,
}

/// The clocks of timed mode, in the order they follow the markings in a state's key. A clock
/// is 0 when off, else 1 + its count of scans.
#[derive(Clone, Debug, Default)]
struct Clocks {
    /// Controller delayed arcs (delay > 0): timers as ages in scans.
    controller: Vec<ControllerTimer>,
    /// Plant delayed arcs whose delay spans at least one scan.
    plant: Vec<PlantTimer>,
    /// Plant transitions with a deadline.
    deadlines: Vec<Deadline>,
}

#[derive(Clone, Debug)]
struct ControllerTimer {
    place: PlaceId,
    weight: u32,
    /// Elapsed at this age: `ceil(d / P)`.
    elapsed_at: u32,
    /// The index in the controller's `timed` list of its transition.
    timed: usize,
}

#[derive(Clone, Debug)]
struct PlantTimer {
    place: PlaceId,
    weight: u32,
    /// Holds from this many scans: `ceil(d / P) - 1` (at least 1, else not tracked).
    holds_at: u32,
    transition: TransitionId,
    /// The place mirrors a controller output (changes only at scans).
    mirrors_controller: bool,
}

#[derive(Clone, Debug)]
struct Deadline {
    transition: TransitionId,
    /// Scans that may happen while it stays enabled: `floor(D / P) + 1`. A scan that enables
    /// it starts its count at 1: the scans after it number at most `floor(D / P)`.
    scans: u32,
}

impl Clocks {
    fn len(&self) -> usize {
        self.controller.len() + self.plant.len() + self.deadlines.len()
    }
}

/// A place of the closed loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    Controller(PlaceId),
    Plant(PlaceId),
}

/// The answer of [`never`] for one place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum NeverResult {
    /// No reachable state marks the place (for the abstraction the module docs describe).
    Proved {
        states: u64,
        /// Controller scans that failed with `Unstable` (until-stable) and so had no successor.
        unstable_scans: u64,
    },
    /// A shortest run (in moves) that marks the place.
    Reached {
        states: u64,
        moves: Vec<Move>,
        /// The controller's inputs, one row per scan at k × period; plant moves as comments.
        /// `petriplc sim CONTROLLER --inputs FILE --period P` replays the controller side.
        timeline_csv: String,
        /// Whether the controller side replays with real timers (always, without delays).
        replays: bool,
    },
    /// `max_states` or the cancel flag stopped the search first: nothing is proved.
    Incomplete { states: u64 },
}

/// The answer of [`never_all`]: the closed loop's state space and a verdict per place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct NeverReport {
    /// States found (all of them when `complete`).
    pub states: u64,
    /// Distinct (state, successor) pairs among the states expanded, self-loops included.
    pub edges: u64,
    /// Whether every reachable state was expanded (false when every place was reached first,
    /// or a limit stopped the search).
    pub complete: bool,
    /// Controller scans that failed with `Unstable` and so had no successor.
    pub unstable_scans: u64,
    /// States from which nothing can happen: no scan (a plant deadline is due) and no plant
    /// move. In timed mode they mean the plant net's timing contradicts itself (a deadline
    /// that no move can meet); they are counted, not followed.
    pub time_locks: u64,
    /// Per place asked, in the order asked: its qualified label and verdict. `Proved` and
    /// `Incomplete` carry the final state count.
    pub verdicts: Vec<(String, NeverResult)>,
}

/// Wires `controller` and `plant` by signal name (see the module docs).
pub fn closed_loop<'n>(
    controller: &'n Net,
    plant: &'n Net,
    options: &PlcOptions,
) -> Result<ClosedLoop<'n>, ClosedLoopError> {
    let mut controller_from_plant = Vec::new();
    let mut plant_from_controller = Vec::new();
    let find = |net: &Net, name: &str, dir: SignalDirection| {
        net.signal_by_name(name)
            .filter(|&s| net.signal(s).direction == dir)
    };
    for s in plant.outputs() {
        let name = &plant.signal(s).name;
        if find(controller, name, SignalDirection::Output).is_some() {
            return Err(ClosedLoopError::DrivenTwice {
                signal: name.clone(),
            });
        }
        if let Some(c) = find(controller, name, SignalDirection::Input) {
            controller_from_plant.push((c, s));
        }
    }
    for s in plant.inputs() {
        if let Some(c) = find(controller, &plant.signal(s).name, SignalDirection::Output) {
            plant_from_controller.push((s, c));
        }
    }
    let plc = Plc::new(controller, options.scan)?;
    let clocks = match options.timed {
        false => Clocks::default(),
        true => clocks(&plc, plant, &plant_from_controller, options)?,
    };
    Ok(ClosedLoop {
        controller: plc,
        plant,
        options: options.clone(),
        controller_reduction: Reduction::new(controller),
        plant_reduction: Reduction::new(plant),
        controller_from_plant,
        plant_from_controller,
        plant_input_places: plant
            .place_ids()
            .filter(|&p| plant.place(p).input.is_some())
            .collect(),
        clocks,
    })
}

/// `ceil(d / p)` in scans, saturating at `u32::MAX - 1` (a clock's value is 1 + count).
fn scans_in(d: std::time::Duration, p: std::time::Duration) -> u32 {
    let (d, p) = (d.as_nanos(), p.as_nanos().max(1));
    u32::try_from(d.div_ceil(p)).map_or(u32::MAX - 1, |n| n.min(u32::MAX - 1))
}

/// The clocks timed mode keeps for these nets at `options.period`.
fn clocks(
    plc: &Plc<'_>,
    plant: &Net,
    plant_from_controller: &[(SignalId, SignalId)],
    options: &PlcOptions,
) -> Result<Clocks, ClosedLoopError> {
    let period = options.period;
    if period.is_zero() {
        return Err(ClosedLoopError::ZeroPeriod);
    }
    let c = plc.net;
    let mut out = Clocks::default();
    for ta in c.timed_arcs() {
        if ta.delay.is_zero() {
            continue;
        }
        let t = c.arcs()[ta.arc.index()].transition;
        let Some(timed) = plc.timed.iter().position(|x| x.t == t) else {
            continue;
        };
        out.controller.push(ControllerTimer {
            place: ta.place,
            weight: ta.weight,
            elapsed_at: scans_in(ta.delay, period),
            timed,
        });
    }
    let driven = |s: SignalId| plant_from_controller.iter().any(|(p, _)| *p == s);
    for ta in plant.timed_arcs() {
        let holds_at = scans_in(ta.delay, period).saturating_sub(1);
        let mirrors = plant.place(ta.place).input;
        // A free input may change at any instant: its timer cannot be followed in scans, so
        // its delay is ignored (which only allows more runs).
        if holds_at == 0 || mirrors.is_some_and(|s| !driven(s)) {
            continue;
        }
        out.plant.push(PlantTimer {
            place: ta.place,
            weight: ta.weight,
            holds_at,
            transition: plant.arcs()[ta.arc.index()].transition,
            mirrors_controller: mirrors.is_some(),
        });
    }
    for t in plant.transition_ids() {
        let Some(d) = plant.transition(t).deadline else {
            continue;
        };
        let mut read = Vec::new();
        plant
            .transition(t)
            .guard
            .0
            .visit_signals(&mut |s: &SignalId| read.push(*s));
        let arcs = plant.arcs_of(t);
        read.extend(
            arcs.read
                .iter()
                .chain(&arcs.inhibit)
                .filter_map(|&(p, _)| plant.place(p).input),
        );
        if let Some(&s) = read.iter().find(|&&s| !driven(s)) {
            return Err(ClosedLoopError::DeadlineReadsFreeInput {
                net: plant.id.clone(),
                transition: plant.transition_label(t).to_string(),
                signal: plant.signal(s).name.clone(),
            });
        }
        let whole = d.as_nanos() / period.as_nanos().max(1);
        out.deadlines.push(Deadline {
            transition: t,
            scans: u32::try_from(whole + 1).map_or(u32::MAX - 1, |n| n.min(u32::MAX - 1)),
        });
    }
    Ok(out)
}

/// How a state was first reached.
#[derive(Clone, Copy, Debug)]
enum Kind {
    Scan { combo: u32, choice: u32 },
    Plant { t: TransitionId, combo: u32 },
}

#[derive(Clone, Copy, Debug)]
struct Edge {
    from: u32,
    kind: Kind,
}

/// A state split into its parts.
#[derive(Clone, Debug)]
struct State {
    started: bool,
    controller: Marking,
    plant: Marking,
    /// Timed mode: every clock of [`Clocks`], in its order (0 off, else 1 + count).
    clocks: Vec<u32>,
}

/// A clock's count, if it runs.
fn count(v: u32) -> Option<u32> {
    v.checked_sub(1)
}

fn running(n: u32) -> u32 {
    n.saturating_add(1)
}

impl<'n> ClosedLoop<'n> {
    pub fn controller(&self) -> &'n Net {
        self.controller.net
    }
    pub fn plant(&self) -> &'n Net {
        self.plant
    }
    /// Whether the loop is analysed at its scan period (see the module docs).
    pub fn timed(&self) -> bool {
        self.options.timed
    }
    /// Controller inputs no plant output drives (free), in declaration order.
    pub fn free_controller_inputs(&self) -> Vec<SignalId> {
        let net = self.controller.net;
        net.inputs()
            .filter(|s| !self.controller_from_plant.iter().any(|(c, _)| c == s))
            .collect()
    }
    /// Plant inputs no controller output drives (free), in declaration order.
    pub fn free_plant_inputs(&self) -> Vec<SignalId> {
        self.plant
            .inputs()
            .filter(|s| !self.plant_from_controller.iter().any(|(p, _)| p == s))
            .collect()
    }

    /// Finds a place by label or id: `NAME`, `controller:NAME` or `plant:NAME`.
    pub fn resolve(&self, place: &str) -> Result<Target, ClosedLoopError> {
        let (c, p) = (self.controller.net, self.plant);
        let lookup = |net: &Net, name: &str| {
            net.place_ids()
                .find(|&q| net.place_label(q) == name)
                .or_else(|| net.place_by_id(name))
        };
        let unknown = |name: &str, where_: &str, nets: &[&Net]| ClosedLoopError::UnknownPlace {
            name: name.to_string(),
            where_: where_.to_string(),
            known: nets
                .iter()
                .flat_map(|n| n.place_ids().map(|q| n.place_label(q).to_string()))
                .collect(),
        };
        let target = if let Some(name) = place.strip_prefix("controller:") {
            Target::Controller(
                lookup(c, name).ok_or_else(|| unknown(name, "the controller", &[c]))?,
            )
        } else if let Some(name) = place.strip_prefix("plant:") {
            Target::Plant(lookup(p, name).ok_or_else(|| unknown(name, "the plant", &[p]))?)
        } else {
            match (lookup(c, place), lookup(p, place)) {
                (Some(q), None) => Target::Controller(q),
                (None, Some(q)) => Target::Plant(q),
                (Some(_), Some(_)) => {
                    return Err(ClosedLoopError::AmbiguousPlace {
                        name: place.to_string(),
                    })
                }
                (None, None) => return Err(unknown(place, "the controller or the plant", &[c, p])),
            }
        };
        let (net, q) = match target {
            Target::Controller(q) => (c, q),
            Target::Plant(q) => (p, q),
        };
        if let Some(s) = net.place(q).input {
            return Err(ClosedLoopError::InputPlace {
                name: net.place_label(q).to_string(),
                signal: net.signal(s).name.clone(),
            });
        }
        Ok(target)
    }

    /// `controller:NAME` or `plant:NAME`.
    pub fn label(&self, target: Target) -> String {
        match target {
            Target::Controller(q) => format!("controller:{}", self.controller.net.place_label(q)),
            Target::Plant(q) => format!("plant:{}", self.plant.place_label(q)),
        }
    }

    fn key(&self, s: &State) -> Box<[u32]> {
        let mut k = Vec::with_capacity(1 + s.controller.0.len() + s.plant.0.len() + s.clocks.len());
        k.push(u32::from(s.started));
        k.extend_from_slice(&s.controller.0);
        k.extend_from_slice(&s.plant.0);
        k.extend_from_slice(&s.clocks);
        k.into_boxed_slice()
    }

    fn split(&self, key: &[u32]) -> State {
        let nc = self.controller.net.places().len();
        let np = self.plant.places().len();
        State {
            started: key[0] == 1,
            controller: Marking(key[1..1 + nc].to_vec()),
            plant: Marking(key[1 + nc..1 + nc + np].to_vec()),
            clocks: key[1 + nc + np..].to_vec(),
        }
    }

    fn marks(&self, key: &[u32], target: Target) -> bool {
        let nc = self.controller.net.places().len();
        match target {
            Target::Controller(q) => key[1 + q.index()] > 0,
            Target::Plant(q) => key[1 + nc + q.index()] > 0,
        }
    }

    /// The state before anything happens.
    fn initial(&self) -> State {
        let (c, p) = (self.controller.net, self.plant);
        let mut controller = c.initial_marking();
        self.controller.normalize(&mut controller);
        let mut plant = p.initial_marking();
        for &q in &self.plant_input_places {
            plant[q] = 0;
        }
        let mut s = State {
            started: false,
            controller,
            plant,
            clocks: vec![0; self.clocks.len()],
        };
        if self.options.timed {
            let signals = self.plant_signals(&s);
            let base = self.clocks.controller.len();
            let mut sampled = s.plant.clone();
            set_input_places(p, &mut sampled, &signals);
            for (i, pt) in self.clocks.plant.iter().enumerate() {
                if sampled[pt.place] >= pt.weight {
                    s.clocks[base + i] = running(0);
                }
            }
            let base = base + self.clocks.plant.len();
            for (i, d) in self.clocks.deadlines.iter().enumerate() {
                if self.plant_allows(d.transition, &s.plant, &signals) {
                    s.clocks[base + i] = running(0);
                }
            }
        }
        s
    }

    /// The controller's signals with the inputs the plant drives set, and the combinations of
    /// its free inputs.
    fn controller_inputs(&self, s: &State) -> Result<(Vec<i64>, Combos), ClosedLoopError> {
        let (c, p) = (self.controller.net, self.plant);
        let mut plant_out = vec![0; p.signals().len()];
        write_outputs(p, &s.plant, &mut plant_out);
        let mut signals = vec![0; c.signals().len()];
        for &(ci, po) in &self.controller_from_plant {
            signals[ci.index()] = plant_out[po.index()];
        }
        let fixed = |x: SignalId| {
            self.controller_from_plant
                .iter()
                .find(|(ci, _)| *ci == x)
                .map(|(ci, _)| signals[ci.index()])
        };
        let combos = Combos::new(c, self.controller_reduction.domains(c, &fixed))?;
        Ok((signals, combos))
    }

    /// The plant's signals: the inputs the controller drives set from its outputs, the others 0.
    fn plant_signals(&self, s: &State) -> Vec<i64> {
        let (c, p) = (self.controller.net, self.plant);
        let mut controller_out = vec![0; c.signals().len()];
        if s.started {
            write_outputs(c, &s.controller, &mut controller_out);
        }
        let mut signals = vec![0; p.signals().len()];
        for &(pi, co) in &self.plant_from_controller {
            signals[pi.index()] = controller_out[co.index()];
        }
        signals
    }

    /// The plant's signals with the inputs the controller drives set, and the combinations of
    /// its free inputs.
    fn plant_inputs(&self, s: &State) -> Result<(Vec<i64>, Combos), ClosedLoopError> {
        let p = self.plant;
        let signals = self.plant_signals(s);
        let fixed = |x: SignalId| {
            self.plant_from_controller
                .iter()
                .find(|(pi, _)| *pi == x)
                .map(|(pi, _)| signals[pi.index()])
        };
        let combos = Combos::new(p, self.plant_reduction.domains(p, &fixed))?;
        Ok((signals, combos))
    }

    /// Whether plant transition `t` passes its guard and arc conditions (not its delays) in
    /// `m` under `signals`.
    fn plant_allows(&self, t: TransitionId, m: &Marking, signals: &[i64]) -> bool {
        let p = self.plant;
        // S1 for input places, read where the arcs look instead of copying the marking.
        let tokens = |q: PlaceId| match p.place(q).input {
            Some(s) => signals[s.index()].clamp(0, i64::from(p.capacity(q))) as u32,
            None => m[q],
        };
        p.transition(t).guard.eval(signals)
            && p.arcs_of(t).allow(
                tokens,
                |q| u64::from(tokens(q)),
                |q| p.bound(q).map_or(u64::MAX, u64::from),
                |_| false,
            )
    }

    /// Whether the delays of plant transition `t` that timed mode follows have held long
    /// enough in state `s`.
    fn plant_delays_hold(&self, t: TransitionId, s: &State) -> bool {
        let base = self.clocks.controller.len();
        self.clocks.plant.iter().enumerate().all(|(i, pt)| {
            pt.transition != t || count(s.clocks[base + i]).is_some_and(|n| n >= pt.holds_at)
        })
    }

    /// The first free-input combination under which plant transition `t` may fire in `s`.
    fn plant_enabled(
        &self,
        t: TransitionId,
        s: &State,
        signals: &mut [i64],
        combos: &Combos,
    ) -> Option<u32> {
        if !self.plant_delays_hold(t, s) {
            return None;
        }
        (0..combos.count()).find_map(|k| {
            combos.write(k, signals);
            self.plant_allows(t, &s.plant, signals).then_some(k as u32)
        })
    }

    /// Fires plant transition `t` in `s`, the clocks following (timed mode).
    fn plant_move(&self, s: &State, t: TransitionId) -> Result<State, ClosedLoopError> {
        let p = self.plant;
        let mut next = s.plant.clone();
        p.fire(&mut next, t)
            .map_err(|source| ClosedLoopError::PlantOverflow {
                net: p.id.clone(),
                source,
            })?;
        for &q in &self.plant_input_places {
            next[q] = 0;
        }
        let mut clocks = s.clocks.clone();
        if self.options.timed {
            let base = self.clocks.controller.len();
            for (i, pt) in self.clocks.plant.iter().enumerate() {
                if pt.mirrors_controller {
                    continue;
                }
                let c = &mut clocks[base + i];
                *c = match (next[pt.place] >= pt.weight, count(*c)) {
                    (false, _) => 0,
                    (true, Some(n)) => running(n),
                    (true, None) => running(0),
                };
            }
            let signals = self.plant_signals(s);
            // The intermediate marking of time Petri nets: t's preset taken, nothing added.
            let mut between = s.plant.clone();
            for &(q, w) in &p.arcs_of(t).consume {
                between[q] = between[q].saturating_sub(w);
            }
            let base = base + self.clocks.plant.len();
            for (i, d) in self.clocks.deadlines.iter().enumerate() {
                let c = &mut clocks[base + i];
                *c = if !self.plant_allows(d.transition, &next, &signals) {
                    0
                } else if d.transition == t
                    || count(*c).is_none()
                    || !self.plant_allows(d.transition, &between, &signals)
                {
                    running(0)
                } else {
                    *c
                };
            }
        }
        Ok(State {
            started: s.started,
            controller: s.controller.clone(),
            plant: next,
            clocks,
        })
    }

    /// Whether a controller scan may happen in `s`: no plant deadline is due.
    fn scan_allowed(&self, s: &State) -> bool {
        let base = self.clocks.controller.len() + self.clocks.plant.len();
        self.clocks
            .deadlines
            .iter()
            .enumerate()
            .all(|(i, d)| count(s.clocks[base + i]).is_none_or(|n| n < d.scans))
    }

    /// The controller's delay outcomes at the start of a scan in timed mode (one per entry of
    /// `timed`) and the controller clocks as that first sample leaves them.
    fn controller_delays(&self, s: &State, signals: &[i64]) -> (Vec<bool>, Vec<u32>) {
        let c = self.controller.net;
        let mut sampled = s.controller.clone();
        set_input_places(c, &mut sampled, signals);
        let mut ages = Vec::with_capacity(self.clocks.controller.len());
        for (i, ct) in self.clocks.controller.iter().enumerate() {
            ages.push(match (sampled[ct.place] >= ct.weight, count(s.clocks[i])) {
                (false, _) => 0,
                (true, Some(n)) => running(n.saturating_add(1).min(ct.elapsed_at)),
                (true, None) => running(0),
            });
        }
        // Delay-0 arcs hold whenever their tokens do, which the passes check.
        let elapsed = (0..self.controller.timed.len())
            .map(|k| {
                self.clocks
                    .controller
                    .iter()
                    .zip(&ages)
                    .filter(|(ct, _)| ct.timed == k)
                    .all(|(ct, &a)| count(a).is_some_and(|n| n >= ct.elapsed_at))
            })
            .collect();
        (elapsed, ages)
    }

    /// One controller scan from `s` with `signals`: the new state (clocks following in timed
    /// mode) and what the scan did.
    fn scan_move(
        &self,
        stepper: &mut Stepper<'_>,
        s: &State,
        signals: &[i64],
        choice: Option<(&[usize], u32)>,
    ) -> Result<(State, crate::plc::Outcome), ScanError> {
        let mut clocks = s.clocks.clone();
        let out = match choice {
            Some((eligible, choice)) => stepper.scan(&s.controller, signals, eligible, choice)?,
            None => {
                let (elapsed, mut ages) = self.controller_delays(s, signals);
                let mut samples = Vec::new();
                let out = stepper.scan_from(&s.controller, signals, elapsed, Some(&mut samples))?;
                // Later passes sample at the same time: a timer whose tokens went restarts.
                for m in samples.iter().skip(1) {
                    for (ct, a) in self.clocks.controller.iter().zip(ages.iter_mut()) {
                        *a = match (m[ct.place] >= ct.weight, count(*a)) {
                            (false, _) => 0,
                            (true, Some(_)) => *a,
                            (true, None) => running(0),
                        };
                    }
                }
                clocks[..ages.len()].copy_from_slice(&ages);
                out
            }
        };
        let mut next = State {
            started: true,
            controller: out.marking.clone(),
            plant: s.plant.clone(),
            clocks,
        };
        if self.options.timed {
            self.advance_plant_clocks(s, &mut next);
        }
        Ok((next, out))
    }

    /// After a scan from `before` to `after`: plant timers and deadlines count the scan.
    fn advance_plant_clocks(&self, before: &State, after: &mut State) {
        let p = self.plant;
        let signals = self.plant_signals(after);
        let mut sampled = after.plant.clone();
        set_input_places(p, &mut sampled, &signals);
        let base = self.clocks.controller.len();
        for (i, pt) in self.clocks.plant.iter().enumerate() {
            let c = &mut after.clocks[base + i];
            *c = match (
                sampled[pt.place] >= pt.weight,
                count(before.clocks[base + i]),
            ) {
                (false, _) => 0,
                (true, Some(n)) => running(n.saturating_add(1).min(pt.holds_at)),
                // Only a mirrored output can come on at a scan: its timer starts now.
                (true, None) => running(0),
            };
        }
        let base = base + self.clocks.plant.len();
        for (i, d) in self.clocks.deadlines.iter().enumerate() {
            let c = &mut after.clocks[base + i];
            *c = match (
                self.plant_allows(d.transition, &after.plant, &signals),
                count(before.clocks[base + i]),
            ) {
                (false, _) => 0,
                (true, Some(n)) => running(n.saturating_add(1)),
                // Enabled by this scan: every later scan is strictly after the enabling.
                (true, None) => running(1),
            };
        }
    }

    /// Applies one move to `s`, describing it.
    fn apply(
        &self,
        stepper: &mut Stepper<'_>,
        s: &State,
        kind: Kind,
    ) -> Result<(State, Move), ClosedLoopError> {
        match kind {
            Kind::Scan { combo, choice } => {
                let c = self.controller.net;
                let (mut signals, combos) = self.controller_inputs(s)?;
                combos.write(u64::from(combo), &mut signals);
                let eligible;
                let how = if self.options.timed {
                    None
                } else {
                    eligible = self.controller.eligible(&s.controller, &signals)?;
                    Some((eligible.as_slice(), choice))
                };
                let (next, out) = self
                    .scan_move(stepper, s, &signals, how)
                    .map_err(|source| ClosedLoopError::Scan {
                        net: c.id.clone(),
                        source,
                    })?;
                let step = ScanStep {
                    inputs: c.inputs().map(|x| signals[x.index()]).collect(),
                    elapsed: out.elapsed,
                    fired: out.fired,
                    marking: out.marking,
                };
                Ok((next, Move::Scan(step)))
            }
            Kind::Plant { t, combo } => {
                let (mut signals, combos) = self.plant_inputs(s)?;
                combos.write(u64::from(combo), &mut signals);
                let next = self.plant_move(s, t)?;
                let free_inputs = combos.varying().map(|x| (x, signals[x.index()])).collect();
                let marking = next.plant.clone();
                Ok((
                    next,
                    Move::Plant {
                        transition: t,
                        free_inputs,
                        marking,
                    },
                ))
            }
        }
    }

    /// Every move from `s`, in order: controller scans (free-input combinations, then delay
    /// choices), then plant transitions in priority order. Counts failed (unstable) scans.
    fn expand(
        &self,
        stepper: &mut Stepper<'_>,
        s: &State,
        out: &mut Vec<(State, Kind)>,
        unstable: &mut u64,
    ) -> Result<(), ClosedLoopError> {
        if self.scan_allowed(s) {
            let (mut signals, combos) = self.controller_inputs(s)?;
            for combo in 0..combos.count() {
                combos.write(combo, &mut signals);
                let eligible = if self.options.timed {
                    Vec::new()
                } else {
                    self.controller.eligible(&s.controller, &signals)?
                };
                let choices = if self.options.timed {
                    1
                } else {
                    1u32 << eligible.len()
                };
                for choice in 0..choices {
                    let how = (!self.options.timed).then_some((eligible.as_slice(), choice));
                    match self.scan_move(stepper, s, &signals, how) {
                        Ok((next, _)) => out.push((
                            next,
                            Kind::Scan {
                                combo: combo as u32,
                                choice,
                            },
                        )),
                        Err(ScanError::Unstable { .. }) => *unstable += 1,
                        Err(source) => {
                            return Err(ClosedLoopError::Scan {
                                net: self.controller.net.id.clone(),
                                source,
                            })
                        }
                    }
                }
            }
        }
        let (mut signals, combos) = self.plant_inputs(s)?;
        for t in self.plant.transition_ids() {
            if let Some(combo) = self.plant_enabled(t, s, &mut signals, &combos) {
                out.push((self.plant_move(s, t)?, Kind::Plant { t, combo }));
            }
        }
        Ok(())
    }

    /// The run from the initial state along `path`, as moves.
    fn replay(
        &self,
        stepper: &mut Stepper<'_>,
        path: &[Kind],
    ) -> Result<Vec<Move>, ClosedLoopError> {
        let mut s = self.initial();
        let mut moves = Vec::with_capacity(path.len());
        for &kind in path {
            let (n, mv) = self.apply(stepper, &s, kind)?;
            moves.push(mv);
            s = n;
        }
        Ok(moves)
    }

    /// The verdict for a place first marked in state `end`: the shortest run and its timeline.
    fn reached(
        &self,
        stepper: &mut Stepper<'_>,
        parent: &[Option<Edge>],
        end: usize,
        target: Target,
        states: u64,
    ) -> Result<NeverResult, ClosedLoopError> {
        let (c, p) = (self.controller.net, self.plant);
        let mut path = Vec::new();
        let mut j = end;
        while let Some(e) = parent[j] {
            path.push(e.kind);
            j = e.from as usize;
        }
        path.reverse();
        let moves = self.replay(stepper, &path)?;
        let scans: Vec<&ScanStep> = moves
            .iter()
            .filter_map(|m| match m {
                Move::Scan(st) => Some(st),
                Move::Plant { .. } => None,
            })
            .collect();
        let label = self.label(target);
        let period = petriplc_net::time::format_iec(self.options.period);
        let period = period.trim_start_matches("T#");
        let mut about = vec![format!(
            "closed loop `{}` + plant `{}`: {label} is marked after {} and {}",
            c.id,
            p.id,
            plural(scans.len(), "controller scan"),
            plural(moves.len() - scans.len(), "plant move")
        )];
        if self.options.timed {
            about.push(format!(
                "timed at a {period} scan period: controller timers exact, plant delays and deadlines kept"
            ));
        }
        about.push("one row per controller scan (its inputs: the plant's outputs and free inputs); plant moves are comments".into());
        about.push(format!(
            "replay the controller side: petriplc sim CONTROLLER.pnml --inputs THIS.csv --period {period}"
        ));
        let mut rows: Vec<Row<'_>> = Vec::with_capacity(moves.len() + 1);
        for m in &moves {
            rows.push(match m {
                Move::Scan(st) => Row::Scan(st),
                Move::Plant {
                    transition,
                    free_inputs,
                    ..
                } => Row::Comment(if free_inputs.is_empty() {
                    format!("plant fires {}", p.transition_label(*transition))
                } else {
                    format!(
                        "plant fires {} (with {})",
                        p.transition_label(*transition),
                        values(p, free_inputs)
                    )
                }),
            });
        }
        rows.push(Row::Comment(format!("now {label} is marked")));
        let timeline_csv = witness::timeline(c, self.options.period, &rows, &about);
        let replays =
            witness::replays(&self.controller, self.options.period, scans.iter().copied());
        Ok(NeverResult::Reached {
            states,
            moves,
            timeline_csv,
            replays,
        })
    }
}

/// Searches the closed loop breadth-first for a state where `place` is marked: proves it never
/// is, or returns a shortest run that marks it, with its timeline. `place` is a place label or
/// id, qualified `controller:NAME` / `plant:NAME` when both nets have it.
pub fn never(cl: &ClosedLoop<'_>, place: &str) -> Result<NeverResult, ClosedLoopError> {
    let mut report = never_all(cl, &[place])?;
    Ok(report.verdicts.remove(0).1)
}

/// [`never`] for several places in one search: the state space is explored once, each place
/// gets the shortest run that marks it (breadth-first), and the search stops early only when
/// every place has been reached. A place named twice is checked once but reported twice.
pub fn never_all(cl: &ClosedLoop<'_>, places: &[&str]) -> Result<NeverReport, ClosedLoopError> {
    let targets = places
        .iter()
        .map(|p| cl.resolve(p))
        .collect::<Result<Vec<_>, _>>()?;
    let init = cl.initial();
    let mut states: IndexSet<Box<[u32]>> = IndexSet::new();
    let mut parent: Vec<Option<Edge>> = vec![None];
    states.insert(cl.key(&init));
    let mut stepper = Stepper::new(&cl.controller);
    let (mut unstable, mut time_locks, mut edges) = (0u64, 0u64, 0u64);
    // Per target, the first state that marks it.
    let mut hits: Vec<Option<usize>> = targets
        .iter()
        .map(|&t| cl.marks(&states[0], t).then_some(0))
        .collect();
    let mut next = Vec::new();
    let mut succ: Vec<u32> = Vec::new();
    let mut i = 0;
    let mut stopped = false;
    'search: while hits.iter().any(Option::is_none) && i < states.len() {
        if cl.options.cancelled() {
            stopped = true;
            break;
        }
        let s = cl.split(&states[i]);
        next.clear();
        cl.expand(&mut stepper, &s, &mut next, &mut unstable)?;
        if next.is_empty() && cl.options.timed && !cl.scan_allowed(&s) {
            time_locks += 1;
        }
        succ.clear();
        for (n, kind) in next.drain(..) {
            let (j, new) = states.insert_full(cl.key(&n));
            succ.push(j as u32);
            if !new {
                continue;
            }
            if states.len() as u64 > cl.options.max_states {
                states.pop();
                stopped = true;
                break 'search;
            }
            parent.push(Some(Edge {
                from: i as u32,
                kind,
            }));
            let mut all = true;
            for (h, &t) in hits.iter_mut().zip(&targets) {
                if h.is_none() && cl.marks(&states[j], t) {
                    *h = Some(j);
                }
                all &= h.is_some();
            }
            if all {
                i += 1;
                break 'search;
            }
        }
        succ.sort_unstable();
        succ.dedup();
        edges += succ.len() as u64;
        i += 1;
    }
    let found = states.len() as u64;
    let complete = !stopped && i >= states.len();
    let mut verdicts = Vec::with_capacity(targets.len());
    for (&target, hit) in targets.iter().zip(&hits) {
        let verdict = match hit {
            Some(end) => cl.reached(&mut stepper, &parent, *end, target, (*end + 1) as u64)?,
            None if complete => NeverResult::Proved {
                states: found,
                unstable_scans: unstable,
            },
            None => NeverResult::Incomplete { states: found },
        };
        verdicts.push((cl.label(target), verdict));
    }
    Ok(NeverReport {
        states: found,
        edges,
        complete,
        unstable_scans: unstable,
        time_locks,
        verdicts,
    })
}

/// `1 plant move`, `3 plant moves`.
fn plural(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

#[cfg(test)]
mod tests {
    //! Wiring, place names, proofs and counterexamples, the latter replayed by the simulator.

    use std::path::Path;
    use std::time::Duration;

    use petriplc_pnml::{Naming, ReadOptions};
    use petriplc_sim::{SimOptions, Simulation, Timeline};

    use super::*;
    use petriplc_testnet::net;

    /// `never(place)` in one line: `proved N states`, `incomplete`, or the moves joined by `; `
    /// with `(replays)` / `(needs other timing)`.
    fn check(controller: &Net, plant: &Net, place: &str, expect: &str) {
        let cl = closed_loop(controller, plant, &PlcOptions::of(controller)).unwrap();
        let got = match never(&cl, place).unwrap() {
            NeverResult::Proved { states, .. } => format!("proved {states} states"),
            NeverResult::Incomplete { .. } => "incomplete".into(),
            NeverResult::Reached { moves, replays, .. } => {
                let mut k = 0;
                let mut lines = Vec::new();
                for m in &moves {
                    lines.push(m.describe(controller, plant, k));
                    k += usize::from(matches!(m, Move::Scan(_)));
                }
                let how = if replays {
                    "replays"
                } else {
                    "needs other timing"
                };
                format!("{} ({how})", lines.join("; "))
            }
        };
        assert_eq!(got, expect);
    }

    fn read(rel: &str, naming: Naming) -> Net {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
        petriplc_pnml::read_file(&path, &ReadOptions { naming })
            .unwrap_or_else(|e| panic!("{rel}: {e}"))
            .net
    }

    #[test]
    fn the_mixer_never_opens_inlet_and_outlet_together() {
        let mixer = read("../../../examples/mixer/mixer.pnml", Naming::Sipn);
        let tank = read("../../../examples/mixer/tank-observed.pnml", Naming::Plain);
        check(&mixer, &tank, "both_open", "proved 25 states");
    }

    /// The limit of the untimed plant: right after the scan that opens V1, the plant may fill
    /// from dry to high before the controller scans again, which takes 4.5 s in the tank.
    #[test]
    fn the_untimed_plant_can_outrun_the_controller() {
        let mixer = read("../../../examples/mixer/mixer.pnml", Naming::Sipn);
        let tank = read("../../../examples/mixer/tank-observed.pnml", Naming::Plain);
        check(
            &mixer,
            &tank,
            "overfill",
            "scan 0: B1=1 N2=0 N3=0 N1=1 → fires B1; plant fires fill_dry_V1; \
             plant fires fill_mid_V1; plant fires fill_high_V1; plant fires see_overfill (replays)",
        );
    }

    #[test]
    fn a_wrong_mixer_does_and_the_counterexample_replays_in_the_simulator() {
        let wrong = read("tests/data/mixer-wrong.pnml", Naming::Sipn);
        let tank = read("../../../examples/mixer/tank-observed.pnml", Naming::Plain);
        check(
            &wrong,
            &tank,
            "plant:both_open",
            "scan 0: B1=1 N2=0 N3=0 N1=1 → fires B1; plant fires fill_dry_V1; \
             plant fires fill_mid_V1; scan 1: B1=0 N2=1 N3=0 N1=0 → fires N2; \
             plant fires fill_high_V1; scan 2: B1=0 N2=1 N3=1 N1=0 → fires N3; \
             plant fires see_both (replays)",
        );
        let cl = closed_loop(&wrong, &tank, &PlcOptions::of(&wrong)).unwrap();
        let NeverResult::Reached {
            moves,
            timeline_csv,
            ..
        } = never(&cl, "both_open").unwrap()
        else {
            panic!("not reached")
        };
        assert_eq!(
            timeline_csv,
            "# closed loop `mixer_wrong` + plant `tank_observed`: plant:both_open is marked after 3 controller scans and 4 plant moves\n\
             # one row per controller scan (its inputs: the plant's outputs and free inputs); plant moves are comments\n\
             # replay the controller side: petriplc sim CONTROLLER.pnml --inputs THIS.csv --period 10ms\n\
             time,B1,N2,N3,N1\n\
             0,1,0,0,1\n\
             # plant fires fill_dry_V1\n\
             # plant fires fill_mid_V1\n\
             0.01,0,1,0,0\n\
             # plant fires fill_high_V1\n\
             0.02,0,1,1,0\n\
             # plant fires see_both\n\
             # now plant:both_open is marked\n"
        );
        // The simulator, fed the timeline alone, goes through the same controller markings.
        let scans: Vec<&ScanStep> = moves
            .iter()
            .filter_map(|m| match m {
                Move::Scan(s) => Some(s),
                Move::Plant { .. } => None,
            })
            .collect();
        let timeline = Timeline::parse(&timeline_csv, "cex.csv").unwrap();
        let period = Duration::from_millis(10);
        let opts = SimOptions::new(&wrong, period, period * (scans.len() as u32 - 1));
        let mut sim = Simulation::new(&wrong, opts, Some(timeline), None).unwrap();
        for step in &scans {
            let row = sim.step().unwrap().unwrap();
            assert_eq!(row.marking, step.marking.0);
            let fired: Vec<&str> = step
                .fired
                .iter()
                .map(|&t| wrong.transition_label(t))
                .collect();
            assert_eq!(row.fired, fired);
        }
        assert!(sim.step().unwrap().is_none());
        // The controller's outputs at the end: V1 and V3 both on.
        assert_eq!((sim.signal("V1"), sim.signal("V3")), (Some(1), Some(1)));
    }

    #[test]
    fn free_inputs_of_both_nets_take_every_value_that_matters() {
        // B is free for the controller; the plant's `go` reads its free input G.
        let c = net("s B in bool\np idle 1\np on 0 >X\nt start idle -> on if B");
        let p = net("s X in bool\ns G in bool\np x 0 <X\np armed 1\np boom 0\n\
                     t fire armed ?x -> boom if G");
        check(
            &c,
            &p,
            "boom",
            "scan 0: B=1 → fires start; plant fires fire (with G=1) (replays)",
        );
    }

    #[test]
    fn before_its_first_scan_the_controller_outputs_nothing() {
        // X's place is marked from the start, but the plant sees X = 0 until the first scan.
        let c = net("p on 1 >X");
        let p = net("s X in bool\np x 0 <X\np seen 0\nt see ?x -> seen");
        check(
            &c,
            &p,
            "seen",
            "scan 0: → fires nothing; plant fires see (replays)",
        );
    }

    #[test]
    fn a_counterexample_may_need_a_delay_to_elapse_sooner_than_the_period_allows() {
        let c = net("p a 1\np b 0 >X\nt t a@1s -> b");
        let p = net("s X in bool\np x 0 <X\np seen 0\nt see ?x -> seen");
        check(
            &c,
            &p,
            "seen",
            "scan 0: delays of t elapsed → fires t; plant fires see (needs other timing)",
        );
    }

    #[test]
    fn wiring_and_names() {
        let c = net("s B in bool\np idle 1\np on 0 >X\nt start idle -> on if B");
        let both = net("p x 0 >X");
        let err = closed_loop(&c, &both, &PlcOptions::of(&c)).unwrap_err();
        assert_eq!(
            err.to_string(),
            "`X` is an output of both the controller and the plant; a signal has one driver, rename one of them"
        );
        let p = net("s X in bool\ns B in bool\np x 0 <X\np idle 0\np b 0 <B");
        let cl = closed_loop(&c, &p, &PlcOptions::of(&c)).unwrap();
        let names = |v: Vec<SignalId>, n: &Net| -> Vec<String> {
            v.iter().map(|&s| n.signal(s).name.clone()).collect()
        };
        assert_eq!(names(cl.free_controller_inputs(), &c), ["B"]);
        assert_eq!(names(cl.free_plant_inputs(), &p), ["B"]);
        let msg = |place: &str| {
            cl.resolve(place)
                .map(|_| String::new())
                .unwrap_or_else(|e| e.to_string())
        };
        assert_eq!(
            msg("idle"),
            "`idle` names a place of the controller and of the plant; write `controller:idle` or `plant:idle`"
        );
        assert_eq!(msg("controller:idle"), "");
        assert_eq!(msg("plant:idle"), "");
        assert_eq!(msg("on"), "");
        assert_eq!(
            msg("x"),
            "`x` is an input place (it mirrors signal `X`); name the place that drives `X` instead, or add an observer place"
        );
        assert_eq!(
            msg("plant:on"),
            "no place `on` in the plant; places: x, idle, b"
        );
    }

    /// `never(place)` untimed (`None`) or timed at a period in ms: `proved`, `incomplete` or
    /// the run's moves, as in [`check`].
    fn at(controller: &Net, plant: &Net, period_ms: Option<u64>, place: &str) -> String {
        let mut opts = PlcOptions::of(controller);
        if let Some(ms) = period_ms {
            opts.period = Duration::from_millis(ms);
            opts.timed = true;
        }
        let cl = closed_loop(controller, plant, &opts).unwrap();
        match never(&cl, place).unwrap() {
            NeverResult::Proved { .. } => "proved".into(),
            NeverResult::Incomplete { .. } => "incomplete".into(),
            NeverResult::Reached { moves, .. } => {
                let mut k = 0;
                let mut lines = Vec::new();
                for m in &moves {
                    lines.push(m.describe(controller, plant, k));
                    k += usize::from(matches!(m, Move::Scan(_)));
                }
                lines.join("; ")
            }
        }
    }

    /// A motor turns until the controller sees the sensor band; crossing the band takes at
    /// least 100 ms (the plant's arc delay). Untimed, the plant may cross before the next
    /// scan; timed, a scan falls inside the band as long as scans are less than 100 ms apart.
    #[test]
    fn plant_delays_are_lower_bounds_at_the_period() {
        let c =
            net("s S in bool\np s 0 <S\np turning 1 >M\np stopped 0\nt stop turning ?s -> stopped");
        let p = net("s M in bool\np m 0 <M\np away 1\np band 0 >S\np over 0\n\
                     t enter away ?m -> band\nt overturn band@100ms ?m -> over");
        let overturns = "scan 0: S=0 → fires nothing; plant fires enter; plant fires overturn";
        assert_eq!(at(&c, &p, None, "over"), overturns);
        assert_eq!(at(&c, &p, Some(10), "over"), "proved");
        assert_eq!(at(&c, &p, Some(60), "over"), "proved");
        // 100 ms apart, a scan need not fall strictly inside the 100 ms crossing.
        assert_eq!(at(&c, &p, Some(100), "over"), overturns);
    }

    /// A belt runs for exactly 1 s (the controller's timer, exact when timed) and the
    /// workpiece on it leaves within the plant's deadline; `stuck` observes a belt that has
    /// run and stopped under the workpiece.
    #[test]
    fn plant_deadlines_are_upper_bounds_and_controller_timers_exact() {
        let c = net("p run 1 >B\np done 0\nt stop run@1s -> done");
        let plant = |deadline: &str| {
            net(&format!(
                "s B in bool\np b 0 <B\np wp 1\np gone 0\np ran 0\np stuck 0\n\
                 t leave wp ?b -> gone within={deadline}\nt note ?b !ran -> ran\n\
                 t see_stuck ?wp ?ran !b !stuck -> stuck"
            ))
        };
        let stuck = "scan 0: → fires nothing; plant fires note";
        // Untimed, the workpiece need not leave at all, and the belt may stop at any scan.
        assert!(at(&c, &plant("600ms"), None, "stuck").starts_with(stuck));
        assert_eq!(at(&c, &plant("600ms"), Some(10), "stuck"), "proved");
        // Enabled by scan 0 at t = 0, it leaves by 0.995 s, before scan 100 stops the belt.
        assert_eq!(at(&c, &plant("995ms"), Some(10), "stuck"), "proved");
        // By 1 s only: scan 100 may stop the belt at the same instant, just before it leaves.
        let late = at(&c, &plant("1s"), Some(10), "stuck");

        assert!(
            late.contains("scan 100: delays of stop elapsed → fires stop"),
            "{late}"
        );
        assert!(late.ends_with("plant fires see_stuck"), "{late}");
        // A controller scanning every 10 ms cannot stop the belt before scan 100 (t = 1 s).
        assert_eq!(late.matches("scan ").count(), 101);
    }

    #[test]
    fn deadlines_on_free_inputs_are_refused_when_timed() {
        let c = net("p idle 1");
        let p = net("s G in bool\np g 0 <G\np a 1\np b 0\nt go a ?g -> b within=1s");
        let mut opts = PlcOptions::of(&c);
        assert!(closed_loop(&c, &p, &opts).is_ok());
        opts.timed = true;
        assert_eq!(
            closed_loop(&c, &p, &opts).unwrap_err().to_string(),
            "plant `test`: transition `go` has a deadline but reads `G`, an input nothing drives; \
             a deadline on a move that depends on a free input cannot be kept in a timed analysis \
             — drive `G` from the controller or drop the deadline"
        );
    }

    /// Several places in one search: states and edges of the whole space, a verdict each.
    #[test]
    fn never_all_explores_once_for_every_place() {
        let mixer = read("../../../examples/mixer/mixer.pnml", Naming::Sipn);
        let tank = read("../../../examples/mixer/tank-observed.pnml", Naming::Plain);
        let cl = closed_loop(&mixer, &tank, &PlcOptions::of(&mixer)).unwrap();
        let report = never_all(&cl, &["both_open", "overfill", "plant:both_open"]).unwrap();
        let verdicts: Vec<String> = report
            .verdicts
            .iter()
            .map(|(label, v)| match v {
                NeverResult::Proved { states, .. } => format!("{label}: proved ({states})"),
                NeverResult::Reached { moves, .. } => format!("{label}: {} moves", moves.len()),
                NeverResult::Incomplete { .. } => format!("{label}: incomplete"),
            })
            .collect();
        assert_eq!(
            verdicts,
            [
                "plant:both_open: proved (25)",
                "plant:overfill: 5 moves",
                "plant:both_open: proved (25)"
            ]
        );
        assert!(report.complete);
        assert_eq!(
            (report.states, report.edges, report.time_locks),
            (25, 45, 0)
        );
    }

    #[test]
    fn a_search_cut_short_proves_nothing() {
        let c = net("s B in bool\np n 0\nt more -> n if B");
        let p = net("p never 0");
        let mut opts = PlcOptions::of(&c);
        opts.max_states = 10;
        let cl = closed_loop(&c, &p, &opts).unwrap();
        assert_eq!(
            never(&cl, "never").unwrap(),
            NeverResult::Incomplete { states: 10 }
        );
    }
}
