//! The incremental evaluator of [`Scanner::incremental`]: tables built once from the net
//! (who reads a place, a signal, a delay), the set of enabled transitions kept across scans,
//! and passes that visit only what can have changed, each visit the reference's own rule.

use std::cmp::Reverse;
use std::collections::BinaryHeap;
use std::time::Duration;

use super::{ScanError, Scanner};
use crate::guard::FlatGuard;
use crate::ids::{PlaceId, SignalId, TransitionId};
use crate::model::{Evolution, Net, SignalType, StepRule, TokenOverflow, TransitionArcs};

/// The incremental evaluator's tables (built once from the net) and state.
#[derive(Clone, Debug)]
pub(super) struct Incremental {
    /// Per place: the transitions whose rule reads it (normal, read and inhibitor arcs, and
    /// output arcs to a place with a capacity).
    readers: Csr,
    /// Per signal: the transitions whose guard reads it.
    guard_readers: Csr,
    /// Per place: its delayed arcs (indices into [`Net::timed_arcs`]).
    place_timers: Csr,
    /// Per transition: the places it takes tokens from or adds tokens to.
    moves: Csr,
    /// Per transition: the places whose tokens its firing changes (C(p, t) ≠ 0).
    changes: Csr,
    /// Per delayed arc: its transition.
    timer_transition: Vec<u32>,
    /// Per place: the output it drives (an index into `Scanner::outputs`), or `NONE`.
    place_output: Vec<u32>,
    /// Signals some guard reads, and their values as the last scan saw them.
    watched: Vec<u32>,
    last: Vec<i64>,
    guards: Vec<FlatGuard>,
    /// False until the first scan and after anything that invalidates the state below: the
    /// next scan then asks everything again.
    pub(super) valid: bool,
    /// Transitions enabled in the current marking (arcs, delays, guard), as bits.
    enabled: Vec<u64>,
    /// A pass's transitions to visit.
    visit: Vec<u64>,
    /// Transitions to ask again before the next pass.
    dirty: Flags,
    /// Delayed arcs whose place changed: their timers are sampled at the next pass.
    timers: Flags,
    /// (when it runs out, arc) for every delay started.
    due: BinaryHeap<Reverse<(Duration, u32)>>,
    /// Outputs whose places changed.
    outputs: Flags,
    /// Places a maximal step took tokens from or added tokens to.
    touched: Flags,
    /// Places whose tokens changed during this scan, and what they held at its start.
    moved: Flags,
    start: Vec<u32>,
}

const NONE: u32 = u32::MAX;

/// Lists of `u32` in one array: `items[start[i]..start[i + 1]]` is list `i`.
#[derive(Clone, Debug, Default)]
struct Csr {
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Csr {
    fn from_lists(lists: Vec<Vec<u32>>) -> Csr {
        let mut c = Csr {
            start: Vec::with_capacity(lists.len() + 1),
            items: Vec::new(),
        };
        c.start.push(0);
        for mut l in lists {
            l.sort_unstable();
            l.dedup();
            c.items.extend(l);
            c.start.push(c.items.len() as u32);
        }
        c
    }

    #[inline]
    fn get(&self, i: usize) -> &[u32] {
        &self.items[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

/// A set of small numbers with the order they were added in, without repeats.
#[derive(Clone, Debug, Default)]
struct Flags {
    on: Vec<bool>,
    list: Vec<u32>,
}

impl Flags {
    fn new(n: usize) -> Flags {
        Flags {
            on: vec![false; n],
            list: Vec::new(),
        }
    }

    #[inline]
    fn add(&mut self, i: u32) {
        if !self.on[i as usize] {
            self.on[i as usize] = true;
            self.list.push(i);
        }
    }

    fn add_all(&mut self) {
        for i in 0..self.on.len() as u32 {
            self.add(i);
        }
    }

    /// Takes the list out, clearing the set (hand it back with [`Flags::give_back`]).
    fn take(&mut self) -> Vec<u32> {
        let list = std::mem::take(&mut self.list);
        for &i in &list {
            self.on[i as usize] = false;
        }
        list
    }

    fn give_back(&mut self, mut list: Vec<u32>) {
        if self.list.is_empty() {
            list.clear();
            self.list = list;
        }
    }
}

#[inline]
fn set_bit(bits: &mut [u64], i: usize, on: bool) {
    let b = 1u64 << (i % 64);
    if on {
        bits[i / 64] |= b;
    } else {
        bits[i / 64] &= !b;
    }
}

/// The first set bit at `from` or after.
#[inline]
fn next_bit(bits: &[u64], from: usize) -> Option<usize> {
    let mut w = from / 64;
    let mut word = *bits.get(w)? & (!0u64 << (from % 64));
    loop {
        if word != 0 {
            return Some(w * 64 + word.trailing_zeros() as usize);
        }
        w += 1;
        word = *bits.get(w)?;
    }
}

impl Incremental {
    pub(super) fn new(net: &Net, outputs: &[(SignalId, SignalType, Vec<PlaceId>)]) -> Incremental {
        let np = net.places().len();
        let nt = net.transitions().len();
        let mut readers = vec![Vec::new(); np];
        let mut moves = vec![Vec::new(); nt];
        let mut guard_readers = vec![Vec::new(); net.signals().len()];
        let mut timer_transition = vec![0; net.timed_arcs().len()];
        for t in net.transition_ids() {
            let a = net.arcs_of(t);
            for &(p, _) in a.consume.iter().chain(&a.read).chain(&a.inhibit) {
                readers[p.index()].push(t.0);
            }
            for &(p, _) in &a.produce {
                if net.bound(p).is_some() {
                    readers[p.index()].push(t.0);
                }
            }
            for &(p, _) in a.consume.iter().chain(&a.produce) {
                moves[t.index()].push(p.0);
            }
            for s in net.transition(t).guard.signals() {
                guard_readers[s.index()].push(t.0);
            }
            for &i in &a.timed {
                timer_transition[i] = t.0;
            }
        }
        let mut place_timers = vec![Vec::new(); np];
        for (i, ta) in net.timed_arcs().iter().enumerate() {
            place_timers[ta.place.index()].push(i as u32);
        }
        let mut place_output = vec![NONE; np];
        for (o, (_, _, places)) in outputs.iter().enumerate() {
            for p in places {
                place_output[p.index()] = o as u32;
            }
        }
        let watched: Vec<u32> = (0..guard_readers.len() as u32)
            .filter(|&s| !guard_readers[s as usize].is_empty())
            .collect();
        let words = nt.div_ceil(64);
        Incremental {
            readers: Csr::from_lists(readers),
            guard_readers: Csr::from_lists(guard_readers),
            place_timers: Csr::from_lists(place_timers),
            changes: Csr::from_lists(
                net.transition_ids()
                    .map(|t| {
                        moves[t.index()]
                            .iter()
                            .copied()
                            .filter(|&p| net.incidence(PlaceId(p), t) != 0)
                            .collect()
                    })
                    .collect(),
            ),
            moves: Csr::from_lists(moves),
            timer_transition,
            place_output,
            last: vec![0; watched.len()],
            watched,
            guards: net
                .transitions()
                .iter()
                .map(|t| FlatGuard::new(&t.guard))
                .collect(),
            valid: false,
            enabled: vec![0; words],
            visit: vec![0; words],
            dirty: Flags::new(nt),
            timers: Flags::new(net.timed_arcs().len()),
            due: BinaryHeap::new(),
            outputs: Flags::new(outputs.len()),
            touched: Flags::new(np),
            moved: Flags::new(np),
            start: vec![0; np],
        }
    }

    /// Place `p`'s tokens changed from `was`: what reads it is asked again.
    #[inline]
    fn place_changed(&mut self, p: usize, was: u32) {
        if !self.moved.on[p] {
            self.moved.add(p as u32);
            self.start[p] = was;
        }
        for i in self.readers.start[p]..self.readers.start[p + 1] {
            let t = self.readers.items[i as usize];
            self.dirty.add(t);
        }
        for i in self.place_timers.start[p]..self.place_timers.start[p + 1] {
            let a = self.place_timers.items[i as usize];
            self.timers.add(a);
        }
        if self.place_output[p] != NONE {
            self.outputs.add(self.place_output[p]);
        }
    }
}

impl Scanner<'_> {
    /// The first part of an incremental scan: what changed since the last one (signals that
    /// guards read, input places), or everything after a reset.
    pub(super) fn read_changes(&mut self, inc: &mut Incremental, signals: &[i64]) {
        if !inc.valid {
            inc.valid = true;
            inc.moved.take();
            inc.enabled.fill(0);
            inc.dirty.add_all();
            inc.timers.add_all();
            inc.outputs.add_all();
            inc.due.clear();
            for (i, s) in self.since.iter().enumerate() {
                if let Some(d) = s.and_then(|s| s.checked_add(self.net.timed_arcs()[i].delay)) {
                    inc.due.push(Reverse((d, i as u32)));
                }
            }
            for (k, &s) in inc.watched.iter().enumerate() {
                inc.last[k] = signals[s as usize];
            }
        } else {
            let Incremental {
                watched,
                last,
                guard_readers,
                dirty,
                ..
            } = inc;
            for (&s, last) in watched.iter().zip(last.iter_mut()) {
                let v = signals[s as usize];
                if v != *last {
                    *last = v;
                    for &t in guard_readers.get(s as usize) {
                        dirty.add(t);
                    }
                }
            }
        }
        for &(p, s) in &self.input_places {
            let cap = i64::from(self.capacity[p.index()]);
            let v = signals[s.index()].clamp(0, cap) as u32;
            if self.marking[p] != v {
                inc.place_changed(p.index(), self.marking[p]);
                self.marking[p] = v;
                self.avail[p.index()] = v;
            }
        }
    }

    /// Whether the scan has nothing to do: nothing to ask again, no timer to sample or
    /// running out, nothing enabled, and no place moved by the inputs.
    #[inline]
    pub(super) fn quiet(&self, inc: &Incremental, now: Duration) -> bool {
        inc.dirty.list.is_empty()
            && inc.timers.list.is_empty()
            && inc.moved.list.is_empty()
            && inc.outputs.list.is_empty()
            && inc.due.peek().is_none_or(|d| d.0 .0 > now)
            && inc.enabled.iter().all(|&w| w == 0)
            && !(self.options.evolve == Evolution::UntilStable && self.options.max_passes == 0)
    }

    /// The passes of an incremental scan, after [`Scanner::read_changes`].
    pub(super) fn scan_incremental(
        &mut self,
        inc: &mut Incremental,
        now: Duration,
        signals: &mut [i64],
    ) -> Result<(), ScanError> {
        self.passes = 0;
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
            self.sample_changed_timers(inc, now);
            self.refresh(inc, now, signals);
            let before = self.fired.len();
            match self.options.step {
                StepRule::MaximalStep => self.maximal_step_incremental(inc, now, signals)?,
                StepRule::Sequential => self.sequential_incremental(inc, now, signals)?,
            }
            self.passes += 1;
            if self.options.evolve == Evolution::OnePass || self.fired.len() == before {
                break;
            }
        }
        let moved = inc.moved.take();
        self.marking_changed = moved
            .iter()
            .any(|&p| self.marking.0[p as usize] != inc.start[p as usize]);
        inc.moved.give_back(moved);
        let outputs = inc.outputs.take();
        for &o in &outputs {
            self.write_output(o as usize, signals);
        }
        inc.outputs.give_back(outputs);
        Ok(())
    }

    /// `sample_timers` for the delayed arcs whose place changed since they were last sampled
    /// (the others would sample the same), then the delays that ran out by `now`.
    fn sample_changed_timers(&mut self, inc: &mut Incremental, now: Duration) {
        let arcs = inc.timers.take();
        for &i in &arcs {
            let ta = &self.net.timed_arcs()[i as usize];
            let since = &mut self.since[i as usize];
            if self.marking[ta.place] >= ta.weight {
                if since.is_none() {
                    *since = Some(now);
                    if let Some(d) = now.checked_add(ta.delay) {
                        inc.due.push(Reverse((d, i)));
                    }
                    inc.dirty.add(inc.timer_transition[i as usize]);
                }
            } else if since.take().is_some() {
                inc.dirty.add(inc.timer_transition[i as usize]);
            }
        }
        inc.timers.give_back(arcs);
        while let Some(&Reverse((d, i))) = inc.due.peek() {
            if d > now {
                break;
            }
            inc.due.pop();
            // Possibly stale (the timer restarted since): asking again costs one evaluation.
            inc.dirty.add(inc.timer_transition[i as usize]);
        }
    }

    /// Asks the transitions marked dirty again, in the current marking.
    fn refresh(&mut self, inc: &mut Incremental, now: Duration, signals: &[i64]) {
        let ts = inc.dirty.take();
        for &t in &ts {
            let on = self.enabled_flat(inc, TransitionId(t), now, signals);
            set_bit(&mut inc.enabled, t as usize, on);
        }
        inc.dirty.give_back(ts);
    }

    /// [`Scanner::enabled_now`] with the compiled guard.
    #[inline]
    fn enabled_flat(
        &self,
        inc: &Incremental,
        t: TransitionId,
        now: Duration,
        signals: &[i64],
    ) -> bool {
        let m = &self.marking;
        self.net.arcs_of(t).allow(
            |p| m[p],
            |p| u64::from(m[p]),
            |p| self.limit[p.index()],
            |_| false,
        ) && self.delays_elapsed(t, now)
            && inc.guards[t.index()].eval(signals)
    }

    /// `maximal_step` over the transitions enabled at the pass's start and those a firing
    /// earlier in the pass disturbed; `avail` equals the marking and `produced` is 0 between
    /// passes, so only the places the step touches are updated.
    fn maximal_step_incremental(
        &mut self,
        inc: &mut Incremental,
        now: Duration,
        signals: &[i64],
    ) -> Result<(), ScanError> {
        let net = self.net;
        for (v, &e) in inc.visit.iter_mut().zip(&inc.enabled) {
            *v = e;
        }
        let mut from = 0;
        while let Some(i) = next_bit(&inc.visit, from) {
            from = i + 1;
            let t = TransitionId(i as u32);
            let a: &TransitionArcs = net.arcs_of(t);
            let (avail, produced, marking, limit) =
                (&self.avail, &self.produced, &self.marking, &self.limit);
            let enabled = a.allow(
                |p| avail[p.index()],
                |p| u64::from(marking[p]).saturating_add(produced[p.index()]),
                |p| limit[p.index()],
                |_| false,
            ) && self.delays_elapsed(t, now)
                && inc.guards[i].eval(signals);
            if !enabled {
                continue;
            }
            for &(p, w) in &a.consume {
                self.avail[p.index()] -= w;
                inc.touched.add(p.0);
            }
            for &(p, w) in &a.produce {
                self.produced[p.index()] = self.produced[p.index()].saturating_add(u64::from(w));
                inc.touched.add(p.0);
            }
            self.fired.push(t);
            // Later transitions reading what this one moved see other values than the pass
            // started with: visit them too.
            for &p in inc.moves.get(i) {
                for &u in inc.readers.get(p as usize) {
                    if u as usize > i {
                        set_bit(&mut inc.visit, u as usize, true);
                    }
                }
            }
        }
        let touched = inc.touched.take();
        let overflow = touched
            .iter()
            .map(|&p| p as usize)
            .filter(|&p| {
                u64::from(self.avail[p]).saturating_add(self.produced[p]) > u64::from(u32::MAX)
            })
            .min();
        if let Some(p) = overflow {
            return Err(ScanError::Overflow {
                time: now,
                overflow: TokenOverflow {
                    place: net.place_label(PlaceId::from(p)).to_string(),
                },
            });
        }
        for &p in &touched {
            let p = p as usize;
            // In range: checked just above.
            let v = (u64::from(self.avail[p]) + self.produced[p]) as u32;
            self.produced[p] = 0;
            self.avail[p] = v;
            if self.marking.0[p] != v {
                inc.place_changed(p, self.marking.0[p]);
                self.marking.0[p] = v;
            }
        }
        inc.touched.give_back(touched);
        Ok(())
    }

    /// `sequential` over the enabled set, which each firing brings up to date at once.
    fn sequential_incremental(
        &mut self,
        inc: &mut Incremental,
        now: Duration,
        signals: &[i64],
    ) -> Result<(), ScanError> {
        let net = self.net;
        let mut from = 0;
        while let Some(i) = next_bit(&inc.enabled, from) {
            from = i + 1;
            let t = TransitionId(i as u32);
            if !self.enabled_flat(inc, t, now, signals) {
                continue;
            }
            for k in inc.changes.start[i]..inc.changes.start[i + 1] {
                let p = inc.changes.items[k as usize] as usize;
                inc.place_changed(p, self.marking.0[p]);
            }
            net.fire(&mut self.marking, t)
                .map_err(|overflow| ScanError::Overflow {
                    time: now,
                    overflow,
                })?;
            self.fired.push(t);
            for k in inc.changes.start[i]..inc.changes.start[i + 1] {
                let p = inc.changes.items[k as usize] as usize;
                self.avail[p] = self.marking.0[p];
            }
            self.refresh(inc, now, signals);
        }
        Ok(())
    }
}
