//! The moves of the closed loop from a state: a controller scan (its inputs from the plant
//! and every free-input combination, its delay choices) or one plant transition, with the
//! clocks of timed mode following each.

use petriplc_net::{Marking, PlaceId, ScanError, SignalId, TransitionId};

use super::{count, running, ClosedLoop, Kind, State};
use crate::domain::Combos;
use crate::plc::{set_input_places, write_outputs, Stepper};
use crate::witness::{Move, ScanStep};
use crate::ClosedLoopError;

impl ClosedLoop<'_> {
    /// The controller's signals with the inputs the plant drives set, and the combinations of
    /// its free inputs.
    pub(super) fn controller_inputs(
        &self,
        s: &State,
    ) -> Result<(Vec<i64>, Combos), ClosedLoopError> {
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
    pub(super) fn plant_signals(&self, s: &State) -> Vec<i64> {
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
    pub(super) fn plant_inputs(&self, s: &State) -> Result<(Vec<i64>, Combos), ClosedLoopError> {
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
    pub(super) fn plant_allows(&self, t: TransitionId, m: &Marking, signals: &[i64]) -> bool {
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
    pub(super) fn plant_delays_hold(&self, t: TransitionId, s: &State) -> bool {
        let base = self.clocks.controller.len();
        self.clocks.plant.iter().enumerate().all(|(i, pt)| {
            pt.transition != t || count(s.clocks[base + i]).is_some_and(|n| n >= pt.holds_at)
        })
    }

    /// The first free-input combination under which plant transition `t` may fire in `s`.
    pub(super) fn plant_enabled(
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
    pub(super) fn plant_move(&self, s: &State, t: TransitionId) -> Result<State, ClosedLoopError> {
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
    pub(super) fn scan_allowed(&self, s: &State) -> bool {
        let base = self.clocks.controller.len() + self.clocks.plant.len();
        self.clocks
            .deadlines
            .iter()
            .enumerate()
            .all(|(i, d)| count(s.clocks[base + i]).is_none_or(|n| n < d.scans))
    }

    /// The controller's delay outcomes at the start of a scan in timed mode (one per entry of
    /// `timed`) and the controller clocks as that first sample leaves them.
    pub(super) fn controller_delays(&self, s: &State, signals: &[i64]) -> (Vec<bool>, Vec<u32>) {
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
    pub(super) fn scan_move(
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
    pub(super) fn advance_plant_clocks(&self, before: &State, after: &mut State) {
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
    pub(super) fn apply(
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
    pub(super) fn expand(
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
}
