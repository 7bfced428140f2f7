//! Conflicts between transitions (seed 002: "the tool notifies the user of the existence of
//! conflicts"): structural ones, read off the arcs, and effective ones, seen in reachable
//! markings with guards and input arcs that can hold together.

use std::borrow::Borrow;

use petriplc_net::{Marking, Net, PlaceId, SignalId, TransitionId};

use crate::satisfy::{and, input_condition, satisfiable};

/// Two transitions that take tokens from the same place.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructuralConflict {
    /// The one with priority (lower index).
    pub a: TransitionId,
    pub b: TransitionId,
    /// The places both consume from, in order.
    pub places: Vec<PlaceId>,
}

/// Transitions `a` and `b` sharing an input place by normal arcs, `a` < `b`, in order of
/// (a, b). Read arcs take no tokens, so a place one of them only reads is not shared;
/// inhibitor arcs neither. (A transition that reads a place another consumes can still be
/// disabled by it; that one-sided case is not reported.)
pub fn structural_conflicts(net: &Net) -> Vec<StructuralConflict> {
    // Per place, its consumers in priority order.
    let mut consumers: Vec<Vec<TransitionId>> = vec![Vec::new(); net.places().len()];
    for t in net.transition_ids() {
        for &(p, _) in &net.arcs_of(t).consume {
            consumers[p.index()].push(t);
        }
    }
    let mut pairs: Vec<(TransitionId, TransitionId, PlaceId)> = Vec::new();
    for (p, ts) in consumers.iter().enumerate() {
        for (i, &a) in ts.iter().enumerate() {
            for &b in &ts[i + 1..] {
                pairs.push((a, b, PlaceId::from(p)));
            }
        }
    }
    pairs.sort_unstable();
    let mut out: Vec<StructuralConflict> = Vec::new();
    for (a, b, p) in pairs {
        match out.last_mut() {
            Some(c) if c.a == a && c.b == b => c.places.push(p),
            _ => out.push(StructuralConflict {
                a,
                b,
                places: vec![p],
            }),
        }
    }
    out
}

/// A conflict that happens: in `witness_marking` both transitions are enabled, but some
/// shared places hold too few tokens for both, and the inputs `witness_inputs` make both
/// guards (and their input-place arcs) TRUE.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EffectiveConflict {
    pub a: TransitionId,
    pub b: TransitionId,
    /// The shared places that cannot serve both in the witness marking.
    pub places: Vec<PlaceId>,
    pub witness_marking: Marking,
    /// A value for every signal the two conditions read, by signal.
    pub witness_inputs: Vec<(SignalId, i64)>,
    /// The one the priority rule lets fire: the lower index, `a`. Under `maximal-step` it
    /// takes the tokens first and the other sees what is left (S3); under `sequential` it
    /// fires first (S4).
    pub winner: TransitionId,
}

/// The structural conflicts that are effective in one of `markings` (reachable markings,
/// from whichever exploration the caller ran) under the PLC semantics: both transitions are
/// enabled there ([`Net::is_enabled`]: arcs and capacities), the places they both consume
/// from do not hold enough for both (W(p,a) + W(p,b) > M(p) for some of them), and some input
/// values make both guards TRUE and their read and inhibitor arcs on input places hold
/// ([`input_condition`], decided exactly by [`satisfiable`]).
///
/// One conflict per pair, with the first witness marking in iteration order, in order of
/// (a, b). Stops reading `markings` once every candidate pair is found. A caller with many
/// markings in memory can test them in parallel with [`ConflictCheck`] instead.
pub fn effective_conflicts<M: Borrow<Marking>>(
    net: &Net,
    markings: impl IntoIterator<Item = M>,
) -> Vec<EffectiveConflict> {
    let check = ConflictCheck::new(net);
    let mut witnesses: Vec<Option<Marking>> = vec![None; check.len()];
    let mut left = check.len();
    let mut hits = Vec::new();
    for m in markings {
        if left == 0 {
            break;
        }
        let m: &Marking = m.borrow();
        check.effective_in(m, |i| witnesses[i].is_none(), |i| hits.push(i));
        for i in hits.drain(..) {
            witnesses[i] = Some(m.clone());
            left -= 1;
        }
    }
    check.conflicts(witnesses)
}

/// The structural conflicts that can be effective, prepared once (guards and input arcs
/// decided, the tokens each shared place must hold for both) so that each marking costs a
/// few comparisons: [`effective_conflicts`] one marking at a time, or a caller's own parallel
/// sweep that keeps, per candidate, its first witness.
pub struct ConflictCheck {
    candidates: Vec<Candidate>,
}

struct Candidate {
    conflict: StructuralConflict,
    /// Tokens each shared place must hold for both: W(p,a) + W(p,b).
    need: Vec<u64>,
    inputs: Vec<(SignalId, i64)>,
    /// Both enabled, as bounds on single places (`None`: never both).
    both: Option<Vec<(PlaceId, u64, u64)>>,
}

impl Candidate {
    /// The shared places that hold too few tokens in `m` for both transitions.
    fn short<'a>(&'a self, m: &'a Marking) -> impl Iterator<Item = PlaceId> + 'a {
        self.conflict
            .places
            .iter()
            .zip(&self.need)
            .filter(|&(&p, &need)| u64::from(m[p]) < need)
            .map(|(&p, _)| p)
    }
}

impl ConflictCheck {
    pub fn new(net: &Net) -> ConflictCheck {
        let candidates = structural_conflicts(net)
            .into_iter()
            .filter_map(|c| {
                let both = and(input_condition(net, c.a), input_condition(net, c.b));
                let inputs = satisfiable(&both, net)?;
                let (wa, wb) = (net.arcs_of(c.a), net.arcs_of(c.b));
                let need = c
                    .places
                    .iter()
                    .map(|&p| u64::from(wa.consumed_from(p)) + u64::from(wb.consumed_from(p)))
                    .collect();
                let both = match (net.enabling_bounds(c.a), net.enabling_bounds(c.b)) {
                    (Some(x), Some(y)) => Some(x.into_iter().chain(y).collect()),
                    _ => None,
                };
                Some(Candidate {
                    conflict: c,
                    need,
                    inputs,
                    both,
                })
            })
            .collect();
        ConflictCheck { candidates }
    }

    /// Number of candidate pairs.
    pub fn len(&self) -> usize {
        self.candidates.len()
    }

    pub fn is_empty(&self) -> bool {
        self.candidates.is_empty()
    }

    /// Calls `hit(i)` for every candidate `i` with `open(i)` that is effective in `m`.
    pub fn effective_in(
        &self,
        m: &Marking,
        open: impl Fn(usize) -> bool,
        mut hit: impl FnMut(usize),
    ) {
        for (i, c) in self.candidates.iter().enumerate() {
            if !open(i) {
                continue;
            }
            let lacking = c.short(m).next().is_some();
            let enabled = |bs: &[(PlaceId, u64, u64)]| {
                bs.iter()
                    .all(|&(p, lo, hi)| (lo..=hi).contains(&u64::from(m[p])))
            };
            if lacking && c.both.as_deref().is_some_and(enabled) {
                hit(i);
            }
        }
    }

    /// The effective conflicts, given each candidate's witness marking (`None`: never
    /// effective), in order of (a, b).
    pub fn conflicts(self, witnesses: Vec<Option<Marking>>) -> Vec<EffectiveConflict> {
        let mut found: Vec<EffectiveConflict> = self
            .candidates
            .into_iter()
            .zip(witnesses)
            .filter_map(|(c, m)| {
                let m = m?;
                let short = c.short(&m).collect();
                Some(EffectiveConflict {
                    a: c.conflict.a,
                    b: c.conflict.b,
                    places: short,
                    witness_marking: m,
                    witness_inputs: c.inputs,
                    winner: c.conflict.a,
                })
            })
            .collect();
        found.sort_by_key(|c| (c.a, c.b));
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testnet::{net, reachable};

    /// Renders the structural conflicts, then the effective ones over every reachable
    /// marking (interleaving), with witness marking (marked places) and inputs.
    fn check(text: &str, expect: &[&str]) {
        let net = net(text);
        let names = |ps: &[PlaceId]| {
            ps.iter()
                .map(|&p| net.place_label(p))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let mut got: Vec<String> = structural_conflicts(&net)
            .iter()
            .map(|c| {
                format!(
                    "structural {} {}: {}",
                    net.transition_label(c.a),
                    net.transition_label(c.b),
                    names(&c.places)
                )
            })
            .collect();
        let markings = reachable(&net);
        for c in effective_conflicts(&net, markings.iter()) {
            let marked: Vec<String> = net
                .place_ids()
                .filter(|&p| c.witness_marking[p] > 0)
                .map(|p| format!("{}={}", net.place_label(p), c.witness_marking[p]))
                .collect();
            let inputs: Vec<String> = c
                .witness_inputs
                .iter()
                .map(|&(s, v)| format!("{}={v}", net.signal(s).name))
                .collect();
            assert_eq!(c.winner, c.a);
            got.push(format!(
                "effective {} {} on {} at [{}] inputs [{}] winner {}",
                net.transition_label(c.a),
                net.transition_label(c.b),
                names(&c.places),
                marked.join(" "),
                inputs.join(" "),
                net.transition_label(c.winner)
            ));
        }
        assert_eq!(got, expect);
    }

    #[test]
    fn a_free_choice_is_a_conflict_unless_the_guards_exclude_each_other() {
        check(
            "int Level
             place p 1
             place a
             place b
             place c
             trans left: p -> a if Level > 3
             trans right: p -> b if Level < 5
             trans never: p -> c if Level < 2 AND Level > 1",
            &[
                "structural left right: p",
                "structural left never: p",
                "structural right never: p",
                "effective left right on p at [p=1] inputs [Level=4] winner left",
            ],
        );
    }

    #[test]
    fn enough_tokens_for_both_is_no_conflict() {
        // With 2 tokens both fire; the conflict shows only once one token is left.
        check(
            "place p 2
             place a
             trans t1: p -> a
             trans t2: p -> a
             trans t3: p*2 -> a",
            &[
                "structural t1 t2: p",
                "structural t1 t3: p",
                "structural t2 t3: p",
                "effective t1 t2 on p at [p=1 a=1] inputs [] winner t1",
                "effective t1 t3 on p at [p=2] inputs [] winner t1",
                "effective t2 t3 on p at [p=2] inputs [] winner t2",
            ],
        );
    }

    #[test]
    fn read_arcs_do_not_conflict_but_input_arcs_constrain() {
        // `look` only reads p. `stop` and `go` read the same button with opposite arcs,
        // so they are never enabled together; `go` and `also` are.
        check(
            "place p 1
             place q 1
             place btn in=Button
             place a
             trans look: q -> a ? p
             trans go: p -> a ? btn
             trans stop: p -> a ! btn
             trans also: p -> a if Button",
            &[
                "structural go stop: p",
                "structural go also: p",
                "structural stop also: p",
                "effective go also on p at [p=1 q=1] inputs [Button=1] winner go",
            ],
        );
    }

    #[test]
    fn unreached_markings_show_no_effective_conflict() {
        // t1 and t2 share p, but p and r are never marked together.
        check(
            "place p 1
             place r
             place a
             trans t1: p -> r
             trans t2: p r -> a",
            &["structural t1 t2: p"],
        );
    }
}
