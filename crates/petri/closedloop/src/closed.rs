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

use petriplc_net::{Marking, Net, PlaceId, SignalDirection, SignalId, TransitionId};

use crate::domain::Reduction;
use crate::plc::{set_input_places, Plc};
use crate::witness::Move;
use crate::{ClosedLoopError, PlcOptions};

mod moves;
mod search;
#[cfg(test)]
mod tests;

pub use search::{never, never_all};

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
}
