//! Coverability with ω: decides boundedness and finds the unbounded places without an endless
//! search.
//!
//! **Karp–Miller phase.** Most-ω-first construction with back pointers, after Valmari and
//! Hansen's minimal coverability set algorithm: a new ω-marking that covers an ancestor
//! (following back pointers to the initial marking) and is larger somewhere gets ω there,
//! because the firings between them can be repeated forever (every ω-marking built is a limit
//! of reachable markings, so ω is sound). A new marking equal to one found before, or covered by
//! a maximal ω-marking found before, is dropped; every marking kept is expanded, so every
//! reachable marking stays covered. Termination follows from Dickson's lemma as for Karp–Miller trees. When it
//! completes, bounds are exact.
//!
//! **Over-approximation phase**, when the first phase reaches its node limit (coverability sets
//! can be huge: the bounded part of the net times the ω-places). More unbounded places are
//! looked for with random Karp–Miller branches (sound, like any branch), then the other places
//! are proven bounded, either structurally (a set of places whose token sum no transition
//! increases) or by exploring the net with the unbounded places removed (their arcs then never
//! block, so every reachable marking of the net, restricted to the other places, is reachable
//! there). Bounds found this way are upper bounds ([`Coverability::bounds_exact`] false).
//!
//! Covering and repeating need monotonic firing, which capacities and inhibitor arcs break; so
//! a place with a capacity or an inhibitor arc (from a non-input place) is "pinned": markings
//! compare only when equal there, and it never becomes ω. Termination is then guaranteed for
//! nets without inhibitor arcs; `max_nodes` bounds the rest.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashMap};
use std::sync::atomic::{AtomicBool, Ordering};

use petriplc_net::{
    ArcDirection, ArcSpec, Net, NetBuilder, PlaceId, PlaceSpec, SignalDirection, TransitionId,
    TransitionSpec,
};

use crate::ExploreOptions;

/// ω: unboundedly many tokens.
const OMEGA: u64 = u64::MAX;

/// The Karp–Miller phase stops here even when `max_nodes` is larger: past it, the
/// over-approximation is cheaper than checking coverage against every marking kept.
const KM_CAP: u64 = 5_000;
/// Random branches in the over-approximation phase (one per 100 allowed nodes, within these
/// bounds) and their length.
const WALKS: (u64, u64) = (20, 1_000);
const WALK_LEN: usize = 500;
/// The over-approximation may explore this many states per allowed ω-marking.
const OVER_STATES: u64 = 16;

/// What [`coverability`] finds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Coverability {
    /// Proven bounded.
    pub bounded: bool,
    /// Places proven unbounded, in order. Complete when `complete` is true.
    pub unbounded_places: Vec<PlaceId>,
    /// Each place's bound, `None` for an unbounded place. See `bounds_exact`; when not
    /// complete, the largest value seen (a lower bound).
    pub place_bounds: Vec<Option<u64>>,
    /// The bounds are the exact maxima over reachable markings; false when they come from the
    /// over-approximation and are upper bounds.
    pub bounds_exact: bool,
    /// ω-markings built, plus the states of the over-approximation when it ran.
    pub nodes: u64,
    /// Every place is proven bounded or unbounded (no limit reached, not cancelled).
    pub complete: bool,
}

/// Decides which places of `net` are bounded, spending at most `max_nodes` ω-markings (and no
/// more than 5 000) on the Karp–Miller phase, one random branch per 100 nodes (20 to 1 000)
/// and 16 states per node on the over-approximation.
pub fn coverability(net: &Net, max_nodes: u64, cancel: Option<&AtomicBool>) -> Coverability {
    let ctx = Ctx::new(net);
    let km = ctx.karp_miller(max_nodes.min(KM_CAP), cancel);
    let cancelled = || cancel.is_some_and(|c| c.load(Ordering::Relaxed));
    if km.complete || cancelled() {
        return km;
    }
    let mut omega: Vec<bool> = km.place_bounds.iter().map(Option::is_none).collect();
    let walks = (max_nodes / 100).clamp(WALKS.0, WALKS.1) as usize;
    ctx.walks(&mut omega, walks, cancel);
    let mut out = Coverability {
        bounded: false,
        unbounded_places: ids(&omega),
        place_bounds: km.place_bounds.clone(),
        bounds_exact: false,
        nodes: km.nodes,
        complete: false,
    };
    for (b, &o) in out.place_bounds.iter_mut().zip(&omega) {
        if o {
            *b = None;
        }
    }
    if cancelled() {
        return out;
    }
    // Structural bounds for the rest.
    let mut upper: Vec<Option<u64>> = ctx.sub_conservative(&omega);
    if upper.iter().zip(&omega).any(|(u, &o)| u.is_none() && !o) {
        // Explore the net without the unbounded places.
        let Some((reduced, keep)) = without(net, &omega) else {
            return out;
        };
        let opts = ExploreOptions {
            max_states: Some(max_nodes.saturating_mul(OVER_STATES)),
            ..Default::default()
        };
        let Ok(space) = crate::explore_with(&reduced, &opts, cancel) else {
            return out;
        };
        out.nodes += space.states();
        if !space.complete() {
            return out;
        }
        for (i, &p) in keep.iter().enumerate() {
            let b = u64::from(space.stats.place_max[i]);
            upper[p] = Some(upper[p].map_or(b, |u| u.min(b)));
        }
        // Nothing was removed: the exploration was of the net itself.
        out.bounds_exact = keep.len() == omega.len();
    }
    for (p, b) in out.place_bounds.iter_mut().enumerate() {
        if !omega[p] {
            *b = upper[p];
        }
    }
    out.complete = true;
    out.bounded = out.unbounded_places.is_empty();
    out
}

fn ids(flags: &[bool]) -> Vec<PlaceId> {
    flags
        .iter()
        .enumerate()
        .filter(|(_, &f)| f)
        .map(|(p, _)| PlaceId(p as u32))
        .collect()
}

/// `net` without the places flagged in `drop` (and their arcs), with the kept places' indices.
fn without(net: &Net, drop: &[bool]) -> Option<(Net, Vec<usize>)> {
    let mut b = NetBuilder::new(net.id.clone(), net.name.clone());
    for s in net.signals() {
        if s.direction == SignalDirection::Input {
            b.signal(&s.name, s.direction, s.ty);
        }
    }
    let mut keep = Vec::new();
    for (i, p) in net.places().iter().enumerate() {
        if drop[i] {
            continue;
        }
        keep.push(i);
        b.place(PlaceSpec {
            id: p.id.clone(),
            name: p.name.clone(),
            initial: p.initial,
            capacity: p.capacity,
            output: None,
            input: p.input.map(|s| net.signal(s).name.clone()),
        });
    }
    for t in net.transitions() {
        b.transition(TransitionSpec {
            id: t.id.clone(),
            name: t.name.clone(),
            guard: petriplc_net::guard::parse("").ok()?,
        });
    }
    for a in net.arcs() {
        if drop[a.place.index()] {
            continue;
        }
        let (p, t) = (
            net.place(a.place).id.clone(),
            net.transition(a.transition).id.clone(),
        );
        let (source, target) = match a.direction {
            ArcDirection::PlaceToTransition => (p, t),
            ArcDirection::TransitionToPlace => (t, p),
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
    b.build().ok().map(|n| (n, keep))
}

/// The net's firing rule over ω-markings.
struct Ctx<'n> {
    net: &'n Net,
    np: usize,
    limit: Vec<u64>,
    free: Vec<bool>,
    pinned: Vec<bool>,
}

impl<'n> Ctx<'n> {
    /// The initial marking, widened to the ω-capable counters.
    fn initial(&self) -> Vec<u64> {
        self.net
            .initial_marking()
            .0
            .iter()
            .map(|&v| u64::from(v))
            .collect()
    }

    fn new(net: &'n Net) -> Ctx<'n> {
        let np = net.places().len();
        let free: Vec<bool> = net.places().iter().map(|p| p.input.is_some()).collect();
        let mut pinned: Vec<bool> = net
            .place_ids()
            .map(|p| net.bound(p).is_some() && !free[p.index()])
            .collect();
        for t in net.transition_ids() {
            for &(p, _) in &net.arcs_of(t).inhibit {
                pinned[p.index()] |= !free[p.index()];
            }
        }
        Ctx {
            net,
            np,
            limit: net
                .place_ids()
                .map(|p| net.bound(p).map_or(u64::MAX, u64::from))
                .collect(),
            free,
            pinned,
        }
    }

    fn enabled(&self, m: &[u64], t: TransitionId) -> bool {
        self.net.arcs_of(t).allow(
            |p| u32::try_from(m[p.index()]).unwrap_or(u32::MAX),
            |p| m[p.index()],
            |p| self.limit[p.index()],
            |p| self.free[p.index()],
        )
    }

    /// Fires an enabled transition on an ω-marking (ω stays ω).
    fn fire(&self, m: &[u64], t: TransitionId, next: &mut [u64]) {
        next.copy_from_slice(m);
        let arcs = self.net.arcs_of(t);
        for &(p, w) in &arcs.consume {
            let v = &mut next[p.index()];
            if *v != OMEGA {
                *v -= u64::from(w);
            }
        }
        for &(p, w) in &arcs.produce {
            let v = &mut next[p.index()];
            // Counts are exact past the 32-bit token counter too: a bounded place whose bound
            // does not fit 32 bits is bounded, not unbounded. Only ω is ω (u64::MAX, which
            // no sum of u32 weights reaches in practice).
            if *v != OMEGA {
                *v = v.saturating_add(u64::from(w));
            }
        }
    }

    /// `x ≤ y` in the order firing is monotonic for: equal on pinned places.
    fn le(&self, x: &[u64], y: &[u64]) -> bool {
        x.iter()
            .zip(y)
            .zip(&self.pinned)
            .all(|((&a, &b), &pin)| if pin { a == b } else { a <= b })
    }

    /// Sets ω wherever `next` exceeds a marking it covers; true if anything changed.
    fn accelerate(&self, anc: &[u64], next: &mut [u64]) -> bool {
        let mut changed = false;
        if self.le(anc, next) {
            for (x, &y) in next.iter_mut().zip(anc) {
                if *x > y && *x != OMEGA {
                    *x = OMEGA;
                    changed = true;
                }
            }
        }
        changed
    }

    fn karp_miller(&self, max_nodes: u64, cancel: Option<&AtomicBool>) -> Coverability {
        let np = self.np;
        let at = |n: u32| n as usize * np..(n as usize + 1) * np;
        // Places with tokens, folded to 64 bits: a marking with tokens where another has none
        // cannot be covered by it (a one-instruction filter before the full comparison).
        let support = |m: &[u64]| {
            m.iter()
                .enumerate()
                .filter(|(_, &v)| v > 0)
                .fold(0u64, |s, (p, _)| s | 1 << (p % 64))
        };
        let m0 = self.initial();
        let mut labels: Vec<u64> = m0.clone();
        let mut sig: Vec<u64> = vec![support(&m0)];
        let mut parent: Vec<u32> = vec![u32::MAX];
        let mut known: HashMap<Vec<u64>, u32> = HashMap::new();
        known.insert(m0, 0);
        // The maximal ω-markings kept: what a new marking is checked against. (Finite markings
        // rarely cover each other in a way worth the comparisons; an ω-marking covers
        // infinitely many.)
        let mut omega_max: Vec<u32> = Vec::new();
        // Markings to expand, the most ω first (they cover the most), oldest first among
        // equals.
        let mut work: BinaryHeap<(usize, Reverse<u32>)> = BinaryHeap::new();
        work.push((0, Reverse(0)));
        let mut complete = true;
        let mut next = vec![0u64; np];
        'search: while let Some((_, Reverse(node))) = work.pop() {
            for tid in self.net.transition_ids() {
                let cur = &labels[at(node)];
                if !self.enabled(cur, tid) {
                    continue;
                }
                self.fire(cur, tid, &mut next);
                if known.contains_key(next.as_slice()) {
                    continue;
                }
                let mut anc = node;
                let mut accelerated = false;
                while anc != u32::MAX {
                    accelerated |= self.accelerate(&labels[at(anc)], &mut next);
                    anc = parent[anc as usize];
                }
                if accelerated && known.contains_key(next.as_slice()) {
                    continue;
                }
                let s = support(&next);
                let covered = omega_max
                    .iter()
                    .any(|&n| s & !sig[n as usize] == 0 && self.le(&next, &labels[at(n)]));
                if covered {
                    continue;
                }
                if known.len() as u64 >= max_nodes
                    || cancel.is_some_and(|c| c.load(Ordering::Relaxed))
                {
                    complete = false;
                    break 'search;
                }
                let id = known.len() as u32;
                let omegas = next.iter().filter(|&&x| x == OMEGA).count();
                if omegas > 0 {
                    omega_max.retain(|&n| !self.le(&labels[at(n)], &next));
                    omega_max.push(id);
                }
                known.insert(next.clone(), id);
                labels.extend_from_slice(&next);
                sig.push(s);
                parent.push(node);
                work.push((omegas, Reverse(id)));
            }
        }
        let mut place_bounds: Vec<Option<u64>> = vec![Some(0); np];
        for m in labels.chunks_exact(np.max(1)).take(known.len()) {
            for (b, &v) in place_bounds.iter_mut().zip(m) {
                *b = match (*b, v) {
                    (None, _) | (_, OMEGA) => None,
                    (Some(x), v) => Some(x.max(v)),
                };
            }
        }
        let unbounded_places = ids(&place_bounds.iter().map(Option::is_none).collect::<Vec<_>>());
        Coverability {
            bounded: complete && unbounded_places.is_empty(),
            unbounded_places,
            place_bounds,
            bounds_exact: complete,
            nodes: known.len() as u64,
            complete,
        }
    }

    /// Random Karp–Miller branches from the initial marking (a fixed seed: the same answer
    /// every run); flags the places that get ω.
    fn walks(&self, omega: &mut [bool], walks: usize, cancel: Option<&AtomicBool>) {
        let np = self.np;
        let mut rng: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut rand = move || {
            rng ^= rng << 13;
            rng ^= rng >> 7;
            rng ^= rng << 17;
            rng
        };
        let m0 = self.initial();
        let mut path: Vec<u64> = Vec::with_capacity(np * (WALK_LEN + 1));
        // Per marking on the path: ω count and finite token sum, a cheap test before `le`.
        let mut shape: Vec<(usize, u64)> = Vec::new();
        let shape_of = |m: &[u64]| {
            let w = m.iter().filter(|&&v| v == OMEGA).count();
            (w, m.iter().filter(|&&v| v != OMEGA).sum::<u64>())
        };
        let mut enabled: Vec<TransitionId> = Vec::new();
        let mut next = vec![0u64; np];
        for _ in 0..walks {
            if cancel.is_some_and(|c| c.load(Ordering::Relaxed)) {
                return;
            }
            path.clear();
            path.extend_from_slice(&m0);
            shape.clear();
            shape.push(shape_of(&m0));
            for step in 0..WALK_LEN {
                let cur = &path[step * np..(step + 1) * np];
                enabled.clear();
                enabled.extend(self.net.transition_ids().filter(|&t| self.enabled(cur, t)));
                if enabled.is_empty() {
                    break;
                }
                let t = enabled[(rand() % enabled.len() as u64) as usize];
                self.fire(cur, t, &mut next);
                let (mut w, mut s) = shape_of(&next);
                for i in 0..=step {
                    let (aw, asum) = shape[i];
                    if aw <= w
                        && (aw < w || asum <= s)
                        && self.accelerate(&path[i * np..(i + 1) * np], &mut next)
                    {
                        (w, s) = shape_of(&next);
                    }
                }
                for (o, &v) in omega.iter_mut().zip(&next) {
                    *o |= v == OMEGA;
                }
                shape.push(shape_of(&next));
                path.extend_from_slice(&next);
            }
        }
    }

    /// Upper bounds from the largest set S of places (not ω, not pinned by an inhibitor) whose
    /// token sum no transition increases: then every place of S holds at most S's initial sum.
    /// Found by removing, while some transition increases the sum, the places it adds to.
    /// Places with a capacity are bounded by it; input places keep their marking.
    fn sub_conservative(&self, omega: &[bool]) -> Vec<Option<u64>> {
        let net = self.net;
        let mut s: Vec<bool> = (0..self.np).map(|p| !omega[p]).collect();
        loop {
            let mut changed = false;
            for t in net.transition_ids() {
                let effect: i64 = net
                    .place_ids()
                    .filter(|p| s[p.index()])
                    .map(|p| net.incidence(p, t))
                    .sum();
                if effect > 0 {
                    for p in net.place_ids() {
                        if s[p.index()] && net.incidence(p, t) > 0 {
                            s[p.index()] = false;
                            changed = true;
                        }
                    }
                }
            }
            if !changed {
                break;
            }
        }
        let total: u64 = net
            .place_ids()
            .filter(|p| s[p.index()])
            .map(|p| u64::from(net.place(p).initial))
            .sum();
        net.place_ids()
            .map(|p| {
                let i = p.index();
                let mut b = s[i].then_some(total);
                if self.free[i] {
                    b = Some(u64::from(net.place(p).initial));
                } else if let Some(c) = net.bound(p) {
                    b = Some(b.map_or(u64::from(c), |x| x.min(u64::from(c))));
                }
                b
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testnet::parse;

    /// Runs the coverability analysis on a net and renders the verdict.
    fn check(net_text: &str, expect: &str) {
        let net = parse(net_text);
        let c = coverability(&net, 10_000, None);
        let bounds: Vec<String> = c
            .place_bounds
            .iter()
            .map(|b| b.map_or("ω".to_string(), |v| v.to_string()))
            .collect();
        let got = format!(
            "bounded {} complete {} exact {} bounds [{}]",
            c.bounded,
            c.complete,
            c.bounds_exact,
            bounds.join(" ")
        );
        assert_eq!(got, expect);
    }

    #[test]
    fn bounded_cycle() {
        check(
            "a=2 b ; t: a -> b ; u: b -> a",
            "bounded true complete true exact true bounds [2 2]",
        );
    }

    #[test]
    fn producer_is_unbounded() {
        check(
            "a=1 b ; t: a -> a b",
            "bounded false complete true exact true bounds [1 ω]",
        );
    }

    #[test]
    fn omega_propagates_through_consumers() {
        check(
            "a=1 b c ; t: a -> a b ; u: b -> c ; v: c c ->",
            "bounded false complete true exact true bounds [1 ω ω]",
        );
    }

    #[test]
    fn capacity_stops_acceleration() {
        // b fills to its capacity; t is then disabled: bounded.
        check(
            "a=1 b<3 ; t: a -> a b",
            "bounded true complete true exact true bounds [1 3]",
        );
    }

    #[test]
    fn inhibitor_place_is_not_accelerated() {
        // b may only grow while below 2 (inhibitor): bounded, though b grows along a cycle.
        check(
            "a=1 b ; t: a -> a b !b*2",
            "bounded true complete true exact true bounds [1 2]",
        );
    }

    #[test]
    fn over_approximation_finishes_what_the_node_limit_stops() {
        // Ten independent 0..=3 counters make 4^10 markings, more than the first phase may
        // build; `u` pumps `x`. The walks find x unbounded, the counters are bounded by their
        // conservation (a_i + b_i = 3).
        let mut text: Vec<String> = (0..10).map(|i| format!("a{i}=3 b{i}")).collect();
        text.push("s=1 x".into());
        let mut trs: Vec<String> = (0..10)
            .map(|i| format!("t{i}: a{i} -> b{i} ; r{i}: b{i} -> a{i}"))
            .collect();
        trs.push("u: s -> s x".into());
        let net = parse(&format!("{} ; {}", text.join(" "), trs.join(" ; ")));
        let c = coverability(&net, 500, None);
        assert!(c.complete && !c.bounded && !c.bounds_exact);
        assert_eq!(c.unbounded_places, vec![PlaceId(21)]);
        assert_eq!(
            c.place_bounds[0],
            Some(31),
            "upper bound: the whole conserved sum"
        );
    }

    #[test]
    fn node_limit_stops_cleanly() {
        // Inhibitor arcs: neither acceleration nor the over-approximation may conclude.
        let net = parse("a=1 b ; t: a -> a b !b*100000");
        let c = coverability(&net, 50, None);
        assert!(!c.complete && !c.bounded && c.unbounded_places.is_empty());
    }
}
