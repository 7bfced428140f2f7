//! Strongly connected components of the reachability graph, summarised for liveness,
//! reversibility and home markings, computed from the explored states without storing the
//! graph: a state's successors are its enabled transitions' keys looked up in the
//! exploration's own hash tables (one `u32` per table slot maps a slot to its state number).
//! The graph would take 4 bytes per edge, more than the states themselves on most nets.
//!
//! 1. **Reversibility first.** Every state is reachable from the initial one, so the graph is
//!    strongly connected exactly when every state can reach the initial one: a breadth-first
//!    search backwards from the initial state, on all cores, whose predecessors are found by
//!    undoing each transition and looking the result up. When it reaches every state, there
//!    is one component, it is bottom, and liveness is quasi-liveness.
//! 2. **Otherwise Tarjan's algorithm**, iterative (the graphs have millions of states), on the
//!    same looked-up successors. A component is bottom when no edge leaves it: in Tarjan's
//!    algorithm an edge `v → w` leaves `v`'s component exactly when `w` already belongs to a
//!    finished component, so one pass finds both.
//!
//! Both stop cleanly at a memory budget or a cancel, with the reason.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use crate::layout::{hash, Dyn, Fixed, Stride};
use crate::space::StateSpace;
use crate::sweep::parallel;

pub(crate) struct SccSummary {
    /// Number of components.
    pub sccs: u64,
    /// Number of bottom components.
    pub bottoms: u64,
    /// Every bottom component contains an edge of every transition (L4 liveness: from any
    /// state, every transition can fire again).
    pub live: bool,
}

const NONE: u32 = u32::MAX;

/// States whose predecessors are looked up together in the backward search.
const BATCH: usize = 8;

/// The budget and the stop flag.
pub(crate) struct Bounds<'a> {
    pub threads: usize,
    pub max_memory: Option<u64>,
    pub cancel: Option<&'a AtomicBool>,
}

impl Bounds<'_> {
    fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }

    /// An error when `bytes` more than what the states hold would pass the budget.
    fn check(&self, space: &StateSpace, bytes: usize, what: &str) -> Result<(), String> {
        let Some(max) = self.max_memory else {
            return Ok(());
        };
        let total = (space.memory_bytes() + bytes) as u64;
        if total > max {
            return Err(format!(
                "{what} needs about {} MB with the states, more than --max-memory allows ({} MB)",
                total.div_ceil(1 << 20),
                max.div_ceil(1 << 20)
            ));
        }
        Ok(())
    }
}

pub(crate) fn analyse(space: &StateSpace, bounds: &Bounds) -> Result<SccSummary, String> {
    match space.layout.words {
        1 => analyse_k(Fixed::<1>, space, bounds),
        2 => analyse_k(Fixed::<2>, space, bounds),
        3 => analyse_k(Fixed::<3>, space, bounds),
        4 => analyse_k(Fixed::<4>, space, bounds),
        k => analyse_k(Dyn(k), space, bounds),
    }
}

fn analyse_k<S: Stride>(s: S, space: &StateSpace, bounds: &Bounds) -> Result<SccSummary, String> {
    if space.stats.deadlocks == 0 {
        // A bit per table slot, and the widest level's keys for the frontier.
        let widest = (0..space.levels())
            .map(|l| space.level_bounds(l))
            .map(|(a, b)| b - a)
            .max()
            .unwrap_or(0) as usize;
        bounds.check(
            space,
            space.slot_ids_bytes() / 32 + widest * 16 * space.layout.words,
            "reversibility",
        )?;
        let g = Graph {
            s,
            space,
            ids: Vec::new(),
        };
        if g.reach_initial(bounds)? {
            return Ok(SccSummary {
                sccs: 1,
                bottoms: 1,
                live: space.stats.fired.iter().all(|&f| f),
            });
        }
    }
    let n = space.states() as usize;
    bounds.check(
        space,
        space.slot_ids_bytes() + n * 8 + n.div_ceil(64) * 16,
        "liveness (Tarjan's algorithm)",
    )?;
    let g = Graph {
        s,
        space,
        ids: space.slot_ids(),
    };
    g.tarjan(bounds)
}

/// The reachability graph, its edges computed when asked.
struct Graph<'a, S: Stride> {
    s: S,
    space: &'a StateSpace,
    ids: Vec<Vec<u32>>,
}

/// One thread's scratch space for successor look-ups.
struct Scratch {
    m: Vec<u32>,
    succ: Vec<u64>,
    hashes: Vec<u64>,
}

impl<S: Stride> Graph<'_, S> {
    fn scratch(&self) -> Scratch {
        Scratch {
            m: self.space.layout.base.clone(),
            succ: Vec::new(),
            hashes: Vec::new(),
        }
    }

    /// The successor keys of the state with key `key`, in transition order, into `w`, their
    /// first table slots touched so that the look-ups' cache misses overlap.
    fn successor_keys(&self, key: &[u64], w: &mut Scratch) {
        let k = self.s.k();
        let sp = self.space;
        sp.decode(key, &mut w.m);
        w.succ.clear();
        w.hashes.clear();
        for t in 0..sp.rules.transitions() {
            if !sp.rules.enabled(t, &w.m) {
                continue;
            }
            let d = &sp.deltas[t * k..t * k + k];
            let at = w.succ.len();
            w.succ
                .extend(key.iter().zip(d).map(|(a, b)| a.wrapping_add(*b)));
            w.hashes.push(hash(&w.succ[at..]));
        }
        let mut sink = 0u64;
        for &h in &w.hashes {
            sink ^= sp.touch(self.s, h);
        }
        std::hint::black_box(sink);
    }

    /// The number of successor `j` of the keys in `w`.
    #[inline]
    fn successor(&self, w: &Scratch, j: usize) -> u32 {
        let k = self.s.k();
        self.space
            .find_id(self.s, &self.ids, &w.succ[j * k..(j + 1) * k], w.hashes[j])
            .expect("every successor of an explored state is stored")
    }

    /// Whether every state can reach the initial one: a breadth-first search backwards from
    /// it, on all cores. A state's predecessors by `t` are found by undoing `t` on its marking
    /// (checked to give a marking that fits the layout and enables `t`) and looking the
    /// result up; the frontier carries keys, so no state's key is searched for.
    fn reach_initial(&self, bounds: &Bounds) -> Result<bool, String> {
        let sp = self.space;
        let k = self.s.k();
        let n = sp.states() as usize;
        // Per transition, the bounds a state must be within to have a predecessor by it.
        let back = sp.rules.back_intervals(&sp.layout);
        // Reached states by table slot (one bit per slot of each shard): the look-up that
        // finds a predecessor gives its slot, and no slot-to-number map is read.
        let base: Vec<usize> = sp
            .shard_capacities()
            .scan(0, |acc, c| {
                let b = *acc;
                *acc += c;
                Some(b)
            })
            .collect();
        let slots: usize = sp.shard_capacities().sum();
        let good: Vec<AtomicU64> = (0..slots.div_ceil(64)).map(|_| AtomicU64::new(0)).collect();
        let is_in = |(g, slot): (usize, usize)| {
            let x = base[g] + slot;
            good[x / 64].load(Ordering::Relaxed) >> (x % 64) & 1 == 1
        };
        // Marks a slot; true when it was not marked yet.
        let join = |(g, slot): (usize, usize)| {
            let x = base[g] + slot;
            let b = 1u64 << (x % 64);
            good[x / 64].fetch_or(b, Ordering::Relaxed) & b == 0
        };
        let key0 = sp.key(0).to_vec();
        join(
            sp.find_slot(self.s, &key0, hash(&key0))
                .expect("the initial state is stored"),
        );
        let mut frontier: Vec<u64> = key0;
        let reached = AtomicU64::new(1);
        let threads = bounds.threads.max(1);
        // Once every state is in, what is left of the search cannot change the answer.
        while !frontier.is_empty() && reached.load(Ordering::Relaxed) < n as u64 {
            if bounds.cancelled() {
                return Err("interrupted".into());
            }
            let next = std::sync::Mutex::new(Vec::<u64>::new());
            let count = (frontier.len() / k) as u64;
            parallel(threads, 0, count, |lo, hi| {
                let mut m = sp.layout.base.clone();
                let mut cand: Vec<u64> = Vec::new();
                let mut hashes: Vec<u64> = Vec::new();
                let mut mine: Vec<u64> = Vec::new();
                let part = &frontier[lo as usize * k..hi as usize * k];
                // The predecessors of BATCH states at a time: every candidate's table slot
                // is touched before the first is probed, so that the cache misses overlap.
                for batch in part.chunks(BATCH * k) {
                    if reached.load(Ordering::Relaxed) == n as u64 {
                        break;
                    }
                    cand.clear();
                    hashes.clear();
                    for y in batch.chunks_exact(k) {
                        sp.decode(y, &mut m);
                        for (t, b) in back.iter().enumerate() {
                            // Undoing t must leave a marking that fits the layout and enables
                            // t for it to be an edge to y: asked before any look-up.
                            let Some(b) = b else { continue };
                            let ok = b.iter().all(|&(p, lo, hi)| {
                                let v = m[p as usize];
                                lo <= v && v <= hi
                            });
                            if ok {
                                let d = &sp.deltas[t * k..t * k + k];
                                let at = cand.len();
                                cand.extend(y.iter().zip(d).map(|(a, b)| a.wrapping_sub(*b)));
                                hashes.push(hash(&cand[at..]));
                            }
                        }
                    }
                    let mut sink = 0u64;
                    for &h in &hashes {
                        sink ^= sp.touch(self.s, h);
                    }
                    std::hint::black_box(sink);
                    let before = mine.len();
                    for (j, &h) in hashes.iter().enumerate() {
                        let x = &cand[j * k..(j + 1) * k];
                        let Some(at) = sp.find_slot(self.s, x, h) else {
                            continue;
                        };
                        if !is_in(at) && join(at) {
                            mine.extend_from_slice(x);
                        }
                    }
                    // Counted once per batch: a shared counter bumped per state would bounce
                    // its cache line between the threads on every new state.
                    let joined = ((mine.len() - before) / k) as u64;
                    if joined > 0 {
                        reached.fetch_add(joined, Ordering::Relaxed);
                    }
                }
                next.lock()
                    .unwrap_or_else(|e| e.into_inner())
                    .extend_from_slice(&mine);
            });
            frontier = next.into_inner().unwrap_or_else(|e| e.into_inner());
        }
        Ok(reached.load(Ordering::Relaxed) == n as u64)
    }

    /// Tarjan's algorithm with successors looked up as each state is first visited.
    fn tarjan(&self, bounds: &Bounds) -> Result<SccSummary, String> {
        let sp = self.space;
        let n = sp.states() as usize;
        let words = n.div_ceil(64);
        bounds.check(
            sp,
            self.ids.iter().map(|v| v.len() * 4).sum::<usize>() + n * 8 + words * 16,
            "liveness (Tarjan's algorithm)",
        )?;
        let mut index = vec![NONE; n];
        let mut low = vec![0u32; n];
        let mut on_stack = vec![0u64; words];
        let mut exits = vec![0u64; words];
        let bit = |v: &[u64], x: usize| v[x / 64] >> (x % 64) & 1 == 1;
        let mut stack: Vec<u32> = Vec::new();
        // Frames: (state, position of its next successor in `succ`, end of its successors).
        let mut call: Vec<(u32, usize, usize)> = Vec::new();
        let mut succ: Vec<u32> = Vec::new();
        let mut counter = 0u32;
        let mut sum = SccSummary {
            sccs: 0,
            bottoms: 0,
            live: true,
        };
        let fixed = self.ids.iter().map(|v| v.len() * 4).sum::<usize>() + n * 8 + words * 16;
        let mut w = self.scratch();
        let mut steps = 0u64;
        let mut seen = vec![false; sp.rules.transitions()];
        for root in 0..n {
            if index[root] != NONE {
                continue;
            }
            let mut enter = |v: usize,
                             index: &mut [u32],
                             low: &mut [u32],
                             on_stack: &mut [u64],
                             stack: &mut Vec<u32>,
                             call: &mut Vec<(u32, usize, usize)>,
                             succ: &mut Vec<u32>,
                             counter: &mut u32| {
                index[v] = *counter;
                low[v] = *counter;
                *counter += 1;
                stack.push(v as u32);
                on_stack[v / 64] |= 1 << (v % 64);
                let key = sp.key(v as u64).to_vec();
                self.successor_keys(&key, &mut w);
                let start = succ.len();
                for j in 0..w.hashes.len() {
                    succ.push(self.successor(&w, j));
                }
                call.push((v as u32, start, succ.len()));
            };
            enter(
                root,
                &mut index,
                &mut low,
                &mut on_stack,
                &mut stack,
                &mut call,
                &mut succ,
                &mut counter,
            );
            while let Some(&(v, pos, end)) = call.last() {
                steps += 1;
                if steps % (1 << 16) == 0 {
                    if bounds.cancelled() {
                        return Err("interrupted".into());
                    }
                    let held = (succ.capacity() + stack.capacity()) * 4 + call.capacity() * 24;
                    bounds.check(sp, fixed + held, "liveness (Tarjan's algorithm)")?;
                }
                let vs = v as usize;
                if pos < end {
                    let wv = succ[pos] as usize;
                    if let Some(top) = call.last_mut() {
                        top.1 += 1;
                    }
                    if index[wv] == NONE {
                        enter(
                            wv,
                            &mut index,
                            &mut low,
                            &mut on_stack,
                            &mut stack,
                            &mut call,
                            &mut succ,
                            &mut counter,
                        );
                    } else if bit(&on_stack, wv) {
                        low[vs] = low[vs].min(index[wv]);
                    } else {
                        exits[vs / 64] |= 1 << (vs % 64);
                    }
                    continue;
                }
                let (_, start, _) = call.pop().expect("a frame");
                succ.truncate(start);
                if let Some(&(u, _, _)) = call.last() {
                    let u = u as usize;
                    low[u] = low[u].min(low[vs]);
                }
                if low[vs] != index[vs] {
                    continue;
                }
                // v is a root: its component is the stack above it.
                let start = stack.iter().rposition(|&x| x == v).expect("root on stack");
                sum.sccs += 1;
                let members = &stack[start..];
                let mut bottom = true;
                for &x in members {
                    let x = x as usize;
                    on_stack[x / 64] &= !(1 << (x % 64));
                    bottom &= !bit(&exits, x);
                }
                if bottom {
                    sum.bottoms += 1;
                    if sum.live {
                        sum.live = covers_all(sp, members, &mut seen);
                    }
                }
                stack.truncate(start);
                if let Some(&(u, _, _)) = call.last() {
                    // The edge parent → v leaves the parent's component.
                    let u = u as usize;
                    exits[u / 64] |= 1 << (u % 64);
                }
            }
        }
        Ok(sum)
    }
}

/// Whether the states `members` of a bottom component together enable every transition. In a
/// bottom component every enabled transition's edge stays inside, so enabledness is enough.
fn covers_all(space: &StateSpace, members: &[u32], seen: &mut [bool]) -> bool {
    seen.fill(false);
    let mut missing = seen.len();
    let mut m = space.layout.base.clone();
    for &x in members {
        space.decode(space.key(u64::from(x)), &mut m);
        for (t, s) in seen.iter_mut().enumerate() {
            if !*s && space.rules.enabled(t, &m) {
                *s = true;
                missing -= 1;
            }
        }
        if missing == 0 {
            return true;
        }
    }
    missing == 0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testnet::parse;
    use crate::{explore, ExploreOptions};

    /// Explores a net and renders the component summary, through the sweeps where they
    /// decide and through Tarjan's algorithm alone, which must agree.
    fn check(net_text: &str, expect: &str) {
        let net = parse(net_text);
        let space = explore(&net, &ExploreOptions::default()).unwrap();
        let bounds = Bounds {
            threads: 2,
            max_memory: None,
            cancel: None,
        };
        let s = analyse(&space, &bounds).unwrap();
        let got = format!("sccs {} bottoms {} live {}", s.sccs, s.bottoms, s.live);
        assert_eq!(got, expect);
        let g = Graph {
            s: Dyn(space.layout.words),
            space: &space,
            ids: space.slot_ids(),
        };
        let t = g.tarjan(&bounds).unwrap();
        assert_eq!(
            (t.sccs == 1, t.bottoms, t.live),
            (s.sccs == 1, s.bottoms, s.live)
        );
    }

    #[test]
    fn one_cycle() {
        check(
            "a=1 b c ; t: a -> b ; u: b -> c ; v: c -> a",
            "sccs 1 bottoms 1 live true",
        );
    }

    #[test]
    fn chain_of_components_into_two_bottoms() {
        // {a,b} cycle exits to c (deadlock) or to the {d,e} cycle.
        check(
            "a=1 b c d e ; t: a -> b ; u: b -> a ; v: b -> c ; w: a -> d ; x: d -> e ; y: e -> d",
            "sccs 3 bottoms 2 live false",
        );
    }

    #[test]
    fn deep_chain_needs_no_recursion() {
        // 200 000 states in a line: a recursive algorithm would overflow the stack.
        check("a=200000 b ; t: a -> b", "sccs 200001 bottoms 1 live false");
    }

    #[test]
    fn reversible_but_only_through_higher_levels() {
        // From b the way back to a goes up through c first: the first sweep cannot take b,
        // a later one does.
        check(
            "a=1 b c d ; t: a -> b ; u: b -> c ; v: c -> d ; w: d -> a ; x: a -> d",
            "sccs 1 bottoms 1 live true",
        );
    }

    #[test]
    fn not_reversible_without_deadlocks() {
        // a leaves for the cycle b ⇄ c and never comes back.
        check(
            "a=1 b c ; t: a -> b ; u: b -> c ; v: c -> b",
            "sccs 2 bottoms 1 live false",
        );
    }

    #[test]
    fn the_memory_budget_stops_it_with_the_reason() {
        let net = parse("a=1 b ; t: a -> b ; u: b -> a");
        let space = explore(&net, &ExploreOptions::default()).unwrap();
        let bounds = Bounds {
            threads: 1,
            max_memory: Some(1),
            cancel: None,
        };
        let err = analyse(&space, &bounds).err().unwrap();
        assert!(err.contains("more than --max-memory"), "{err}");
    }
}
