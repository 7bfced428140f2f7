//! Minimal semi-positive P- and T-invariants (semiflows) by the Farkas algorithm with
//! Martinez–Silva minimal-support pruning, and what follows from them: conservation laws,
//! the places they cover and structural bounds.
//!
//! A P-invariant is y ≥ 0, y ≠ 0 with yᵀC = 0: the weighted token count y·M is the same in
//! every reachable marking. A T-invariant is x ≥ 0, x ≠ 0 with Cx = 0: a firing count vector
//! that leads back to the marking it started from. C is [`Net::incidence`]: read and
//! inhibitor arcs count 0 and capacities are left out, since they only ever stop a firing and
//! never change what a firing does.
//!
//! # The algorithm
//!
//! The semiflows form the pointed cone K = {y ≥ 0 : yᵀC = 0}. Its extreme rays are exactly
//! its elements of minimal support, each unique up to a positive factor, and every semiflow
//! is a non-negative combination of them; those rays, scaled to integers with gcd 1, are the
//! "minimal semi-positive invariants" returned here.
//!
//! Farkas' algorithm starts from the identity (the rays of y ≥ 0) and adds the constraints
//! yᵀC(·, j) = 0 one column j at a time: a row that is 0 in column j stays; each pair of a
//! positive and a negative row is combined to cancel column j. Keeping only rows of minimal
//! support after every step (Martinez & Silva, 1982) keeps exactly the extreme rays of the
//! intermediate cone, so rows do not multiply needlessly. The pruning is done before a
//! combination is built, as the double-description method's combinatorial adjacency test:
//! the combination of p and n (support supp(p) ∪ supp(n), as all weights are positive) is
//! an extreme ray of the new cone iff no other current row has its support inside
//! supp(p) ∪ supp(n). A cheaper necessary condition comes first: the vectors supported in
//! the support S of an extreme ray form a line, so |S| ≤ 1 + the number of constraints that
//! cut that space. A column that was 0 or of one sign on every row when it was eliminated
//! cuts nothing there (a point of the cone positive on S can move a little in any direction
//! within that space and stay in the cone before the column, on which the column is ≥ 0; so
//! the column is 0 on the whole space), hence only the columns that had both signs count.
//!
//! Columns of one sign go first (they only remove rows), then the one that adds the fewest
//! rows (|pos|·|neg| − |pos| − |neg|, the usual heuristic), the lowest index on ties, so
//! results are deterministic. Columns that are 0 or a multiple of an earlier one constrain
//! nothing new and are dropped at the start.
//!
//! # Limits
//!
//! The number of minimal invariants can grow exponentially with the net, so the computation
//! stops cleanly at [`Limits`]: a cap on the rows held at once and on the work done (support
//! comparisons and combinations, a deterministic stand-in for time). Arithmetic is exact:
//! combinations are computed in `i128` (a product of two `i64` cannot overflow it), divided
//! by their gcd and stored as `i64`; a weight that does not fit stops the computation too.
//! A stopped computation still returns the rows that already satisfy every constraint: each
//! is an extreme ray of a cone that contains K and lies in K, hence one of K's, so what is
//! listed is correct and minimal, only perhaps not everything ([`Invariants::complete`]).

use std::collections::HashSet;
use std::fmt::Write as _;

use petriplc_net::{Net, PlaceId, TransitionId};

/// Bounds on one invariant computation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limits {
    /// The most rows (candidate invariants) held at once.
    pub max_rows: usize,
    /// The most elementary steps (support comparisons and row combinations).
    pub max_work: u64,
}

impl Limits {
    /// For a cheap first pass, such as bounds for a state-space encoding: at most about
    /// 0.1 s in release mode on the MCC models. What it finds is still correct and minimal,
    /// so the bounds it gives hold even when it is incomplete.
    pub const QUICK: Limits = Limits {
        max_rows: 20_000,
        max_work: 20_000_000,
    };
}

impl Default for Limits {
    /// 100 000 rows and 10⁹ steps: a few seconds in release mode at worst.
    fn default() -> Self {
        Limits {
            max_rows: 100_000,
            max_work: 1_000_000_000,
        }
    }
}

/// Minimal semi-positive invariants, each a sparse vector of (index, weight) sorted by index,
/// with weights ≥ 1 and gcd 1; the vectors are sorted lexicographically. Indices are
/// [`PlaceId`] indices for P-invariants and [`TransitionId`] indices for T-invariants.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Invariants {
    pub vectors: Vec<Vec<(usize, u64)>>,
    /// False when the computation stopped at a limit: every vector listed is a minimal
    /// invariant, but there may be more.
    pub complete: bool,
    /// Why the computation stopped, when it did.
    pub reason: Option<String>,
}

/// Why a Farkas computation stopped before the end.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
enum Stop {
    #[error("stopped at {limit} intermediate rows after eliminating {done} of {total} distinct {what} of the incidence matrix; the invariants listed are minimal, but there may be more (raise the row limit)")]
    TooManyRows {
        limit: usize,
        done: usize,
        total: usize,
        what: &'static str,
    },
    #[error("stopped after {limit} steps after eliminating {done} of {total} distinct {what} of the incidence matrix; the invariants listed are minimal, but there may be more (raise the work limit)")]
    TooMuchWork {
        limit: u64,
        done: usize,
        total: usize,
        what: &'static str,
    },
    #[error("stopped after eliminating {done} of {total} distinct {what} of the incidence matrix: a weight does not fit in 64 bits; the invariants listed are minimal, but there may be more")]
    Overflow {
        done: usize,
        total: usize,
        what: &'static str,
    },
}

/// Minimal semi-positive P-invariants: y ≥ 0 with yᵀC = 0.
///
/// Input places are left out: their marking follows the input signal every scan (S1), not
/// the incidence matrix, so no conservation law holds for them under the PLC semantics.
pub fn p_invariants(net: &Net, limits: Limits) -> Invariants {
    let vars: Vec<PlaceId> = net
        .place_ids()
        .filter(|&p| net.place(p).input.is_none())
        .collect();
    let mut var_of = vec![None; net.places().len()];
    for (i, p) in vars.iter().enumerate() {
        var_of[p.index()] = Some(i);
    }
    let mut rows = vec![Vec::new(); vars.len()];
    for t in net.transition_ids() {
        for (p, v) in column(net, t) {
            // An input place has no normal arcs, so no entry in C.
            if let Some(i) = var_of[p.index()] {
                rows[i].push((t.0, v));
            }
        }
    }
    let mut inv = semiflows(rows, net.transitions().len(), limits, "transition columns");
    for v in &mut inv.vectors {
        for (i, _) in v.iter_mut() {
            *i = vars[*i].index();
        }
    }
    inv.vectors.sort();
    inv
}

/// Minimal semi-positive T-invariants: x ≥ 0 with Cx = 0.
pub fn t_invariants(net: &Net, limits: Limits) -> Invariants {
    let rows = net
        .transition_ids()
        .map(|t| column(net, t).into_iter().map(|(p, v)| (p.0, v)).collect())
        .collect();
    let mut inv = semiflows(rows, net.places().len(), limits, "place rows");
    inv.vectors.sort();
    inv
}

/// Column t of C, sparse and sorted by place.
fn column(net: &Net, t: TransitionId) -> Vec<(PlaceId, i64)> {
    let a = net.arcs_of(t);
    let mut places: Vec<PlaceId> = a.consume.iter().chain(&a.produce).map(|x| x.0).collect();
    places.sort_unstable();
    places.dedup();
    places
        .into_iter()
        .map(|p| (p, net.incidence(p, t)))
        .filter(|&(_, v)| v != 0)
        .collect()
}

/// One row of the Farkas tableau: a combination of the variables (`comb`, all weights > 0)
/// and its value in the constraint columns not yet eliminated (`rest`), both sparse.
#[derive(Clone, Debug)]
struct Row {
    comb: Vec<(u32, i64)>,
    rest: Vec<(u32, i64)>,
    /// The support of `comb` as a bit set.
    support: Vec<u64>,
    /// |support|.
    size: u32,
}

impl Row {
    fn value(&self, col: u32) -> i64 {
        self.rest
            .binary_search_by_key(&col, |x| x.0)
            .map_or(0, |i| self.rest[i].1)
    }
}

fn subset(a: &[u64], b: &[u64]) -> bool {
    a.iter().zip(b).all(|(x, y)| x & !y == 0)
}

/// The minimal semi-positive y with Σ y_i rows[i] = 0, without letting the enumeration's
/// cost grow with the net when the answer is small:
///
/// 1. a basis of the whole kernel {y : Σ y_i rows[i] = 0} by fraction-free integer
///    elimination ([`kernel_basis`]), in time about the size of the basis;
/// 2. variables in no basis vector's support are 0 in every semiflow and are dropped; the
///    rest split into groups whose basis vectors' supports overlap (the kernel is the direct
///    sum of the groups' spans, so the cone of semiflows is the direct sum of the groups'
///    cones);
/// 3. a group spanned by one vector has that vector (with its sign made positive) as its only
///    minimal semiflow when its entries share a sign, and none otherwise; only groups of
///    several vectors need the Farkas enumeration, run on their own variables, within what
///    is left of the work limit.
fn semiflows(
    rows: Vec<Vec<(u32, i64)>>,
    ncols: usize,
    limits: Limits,
    what: &'static str,
) -> Invariants {
    let n = rows.len();
    let (basis, mut work) = match kernel_basis(&rows, ncols, limits, what) {
        Ok(b) => b,
        Err(stop) => {
            return Invariants {
                vectors: Vec::new(),
                complete: false,
                reason: Some(stop.to_string()),
            }
        }
    };
    // Groups of basis vectors whose supports overlap (union-find over variables).
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut x: usize) -> usize {
        while parent[x] != x {
            parent[x] = parent[parent[x]];
            x = parent[x];
        }
        x
    }
    for b in &basis {
        for w in b.windows(2) {
            let (x, y) = (
                root(&mut parent, w[0].0 as usize),
                root(&mut parent, w[1].0 as usize),
            );
            if x != y {
                parent[x.max(y)] = x.min(y);
            }
        }
    }
    let mut groups: Vec<(usize, Vec<usize>)> = Vec::new();
    let mut group_of = vec![usize::MAX; n];
    for (k, b) in basis.iter().enumerate() {
        let r = root(&mut parent, b[0].0 as usize);
        if group_of[r] == usize::MAX {
            group_of[r] = groups.len();
            groups.push((r, Vec::new()));
        }
        groups[group_of[r]].1.push(k);
    }
    let mut vectors = Vec::new();
    let mut reasons = Vec::new();
    for (_, members) in &groups {
        if let [k] = members.as_slice() {
            let b = &basis[*k];
            let sign = b[0].1.signum();
            if b.iter().all(|&(_, v)| v.signum() == sign) {
                vectors.push(
                    b.iter()
                        .map(|&(i, v)| (i as usize, v.unsigned_abs()))
                        .collect(),
                );
            }
            continue;
        }
        // The group's variables, renumbered, with their rows.
        let mut vars: Vec<usize> = members
            .iter()
            .flat_map(|&k| basis[k].iter().map(|&(i, _)| i as usize))
            .collect();
        vars.sort_unstable();
        vars.dedup();
        let sub: Vec<Vec<(u32, i64)>> = vars.iter().map(|&i| rows[i].clone()).collect();
        let left = Limits {
            max_rows: limits.max_rows,
            max_work: limits.max_work.saturating_sub(work),
        };
        let inv = farkas(sub, ncols, left, what);
        work = work.saturating_add(inv_work(&inv));
        for v in inv.vectors {
            vectors.push(v.into_iter().map(|(i, w)| (vars[i], w)).collect());
        }
        if let Some(r) = inv.reason {
            reasons.push(r);
        }
    }
    Invariants {
        vectors,
        complete: reasons.is_empty(),
        reason: (!reasons.is_empty()).then(|| reasons.join("; ")),
    }
}

/// A rough charge for a group's Farkas run against the shared work limit: its answer's size
/// (its own steps are bounded by the limit it was given).
fn inv_work(inv: &Invariants) -> u64 {
    inv.vectors.iter().map(|v| v.len() as u64).sum()
}

/// A sparse integer vector: (index, value) sorted by index, no zeros.
type SparseRow = Vec<(u32, i64)>;

/// A basis of {y ∈ ℤⁿ : Σ y_i rows[i] = 0} (sparse vectors sorted by index, gcd 1), and the
/// work spent. Fraction-free elimination: each constraint column in turn, cheapest first
/// (the rows it touches have the fewest entries), is cancelled from every row that has it by
/// an integer combination with the shortest of them, which then leaves; the rows left at the
/// end are the basis. Choosing the cheapest column keeps fill-in low: on a ring of n places
/// the rows merge pairwise, about n log n steps instead of n².
fn kernel_basis(
    rows: &[Vec<(u32, i64)>],
    ncols: usize,
    limits: Limits,
    what: &'static str,
) -> Result<(Vec<SparseRow>, u64), Stop> {
    use std::cmp::Reverse;
    use std::collections::BinaryHeap;

    struct ERow {
        comb: Vec<(u32, i64)>,
        rest: Vec<(u32, i64)>,
    }
    let len = |r: &ERow| (r.comb.len() + r.rest.len()) as u64;
    let value = |r: &ERow, c: u32| {
        r.rest
            .binary_search_by_key(&c, |x| x.0)
            .map_or(0, |i| r.rest[i].1)
    };
    let mut live: Vec<Option<ERow>> = rows
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let mut rest: Vec<(u32, i64)> = r.iter().copied().filter(|&(_, v)| v != 0).collect();
            rest.sort_unstable();
            Some(ERow {
                comb: vec![(i as u32, 1)],
                rest,
            })
        })
        .collect();
    let mut col_rows: Vec<Vec<u32>> = vec![Vec::new(); ncols];
    for (i, r) in live.iter().enumerate() {
        for &(c, _) in &r.as_ref().expect("every row is live").rest {
            col_rows[c as usize].push(i as u32);
        }
    }
    let mut heap: BinaryHeap<Reverse<(u64, u32)>> = (0..ncols)
        .filter(|&c| !col_rows[c].is_empty())
        .map(|c| Reverse((col_rows[c].len() as u64 * 3, c as u32)))
        .collect();
    let total = heap.len();
    let mut done = vec![false; ncols];
    let mut eliminated = 0;
    let mut work: u64 = 0;
    let mut touching: Vec<u32> = Vec::new();
    while let Some(Reverse((cost, c))) = heap.pop() {
        let cu = c as usize;
        if done[cu] {
            continue;
        }
        // The rows that still have column c (the list is kept lazily).
        touching.clear();
        touching.extend(col_rows[cu].iter().copied().filter(|&r| {
            live[r as usize]
                .as_ref()
                .is_some_and(|row| value(row, c) != 0)
        }));
        touching.sort_unstable();
        touching.dedup();
        let actual: u64 = touching
            .iter()
            .map(|&r| len(live[r as usize].as_ref().expect("live")))
            .sum();
        work += touching.len() as u64 + 1;
        if actual > cost {
            heap.push(Reverse((actual, c)));
            continue;
        }
        done[cu] = true;
        eliminated += 1;
        col_rows[cu] = Vec::new();
        let Some(&pivot) = touching
            .iter()
            .min_by_key(|&&r| (len(live[r as usize].as_ref().expect("live")), r))
        else {
            continue;
        };
        let p = live[pivot as usize].take().expect("live");
        let pv = value(&p, c);
        for &r in &touching {
            if r == pivot {
                continue;
            }
            let row = live[r as usize].as_mut().expect("live");
            let rv = value(row, c);
            let g = gcd(pv.unsigned_abs(), rv.unsigned_abs());
            let (a, b) = (i128::from(pv / g as i64), i128::from(-(rv / g as i64)));
            let overflow = || Stop::Overflow {
                done: eliminated - 1,
                total,
                what,
            };
            let comb = merge(&row.comb, &p.comb, a, b).ok_or_else(overflow)?;
            let rest = merge(&row.rest, &p.rest, a, b).ok_or_else(overflow)?;
            let g = comb
                .iter()
                .fold(0u128, |g, &(_, v)| gcd128(g, v.unsigned_abs()))
                .max(1);
            let shrink = |v: Vec<(u32, i128)>| -> Option<Vec<(u32, i64)>> {
                v.into_iter()
                    .filter(|&(_, v)| v != 0)
                    .map(|(c, v)| i64::try_from(v / g as i128).ok().map(|v| (c, v)))
                    .collect()
            };
            let comb = shrink(comb).ok_or_else(overflow)?;
            let rest = shrink(rest).ok_or_else(overflow)?;
            work += (comb.len() + rest.len()) as u64;
            // Columns the row gained: it joins their lists, and their costs grew.
            for &(col, _) in &rest {
                if value(row, col) == 0 {
                    col_rows[col as usize].push(r);
                }
            }
            row.comb = comb;
            row.rest = rest;
            for &(col, _) in &row.rest {
                let n = col_rows[col as usize].len() as u64;
                heap.push(Reverse((n, col)));
            }
            if work > limits.max_work {
                return Err(Stop::TooMuchWork {
                    limit: limits.max_work,
                    done: eliminated - 1,
                    total,
                    what,
                });
            }
        }
    }
    let basis = live
        .into_iter()
        .flatten()
        .map(|r| {
            debug_assert!(
                r.rest.is_empty(),
                "a basis vector satisfies every constraint"
            );
            r.comb
        })
        .collect();
    Ok((basis, work))
}

/// The Farkas algorithm on `rows[i]` = the constraint coefficients of variable i (sparse,
/// sorted by column, columns < `ncols`). Returns the minimal-support semi-positive vectors y
/// with Σ y_i rows[i] = 0.
fn farkas(
    rows: Vec<Vec<(u32, i64)>>,
    ncols: usize,
    limits: Limits,
    what: &'static str,
) -> Invariants {
    let n = rows.len();
    let words = n.div_ceil(64).max(1);

    // Columns that are 0 or a multiple of an earlier one constrain nothing new.
    let mut cols: Vec<Vec<(usize, i64)>> = vec![Vec::new(); ncols];
    for (i, r) in rows.iter().enumerate() {
        for &(c, v) in r {
            cols[c as usize].push((i, v));
        }
    }
    let mut active: Vec<u32> = Vec::new();
    let mut is_active = vec![false; ncols];
    let mut seen: HashSet<Vec<(usize, i64)>> = HashSet::new();
    for (c, col) in cols.iter().enumerate() {
        if col.is_empty() {
            continue;
        }
        let g = col.iter().fold(0, |g, &(_, v)| gcd(g, v.unsigned_abs()));
        let sign = if col[0].1 < 0 { -1 } else { 1 };
        // g ≤ |v|, so the quotient fits.
        let norm: Vec<(usize, i64)> = col
            .iter()
            .map(|&(i, v)| (i, sign * (i128::from(v) / i128::from(g)) as i64))
            .collect();
        if seen.insert(norm) {
            active.push(c as u32);
            is_active[c] = true;
        }
    }
    let total = active.len();

    let mut current: Vec<Row> = rows
        .into_iter()
        .enumerate()
        .map(|(i, rest)| {
            let mut support = vec![0u64; words];
            support[i / 64] |= 1 << (i % 64);
            Row {
                comb: vec![(i as u32, 1)],
                rest: rest
                    .into_iter()
                    .filter(|&(c, v)| v != 0 && is_active[c as usize])
                    .collect(),
                support,
                size: 1,
            }
        })
        .collect();

    let mut work: u64 = 0;
    let mut done = 0;
    let mut rank: u32 = 0;
    let mut stop = None;
    while !active.is_empty() {
        // One-signed columns first, then the one that adds the fewest rows.
        let mut pos = vec![0i64; ncols];
        let mut neg = vec![0i64; ncols];
        for r in &current {
            for &(c, v) in &r.rest {
                if v > 0 {
                    pos[c as usize] += 1;
                } else {
                    neg[c as usize] += 1;
                }
            }
        }
        let (k, &col) = active
            .iter()
            .enumerate()
            .min_by_key(|&(_, &c)| {
                let (p, q) = (pos[c as usize], neg[c as usize]);
                (p * q != 0, p * q - p - q, c)
            })
            .expect("active is not empty");
        active.swap_remove(k);
        done += 1;

        let mut next: Vec<Row> = Vec::new();
        let (mut plus, mut minus) = (Vec::new(), Vec::new());
        for (i, r) in current.iter().enumerate() {
            match r.value(col) {
                0 => next.push(r.clone()),
                v if v > 0 => plus.push(i),
                _ => minus.push(i),
            }
        }
        // Only a column with both signs can cut the space of vectors supported in a
        // support of the cone (see the module comment).
        if !plus.is_empty() && !minus.is_empty() {
            rank += 1;
        }
        let max_size = rank + 1;
        let mut union = vec![0u64; words];
        'pairs: for &i in &plus {
            for &j in &minus {
                let (p, q) = (&current[i], &current[j]);
                work += 1;
                let mut size = 0;
                for (w, (a, b)) in union.iter_mut().zip(p.support.iter().zip(&q.support)) {
                    *w = a | b;
                    size += w.count_ones();
                }
                if size > max_size {
                    continue;
                }
                // Adjacency: no other row's support lies within the union. Rows are sorted
                // by support size, so the scan ends at the first one larger than the union.
                let mut adjacent = true;
                for (m, r) in current.iter().enumerate() {
                    if r.size > size {
                        break;
                    }
                    if m != i && m != j {
                        work += 1;
                        if subset(&r.support, &union) {
                            adjacent = false;
                            break;
                        }
                    }
                }
                if work > limits.max_work {
                    stop = Some(Stop::TooMuchWork {
                        limit: limits.max_work,
                        done: done - 1,
                        total,
                        what,
                    });
                    break 'pairs;
                }
                if !adjacent {
                    continue;
                }
                match combine(p, q, col, &union, size) {
                    Some(row) => next.push(row),
                    None => {
                        stop = Some(Stop::Overflow {
                            done: done - 1,
                            total,
                            what,
                        });
                        break 'pairs;
                    }
                }
                if next.len() > limits.max_rows {
                    stop = Some(Stop::TooManyRows {
                        limit: limits.max_rows,
                        done: done - 1,
                        total,
                        what,
                    });
                    break 'pairs;
                }
            }
        }
        if stop.is_some() {
            break;
        }
        // Stable, so the order stays deterministic.
        next.sort_by_key(|r| r.size);
        current = next;
    }

    let vectors = current
        .iter()
        .filter(|r| r.rest.is_empty())
        .map(|r| {
            r.comb
                .iter()
                .map(|&(i, v)| (i as usize, v as u64))
                .collect()
        })
        .collect();
    Invariants {
        vectors,
        complete: stop.is_none(),
        reason: stop.map(|s| s.to_string()),
    }
}

/// The row a·p + b·q that cancels column `col` (p positive there, q negative), divided by
/// the gcd of its weights; `None` when a weight does not fit in an `i64`.
fn combine(p: &Row, q: &Row, col: u32, support: &[u64], size: u32) -> Option<Row> {
    let (x, y) = (p.value(col), q.value(col));
    let g = gcd(x.unsigned_abs(), y.unsigned_abs());
    let a = i128::from(-y) / i128::from(g);
    let b = i128::from(x) / i128::from(g);
    let comb = merge(&p.comb, &q.comb, a, b)?;
    let rest = merge(&p.rest, &q.rest, a, b)?;
    // The weights' gcd divides every entry of `rest` too: rest is an integer combination of
    // the weights.
    let g = comb
        .iter()
        .fold(0u128, |g, &(_, v)| gcd128(g, v.unsigned_abs()));
    let shrink = |v: Vec<(u32, i128)>| -> Option<Vec<(u32, i64)>> {
        v.into_iter()
            .map(|(c, v)| i64::try_from(v / g as i128).ok().map(|v| (c, v)))
            .collect()
    };
    Some(Row {
        comb: shrink(comb)?,
        rest: shrink(rest.into_iter().filter(|&(c, _)| c != col).collect())?,
        support: support.to_vec(),
        size,
    })
}

/// a·u + b·v for sparse vectors sorted by index, without zeros; `None` on overflow. With
/// 1 ≤ a, b ≤ 2⁶³ and `i64` entries every product lies in [−2¹²⁶, 2¹²⁶), so only the sum
/// needs checking (and it cannot actually overflow either).
fn merge(u: &[(u32, i64)], v: &[(u32, i64)], a: i128, b: i128) -> Option<Vec<(u32, i128)>> {
    let mut out = Vec::with_capacity(u.len() + v.len());
    let (mut i, mut j) = (0, 0);
    loop {
        let (c, x) = match (u.get(i), v.get(j)) {
            (Some(&(cu, xu)), Some(&(cv, xv))) if cu == cv => {
                i += 1;
                j += 1;
                (cu, (a * i128::from(xu)).checked_add(b * i128::from(xv))?)
            }
            (Some(&(cu, xu)), Some(&(cv, _))) if cu < cv => {
                i += 1;
                (cu, a * i128::from(xu))
            }
            (Some(&(cu, xu)), None) => {
                i += 1;
                (cu, a * i128::from(xu))
            }
            (_, Some(&(cv, xv))) => {
                j += 1;
                (cv, b * i128::from(xv))
            }
            (None, None) => return Some(out),
        };
        if x != 0 {
            out.push((c, x));
        }
    }
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

fn gcd128(mut a: u128, mut b: u128) -> u128 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

/// y·M0 for a P-invariant, exactly.
fn weighted_initial(net: &Net, y: &[(usize, u64)]) -> u128 {
    y.iter()
        .map(|&(p, w)| u128::from(w) * u128::from(net.places()[p].initial))
        .sum()
}

/// Each P-invariant as the conservation law it states, with place labels:
/// `M(idle) + M(busy) + 2·M(pair) = 3` (the constant is y·M0).
pub fn conservation_laws(net: &Net, inv: &Invariants) -> Vec<String> {
    inv.vectors
        .iter()
        .map(|y| {
            let mut s = String::new();
            for (k, &(p, w)) in y.iter().enumerate() {
                if k > 0 {
                    s.push_str(" + ");
                }
                if w != 1 {
                    let _ = write!(s, "{w}·");
                }
                let _ = write!(s, "M({})", net.place_label(PlaceId::from(p)));
            }
            let _ = write!(s, " = {}", weighted_initial(net, y));
            s
        })
        .collect()
}

/// Per place: whether some P-invariant covers it (gives it a positive weight).
pub fn covered_places(net: &Net, inv: &Invariants) -> Vec<bool> {
    let mut covered = vec![false; net.places().len()];
    for y in &inv.vectors {
        for &(p, _) in y {
            covered[p] = true;
        }
    }
    covered
}

/// Whether every place other than an input place is covered by a P-invariant (the net is
/// conservative, which makes it structurally bounded: bounded from any initial marking).
/// With incomplete invariants, `false` means "not shown".
pub fn structurally_bounded(net: &Net, inv: &Invariants) -> bool {
    let covered = covered_places(net, inv);
    net.place_ids()
        .all(|p| covered[p.index()] || net.place(p).input.is_some())
}

/// Per place, an upper bound on its tokens in every reachable marking, or `None` when none
/// is known: the least over the P-invariants y with y_p > 0 of ⌊y·M0 / y_p⌋ (from
/// y_p·M(p) ≤ y·M = y·M0), and the place's capacity ([`Net::bound`], which for an input
/// place is the range of its signal). Never more than `u32::MAX`, the token counter's limit.
///
/// The bounds hold under the PLC scan too: a step of several transitions changes the
/// marking by the sum of their columns of C.
pub fn structural_bounds(net: &Net, inv: &Invariants) -> Vec<Option<u64>> {
    let mut bounds: Vec<Option<u64>> = net
        .place_ids()
        .map(|p| net.bound(p).map(u64::from))
        .collect();
    for y in &inv.vectors {
        let total = weighted_initial(net, y);
        for &(p, w) in y {
            let b = (total / u128::from(w)).min(u128::from(u32::MAX)) as u64;
            bounds[p] = Some(bounds[p].map_or(b, |old| old.min(b)));
        }
    }
    bounds
}

#[cfg(test)]
mod tests;
