//! Breadth-first exploration on all cores, with results that do not depend on thread timing.
//!
//! The state set is split into [`SHARDS`](crate::shard::SHARDS) hash tables by hash; thread `i` owns the shards
//! `g ≡ i (mod threads)`. A level of the search is expanded in rounds of [`CHUNK`] states, each
//! in two phases separated by barriers:
//!
//! 1. every thread expands its slice of the round, looking successors up in all shards (read
//!    only, no locks on the hot path) and sending the ones not found to the owner's buffer;
//! 2. every owner inserts what it was sent into its shards, in sender order.
//!
//! Because the tables are frozen during phase 1 and phase 2 inserts in frontier order, the set
//! of states, their numbering and every figure are the same for any thread count. Rounds
//! smaller than [`SOLO`] are run by the leader alone (barriers would cost more).
//!
//! The frontier is kept apart from the tables as records `key ++ enabled transitions`, written
//! in order when a state is inserted, so expanding a state reads memory sequentially and
//! calls the enabling rule only for the transitions its parent's firing could have changed.
//!
//! A successor that overflows its bit field is kept aside (decoded) and the layout is widened
//! at the end of the level, when all states are re-encoded; see [`crate::layout`].

use std::collections::HashSet;
use std::ops::DerefMut;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Barrier, Mutex, RwLock, RwLockReadGuard, RwLockWriteGuard};
use std::time::Instant;

use petriplc_net::Net;

use crate::layout::{hash, Dyn, Fixed, Layout, Stride};
use crate::rules::{deltas, Rules, Stats};
use crate::shard::{shard_of, Shard, SHARDS};
use crate::space::StateSpace;
use crate::{ExploreOptions, Limit, Progress, ReachError};

/// Frontier states per parallel round. Fixed, so round boundaries never depend on threads.
const CHUNK: u64 = 16_384;
/// States re-encoded together when widening.
const REBUILD_BATCH: usize = 32;
/// Rounds smaller than this run on the leader alone.
const SOLO: u64 = 1_024;

/// One shard: its table, and the frontier records of its states of the level being expanded
/// (`cur`) and of the next level (`next`), in insertion order.
pub(crate) struct Part {
    pub table: Shard,
    cur: Vec<u64>,
    next: Vec<u64>,
}

/// What a round works on: positions `start..end` of level `level`'s frontier.
#[derive(Clone, Debug)]
struct Round {
    level: usize,
    start: u64,
    end: u64,
    /// Frontier positions where each shard's part begins (`SHARDS + 1` entries).
    prefix: Vec<u64>,
}

#[derive(Clone, Debug)]
enum Plan {
    Round(Round),
    Exit,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Exit {
    /// The frontier is empty: everything is explored.
    Done,
    /// A level ended with successors that need a wider layout.
    Widen,
    /// Cancelled, the state limit was reached, or an error.
    Stopped,
}

/// The leader's bookkeeping, which survives across runs (a run ends at every widening).
struct Ctl {
    /// `marks[l][g]`: shard `g`'s length when level `l` began, i.e. its states of levels
    /// `< l`. The last entry is the end of the level being expanded.
    marks: Vec<Vec<u32>>,
    level: usize,
    pos: u64,
    frontier: u64,
    /// Decoded successors that did not fit, in frontier order, without repeats.
    stash: Vec<u32>,
    stash_seen: HashSet<Vec<u32>>,
    /// A stop came in the middle of a level with successors still stashed: that level counts
    /// as not expanded.
    partial: bool,
    /// The limit that stopped the exploration, if one did.
    limit: Option<Limit>,
    last_progress: Instant,
}

pub(crate) struct Engine<'a> {
    rules: Rules,
    opts: &'a ExploreOptions,
    cancel: Option<&'a AtomicBool>,
    threads: usize,
    pub layout: Layout,
    deltas: Vec<u64>,
    /// Words of enabled-transition bits in a frontier record.
    ewords: usize,
    parts: Vec<RwLock<Part>>,
    ctl: Ctl,
    stats: Stats,
    started: Instant,
}

/// States expanded together: their successors' look-ups are started (touched) together and
/// finished together, so that many cache misses overlap.
const BATCH: usize = 4;
/// A batch is finished early once this many look-ups are pending.
const PENDING: usize = 40;

/// One thread's scratch space.
struct Worker {
    /// Decoded markings of the batch, `places` each.
    ms: Vec<u32>,
    /// Per batch slot: the record's index in the run being expanded.
    slot_rec: Vec<usize>,
    succ: Vec<u64>,
    hashes: Vec<u64>,
    fired: Vec<u32>,
    parent: Vec<u8>,
    en: Vec<u64>,
    stats: Stats,
    stash: Vec<u32>,
    error: Option<ReachError>,
}

impl Worker {
    fn new(layout: &Layout, transitions: usize, ewords: usize) -> Worker {
        let cap = (BATCH * transitions).max(1);
        Worker {
            ms: layout.base.repeat(BATCH),
            slot_rec: vec![0; BATCH],
            succ: vec![0; cap * layout.words],
            hashes: vec![0; cap],
            fired: vec![0; cap],
            parent: vec![0; cap],
            en: vec![0; ewords],
            stats: Stats::new(layout.base.len(), transitions),
            stash: Vec::new(),
            error: None,
        }
    }
}

/// Everything the threads of one run share.
struct Shared<'e> {
    rules: &'e Rules,
    layout: &'e Layout,
    deltas: &'e [u64],
    ewords: usize,
    parts: &'e [RwLock<Part>],
    threads: usize,
    /// `out[src * threads + dst]`: records `src` found new for shards `dst` owns.
    out: Vec<Mutex<Vec<u64>>>,
    stash: Vec<Mutex<Vec<u32>>>,
    barrier: Barrier,
    plan: Mutex<Plan>,
    edges: AtomicU64,
    failed: AtomicBool,
}

impl<'a> Engine<'a> {
    pub fn new(net: &Net, opts: &'a ExploreOptions, cancel: Option<&'a AtomicBool>) -> Engine<'a> {
        let threads = crate::threads(opts.threads);
        let rules = Rules::new(net);
        let layout = Layout::new(net);
        let deltas = deltas(net, &layout);
        let ewords = rules.transitions().div_ceil(64);
        let k = layout.words;
        let parts: Vec<RwLock<Part>> = (0..SHARDS)
            .map(|_| {
                RwLock::new(Part {
                    table: Shard::new(k, 16),
                    cur: Vec::new(),
                    next: Vec::new(),
                })
            })
            .collect();
        let m0 = net.initial_marking().0;
        let mut rec = vec![0; k + ewords];
        layout.encode(&m0, &mut rec[..k]);
        rules.enabled_set(&m0, &mut rec[k..]);
        let h = hash(&rec[..k]);
        {
            let mut p = write(&parts[shard_of(h)]);
            p.table.insert(Dyn(k), &rec[..k], h);
            p.next.extend_from_slice(&rec);
        }
        let stats = Stats::new(m0.len(), rules.transitions());
        let mut e = Engine {
            rules,
            opts,
            cancel,
            threads,
            layout,
            deltas,
            ewords,
            parts,
            ctl: Ctl {
                marks: vec![vec![0; SHARDS]],
                level: 0,
                pos: 0,
                frontier: 0,
                stash: Vec::new(),
                stash_seen: HashSet::new(),
                partial: false,
                limit: None,
                last_progress: Instant::now(),
            },
            stats,
            started: Instant::now(),
        };
        begin_level(&e.parts, &mut e.ctl, 0);
        e
    }

    pub fn threads(&self) -> usize {
        self.threads
    }

    fn states(&self) -> u64 {
        self.parts.iter().map(|s| read(s).table.len() as u64).sum()
    }

    /// Runs the exploration to its end.
    pub fn run_all(mut self) -> Result<StateSpace, ReachError> {
        let complete = loop {
            let exit = match self.layout.words {
                1 => self.run(Fixed::<1>)?,
                2 => self.run(Fixed::<2>)?,
                3 => self.run(Fixed::<3>)?,
                4 => self.run(Fixed::<4>)?,
                k => self.run(Dyn(k))?,
            };
            match exit {
                Exit::Done => break true,
                Exit::Widen => self.widen(),
                Exit::Stopped => {
                    if self.ctl.pos == self.ctl.frontier && !self.ctl.stash.is_empty() {
                        self.widen();
                    } else if !self.ctl.stash.is_empty() {
                        // Widening now would renumber this level; count it as not expanded.
                        self.ctl.partial = true;
                    }
                    break false;
                }
            }
        };
        let expanded = self.expanded(complete);
        let mut marks = self.ctl.marks;
        let lens: Vec<u32> = self
            .parts
            .iter()
            .map(|s| read(s).table.len() as u32)
            .collect();
        if marks.last() != Some(&lens) {
            // States found but not expanded: the next level, as far as it got.
            marks.push(lens);
        }
        let tables = self
            .parts
            .into_iter()
            .map(|s| s.into_inner().unwrap_or_else(|e| e.into_inner()).table)
            .collect();
        Ok(StateSpace::new(
            self.rules,
            self.layout,
            self.deltas,
            tables,
            marks,
            self.stats,
            complete,
            expanded,
            self.started.elapsed(),
            self.ctl.limit.filter(|_| !complete),
        ))
    }

    /// States whose successors are all stored: every level before the current one and the
    /// part of the current one already expanded (in the final numbering, which is level by
    /// level, then shard by shard, as the frontier is).
    fn expanded(&self, complete: bool) -> u64 {
        let n = self.ctl.marks.len();
        let before: u64 = self.ctl.marks[n - 2].iter().map(|&x| u64::from(x)).sum();
        if complete {
            self.states()
        } else if self.ctl.partial {
            before
        } else {
            before + self.ctl.pos
        }
    }

    /// Re-encodes every state in a layout wide enough for the stashed successors, then adds
    /// them. Keys change, so states move between shards: the tables are rebuilt in the order
    /// of the numbering, which keeps each level's states together and in frontier order. Runs
    /// only at the end of a level.
    fn widen(&mut self) {
        let p = self.layout.base.len();
        let (ko, e) = (Dyn(self.layout.words), self.ewords);
        let old: Vec<Part> = std::mem::take(&mut self.parts)
            .into_iter()
            .map(|s| s.into_inner().unwrap_or_else(|e| e.into_inner()))
            .collect();
        // The most tokens of every place over all states: expanded ones (the figures), the
        // next level's (not expanded yet) and the stashed ones.
        let mut most: Vec<u64> = self.stats.place_max.iter().map(|&v| u64::from(v)).collect();
        let mut m = self.layout.base.clone();
        let mut fold = |m: &[u32]| {
            for (n, &v) in most.iter_mut().zip(m) {
                *n = (*n).max(u64::from(v));
            }
        };
        for part in &old {
            for rec in part.next.chunks_exact(ko.0 + e) {
                self.layout.decode(&rec[..ko.0], &mut m);
                fold(&m);
            }
        }
        for sm in self.ctl.stash.chunks_exact(p.max(1)) {
            fold(sm);
        }
        let new = self.layout.widen(&most);
        let kn = Dyn(new.words);
        let total: usize = old.iter().map(|o| o.table.len()).sum();
        let cap = (total + self.ctl.stash.len() / p.max(1)) / SHARDS * 4 / 3;
        // Each thread rebuilds the new shards it owns, reading every old state in numbering
        // order and keeping those that hash to its shards.
        let n = self.threads.min(SHARDS);
        let (marks_ref, layout, newl) = (&self.ctl.marks, &self.layout, &new);
        let rebuilt: Vec<Vec<(usize, Part, Vec<u32>)>> = std::thread::scope(|sc| {
            let old = &old;
            let handles: Vec<_> = (0..n)
                .map(|me| {
                    sc.spawn(move || {
                        let mine: Vec<usize> = (me..SHARDS).step_by(n).collect();
                        let mut fresh: Vec<Part> = mine
                            .iter()
                            .map(|_| Part {
                                table: Shard::new(kn.0, cap),
                                cur: Vec::new(),
                                next: Vec::new(),
                            })
                            .collect();
                        let mut marks: Vec<Vec<u32>> = Vec::with_capacity(marks_ref.len());
                        let mut m = layout.base.clone();
                        let mut key = vec![0u64; kn.0];
                        let mut keys: Vec<u64> = Vec::new();
                        let mut batch: Vec<(usize, u64)> = Vec::new();
                        let last = marks_ref.len() - 1;
                        for l in 0..=last {
                            marks.push(fresh.iter().map(|s| s.table.len() as u32).collect());
                            for (g, part) in old.iter().enumerate() {
                                let lo = marks_ref[l][g] as usize;
                                let hi = match marks_ref.get(l + 1) {
                                    Some(next) => next[g] as usize,
                                    None => part.table.len(),
                                };
                                // In batches, touching old keys and new slots first so
                                // that the cache misses overlap.
                                for b0 in (lo..hi).step_by(REBUILD_BATCH) {
                                    let b1 = (b0 + REBUILD_BATCH).min(hi);
                                    let mut sink = 0u64;
                                    for i in b0..b1 {
                                        sink ^= part.table.key(ko, i)[0];
                                    }
                                    batch.clear();
                                    for i in b0..b1 {
                                        layout.decode(part.table.key(ko, i), &mut m);
                                        newl.encode(&m, &mut key);
                                        let h = hash(&key);
                                        let g2 = shard_of(h);
                                        if g2 % n == me {
                                            sink ^= fresh[g2 / n].table.touch(kn, h);
                                            batch.push((i, h));
                                            keys.extend_from_slice(&key);
                                        }
                                    }
                                    std::hint::black_box(sink);
                                    for (x, &(i, h)) in batch.iter().enumerate() {
                                        let key = &keys[x * kn.0..(x + 1) * kn.0];
                                        let dst = &mut fresh[shard_of(h) / n];
                                        dst.table.insert(kn, key, h);
                                        if l == last {
                                            // The next level's frontier: keep its enabled
                                            // sets.
                                            let j = (i - lo) * (ko.0 + e) + ko.0;
                                            dst.next.extend_from_slice(key);
                                            dst.next.extend_from_slice(&part.next[j..j + e]);
                                        }
                                    }
                                    keys.clear();
                                }
                            }
                        }
                        mine.into_iter()
                            .zip(fresh)
                            .enumerate()
                            .map(|(x, (g, part))| {
                                (g, part, marks.iter().map(|lens| lens[x]).collect())
                            })
                            .collect()
                    })
                })
                .collect();
            handles
                .into_iter()
                .map(|h| h.join().expect("widening thread panicked"))
                .collect()
        });
        let mut slots: Vec<Option<Part>> = (0..SHARDS).map(|_| None).collect();
        let mut marks = vec![vec![0u32; SHARDS]; self.ctl.marks.len()];
        for (g, part, lens) in rebuilt.into_iter().flatten() {
            for (l, len) in lens.into_iter().enumerate() {
                marks[l][g] = len;
            }
            slots[g] = Some(part);
        }
        let mut fresh: Vec<Part> = slots
            .into_iter()
            .map(|p| p.expect("every shard rebuilt"))
            .collect();
        let mut rec = vec![0u64; kn.0 + e];
        drop(old);
        for sm in self.ctl.stash.chunks_exact(p.max(1)) {
            new.encode(sm, &mut rec[..kn.0]);
            self.rules.enabled_set(sm, &mut rec[kn.0..]);
            let h = hash(&rec[..kn.0]);
            let dst = &mut fresh[shard_of(h)];
            if dst.table.insert(kn, &rec[..kn.0], h) {
                dst.next.extend_from_slice(&rec);
            }
        }
        self.ctl.stash.clear();
        self.ctl.stash_seen.clear();
        self.ctl.marks = marks;
        self.deltas = deltas(&self.rules.net, &new);
        self.layout = new;
        self.parts = fresh.into_iter().map(RwLock::new).collect();
    }

    /// One run: threads expand levels until the end, a stop, or a widening.
    fn run<S: Stride>(&mut self, s: S) -> Result<Exit, ReachError> {
        let n = self.threads;
        let t = self.rules.transitions();
        let e = self.ewords;
        let shared = Shared {
            rules: &self.rules,
            layout: &self.layout,
            deltas: &self.deltas,
            ewords: e,
            parts: &self.parts,
            threads: n,
            out: (0..n * n).map(|_| Mutex::new(Vec::new())).collect(),
            stash: (0..n).map(|_| Mutex::new(Vec::new())).collect(),
            barrier: Barrier::new(n),
            plan: Mutex::new(Plan::Exit),
            edges: AtomicU64::new(self.stats.edges),
            failed: AtomicBool::new(false),
        };
        let ctl = &mut self.ctl;
        let limits = (self.opts, self.cancel);
        let started = self.started;
        let (exit, workers) = std::thread::scope(|sc| {
            let handles: Vec<_> = (1..n)
                .map(|me| {
                    let shared = &shared;
                    sc.spawn(move || {
                        let mut w = Worker::new(shared.layout, t, e);
                        worker_loop(s, me, shared, &mut w);
                        w
                    })
                })
                .collect();
            let mut w = Worker::new(shared.layout, t, e);
            let exit = leader_loop(s, &shared, ctl, &mut w, limits, started);
            let mut workers = vec![w];
            for h in handles {
                workers.push(h.join().expect("explorer thread panicked"));
            }
            (exit, workers)
        });
        for w in workers {
            if let Some(e) = w.error {
                return Err(e);
            }
            self.stats.merge(w.stats);
        }
        Ok(exit)
    }
}

fn read(s: &RwLock<Part>) -> RwLockReadGuard<'_, Part> {
    s.read().unwrap_or_else(|e| e.into_inner())
}

fn write(s: &RwLock<Part>) -> RwLockWriteGuard<'_, Part> {
    s.write().unwrap_or_else(|e| e.into_inner())
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// Starts expanding level `l`: its states are the `next` records, which become `cur`.
fn begin_level(parts: &[RwLock<Part>], ctl: &mut Ctl, l: usize) -> u64 {
    let mut lens = Vec::with_capacity(SHARDS);
    for p in parts {
        let mut p = write(p);
        let p = &mut *p;
        std::mem::swap(&mut p.cur, &mut p.next);
        p.next.clear();
        lens.push(p.table.len() as u32);
    }
    let last = ctl.marks.last().expect("marks");
    let frontier = lens.iter().zip(last).map(|(a, b)| u64::from(a - b)).sum();
    ctl.marks.push(lens);
    ctl.level = l;
    ctl.pos = 0;
    ctl.frontier = frontier;
    frontier
}

fn worker_loop<S: Stride>(s: S, me: usize, sh: &Shared, w: &mut Worker) {
    loop {
        sh.barrier.wait();
        let plan = lock(&sh.plan).clone();
        let Plan::Round(r) = plan else { break };
        parallel_round(s, me, sh, &r, w);
    }
}

/// Phase 1, barrier, phase 2, barrier: one round on `threads` threads.
fn parallel_round<S: Stride>(s: S, me: usize, sh: &Shared, r: &Round, w: &mut Worker) {
    let n = sh.threads;
    let len = r.end - r.start;
    let (a, b) = (
        r.start + len * me as u64 / n as u64,
        r.start + len * (me as u64 + 1) / n as u64,
    );
    {
        let guards: Vec<_> = sh.parts.iter().map(read).collect();
        let mut outs: Vec<_> = (0..n).map(|d| lock(&sh.out[me * n + d])).collect();
        let before = w.stats.edges;
        expand_range(s, sh, r, a, b, &guards, &mut outs, n, w);
        sh.edges
            .fetch_add(w.stats.edges - before, Ordering::Relaxed);
        lock(&sh.stash[me]).append(&mut w.stash);
    }
    sh.barrier.wait();
    {
        let mut guards: Vec<_> = (me..SHARDS)
            .step_by(n)
            .map(|g| write(&sh.parts[g]))
            .collect();
        for src in 0..n {
            let mut buf = lock(&sh.out[src * n + me]);
            insert_all(s, sh.ewords, &buf, &mut guards, n);
            buf.clear();
        }
    }
    sh.barrier.wait();
}

/// Inserts records into the shards of one owner (`guards[g / n]` is shard `g`); the new ones
/// join the next level's frontier.
fn insert_all<S: Stride>(
    s: S,
    ewords: usize,
    buf: &[u64],
    guards: &mut [RwLockWriteGuard<Part>],
    n: usize,
) {
    let k = s.k();
    for rec in buf.chunks_exact(k + ewords) {
        let key = &rec[..k];
        let h = hash(key);
        let part = &mut *guards[shard_of(h) / n];
        if part.table.insert(s, key, h) {
            part.next.extend_from_slice(rec);
        }
    }
}

/// Expands frontier positions `a..b`: figures into `w.stats`, records not found into
/// `outs[owner]`, successors that do not fit into `w.stash`.
#[allow(clippy::too_many_arguments)]
fn expand_range<S: Stride>(
    s: S,
    sh: &Shared,
    r: &Round,
    a: u64,
    b: u64,
    guards: &[RwLockReadGuard<Part>],
    outs: &mut [impl DerefMut<Target = Vec<u64>>],
    owners: usize,
    w: &mut Worker,
) {
    let k = s.k();
    let e = sh.ewords;
    let rl = k + e;
    let rules = sh.rules;
    let layout = sh.layout;
    let mut pos = a;
    while pos < b {
        let g = r.prefix.partition_point(|&x| x <= pos) - 1;
        let first = (pos - r.prefix[g]) as usize;
        // The rest of this shard's part of the frontier, within the range.
        let run_end = r.prefix[g + 1].min(b);
        let recs = &guards[g].cur[first * rl..(first + (run_end - pos) as usize) * rl];
        let places = layout.base.len();
        let mut slot = 0;
        let mut n_succ = 0;
        for (ri, rec) in recs.chunks_exact(rl).enumerate() {
            let (cur, en) = rec.split_at(k);
            let m = &mut w.ms[slot * places..(slot + 1) * places];
            layout.decode(cur, m);
            let mut sum = 0u64;
            for (mx, &v) in w.stats.place_max.iter_mut().zip(m.iter()) {
                *mx = (*mx).max(v);
                sum += u64::from(v);
            }
            w.stats.marking_max = w.stats.marking_max.max(sum);
            let mut degree = 0u64;
            for (word, &bits) in en.iter().enumerate() {
                let mut bits = bits;
                while bits != 0 {
                    let t = word * 64 + bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    degree += 1;
                    w.stats.fired[t] = true;
                    if !rules.fits(t, m, layout) {
                        match rules.fire_decoded(t, m) {
                            Ok(next) => w.stash.extend_from_slice(&next),
                            Err(err) => {
                                sh.failed.store(true, Ordering::Relaxed);
                                w.error.get_or_insert(err);
                            }
                        }
                        continue;
                    }
                    let d = &sh.deltas[t * k..t * k + k];
                    let dst = &mut w.succ[n_succ * k..n_succ * k + k];
                    for j in 0..k {
                        dst[j] = cur[j].wrapping_add(d[j]);
                    }
                    w.hashes[n_succ] = hash(dst);
                    w.fired[n_succ] = t as u32;
                    w.parent[n_succ] = slot as u8;
                    n_succ += 1;
                }
            }
            w.stats.edges += degree;
            if degree == 0 {
                w.stats.deadlocks += 1;
                let lvl = r.level;
                match &mut w.stats.first_deadlocks {
                    Some((l, list)) if *l == lvl => list.push(m.to_vec()),
                    Some((l, _)) if *l < lvl => {}
                    slot => *slot = Some((lvl, vec![m.to_vec()])),
                }
            }
            w.slot_rec[slot] = ri;
            slot += 1;
            if slot == BATCH || n_succ >= PENDING {
                finish(s, sh, guards, outs, owners, w, recs, n_succ);
                slot = 0;
                n_succ = 0;
            }
        }
        finish(s, sh, guards, outs, owners, w, recs, n_succ);
        pos = run_end;
    }
}

/// Finishes a batch's look-ups; successors not found go to their owner with their enabled
/// sets, computed from the parent's.
#[allow(clippy::too_many_arguments)]
fn finish<S: Stride>(
    s: S,
    sh: &Shared,
    guards: &[RwLockReadGuard<Part>],
    outs: &mut [impl DerefMut<Target = Vec<u64>>],
    owners: usize,
    w: &mut Worker,
    recs: &[u64],
    n_succ: usize,
) {
    let k = s.k();
    let rl = k + sh.ewords;
    let places = sh.layout.base.len();
    // Start every look-up's cache miss before waiting on the first: a tight loop of loads,
    // so that many are in flight at once.
    let mut sink = 0u64;
    for &h in &w.hashes[..n_succ] {
        sink ^= guards[shard_of(h)].table.touch(s, h);
    }
    std::hint::black_box(sink);
    for j in 0..n_succ {
        let h = w.hashes[j];
        let g = shard_of(h);
        let succ = &w.succ[j * k..j * k + k];
        if guards[g].table.find(s, succ, h).is_none() {
            let slot = w.parent[j] as usize;
            let ri = w.slot_rec[slot];
            let en = &recs[ri * rl + k..(ri + 1) * rl];
            let m = &mut w.ms[slot * places..(slot + 1) * places];
            sh.rules
                .successor_set(w.fired[j] as usize, m, en, &mut w.en);
            let out = &mut outs[g % owners];
            out.extend_from_slice(succ);
            out.extend_from_slice(&w.en);
        }
    }
}

fn leader_loop<S: Stride>(
    s: S,
    sh: &Shared,
    ctl: &mut Ctl,
    w: &mut Worker,
    limits: (&ExploreOptions, Option<&AtomicBool>),
    started: Instant,
) -> Exit {
    let exit = loop {
        match next_step(s, sh, ctl, w, limits, started) {
            Ok(r) => {
                *lock(&sh.plan) = Plan::Round(r.clone());
                sh.barrier.wait();
                parallel_round(s, 0, sh, &r, w);
                ctl.pos = r.end;
                for src in 0..sh.threads {
                    let part = std::mem::take(&mut *lock(&sh.stash[src]));
                    add_stash(ctl, sh.layout.base.len(), &part);
                }
            }
            Err(exit) => break exit,
        }
    };
    *lock(&sh.plan) = Plan::Exit;
    sh.barrier.wait();
    exit
}

fn add_stash(ctl: &mut Ctl, p: usize, part: &[u32]) {
    // A net without places has one marking, which never needs a wider layout: nothing is
    // stashed then, and `max(1)` only spares `chunks_exact` a zero size (here and in
    // `widen`).
    for m in part.chunks_exact(p.max(1)) {
        if ctl.stash_seen.insert(m.to_vec()) {
            ctl.stash.extend_from_slice(m);
        }
    }
}

/// Decides what comes next; runs small rounds on the spot. `Err` ends the run.
fn next_step<S: Stride>(
    s: S,
    sh: &Shared,
    ctl: &mut Ctl,
    w: &mut Worker,
    (opts, cancel): (&ExploreOptions, Option<&AtomicBool>),
    started: Instant,
) -> Result<Round, Exit> {
    loop {
        if sh.failed.load(Ordering::Relaxed) || w.error.is_some() {
            return Err(Exit::Stopped);
        }
        if ctl.pos == ctl.frontier {
            if !ctl.stash.is_empty() {
                return Err(Exit::Widen);
            }
            let has_next = sh.parts.iter().any(|p| !read(p).next.is_empty());
            if !has_next {
                return Err(Exit::Done);
            }
            begin_level(sh.parts, ctl, ctl.level + 1);
        }
        let states: u64 = sh.parts.iter().map(|x| read(x).table.len() as u64).sum();
        let reserve = CHUNK.saturating_mul(sh.rules.transitions() as u64 + 1);
        if states.saturating_add(reserve) >= u64::from(u32::MAX) {
            w.error.get_or_insert(ReachError::TooManyStates);
            return Err(Exit::Stopped);
        }
        let cancelled = opts
            .cancel
            .as_deref()
            .into_iter()
            .chain(cancel)
            .any(|c| c.load(Ordering::Relaxed));
        if cancelled {
            ctl.limit = Some(Limit::Cancelled);
            return Err(Exit::Stopped);
        }
        if let Some(m) = opts.max_states.filter(|&m| states >= m) {
            ctl.limit = Some(Limit::States(m));
            return Err(Exit::Stopped);
        }
        if let Some(m) = opts.max_memory.filter(|&m| memory(sh.parts) as u64 >= m) {
            ctl.limit = Some(Limit::Memory(m));
            return Err(Exit::Stopped);
        }
        if let Some(p) = &opts.progress {
            if ctl.last_progress.elapsed().as_millis() >= 100 {
                ctl.last_progress = Instant::now();
                p(Progress {
                    states,
                    edges: sh.edges.load(Ordering::Relaxed),
                    elapsed: started.elapsed(),
                    bytes: memory(sh.parts) as u64,
                });
            }
        }
        let end = (ctl.pos + CHUNK).min(ctl.frontier);
        let r = round_of(sh, ctl, ctl.pos, end);
        if sh.threads > 1 && end - ctl.pos >= SOLO {
            return Ok(r);
        }
        solo_round(s, sh, &r, w);
        ctl.pos = end;
        let part = std::mem::take(&mut w.stash);
        add_stash(ctl, sh.layout.base.len(), &part);
    }
}

/// Bytes the tables and the frontier hold.
fn memory(parts: &[RwLock<Part>]) -> usize {
    parts
        .iter()
        .map(|p| {
            let p = read(p);
            p.table.bytes() + (p.cur.capacity() + p.next.capacity()) * 8
        })
        .sum()
}

fn round_of(sh: &Shared, ctl: &Ctl, start: u64, end: u64) -> Round {
    let rl = (sh.layout.words + sh.ewords) as u64;
    let mut prefix = Vec::with_capacity(SHARDS + 1);
    let mut acc = 0u64;
    prefix.push(0);
    for p in sh.parts {
        acc += read(p).cur.len() as u64 / rl;
        prefix.push(acc);
    }
    debug_assert_eq!(acc, ctl.frontier);
    Round {
        level: ctl.level,
        start,
        end,
        prefix,
    }
}

/// A whole round on the leader, the others waiting.
fn solo_round<S: Stride>(s: S, sh: &Shared, r: &Round, w: &mut Worker) {
    let mut buf = Vec::new();
    {
        let guards: Vec<_> = sh.parts.iter().map(read).collect();
        let before = w.stats.edges;
        expand_range(s, sh, r, r.start, r.end, &guards, &mut [&mut buf], 1, w);
        sh.edges
            .fetch_add(w.stats.edges - before, Ordering::Relaxed);
    }
    let mut guards: Vec<_> = sh.parts.iter().map(write).collect();
    insert_all(s, sh.ewords, &buf, &mut guards, 1);
}

#[cfg(test)]
mod tests;
