//! What expanding a state needs and yields, shared by the search (`explore`) and the state
//! space it leaves (`space`): the enabling and firing rule in flat arrays ([`Rules`]), the
//! deltas of the packed layout, and the figures gathered on the way ([`Stats`]).

use petriplc_net::{Marking, Net, PlaceId, TransitionId};

use crate::layout::Layout;
use crate::ReachError;

/// The enabling rule's inputs in flat arrays, and what firing needs beyond it.
pub(crate) struct Rules {
    pub net: Net,
    limit: Vec<u64>,
    free: Vec<bool>,
    /// Per transition: places it adds tokens to on balance, with the gain (to check the
    /// successor fits its fields).
    gain: Vec<Vec<(u32, u32)>>,
    /// Per transition `t`: the transitions whose enabling reads a place `t` changes.
    affected: Vec<Vec<u32>>,
}

impl Rules {
    pub fn new(net: &Net) -> Rules {
        // Per transition, the places its firing changes, with C(p, t) (from its own arcs:
        // nothing here may cost places × transitions, nets have 100 000 of each).
        let changes: Vec<Vec<(PlaceId, i64)>> = net
            .transition_ids()
            .map(|t| {
                let a = net.arcs_of(t);
                let mut ps: Vec<PlaceId> = a
                    .consume
                    .iter()
                    .chain(&a.produce)
                    .map(|&(p, _)| p)
                    .collect();
                ps.sort_unstable();
                ps.dedup();
                ps.into_iter()
                    .map(|p| (p, net.incidence(p, t)))
                    .filter(|&(_, c)| c != 0)
                    .collect()
            })
            .collect();
        let gain = changes
            .iter()
            .map(|ch| {
                ch.iter()
                    .filter(|&&(_, c)| c > 0)
                    .map(|&(p, c)| (p.0, u32::try_from(c).unwrap_or(u32::MAX)))
                    .collect()
            })
            .collect();
        // Per place, the transitions whose enabling looks at it: every arc but an output arc
        // to a place without capacity.
        let mut readers: Vec<Vec<u32>> = vec![Vec::new(); net.places().len()];
        for u in net.transition_ids() {
            let a = net.arcs_of(u);
            for &(p, _) in a.consume.iter().chain(&a.read).chain(&a.inhibit) {
                readers[p.index()].push(u.0);
            }
            for &(p, _) in &a.produce {
                if net.bound(p).is_some() {
                    readers[p.index()].push(u.0);
                }
            }
        }
        let affected = changes
            .iter()
            .map(|ch| {
                let mut us: Vec<u32> = ch
                    .iter()
                    .flat_map(|&(p, _)| readers[p.index()].iter().copied())
                    .collect();
                us.sort_unstable();
                us.dedup();
                us
            })
            .collect();
        Rules {
            net: net.clone(),
            limit: net
                .place_ids()
                .map(|p| net.bound(p).map_or(u64::MAX, u64::from))
                .collect(),
            free: net.places().iter().map(|p| p.input.is_some()).collect(),
            gain,
            affected,
        }
    }

    pub fn transitions(&self) -> usize {
        self.net.transitions().len()
    }

    /// Interleaving enabling of transition `t` in the decoded marking `m`: the net's one rule,
    /// [`petriplc_net::TransitionArcs::allow`], read from flat arrays.
    #[inline]
    pub fn enabled(&self, t: usize, m: &[u32]) -> bool {
        self.net.arcs_of(TransitionId(t as u32)).allow(
            |p| m[p.index()],
            |p| u64::from(m[p.index()]),
            |p| self.limit[p.index()],
            |p| self.free[p.index()],
        )
    }

    /// The enabled transitions of `m` as a bit set.
    pub fn enabled_set(&self, m: &[u32], bits: &mut [u64]) {
        bits.fill(0);
        for t in 0..self.transitions() {
            if self.enabled(t, m) {
                bits[t / 64] |= 1 << (t % 64);
            }
        }
    }

    /// Whether firing `t` in `m` (enabled) gives a marking that fits `layout`.
    #[inline]
    pub fn fits(&self, t: usize, m: &[u32], layout: &Layout) -> bool {
        self.gain[t].iter().all(|&(p, g)| {
            u64::from(m[p as usize]) + u64::from(g) <= u64::from(layout.fields[p as usize].max)
        })
    }

    /// Applies (or with `back`, undoes) the firing of `t` on a decoded marking whose successor
    /// is known to fit.
    #[inline]
    fn apply(&self, t: usize, m: &mut [u32], back: bool) {
        let a = self.net.arcs_of(TransitionId(t as u32));
        for &(p, w) in &a.consume {
            let v = &mut m[p.index()];
            *v = if back { *v + w } else { *v - w };
        }
        for &(p, w) in &a.produce {
            let v = &mut m[p.index()];
            *v = if back { *v - w } else { *v + w };
        }
    }

    /// Per transition `t`, what a marking `y` must hold for `y` to have a predecessor by
    /// `t` in `layout`: undoing `t` gives `x = y - C(·, t)`, which must fit its fields and
    /// enable `t`. Enabling is a bound on single places of `x`
    /// ([`petriplc_net::Net::enabling_bounds`]), so with the fields it is
    /// `lo ≤ y(p) ≤ hi` for a few places: `None` when no `y` can pass.
    pub fn back_intervals(&self, layout: &Layout) -> Vec<Option<Vec<(u32, u32, u32)>>> {
        let net = &self.net;
        net.transition_ids()
            .map(|t| {
                let a = net.arcs_of(t);
                let c = |p: PlaceId| i128::from(net.incidence(p, t));
                let enabling = net.enabling_bounds(t)?;
                // (place, lo, hi) on y.
                let mut b: Vec<(PlaceId, i128, i128)> = enabling
                    .into_iter()
                    .map(|(p, lo, hi)| (p, i128::from(lo) + c(p), i128::from(hi) + c(p)))
                    .collect();
                // x(p) fits its field: C ≤ y ≤ max + C.
                for &(p, _) in a.consume.iter().chain(&a.produce) {
                    let max = i128::from(layout.fields[p.index()].max);
                    b.push((p, c(p), max + c(p)));
                }
                b.sort_unstable_by_key(|x| x.0);
                let mut out: Vec<(u32, u32, u32)> = Vec::new();
                let mut i = 0;
                while i < b.len() {
                    let p = b[i].0;
                    let (mut lo, mut hi) = (0i128, i128::from(u32::MAX));
                    while i < b.len() && b[i].0 == p {
                        lo = lo.max(b[i].1);
                        hi = hi.min(b[i].2);
                        i += 1;
                    }
                    if lo > hi {
                        return None;
                    }
                    if lo > 0 || hi < i128::from(u32::MAX) {
                        out.push((p.0, lo as u32, hi as u32));
                    }
                }
                Some(out)
            })
            .collect()
    }

    /// The enabled set after firing `t` from a marking `m` with enabled set `en`: only the
    /// transitions `t` can affect are asked again.
    #[inline]
    pub(crate) fn successor_set(&self, t: usize, m: &mut [u32], en: &[u64], out: &mut [u64]) {
        out.copy_from_slice(en);
        self.apply(t, m, false);
        for &u in &self.affected[t] {
            let u = u as usize;
            let bit = 1u64 << (u % 64);
            if self.enabled(u, m) {
                out[u / 64] |= bit;
            } else {
                out[u / 64] &= !bit;
            }
        }
        self.apply(t, m, true);
    }

    /// Fires `t` on a decoded marking the slow, fully checked way.
    pub fn fire_decoded(&self, t: usize, m: &[u32]) -> Result<Vec<u32>, ReachError> {
        let mut mk = Marking(m.to_vec());
        self.net
            .fire(&mut mk, TransitionId(t as u32))
            .map_err(|e| ReachError::TokenOverflow { place: e.place })?;
        Ok(mk.0)
    }
}

/// Deltas of every transition under `layout`, `words` per transition.
pub(crate) fn deltas(net: &Net, layout: &Layout) -> Vec<u64> {
    net.transition_ids()
        .flat_map(|t| layout.delta(net.arcs_of(t)))
        .collect()
}

/// Figures gathered while expanding states.
#[derive(Clone, Debug)]
pub(crate) struct Stats {
    pub edges: u64,
    pub place_max: Vec<u32>,
    pub marking_max: u64,
    pub fired: Vec<bool>,
    pub deadlocks: u64,
    /// The smallest level with a deadlock, and the deadlocks found there (decoded).
    pub first_deadlocks: Option<(usize, Vec<Vec<u32>>)>,
}

impl Stats {
    pub(crate) fn new(places: usize, transitions: usize) -> Stats {
        Stats {
            edges: 0,
            place_max: vec![0; places],
            marking_max: 0,
            fired: vec![false; transitions],
            deadlocks: 0,
            first_deadlocks: None,
        }
    }

    pub(crate) fn merge(&mut self, o: Stats) {
        self.edges += o.edges;
        for (a, b) in self.place_max.iter_mut().zip(&o.place_max) {
            *a = (*a).max(*b);
        }
        self.marking_max = self.marking_max.max(o.marking_max);
        for (a, b) in self.fired.iter_mut().zip(&o.fired) {
            *a |= *b;
        }
        self.deadlocks += o.deadlocks;
        self.first_deadlocks = match (self.first_deadlocks.take(), o.first_deadlocks) {
            (None, x) | (x, None) => x,
            (Some((la, mut a)), Some((lb, b))) => match la.cmp(&lb) {
                std::cmp::Ordering::Less => Some((la, a)),
                std::cmp::Ordering::Greater => Some((lb, b)),
                std::cmp::Ordering::Equal => {
                    a.extend(b);
                    Some((la, a))
                }
            },
        };
    }
}
