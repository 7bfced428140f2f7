//! The explored state space: states numbered breadth-first (level by level, then by shard and
//! insertion order), their markings, and, when kept, the reachability graph as compressed rows
//! of `u32` targets. Edge labels are not stored: the k-th edge of a state is its k-th enabled
//! transition, recomputed from the marking when asked for.

use std::time::Duration;

use petriplc_net::{Marking, TransitionId};

use crate::explore::{shard_of, Rules, Stats, SHARDS};
use crate::layout::{hash, Dyn, Fixed, Layout, Stride};
use crate::shard::Shard;

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

/// Compressed sparse rows: the successors of state `s` are
/// `targets[offsets[s]..offsets[s + 1]]`, in transition order.
pub(crate) struct Graph {
    pub offsets: Vec<u64>,
    pub targets: Vec<u32>,
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
    ) -> StateSpace {
        let mut segs = Vec::new();
        let mut level_first = Vec::new();
        let mut id = 0u64;
        for pair in marks.windows(2) {
            let (here, next) = (&pair[0], &pair[1]);
            level_first.push(id);
            for g in 0..SHARDS {
                let len = next[g] - here[g];
                if len > 0 {
                    segs.push(Seg {
                        first: id,
                        shard: g as u32,
                        lo: here[g],
                        len,
                    });
                    id += u64::from(len);
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
        let g = self
            .graph
            .as_ref()
            .map_or(0, |g| g.offsets.capacity() * 8 + g.targets.capacity() * 4);
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
            for x in id..end {
                f(x, shard.key(k, (s.lo + (x - s.first) as u32) as usize));
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
        let (a, b) = (
            g.offsets[s.index()] as usize,
            g.offsets[s.index() + 1] as usize,
        );
        let ts = if a == b { Vec::new() } else { self.enabled(s) };
        debug_assert_eq!(ts.len(), b - a);
        ts.into_iter()
            .zip(g.targets[a..b].iter().map(|&x| StateId(x)))
    }

    /// The successor state numbers of `s` (graph kept).
    pub(crate) fn targets(&self, s: usize) -> &[u32] {
        let g = self.graph.as_ref().expect("graph");
        &g.targets[g.offsets[s] as usize..g.offsets[s + 1] as usize]
    }

    /// Builds the graph of the expanded states on `threads` threads: degrees first (so rows
    /// are written in place), then each row's targets by looking successors up.
    pub(crate) fn build_graph(&mut self, threads: usize) {
        let n = self.states() as usize;
        let exp = self.expanded as usize;
        // Slot → state number, per shard.
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
        let threads = threads.max(1);
        let per = exp.div_ceil(threads).max(1);
        let mut offsets = vec![0u64; n + 1];
        std::thread::scope(|sc| {
            for (c, part) in offsets[1..=exp].chunks_mut(per).enumerate() {
                let me = &*self;
                sc.spawn(move || {
                    let a = (c * per) as u64;
                    let mut m = me.layout.base.clone();
                    me.for_range(a, a + part.len() as u64, |id, key| {
                        me.layout.decode(key, &mut m);
                        part[(id - a) as usize] = (0..me.rules.transitions())
                            .filter(|&t| me.rules.enabled(t, &m))
                            .count() as u64;
                    });
                });
            }
        });
        for i in 0..n {
            offsets[i + 1] += offsets[i];
        }
        let mut targets = vec![0u32; offsets[n] as usize];
        match self.layout.words {
            1 => self.fill(Fixed::<1>, &offsets, &mut targets, &ids, per),
            2 => self.fill(Fixed::<2>, &offsets, &mut targets, &ids, per),
            3 => self.fill(Fixed::<3>, &offsets, &mut targets, &ids, per),
            4 => self.fill(Fixed::<4>, &offsets, &mut targets, &ids, per),
            k => self.fill(Dyn(k), &offsets, &mut targets, &ids, per),
        }
        self.graph = Some(Graph { offsets, targets });
    }

    fn fill<S: Stride>(
        &self,
        s: S,
        offsets: &[u64],
        targets: &mut [u32],
        ids: &[Vec<u32>],
        per: usize,
    ) {
        let exp = self.expanded as usize;
        let k = s.k();
        std::thread::scope(|sc| {
            let mut rest = targets;
            let mut a = 0usize;
            while a < exp {
                let b = (a + per).min(exp);
                let (mine, tail) = rest.split_at_mut((offsets[b] - offsets[a]) as usize);
                rest = tail;
                sc.spawn(move || {
                    let mut m = self.layout.base.clone();
                    let mut succ = vec![0u64; k];
                    let mut at = 0usize;
                    self.for_range(a as u64, b as u64, |_, key| {
                        self.layout.decode(key, &mut m);
                        for t in 0..self.rules.transitions() {
                            if !self.rules.enabled(t, &m) {
                                continue;
                            }
                            let d = &self.deltas[t * k..t * k + k];
                            for j in 0..k {
                                succ[j] = key[j].wrapping_add(d[j]);
                            }
                            let h = hash(&succ);
                            let g = shard_of(h);
                            let slot = self.shards[g]
                                .find(s, &succ, h)
                                .expect("every successor of an expanded state is stored");
                            mine[at] = ids[g][slot];
                            at += 1;
                        }
                    });
                });
                a = b;
            }
        });
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
}
