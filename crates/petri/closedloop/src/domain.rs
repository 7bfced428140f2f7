//! The input values that matter: an exact reduction of each input's range to a few
//! representatives, and the enumeration of their combinations.
//!
//! # Why the reduction is exact
//!
//! A scan reads its input signals in exactly two ways (docs/semantics.md):
//!
//! - guards (S2): a boolean use `s` (TRUE iff s ≠ 0) and comparisons `s op c`, `c op s`,
//!   `s op r` with a literal `c` or another signal `r`;
//! - input places (S1): the place takes `clamp(s, 0, cap)`, and only read and inhibitor arcs
//!   look at it (E1, E2, and the timers of delayed read arcs, T2): `clamp(s) ≥ w` or
//!   `clamp(s) < w`. For `1 ≤ w ≤ cap` that is `s ≥ w` / `s < w`; for `w > cap` it is a
//!   constant. The input place's own token count is overwritten by S1 at the start of every
//!   scan, so the analysis does not keep it in the state (it is 0 there).
//!
//! Call these the *atoms*. Two input vectors that give every atom the same truth value give the
//! same scan: the same transitions fire in every pass, so the same marking and outputs follow.
//!
//! For an integer signal `s`, let T be the set of thresholds it is compared with: 0 (the
//! boolean use and the clamp), each literal, each weight `w ≤ cap` of an arc on its input place,
//! 0 and 1 for a boolean signal it is compared with, and the value of a signal that is fixed
//! (driven by the plant in a closed loop). An atom `s op c` with `c ∈ T` is constant on each of
//! the pieces (−∞, t₁), {t₁}, (t₁, t₂), …, {tₙ}, (tₙ, ∞). Free integer signals compared with
//! each other form groups (connected components, of size k); inside a group the order between
//! members matters too. The representatives of a group's members are every threshold of the
//! group, and in every open piece its first k integers (all of them when the piece has fewer).
//! Any vector maps to representatives by a map that keeps, for every member, which piece it
//! lies in and the order (and equalities) among members of the same piece — possible because
//! each piece offers k values or all its values — so every atom keeps its truth value. A
//! boolean input takes 0 and 1, its whole range; an input no atom reads takes only 0.

use std::collections::BTreeSet;

use petriplc_net::guard::{Expr, Operand};
use petriplc_net::{Net, SignalDirection, SignalId, SignalType};

use crate::{ClosedLoopError, MAX_INPUT_COMBINATIONS};

/// What the net's atoms say about each of its input signals.
#[derive(Clone, Debug)]
pub(crate) struct Reduction {
    /// Per signal (indexed by [`SignalId`]); meaningful for inputs only.
    info: Vec<Info>,
}

#[derive(Clone, Debug, Default)]
struct Info {
    /// Some atom reads the signal.
    used: bool,
    /// Thresholds from literals and input-place arcs.
    thresholds: BTreeSet<i64>,
    /// Signals it is compared with.
    links: BTreeSet<SignalId>,
}

impl Reduction {
    pub(crate) fn new(net: &Net) -> Self {
        let mut info = vec![Info::default(); net.signals().len()];
        for t in net.transition_ids() {
            collect(&net.transition(t).guard.0, &mut info);
        }
        for p in net.place_ids() {
            let Some(s) = net.place(p).input else {
                continue;
            };
            let cap = net.capacity(p);
            let i = &mut info[s.index()];
            i.used = true;
            i.thresholds.insert(0);
            for t in net.transition_ids() {
                let a = net.arcs_of(t);
                for &(q, w) in a.read.iter().chain(&a.inhibit) {
                    if q == p && w <= cap {
                        i.thresholds.insert(i64::from(w));
                    }
                }
            }
        }
        Reduction { info }
    }

    /// The values that matter for each input of `net` that `fixed` does not fix, in input
    /// declaration order; `fixed` gives the values of inputs driven from elsewhere.
    pub(crate) fn domains(
        &self,
        net: &Net,
        fixed: &dyn Fn(SignalId) -> Option<i64>,
    ) -> Vec<(SignalId, Vec<i64>)> {
        let free: Vec<SignalId> = net.inputs().filter(|&s| fixed(s).is_none()).collect();
        let is_free_int = |s: SignalId| free.contains(&s) && net.signal(s).ty == SignalType::Int;
        let mut out = Vec::with_capacity(free.len());
        for &s in &free {
            let info = &self.info[s.index()];
            let values = if !info.used {
                vec![0]
            } else if net.signal(s).ty == SignalType::Bool {
                vec![0, 1]
            } else {
                // The group: free integer inputs linked to `s` by comparisons.
                let mut group = vec![s];
                let mut i = 0;
                while i < group.len() {
                    for &r in &self.info[group[i].index()].links {
                        if is_free_int(r) && !group.contains(&r) {
                            group.push(r);
                        }
                    }
                    i += 1;
                }
                let mut thresholds = BTreeSet::new();
                for &g in &group {
                    let gi = &self.info[g.index()];
                    thresholds.extend(&gi.thresholds);
                    for &r in &gi.links {
                        if let Some(v) = fixed(r) {
                            thresholds.insert(v);
                        } else if net.signal(r).ty == SignalType::Bool
                            && net.signal(r).direction == SignalDirection::Input
                        {
                            thresholds.extend([0, 1]);
                        }
                    }
                }
                if thresholds.is_empty() {
                    // Only compared with each other: any k distinct values around 0 do.
                    thresholds.insert(0);
                }
                representatives(&thresholds, group.len() as i64)
            };
            out.push((s, values));
        }
        out
    }
}

/// Every threshold, the first `k` integers of every open piece between and around them.
fn representatives(thresholds: &BTreeSet<i64>, k: i64) -> Vec<i64> {
    let mut v: Vec<i64> = thresholds.iter().copied().collect();
    let ts: Vec<i64> = v.clone();
    if let (Some(&lo), Some(&hi)) = (ts.first(), ts.last()) {
        v.extend((1..=k).filter_map(|d| lo.checked_sub(d)));
        v.extend((1..=k).filter_map(|d| hi.checked_add(d)));
    }
    for w in ts.windows(2) {
        let (a, b) = (i128::from(w[0]), i128::from(w[1]));
        let n = (b - a - 1).min(i128::from(k));
        // In range: a < a + d < b for d ≤ n.
        v.extend((1..=n).map(|d| (a + d) as i64));
    }
    // Small magnitudes first, so that witnesses prefer 0, 1, -1, …
    v.sort_by_key(|&x| (x.unsigned_abs(), x < 0));
    v.dedup();
    v
}

fn collect(e: &Expr<SignalId>, info: &mut [Info]) {
    match e {
        Expr::Const(_) => {}
        Expr::Signal(s) => {
            info[s.index()].used = true;
            info[s.index()].thresholds.insert(0);
        }
        Expr::Not(a) => collect(a, info),
        Expr::And(a, b) | Expr::Xor(a, b) | Expr::Or(a, b) => {
            collect(a, info);
            collect(b, info);
        }
        Expr::Cmp(a, _, b) => match (a, b) {
            (Operand::Signal(s), Operand::Literal(c))
            | (Operand::Literal(c), Operand::Signal(s)) => {
                info[s.index()].used = true;
                info[s.index()].thresholds.insert(*c);
            }
            (Operand::Signal(s), Operand::Signal(r)) => {
                info[s.index()].used = true;
                info[r.index()].used = true;
                if s != r {
                    info[s.index()].links.insert(*r);
                    info[r.index()].links.insert(*s);
                }
            }
            (Operand::Literal(_), Operand::Literal(_)) => {}
        },
    }
}

/// The combinations of free input values, numbered in mixed radix: the first input varies
/// slowest, each input's values in the order [`Reduction::domains`] gives them.
#[derive(Clone, Debug)]
pub(crate) struct Combos {
    free: Vec<(SignalId, Vec<i64>)>,
    count: u64,
}

impl Combos {
    /// Checks the number of combinations against [`MAX_INPUT_COMBINATIONS`].
    pub(crate) fn new(
        net: &Net,
        free: Vec<(SignalId, Vec<i64>)>,
    ) -> Result<Combos, ClosedLoopError> {
        let count = free
            .iter()
            .fold(1u64, |n, (_, v)| n.saturating_mul(v.len() as u64));
        if count > MAX_INPUT_COMBINATIONS {
            return Err(ClosedLoopError::TooManyInputCombinations {
                net: net.id.clone(),
                combinations: count,
                limit: MAX_INPUT_COMBINATIONS,
                inputs: free
                    .iter()
                    .map(|(s, v)| (net.signal(*s).name.clone(), v.len() as u64))
                    .collect(),
            });
        }
        Ok(Combos { free, count })
    }

    pub(crate) fn count(&self) -> u64 {
        self.count
    }

    /// The free inputs that take more than one value.
    pub(crate) fn varying(&self) -> impl Iterator<Item = SignalId> + '_ {
        self.free
            .iter()
            .filter(|(_, v)| v.len() > 1)
            .map(|(s, _)| *s)
    }

    /// Writes combination `k` into `signals` (indexed by [`SignalId`]).
    pub(crate) fn write(&self, mut k: u64, signals: &mut [i64]) {
        for (s, values) in self.free.iter().rev() {
            let n = values.len() as u64;
            signals[s.index()] = values[(k % n) as usize];
            k /= n;
        }
    }
}

#[cfg(test)]
mod tests {
    //! Representatives per input, and exactness by brute force on small ranges.

    use super::*;
    use petriplc_testnet::net;

    fn check(text: &str, expect: &str) {
        let n = net(text);
        let r = Reduction::new(&n);
        let got: Vec<String> = r
            .domains(&n, &|_| None)
            .iter()
            .map(|(s, v)| format!("{}={v:?}", n.signal(*s).name))
            .collect();
        assert_eq!(got.join(" "), expect);
    }

    #[test]
    fn booleans_take_both_values_unused_inputs_one() {
        check(
            "s A in bool\ns B in bool\np p 1\nt t p -> p if A",
            "A=[0, 1] B=[0]",
        );
    }

    #[test]
    fn integers_take_thresholds_and_their_neighbours() {
        check("s L in int\np p 1\nt t p -> p if L >= 3", "L=[2, 3, 4]");
        // An input place of capacity 5 with a read arc of weight 2 and an inhibitor of 7
        // (never reached: the clamp stops at 5).
        check(
            "s L in int\np q 0 <L cap=5\np p 1\nt t p ?q*2 !q*7 -> p",
            "L=[0, 1, -1, 2, 3]",
        );
    }

    #[test]
    fn compared_integers_get_room_for_every_order() {
        check(
            "s A in int\ns B in int\np p 1\nt t p -> p if A < B",
            "A=[0, 1, -1, 2, -2] B=[0, 1, -1, 2, -2]",
        );
    }

    /// Brute force: every vector in a small box is matched by a representative vector giving
    /// every transition's guard the same value.
    #[test]
    fn reduction_is_exact_on_a_box() {
        let n = net("s A in int\ns B in int\ns C in bool\np p 1\n\
             t t1 p -> p if A < B AND B <> 2\n\
             t t2 p -> p if A = C OR A > 4\n\
             t t3 p -> p if B >= -1");
        let r = Reduction::new(&n);
        let doms = r.domains(&n, &|_| None);
        let combos = Combos::new(&n, doms).unwrap();
        let guards = |v: &[i64]| -> Vec<bool> {
            n.transition_ids()
                .map(|t| n.transition(t).guard.eval(v))
                .collect()
        };
        let mut reps = BTreeSet::new();
        let mut v = vec![0; 3];
        for k in 0..combos.count() {
            combos.write(k, &mut v);
            reps.insert(guards(&v));
        }
        for a in -8..=8 {
            for b in -8..=8 {
                for c in 0..=1 {
                    assert!(reps.contains(&guards(&[a, b, c])), "A={a} B={b} C={c}");
                }
            }
        }
    }

    #[test]
    fn too_many_combinations_is_a_clear_error() {
        let mut text: String = (0..17).map(|i| format!("s I{i} in bool\n")).collect();
        let all: Vec<String> = (0..17).map(|i| format!("I{i}")).collect();
        text += &format!("p p 1\nt t p -> p if {}", all.join(" AND "));
        let n = net(&text);
        let err = Combos::new(&n, Reduction::new(&n).domains(&n, &|_| None)).unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.starts_with(
                "net `test`: its inputs take 131072 combinations of the values that matter \
                 (I0: 2, I1: 2, "
            ),
            "{msg}"
        );
        assert!(msg.ends_with("more than the 65536 the PLC-scan analysis tries per state; split the net or drive some inputs from a plant"), "{msg}");
    }
}
