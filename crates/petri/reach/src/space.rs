//! The explored state space: states numbered breadth-first (level by level, then by shard and
//! insertion order), their markings, and, when kept, the reachability graph as compressed rows
//! of `u32` targets. Edge labels are not stored: the k-th edge of a state is its k-th enabled
//! transition, recomputed from the marking when asked for.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use petriplc_net::{Marking, TransitionId};

use crate::layout::{hash, Dyn, Fixed, Layout, Stride};
use crate::rules::{Rules, Stats};
use crate::shard::{shard_of, Shard};
use crate::Limit;

/// A state, numbered breadth-first from the initial marking (state 0). The numbering is the
/// same for every thread count.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct StateId(pub u32);

impl StateId {
    #[inline]
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A run of consecutive state numbers stored in one shard.
#[derive(Clone, Copy, Debug)]
struct Seg {
    first: u64,
    shard: u32,
    lo: u32,
    len: u32,
}

/// States whose keys [`StateSpace::for_range`] touches together.
const PREFETCH: u64 = 16;
/// States per block of the graph, at most (fewer when a block's edges could pass `u32`).
const BLOCK: usize = 1 << 16;
/// States expanded together when building the graph (their look-ups overlap).
const GRAPH_BATCH: usize = 8;

/// Compressed sparse rows in blocks of `len` states (built in parallel, one block at a time,
/// without a second pass or a copy): the successors of state `s` are
/// `targets[offsets[i]..offsets[i + 1]]` of block `s / len`, `i = s % len`, in transition
/// order. States not expanded have none.
pub(crate) struct Graph {
    len: usize,
    blocks: Vec<Block>,
}

struct Block {
    offsets: Vec<u32>,
    targets: Vec<u32>,
}

impl Graph {
    fn targets(&self, s: usize) -> &[u32] {
        let Some(b) = self.blocks.get(s / self.len) else {
            return &[];
        };
        let i = s % self.len;
        match (b.offsets.get(i), b.offsets.get(i + 1)) {
            (Some(&a), Some(&z)) => &b.targets[a as usize..z as usize],
            _ => &[],
        }
    }

    fn bytes(&self) -> usize {
        self.blocks
            .iter()
            .map(|b| (b.offsets.capacity() + b.targets.capacity()) * 4)
            .sum()
    }
}

/// The reachable markings found by [`crate::explore`], and their graph when it was kept.
pub struct StateSpace {
    pub(crate) rules: Rules,
    pub(crate) layout: Layout,
    pub(crate) deltas: Vec<u64>,
    shards: Vec<Shard>,
    segs: Vec<Seg>,
    /// First state of each level, then the number of states.
    level_first: Vec<u64>,
    pub(crate) stats: Stats,
    complete: bool,
    expanded: u64,
    elapsed: Duration,
    limit: Option<Limit>,
    pub(crate) graph: Option<Graph>,
}

impl StateSpace {
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn new(
        rules: Rules,
        layout: Layout,
        deltas: Vec<u64>,
        mut shards: Vec<Shard>,
        marks: Vec<Vec<u32>>,
        stats: Stats,
        complete: bool,
        expanded: u64,
        elapsed: Duration,
        limit: Option<Limit>,
    ) -> StateSpace {
        let mut segs = Vec::new();
        let mut level_first = Vec::new();
        let mut id = 0u64;
        for pair in marks.windows(2) {
            level_first.push(id);
            for (g, (&lo, &hi)) in pair[0].iter().zip(&pair[1]).enumerate() {
                if hi > lo {
                    segs.push(Seg {
                        first: id,
                        shard: g as u32,
                        lo,
                        len: hi - lo,
                    });
                    id += u64::from(hi - lo);
                }
            }
        }
        level_first.push(id);
        for s in &mut shards {
            s.shrink();
        }
        StateSpace {
            rules,
            layout,
            deltas,
            shards,
            segs,
            level_first,
            stats,
            complete,
            expanded,
            elapsed,
            limit,
            graph: None,
        }
    }

    /// Reachable markings found.
    pub fn states(&self) -> u64 {
        *self.level_first.last().expect("levels")
    }

    /// Edges of the reachability graph: (state, enabled transition) pairs over the expanded
    /// states, so parallel edges count separately (the Model Checking Contest's TRANSITIONS).
    pub fn edges(&self) -> u64 {
        self.stats.edges
    }

    /// False when a state limit or a cancel stopped the exploration: then the figures are
    /// those of the part explored.
    pub fn complete(&self) -> bool {
        self.complete
    }

    /// The limit that stopped an incomplete exploration.
    pub fn limit(&self) -> Option<Limit> {
        self.limit
    }

    /// States whose successors were all computed: every state when complete; a prefix of the
    /// numbering otherwise.
    pub fn expanded(&self) -> u64 {
        self.expanded
    }

    /// Breadth-first levels (the initial marking is level 0).
    pub fn levels(&self) -> usize {
        self.level_first.len() - 1
    }

    /// The state numbers of level `l`.
    pub(crate) fn level_bounds(&self, l: usize) -> (u64, u64) {
        (self.level_first[l], self.level_first[l + 1])
    }

    /// The level (distance from the initial marking) of state `s`.
    pub fn depth(&self, s: StateId) -> usize {
        self.level_first.partition_point(|&x| x <= u64::from(s.0)) - 1
    }

    /// Wall-clock time of the exploration (without building the graph).
    pub fn elapsed(&self) -> Duration {
        self.elapsed
    }

    /// The initial marking's state.
    pub fn initial(&self) -> StateId {
        StateId(0)
    }

    /// Whether the graph was kept ([`crate::ExploreOptions::keep_graph`]).
    pub fn has_graph(&self) -> bool {
        self.graph.is_some()
    }

    /// Words (of 64 bits) in a packed marking.
    pub fn key_words(&self) -> usize {
        self.layout.words
    }

    /// Bytes held by states and graph (for reports).
    pub fn memory_bytes(&self) -> usize {
        let g = self.graph.as_ref().map_or(0, Graph::bytes);
        self.shards.iter().map(Shard::bytes).sum::<usize>() + g
    }

    fn seg_of(&self, id: u64) -> Seg {
        self.segs[self.segs.partition_point(|s| s.first <= id) - 1]
    }

    /// The packed key of state `id`.
    pub(crate) fn key(&self, id: u64) -> &[u64] {
        let s = self.seg_of(id);
        self.shards[s.shard as usize].key(
            Dyn(self.layout.words),
            (s.lo + (id - s.first) as u32) as usize,
        )
    }

    /// Decodes a key into `m` (which starts as any earlier decode or [`Layout::base`]).
    pub(crate) fn decode(&self, key: &[u64], m: &mut [u32]) {
        self.layout.decode(key, m);
    }

    /// The marking of state `s`.
    pub fn marking(&self, s: StateId) -> Marking {
        let mut m = self.layout.base.clone();
        self.layout.decode(self.key(u64::from(s.0)), &mut m);
        Marking(m)
    }

    /// Every state with its marking, in state order.
    pub fn iter_markings(&self) -> impl Iterator<Item = (StateId, Marking)> + '_ {
        let k = Dyn(self.layout.words);
        self.segs.iter().flat_map(move |s| {
            let shard = &self.shards[s.shard as usize];
            (0..s.len).map(move |j| {
                let mut m = self.layout.base.clone();
                self.layout
                    .decode(shard.key(k, (s.lo + j) as usize), &mut m);
                (StateId((s.first + u64::from(j)) as u32), Marking(m))
            })
        })
    }

    /// For each of `n` properties of single markings, the first state (in state order) that
    /// has it, found on `threads` cores (0: all) without keeping markings: `f(m, open, hit)`
    /// calls `hit(i)` for the properties `i` that marking `m` has, and may skip those for
    /// which `open(i)` is false (found in an earlier state already). Deterministic: the
    /// answer is the smallest such state whatever the timing.
    pub fn first_states<F>(&self, threads: usize, n: usize, f: F) -> Vec<Option<StateId>>
    where
        F: Fn(&Marking, &dyn Fn(usize) -> bool, &mut dyn FnMut(usize)) + Sync,
    {
        let first: Vec<AtomicU64> = (0..n).map(|_| AtomicU64::new(u64::MAX)).collect();
        let threads = crate::threads(threads);
        if n > 0 {
            crate::sweep::parallel(threads, 0, self.states(), |lo, hi| {
                // Nothing left to find from here on.
                if first.iter().all(|x| x.load(Ordering::Relaxed) < lo) {
                    return;
                }
                let mut m = Marking(self.layout.base.clone());
                self.for_range(lo, hi, |id, key| {
                    self.layout.decode(key, &mut m.0);
                    let open = |i: usize| first[i].load(Ordering::Relaxed) > id;
                    f(&m, &open, &mut |i| {
                        first[i].fetch_min(id, Ordering::Relaxed);
                    });
                });
            });
        }
        first
            .into_iter()
            .map(|x| {
                let x = x.into_inner();
                (x != u64::MAX).then_some(StateId(x as u32))
            })
            .collect()
    }

    /// Calls `f(id, key)` for states `a..b` in order.
    pub(crate) fn for_range(&self, a: u64, b: u64, mut f: impl FnMut(u64, &[u64])) {
        if a >= b {
            return;
        }
        let k = Dyn(self.layout.words);
        let mut i = self.segs.partition_point(|s| s.first <= a) - 1;
        let mut id = a;
        while id < b {
            let s = self.segs[i];
            let shard = &self.shards[s.shard as usize];
            let end = (s.first + u64::from(s.len)).min(b);
            // States are stored at hashed slots: touch a group's keys before reading the
            // first, so that their cache misses overlap.
            let mut x = id;
            while x < end {
                let group = (end - x).min(PREFETCH);
                let mut sink = 0u64;
                for y in x..x + group {
                    sink ^= shard.key(k, (s.lo + (y - s.first) as u32) as usize)[0];
                }
                std::hint::black_box(sink);
                for y in x..x + group {
                    f(y, shard.key(k, (s.lo + (y - s.first) as u32) as usize));
                }
                x += group;
            }
            id = end;
            i += 1;
        }
    }

    /// The transitions enabled in state `s`, in order.
    pub fn enabled(&self, s: StateId) -> Vec<TransitionId> {
        let m = self.marking(s);
        (0..self.rules.transitions())
            .filter(|&t| self.rules.enabled(t, &m.0))
            .map(|t| TransitionId(t as u32))
            .collect()
    }

    /// The outgoing edges of `s` as (transition, successor), in transition order. Empty for a
    /// state that was not expanded.
    ///
    /// # Panics
    /// If the graph was not kept ([`crate::ExploreOptions::keep_graph`]).
    pub fn successors(&self, s: StateId) -> impl Iterator<Item = (TransitionId, StateId)> + '_ {
        let g = self
            .graph
            .as_ref()
            .expect("successors() needs ExploreOptions::keep_graph");
        let targets = g.targets(s.index());
        let ts = if targets.is_empty() {
            Vec::new()
        } else {
            self.enabled(s)
        };
        debug_assert_eq!(ts.len(), targets.len());
        ts.into_iter().zip(targets.iter().map(|&x| StateId(x)))
    }

    /// Bytes [`StateSpace::slot_ids`] takes.
    pub(crate) fn slot_ids_bytes(&self) -> usize {
        self.shards.iter().map(|s| s.capacity() * 4).sum()
    }

    /// Per shard, slot → state number (`u32::MAX` for an empty slot): with it a look-up in
    /// the tables gives a state's number.
    pub(crate) fn slot_ids(&self) -> Vec<Vec<u32>> {
        let mut ids: Vec<Vec<u32>> = self
            .shards
            .iter()
            .map(|s| vec![u32::MAX; s.capacity()])
            .collect();
        for s in &self.segs {
            let shard = &self.shards[s.shard as usize];
            for j in 0..s.len {
                ids[s.shard as usize][shard.order[(s.lo + j) as usize] as usize] =
                    (s.first + u64::from(j)) as u32;
            }
        }
        ids
    }

    /// Starts the cache miss of looking `h` up (see [`Shard::touch`]).
    #[inline]
    pub(crate) fn touch<S: Stride>(&self, s: S, h: u64) -> u64 {
        self.shards[shard_of(h)].touch(s, h)
    }

    /// The capacity of each shard's table, in shard order.
    pub(crate) fn shard_capacities(&self) -> impl Iterator<Item = usize> + Clone + '_ {
        self.shards.iter().map(Shard::capacity)
    }

    /// The (shard, slot) holding `key` (hash `h`), if stored.
    #[inline]
    pub(crate) fn find_slot<S: Stride>(&self, s: S, key: &[u64], h: u64) -> Option<(usize, usize)> {
        let g = shard_of(h);
        self.shards[g].find(s, key, h).map(|slot| (g, slot))
    }

    /// The number of the state with key `key` (hash `h`), if stored.
    #[inline]
    pub(crate) fn find_id<S: Stride>(
        &self,
        s: S,
        ids: &[Vec<u32>],
        key: &[u64],
        h: u64,
    ) -> Option<u32> {
        let g = shard_of(h);
        self.shards[g].find(s, key, h).map(|slot| ids[g][slot])
    }

    /// Builds the reachability graph after the exploration (as
    /// [`crate::ExploreOptions::keep_graph`] does), for [`StateSpace::successors`]: 4 bytes
    /// per edge.
    pub fn keep_graph(&mut self, threads: usize) {
        if self.graph.is_none() {
            self.build_graph(threads.max(1));
        }
    }

    /// Builds the graph of the expanded states on `threads` threads, which take blocks of
    /// states in turn and look every successor up.
    pub(crate) fn build_graph(&mut self, threads: usize) {
        let ids = self.slot_ids();
        let len = (u32::MAX as usize / self.rules.transitions().max(1)).clamp(1, BLOCK);
        let blocks = match self.layout.words {
            1 => self.blocks(Fixed::<1>, &ids, threads, len),
            2 => self.blocks(Fixed::<2>, &ids, threads, len),
            3 => self.blocks(Fixed::<3>, &ids, threads, len),
            4 => self.blocks(Fixed::<4>, &ids, threads, len),
            k => self.blocks(Dyn(k), &ids, threads, len),
        };
        self.graph = Some(Graph { len, blocks });
    }

    fn blocks<S: Stride>(&self, s: S, ids: &[Vec<u32>], threads: usize, len: usize) -> Vec<Block> {
        let exp = self.expanded as usize;
        let count = exp.div_ceil(len);
        let next = std::sync::atomic::AtomicUsize::new(0);
        let mut done: Vec<(usize, Block)> = std::thread::scope(|sc| {
            let handles: Vec<_> = (0..threads.max(1))
                .map(|_| {
                    sc.spawn(|| {
                        let mut mine = Vec::new();
                        loop {
                            let b = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                            if b >= count {
                                return mine;
                            }
                            let (lo, hi) = (b * len, ((b + 1) * len).min(exp));
                            mine.push((b, self.block(s, ids, lo as u64, hi as u64)));
                        }
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().expect("graph thread panicked"))
                .collect()
        });
        done.sort_by_key(|(b, _)| *b);
        done.into_iter().map(|(_, b)| b).collect()
    }

    /// The rows of states `lo..hi`.
    fn block<S: Stride>(&self, s: S, ids: &[Vec<u32>], lo: u64, hi: u64) -> Block {
        let k = s.k();
        let t_count = self.rules.transitions();
        let mut m = self.layout.base.clone();
        let mut offsets = Vec::with_capacity((hi - lo) as usize + 1);
        offsets.push(0u32);
        let mut targets: Vec<u32> = Vec::new();
        let mut succ: Vec<u64> = Vec::new();
        let mut hashes: Vec<u64> = Vec::new();
        let mut pending = 0;
        let finish = |succ: &mut Vec<u64>, hashes: &mut Vec<u64>, targets: &mut Vec<u32>| {
            let mut sink = 0u64;
            for &h in hashes.iter() {
                sink ^= self.shards[shard_of(h)].touch(s, h);
            }
            std::hint::black_box(sink);
            for (j, &h) in hashes.iter().enumerate() {
                let g = shard_of(h);
                let slot = self.shards[g]
                    .find(s, &succ[j * k..(j + 1) * k], h)
                    .expect("every successor of an expanded state is stored");
                targets.push(ids[g][slot]);
            }
            succ.clear();
            hashes.clear();
        };
        self.for_range(lo, hi, |_, key| {
            self.layout.decode(key, &mut m);
            let mut degree = 0u32;
            for t in 0..t_count {
                if !self.rules.enabled(t, &m) {
                    continue;
                }
                degree += 1;
                let d = &self.deltas[t * k..t * k + k];
                let at = succ.len();
                succ.extend(key.iter().zip(d).map(|(a, b)| a.wrapping_add(*b)));
                hashes.push(hash(&succ[at..]));
            }
            let last = *offsets.last().expect("offsets");
            offsets.push(last + degree);
            pending += 1;
            if pending == GRAPH_BATCH {
                finish(&mut succ, &mut hashes, &mut targets);
                pending = 0;
            }
        });
        finish(&mut succ, &mut hashes, &mut targets);
        Block { offsets, targets }
    }
}

#[cfg(test)]
mod tests {
    use crate::testnet::parse;
    use crate::{explore, ExploreOptions};

    /// Explores a net with its graph and renders each state: marking and edges.
    fn check(net_text: &str, threads: usize, expect: &str) {
        let net = parse(net_text);
        let opts = ExploreOptions {
            keep_graph: true,
            threads,
            ..Default::default()
        };
        let space = explore(&net, &opts).unwrap();
        let rows: Vec<String> = space
            .iter_markings()
            .map(|(s, m)| {
                assert_eq!(space.marking(s), m);
                let edges: Vec<String> = space
                    .successors(s)
                    .map(|(t, d)| format!("{}>{}", net.transition_label(t), d.0))
                    .collect();
                format!("{} {:?} d{} {}", s.0, m.0, space.depth(s), edges.join(","))
            })
            .collect();
        assert_eq!(rows.join(" | "), expect);
    }

    #[test]
    fn states_are_numbered_breadth_first_with_edges_in_transition_order() {
        let net = "a=2 b ; t: a -> b ; u: b -> a";
        let expect = "0 [2, 0] d0 t>1 | 1 [1, 1] d1 t>2,u>0 | 2 [0, 2] d2 u>1";
        check(net, 1, expect);
        check(net, 2, expect);
    }

    #[test]
    fn parallel_edges_count_separately() {
        // t and u lead to the same marking: two edges.
        check(
            "a=1 b ; t: a -> b ; u: a -> b",
            1,
            "0 [1, 0] d0 t>1,u>1 | 1 [0, 1] d1 ",
        );
    }

    #[test]
    fn first_states_are_the_sequential_sweeps_for_any_thread_count() {
        // 3003 states: more than one parallel chunk.
        let net = parse("a=10 b c d e f ; t: a -> b ; u: b -> c ; v: c -> d ; w: d -> e ; x: e -> f ; y: f -> a");
        let space = explore(&net, &ExploreOptions::default()).unwrap();
        let props = |m: &petriplc_net::Marking| -> Vec<bool> {
            vec![
                m.0[1] >= 5,
                m.0[5] == 10,
                m.0[0] > 10,
                m.0[2] == 3 && m.0[4] == 2,
            ]
        };
        let mut expect = vec![None; 4];
        for (id, m) in space.iter_markings() {
            for (i, has) in props(&m).into_iter().enumerate() {
                if has && expect[i].is_none() {
                    expect[i] = Some(id);
                }
            }
        }
        assert!(expect[1].is_some_and(|s| s.0 > 2048), "{expect:?}");
        for threads in [1, 2, 3] {
            let got = space.first_states(threads, 4, |m, open, hit| {
                for (i, has) in props(m).into_iter().enumerate() {
                    if has && open(i) {
                        hit(i);
                    }
                }
            });
            assert_eq!(got, expect, "{threads} threads");
        }
    }
}
