//! Exact satisfiability of guards over input signals, with a witness: can these input values
//! make a transition's guard (and the arcs from its input places) TRUE?
//!
//! # Why a finite search is exact
//!
//! Boolean signals take 0 or 1. Integer signals range over all of `i64`, but a guard only
//! compares operands (a signal or a literal) with `=`, `<>`, `<`, `<=`, `>`, `>=`, and reads a
//! signal as a boolean as `s <> 0`. So whether an assignment satisfies the guard depends only
//! on how each integer signal is ordered against the literals and against the signals it is
//! compared with.
//!
//! Group the signals into *components*: two signals are in one component when some atom
//! compares them with each other. Per component let L be the literals of the atoms that
//! mention one of its signals, plus 0 (for `s <> 0`), plus 0 and 1 when it has a boolean
//! signal (whose values are then "literals" too). L cuts the integers into the points of L
//! and the open gaps between them (and below and above them). Take any satisfying
//! assignment v, let k be the number of integer signals of the component and, in a gap
//! (a, b), let d ≤ k be the number of distinct values v gives the component's integer
//! signals there. Replace the i-th smallest of those values (i = 1…d) by a + i, or by
//! b − d − 1 + i in the unbounded gap below the smallest literal b. These fit in the gap
//! (d distinct integers lie strictly between a and b, so a + d < b), the map is strictly
//! increasing inside each gap and leaves points of L alone, so every comparison between two
//! of the component's signals and between a signal and a literal of L keeps its value, and
//! every atom of the guard is one of those (or compares two literals). The new assignment
//! satisfies the guard as well. Hence it is enough to try, per integer signal, the points
//! of L and the k integers just above each point (and just below the smallest): the
//! literals ±1 when nothing compares the signal with another signal.
//!
//! The search assigns the signals one at a time, candidates closest to 0 first, and
//! evaluates the guard in three-valued logic after each assignment to cut off branches that
//! are already FALSE (or already TRUE). Boolean guard satisfiability is SAT, so the worst
//! case is exponential in the number of signals; guards of controllers read few.

use petriplc_net::guard::{CmpOp, Expr, Operand};
use petriplc_net::{Net, SignalId, SignalType, TransitionId};

/// An assignment of the signals `expr` reads that makes it TRUE, sorted by signal, or `None`
/// when no assignment does. Booleans are 0 or 1; integers any `i64`.
pub fn satisfiable(expr: &Expr<SignalId>, net: &Net) -> Option<Vec<(SignalId, i64)>> {
    let mut signals = Vec::new();
    expr.visit_signals(&mut |s| signals.push(*s));
    signals.sort_unstable();
    signals.dedup();
    let local = |s: &SignalId| {
        signals
            .binary_search(s)
            .expect("every signal of the expression was collected")
    };
    let n = signals.len();
    let is_bool: Vec<bool> = signals
        .iter()
        .map(|&s| net.signal(s).ty == SignalType::Bool)
        .collect();

    // Components of "is compared with", and the literals that touch each signal.
    let mut parent: Vec<usize> = (0..n).collect();
    let mut literals: Vec<Vec<i64>> = vec![vec![0]; n];
    atoms(expr, &mut |a, b| match (a, b) {
        (Operand::Signal(x), Operand::Signal(y)) => {
            let (x, y) = (find(&mut parent, local(x)), find(&mut parent, local(y)));
            parent[x] = y;
        }
        (Operand::Signal(x), Operand::Literal(l)) | (Operand::Literal(l), Operand::Signal(x)) => {
            literals[local(x)].push(*l);
        }
        (Operand::Literal(_), Operand::Literal(_)) => {}
    });
    let mut component_literals: Vec<Vec<i64>> = vec![Vec::new(); n];
    let mut ints_in: Vec<usize> = vec![0; n];
    for i in 0..n {
        let r = find(&mut parent, i);
        component_literals[r].extend_from_slice(&literals[i]);
        if is_bool[i] {
            component_literals[r].extend([0, 1]);
        } else {
            ints_in[r] += 1;
        }
    }

    let candidates: Vec<Vec<i64>> = (0..n)
        .map(|i| {
            if is_bool[i] {
                return vec![0, 1];
            }
            let r = find(&mut parent, i);
            let mut l = component_literals[r].clone();
            l.sort_unstable();
            l.dedup();
            representatives(&l, ints_in[r])
        })
        .collect();

    let mut values: Vec<Option<i64>> = vec![None; n];
    search(expr, &local, &candidates, &mut values, 0).then(|| {
        signals
            .iter()
            .zip(&values)
            // A branch may end TRUE before every signal is set: any value then does.
            .map(|(&s, v)| (s, v.unwrap_or(0)))
            .collect()
    })
}

/// The points of `l` (sorted, not empty) and up to `k` integers just above each and just
/// below the first, sorted by distance from 0 (then negative first).
fn representatives(l: &[i64], k: usize) -> Vec<i64> {
    let mut out = l.to_vec();
    for (i, &a) in l.iter().enumerate() {
        let next = l.get(i + 1).copied();
        let mut x = a;
        for _ in 0..k {
            match x.checked_add(1) {
                Some(y) if next.is_none_or(|b| y < b) => {
                    out.push(y);
                    x = y;
                }
                _ => break,
            }
        }
    }
    let mut x = l[0];
    for _ in 0..k {
        match x.checked_sub(1) {
            Some(y) => {
                out.push(y);
                x = y;
            }
            None => break,
        }
    }
    out.sort_unstable_by_key(|&v| (v.unsigned_abs(), v));
    out.dedup();
    out
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// Calls `f` with the operands of every comparison; `s` alone counts as `s <> 0`.
fn atoms(e: &Expr<SignalId>, f: &mut impl FnMut(&Operand<SignalId>, &Operand<SignalId>)) {
    match e {
        Expr::Const(_) => {}
        Expr::Signal(s) => f(&Operand::Signal(*s), &Operand::Literal(0)),
        Expr::Not(a) => atoms(a, f),
        Expr::And(a, b) | Expr::Xor(a, b) | Expr::Or(a, b) => {
            atoms(a, f);
            atoms(b, f);
        }
        Expr::Cmp(a, _, b) => f(a, b),
    }
}

/// Depth-first search over the candidates of signals `i..`.
fn search(
    expr: &Expr<SignalId>,
    local: &impl Fn(&SignalId) -> usize,
    candidates: &[Vec<i64>],
    values: &mut [Option<i64>],
    i: usize,
) -> bool {
    match eval3(expr, &|s| values[local(s)]) {
        Some(result) => return result,
        None if i == values.len() => unreachable!("a full assignment decides the guard"),
        None => {}
    }
    for &v in &candidates[i] {
        values[i] = Some(v);
        if search(expr, local, candidates, values, i + 1) {
            return true;
        }
    }
    values[i] = None;
    false
}

/// Kleene's three-valued evaluation: `None` when the value depends on unassigned signals.
fn eval3(e: &Expr<SignalId>, value: &impl Fn(&SignalId) -> Option<i64>) -> Option<bool> {
    match e {
        Expr::Const(b) => Some(*b),
        Expr::Signal(s) => value(s).map(|v| v != 0),
        Expr::Not(a) => eval3(a, value).map(|b| !b),
        Expr::And(a, b) => match (eval3(a, value), eval3(b, value)) {
            (Some(false), _) | (_, Some(false)) => Some(false),
            (Some(true), Some(true)) => Some(true),
            _ => None,
        },
        Expr::Or(a, b) => match (eval3(a, value), eval3(b, value)) {
            (Some(true), _) | (_, Some(true)) => Some(true),
            (Some(false), Some(false)) => Some(false),
            _ => None,
        },
        Expr::Xor(a, b) => Some(eval3(a, value)? != eval3(b, value)?),
        Expr::Cmp(a, op, b) => {
            let get = |o: &Operand<SignalId>| match o {
                Operand::Signal(s) => value(s),
                Operand::Literal(v) => Some(*v),
            };
            Some(op.apply(get(a)?, get(b)?))
        }
    }
}

/// The condition on the input signals under which transition `t` may fire as far as inputs
/// go: its guard, and each read or inhibitor arc from an input place, with the place holding
/// its signal clamped to [0, capacity] (S1). For weight w ≥ 1 and capacity c,
/// clamp(v) ≥ w holds iff w ≤ c and v ≥ w, and clamp(v) < w iff w > c or v < w.
pub fn input_condition(net: &Net, t: TransitionId) -> Expr<SignalId> {
    let arcs = net.arcs_of(t);
    let mut conds = Vec::new();
    for (list, read) in [(&arcs.read, true), (&arcs.inhibit, false)] {
        for &(p, w) in list {
            let Some(s) = net.place(p).input else {
                continue;
            };
            let fits = w <= net.capacity(p);
            conds.push(match (read, fits) {
                (true, false) => Expr::Const(false),
                (false, false) => Expr::Const(true),
                (true, true) => cmp(s, CmpOp::Ge, w),
                (false, true) => cmp(s, CmpOp::Lt, w),
            });
        }
    }
    conds
        .into_iter()
        .fold(net.transition(t).guard.0.clone(), and)
}

fn cmp(s: SignalId, op: CmpOp, w: u32) -> Expr<SignalId> {
    Expr::Cmp(Operand::Signal(s), op, Operand::Literal(i64::from(w)))
}

/// `a AND b`, leaving out a constant TRUE.
pub(crate) fn and(a: Expr<SignalId>, b: Expr<SignalId>) -> Expr<SignalId> {
    match (a, b) {
        (Expr::Const(true), x) | (x, Expr::Const(true)) => x,
        (a, b) => Expr::And(Box::new(a), Box::new(b)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testnet::net;
    use petriplc_net::guard::parse;

    /// Decides `guard` in a net with int inputs `x`, `y`, bool inputs `b`, `c`; renders the
    /// witness as `x=4 b=1` or `unsat`, and checks that the witness makes it TRUE.
    fn check(guard: &str, expect: &str) {
        let net = net("int x
             int y
             place p
             trans t: p -> p if x = y OR b OR c");
        let expr = parse(guard)
            .unwrap()
            .try_map(&mut |n: &String| net.signal_by_name(n).ok_or(()))
            .unwrap();
        let got = match satisfiable(&expr, &net) {
            None => "unsat".to_string(),
            Some(w) => {
                let mut values = vec![0; net.signals().len()];
                for &(s, v) in &w {
                    values[s.index()] = v;
                }
                assert!(
                    expr.eval(&|s: &SignalId| values[s.index()]),
                    "{guard}: witness {w:?} does not satisfy it"
                );
                w.iter()
                    .map(|&(s, v)| format!("{}={v}", net.signal(s).name))
                    .collect::<Vec<_>>()
                    .join(" ")
            }
        };
        assert_eq!(got, expect, "{guard}");
    }

    #[test]
    fn integer_intervals() {
        check("x > 3 AND x < 4", "unsat");
        check("x > 3 AND x < 5", "x=4");
        check("x >= 3 AND x <= 3", "x=3");
        check("x <> 0 AND x <> 1 AND x <> -1", "x=-2");
        check("x > 9223372036854775806", "x=9223372036854775807");
        check("x > 9223372036854775807", "unsat");
        check("x < -9223372036854775808", "unsat");
        check("NOT (x < 5) AND NOT (x > 5)", "x=5");
    }

    #[test]
    fn booleans() {
        check("b AND NOT b", "unsat");
        check("b AND c", "b=1 c=1");
        check("b XOR c", "b=0 c=1");
        check("(b XOR c) AND (b = c)", "unsat");
        check("b > 0 AND b < 1", "unsat");
        check("b = 2", "unsat");
        check("TRUE", "");
        check("FALSE", "unsat");
        check("1 < 2 AND b", "b=1");
    }

    #[test]
    fn signal_against_signal() {
        check("x = y AND x > y", "unsat");
        check("x < y AND y < x", "unsat");
        check("x > 3 AND y > 3 AND x <> y", "x=4 y=5");
        // Two distinct integers strictly between 3 and 5 do not exist.
        check("x > 3 AND x < 5 AND y > 3 AND y < 5 AND x <> y", "unsat");
        check("x > 3 AND x < 6 AND y > 3 AND y < 6 AND x <> y", "x=4 y=5");
        check("x < 0 AND y < x", "x=-1 y=-2");
        // A boolean compared with an integer takes part in the ordering.
        check("x > b AND x < 1", "unsat");
        check("x > b AND x < 2", "x=1 b=0");
        check("x > b AND x < 2 AND b", "unsat");
        check("x > b AND b", "x=2 b=1");
    }

    #[test]
    fn xor_of_comparisons() {
        check("(x > 2) XOR (x > 5)", "x=3");
        check("(x > 2) XOR (x > 5) XOR (x < 0)", "x=-1");
    }

    /// Renders `input_condition` of each transition.
    fn check_condition(text: &str, expect: &[&str]) {
        let net = net(text);
        let got: Vec<String> = net
            .transition_ids()
            .map(|t| {
                let e = input_condition(&net, t);
                let w = satisfiable(&e, &net).map_or("unsat".to_string(), |w| {
                    w.iter()
                        .map(|&(s, v)| format!("{}={v}", net.signal(s).name))
                        .collect::<Vec<_>>()
                        .join(" ")
                });
                format!(
                    "{}: {} → {w}",
                    net.transition_label(t),
                    e.to_iec(&|s: &SignalId| net.signal(*s).name.clone())
                )
            })
            .collect();
        assert_eq!(got, expect);
    }

    #[test]
    fn input_place_arcs_are_clamped_conditions() {
        check_condition(
            "int Level
             place lvl in=Level cap=5
             place go in=Go
             place p 1
             trans fill: p -> p ! lvl*3 if Level >= 0
             trans high: p -> p ? lvl*5
             trans never: p -> p ? lvl*6
             trans always: p -> p ! lvl*6 ? go if NOT Go2
             trans clash: p -> p ? go if NOT Go",
            &[
                "fill: Level >= 0 AND Level < 3 → Level=0",
                "high: Level >= 5 → Level=5",
                "never: FALSE → unsat",
                "always: NOT Go2 AND Go >= 1 → Go=1 Go2=0",
                "clash: NOT Go AND Go >= 1 → unsat",
            ],
        );
    }
}
