//! The closed loop: a controller net under its PLC-scan semantics and a plant net (seed 004's
//! process model) wired by signal name, and `never PLACE`, which proves a place is never
//! marked or finds a shortest run that marks it.
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
//! A state is (controller marking, plant marking, whether the controller has scanned). From a
//! state, either
//!
//! - **the controller scans**: its inputs are the plant's outputs (S6 of the plant marking:
//!   a boolean output is on iff one of its places is marked, an integer output is its place's
//!   marking) and every combination of its free inputs; the scan is the `Scanner`'s, with the
//!   delay choices of `plc.rs`; or
//! - **one plant transition fires** under the interleaving rule (I1, I2) — except that inputs
//!   are not abstracted as I1 does: its guard reads the controller's current outputs, and its
//!   input places mirror them, clamped to their capacity (S1). Plant delays are ignored: a
//!   plant move may happen whenever its token conditions hold.
//!
//! Any number of plant moves may happen between two scans and any number of scans between two
//! plant moves. A run of `petriplc sim` with the same nets is one of these runs when the
//! plant has no inhibitor arcs: the simulated plant fires maximal steps, each of which is a
//! sequence of interleaved moves in priority order (semantics.md §8), and its timers only
//! restrict when moves happen. So when no state marks the place, it is never marked by the
//! closed loop for any scan period, any plant timing and any behaviour of the free inputs:
//! **proved** means exactly that. A run found may be one that timing rules out (the plant
//! filling faster than its delays allow); the run lists every move so that can be judged.

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
}

/// A place of the closed loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    Controller(PlaceId),
    Plant(PlaceId),
}

/// The answer of [`never`].
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
    Ok(ClosedLoop {
        controller: Plc::new(controller, options.scan)?,
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
    })
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
struct State {
    started: bool,
    controller: Marking,
    plant: Marking,
}

impl<'n> ClosedLoop<'n> {
    pub fn controller(&self) -> &'n Net {
        self.controller.net
    }
    pub fn plant(&self) -> &'n Net {
        self.plant
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

    fn label(&self, target: Target) -> String {
        match target {
            Target::Controller(q) => format!("controller:{}", self.controller.net.place_label(q)),
            Target::Plant(q) => format!("plant:{}", self.plant.place_label(q)),
        }
    }

    fn key(&self, s: &State) -> Box<[u32]> {
        let mut k = Vec::with_capacity(1 + s.controller.0.len() + s.plant.0.len());
        k.push(u32::from(s.started));
        k.extend_from_slice(&s.controller.0);
        k.extend_from_slice(&s.plant.0);
        k.into_boxed_slice()
    }

    fn split(&self, key: &[u32]) -> State {
        let nc = self.controller.net.places().len();
        State {
            started: key[0] == 1,
            controller: Marking(key[1..1 + nc].to_vec()),
            plant: Marking(key[1 + nc..].to_vec()),
        }
    }

    fn marks(&self, key: &[u32], target: Target) -> bool {
        let nc = self.controller.net.places().len();
        match target {
            Target::Controller(q) => key[1 + q.index()] > 0,
            Target::Plant(q) => key[1 + nc + q.index()] > 0,
        }
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

    /// The plant's signals with the inputs the controller drives set, and the combinations of
    /// its free inputs.
    fn plant_inputs(&self, s: &State) -> Result<(Vec<i64>, Combos), ClosedLoopError> {
        let (c, p) = (self.controller.net, self.plant);
        let mut controller_out = vec![0; c.signals().len()];
        if s.started {
            write_outputs(c, &s.controller, &mut controller_out);
        }
        let mut signals = vec![0; p.signals().len()];
        for &(pi, co) in &self.plant_from_controller {
            signals[pi.index()] = controller_out[co.index()];
        }
        let fixed = |x: SignalId| {
            self.plant_from_controller
                .iter()
                .find(|(pi, _)| *pi == x)
                .map(|(pi, _)| signals[pi.index()])
        };
        let combos = Combos::new(p, self.plant_reduction.domains(p, &fixed))?;
        Ok((signals, combos))
    }

    /// The first free-input combination under which plant transition `t` may fire in `m`.
    fn plant_enabled(
        &self,
        t: TransitionId,
        m: &Marking,
        signals: &mut [i64],
        combos: &Combos,
    ) -> Option<u32> {
        let p = self.plant;
        let arcs = p.arcs_of(t);
        let mut sampled = m.clone();
        (0..combos.count()).find_map(|k| {
            combos.write(k, signals);
            set_input_places(p, &mut sampled, signals);
            let ok = p.transition(t).guard.eval(signals)
                && arcs.allow(
                    |q| sampled[q],
                    |q| u64::from(sampled[q]),
                    |q| p.bound(q).map_or(u64::MAX, u64::from),
                    |_| false,
                );
            ok.then_some(k as u32)
        })
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
                let eligible = self.controller.eligible(&s.controller, &signals)?;
                let out = stepper
                    .scan(&s.controller, &signals, &eligible, choice)
                    .map_err(|source| ClosedLoopError::Scan {
                        net: c.id.clone(),
                        source,
                    })?;
                let next = State {
                    started: true,
                    controller: out.marking.clone(),
                    plant: s.plant.clone(),
                };
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
                let marking = self.fire_plant(&s.plant, t)?;
                let free_inputs = combos.varying().map(|x| (x, signals[x.index()])).collect();
                let next = State {
                    started: s.started,
                    controller: s.controller.clone(),
                    plant: marking.clone(),
                };
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

    fn fire_plant(&self, m: &Marking, t: TransitionId) -> Result<Marking, ClosedLoopError> {
        let mut next = m.clone();
        self.plant
            .fire(&mut next, t)
            .map_err(|source| ClosedLoopError::PlantOverflow {
                net: self.plant.id.clone(),
                source,
            })?;
        for &q in &self.plant_input_places {
            next[q] = 0;
        }
        Ok(next)
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
        let (mut signals, combos) = self.controller_inputs(s)?;
        for combo in 0..combos.count() {
            combos.write(combo, &mut signals);
            let eligible = self.controller.eligible(&s.controller, &signals)?;
            for choice in 0..1u32 << eligible.len() {
                match stepper.scan(&s.controller, &signals, &eligible, choice) {
                    Ok(o) => out.push((
                        State {
                            started: true,
                            controller: o.marking,
                            plant: s.plant.clone(),
                        },
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
        let (mut signals, combos) = self.plant_inputs(s)?;
        for t in self.plant.transition_ids() {
            if let Some(combo) = self.plant_enabled(t, &s.plant, &mut signals, &combos) {
                out.push((
                    State {
                        started: s.started,
                        controller: s.controller.clone(),
                        plant: self.fire_plant(&s.plant, t)?,
                    },
                    Kind::Plant { t, combo },
                ));
            }
        }
        Ok(())
    }
}

/// Searches the closed loop breadth-first for a state where `place` is marked: proves it never
/// is, or returns a shortest run that marks it, with its timeline. `place` is a place label or
/// id, qualified `controller:NAME` / `plant:NAME` when both nets have it.
pub fn never(cl: &ClosedLoop<'_>, place: &str) -> Result<NeverResult, ClosedLoopError> {
    let target = cl.resolve(place)?;
    let (c, p) = (cl.controller.net, cl.plant);
    let mut cm = c.initial_marking();
    cl.controller.normalize(&mut cm);
    let mut pm = p.initial_marking();
    for &q in &cl.plant_input_places {
        pm[q] = 0;
    }
    let init = State {
        started: false,
        controller: cm,
        plant: pm,
    };
    let mut states: IndexSet<Box<[u32]>> = IndexSet::new();
    let mut parent: Vec<Option<Edge>> = vec![None];
    states.insert(cl.key(&init));
    let mut stepper = Stepper::new(&cl.controller);
    let mut unstable = 0;
    let mut hit = cl.marks(&states[0], target).then_some(0);
    let mut next = Vec::new();
    let mut i = 0;
    'search: while hit.is_none() && i < states.len() {
        if cl.options.cancelled() {
            return Ok(NeverResult::Incomplete {
                states: states.len() as u64,
            });
        }
        let s = cl.split(&states[i]);
        next.clear();
        cl.expand(&mut stepper, &s, &mut next, &mut unstable)?;
        for (n, kind) in next.drain(..) {
            let (j, new) = states.insert_full(cl.key(&n));
            if !new {
                continue;
            }
            if states.len() as u64 > cl.options.max_states {
                states.pop();
                return Ok(NeverResult::Incomplete {
                    states: states.len() as u64,
                });
            }
            parent.push(Some(Edge {
                from: i as u32,
                kind,
            }));
            if cl.marks(&states[j], target) {
                hit = Some(j);
                break 'search;
            }
        }
        i += 1;
    }
    let Some(end) = hit else {
        return Ok(NeverResult::Proved {
            states: states.len() as u64,
            unstable_scans: unstable,
        });
    };

    // The run: edges back to the initial state, replayed forwards to describe each move.
    let mut path = Vec::new();
    let mut j = end;
    while let Some(e) = parent[j] {
        path.push(e.kind);
        j = e.from as usize;
    }
    path.reverse();
    let mut s = init;
    let mut moves = Vec::with_capacity(path.len());
    for kind in path {
        let (n, mv) = cl.apply(&mut stepper, &s, kind)?;
        moves.push(mv);
        s = n;
    }
    let scans: Vec<&ScanStep> = moves
        .iter()
        .filter_map(|m| match m {
            Move::Scan(st) => Some(st),
            Move::Plant { .. } => None,
        })
        .collect();
    let label = cl.label(target);
    let about = vec![
        format!(
            "closed loop `{}` + plant `{}`: {label} is marked after {} and {}",
            c.id,
            p.id,
            plural(scans.len(), "controller scan"),
            plural(moves.len() - scans.len(), "plant move")
        ),
        "one row per controller scan (its inputs: the plant's outputs and free inputs); plant moves are comments".into(),
        format!(
            "replay the controller side: petriplc sim CONTROLLER.pnml --inputs THIS.csv --period {}",
            petriplc_net::time::format_iec(cl.options.period).trim_start_matches("T#")
        ),
    ];
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
    let timeline_csv = witness::timeline(c, cl.options.period, &rows, &about);
    let replays = witness::replays(&cl.controller, cl.options.period, scans.iter().copied());
    Ok(NeverResult::Reached {
        states: states.len() as u64,
        moves,
        timeline_csv,
        replays,
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
        let mixer = read("../../examples/mixer/mixer.pnml", Naming::Sipn);
        let tank = read("../../examples/mixer/tank-observed.pnml", Naming::Plain);
        check(&mixer, &tank, "both_open", "proved 25 states");
    }

    /// The limit of the untimed plant: right after the scan that opens V1, the plant may fill
    /// from dry to high before the controller scans again, which takes 4.5 s in the tank.
    #[test]
    fn the_untimed_plant_can_outrun_the_controller() {
        let mixer = read("../../examples/mixer/mixer.pnml", Naming::Sipn);
        let tank = read("../../examples/mixer/tank-observed.pnml", Naming::Plain);
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
        let tank = read("../../examples/mixer/tank-observed.pnml", Naming::Plain);
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
