//! Behavioural properties of an explored state space, as the Model Checking Contest defines
//! them: bounds, safeness, deadlocks (with a shortest trace), quasi-liveness, and, from the
//! strongly connected components of the graph, liveness, reversibility and home markings.

use std::collections::HashSet;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use petriplc_net::{Net, TransitionId};

use crate::space::StateSpace;

/// What [`properties`] finds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Properties {
    pub states: u64,
    pub edges: u64,
    /// The most tokens any place holds in any state (MAX_TOKEN_IN_PLACE).
    pub max_tokens_place: u64,
    /// The most tokens in one marking (MAX_TOKEN_PER_MARKING).
    pub max_tokens_marking: u64,
    /// The bound of every place, by place index.
    pub place_bounds: Vec<u64>,
    /// Every place bound is at most 1.
    pub safe: bool,
    /// A reachable marking enables no transition.
    pub deadlock: bool,
    /// The lexicographically smallest among the shortest firing sequences from the initial
    /// marking to a deadlock.
    pub deadlock_trace: Option<Vec<TransitionId>>,
    /// Every transition fires in some reachable marking.
    pub quasi_live: bool,
    /// Transitions enabled in no reachable marking, in order.
    pub dead_transitions: Vec<TransitionId>,
    /// From every reachable marking every transition can fire again (L4). `None` when the
    /// exploration is incomplete or [`Properties::unknown`] says why.
    pub live: Option<bool>,
    /// The initial marking is reachable from every reachable marking.
    pub reversible: Option<bool>,
    /// Some marking is reachable from every reachable marking.
    pub home_marking: Option<bool>,
    /// The state space was explored to the end. When false, the figures describe the explored
    /// part: a deadlock found is real, the absence of one proves nothing.
    pub complete: bool,
    /// Why liveness, reversibility and home markings are unknown although the exploration is
    /// complete (a memory budget, an interruption).
    pub unknown: Option<String>,
}

/// How [`properties_with`] may work.
#[derive(Clone, Debug, Default)]
pub struct PropertyOptions {
    /// Threads to use; 0 means one per core.
    pub threads: usize,
    /// Skip liveness, reversibility and home markings (with the reason in
    /// [`Properties::unknown`]) rather than hold more than this many bytes with the states.
    pub max_memory: Option<u64>,
    /// Set to stop early (the same three are then unknown).
    pub cancel: Option<Arc<AtomicBool>>,
}

/// Computes the properties of `space`, the state space of `net`, on all cores and without a
/// memory bound.
pub fn properties(net: &Net, space: &StateSpace) -> Properties {
    properties_with(net, space, &PropertyOptions::default())
}

/// Computes the properties of `space`, the state space of `net`. Liveness, reversibility and
/// home markings come from the graph's strongly connected components, computed from the
/// explored states without storing the graph.
pub fn properties_with(net: &Net, space: &StateSpace, opts: &PropertyOptions) -> Properties {
    assert_eq!(
        net.transitions().len(),
        space.rules.transitions(),
        "space explored from another net"
    );
    let st = &space.stats;
    let place_bounds: Vec<u64> = st.place_max.iter().map(|&v| u64::from(v)).collect();
    let dead_transitions: Vec<TransitionId> = st
        .fired
        .iter()
        .enumerate()
        .filter(|(_, f)| !**f)
        .map(|(t, _)| TransitionId(t as u32))
        .collect();
    let threads = crate::threads(opts.threads);
    let bounds = crate::scc::Bounds {
        threads,
        max_memory: opts.max_memory,
        cancel: opts.cancel.as_deref(),
    };
    let (scc, unknown) = if space.complete() {
        match crate::scc::analyse(space, &bounds) {
            Ok(s) => (Some(s), None),
            Err(why) => (None, Some(why)),
        }
    } else {
        (None, None)
    };
    Properties {
        states: space.states(),
        edges: space.edges(),
        max_tokens_place: place_bounds.iter().copied().max().unwrap_or(0),
        max_tokens_marking: st.marking_max,
        safe: place_bounds.iter().all(|&b| b <= 1),
        place_bounds,
        deadlock: st.deadlocks > 0,
        deadlock_trace: deadlock_trace(space),
        quasi_live: dead_transitions.is_empty(),
        dead_transitions,
        live: scc.as_ref().map(|s| s.live),
        reversible: scc.as_ref().map(|s| s.sccs == 1),
        home_marking: scc.as_ref().map(|s| s.bottoms == 1),
        complete: space.complete(),
        unknown,
    }
}

/// The lexicographically smallest shortest firing sequence to a deadlock. Going back from the
/// deadlocks of the first level that has any, `good[k]` is the set of level-k states with a
/// path of the remaining length to one of them; then the smallest transition into `good[k+1]`
/// is chosen at each step. Independent of the state numbering.
fn deadlock_trace(space: &StateSpace) -> Option<Vec<TransitionId>> {
    let (d, dead) = space.stats.first_deadlocks.as_ref()?;
    let d = *d;
    let lay = &space.layout;
    let k = lay.words;
    let encode = |m: &[u32]| {
        let mut key = vec![0u64; k];
        lay.encode(m, &mut key);
        key
    };
    let mut good: Vec<HashSet<Vec<u64>>> = vec![HashSet::new(); d + 1];
    good[d] = dead.iter().map(|m| encode(m)).collect();
    let rules = &space.rules;
    let mut m = lay.base.clone();
    let mut succ = vec![0u64; k];
    // Successor keys of a state, in transition order.
    let mut step = |key: &[u64], m: &mut Vec<u32>, f: &mut dyn FnMut(usize, &[u64]) -> bool| {
        space.decode(key, m);
        for t in 0..rules.transitions() {
            if rules.enabled(t, m) {
                let dl = &space.deltas[t * k..t * k + k];
                for j in 0..k {
                    succ[j] = key[j].wrapping_add(dl[j]);
                }
                if f(t, &succ) {
                    return;
                }
            }
        }
    };
    for l in (0..d).rev() {
        let (a, b) = space.level_bounds(l);
        let (lower, upper) = good.split_at_mut(l + 1);
        let (here, next) = (&mut lower[l], &upper[0]);
        space.for_range(a, b, |_, key| {
            let mut hit = false;
            step(key, &mut m, &mut |_, s| {
                hit = next.contains(s);
                hit
            });
            if hit {
                here.insert(key.to_vec());
            }
        });
    }
    let mut cur = space.key(0).to_vec();
    let mut trace = Vec::with_capacity(d);
    for next in good.iter().skip(1) {
        let mut chosen = None;
        step(&cur, &mut m, &mut |t, s| {
            if next.contains(s) {
                chosen = Some((t, s.to_vec()));
            }
            chosen.is_some()
        });
        let (t, s) = chosen.expect("a good state has a good successor");
        trace.push(TransitionId(t as u32));
        cur = s;
    }
    Some(trace)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testnet::parse;
    use crate::{explore, ExploreOptions};

    /// Explores a net with its graph and renders every property.
    fn check(net_text: &str, expect: &str) {
        let net = parse(net_text);
        let opts = ExploreOptions {
            keep_graph: true,
            threads: 2,
            ..Default::default()
        };
        let p = properties(&net, &explore(&net, &opts).unwrap());
        let names = |ts: &[TransitionId]| {
            ts.iter()
                .map(|&t| net.transition_label(t))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let got = format!(
            "states {} edges {} max {}/{} bounds {:?} safe {} deadlock {} trace [{}] quasi-live {} dead [{}] live {:?} reversible {:?} home {:?}",
            p.states,
            p.edges,
            p.max_tokens_place,
            p.max_tokens_marking,
            p.place_bounds,
            p.safe,
            p.deadlock,
            p.deadlock_trace.as_deref().map_or(String::from("-"), names),
            p.quasi_live,
            names(&p.dead_transitions),
            p.live,
            p.reversible,
            p.home_marking
        );
        assert_eq!(got, expect);
    }

    #[test]
    fn cycle_is_live_and_reversible() {
        check(
            "a=1 b ; t: a -> b ; u: b -> a",
            "states 2 edges 2 max 1/1 bounds [1, 1] safe true deadlock false trace [-] quasi-live true dead [] live Some(true) reversible Some(true) home Some(true)",
        );
    }

    #[test]
    fn shortest_trace_is_the_lexicographically_smallest() {
        // z is reached by t2 t4 and by t1 t3 t2 t4; a sibling path t5 t6 is as short but
        // larger.
        check(
            "a=1 x y z w ; t1: a -> x ; t2: a -> y ; t3: x -> a ; t4: y -> z ; t5: a -> w ; t6: w -> z",
            "states 5 edges 6 max 1/1 bounds [1, 1, 1, 1, 1] safe true deadlock true trace [t2 t4] quasi-live true dead [] live Some(false) reversible Some(false) home Some(true)",
        );
    }

    #[test]
    fn a_dead_transition_breaks_quasi_liveness_not_reversibility() {
        check(
            "a=1 b ; t: a -> b ; u: b -> a ; v: b b -> a",
            "states 2 edges 2 max 1/1 bounds [1, 1] safe true deadlock false trace [-] quasi-live false dead [v] live Some(false) reversible Some(true) home Some(true)",
        );
    }

    #[test]
    fn two_bottom_components_have_no_home_marking() {
        check(
            "a=1 b c ; t: a -> b ; u: a -> c ; v: b -> b ; w: c -> c",
            "states 3 edges 4 max 1/1 bounds [1, 1, 1] safe true deadlock false trace [-] quasi-live true dead [] live Some(false) reversible Some(false) home Some(false)",
        );
    }

    #[test]
    fn a_transition_that_fires_once_is_not_live() {
        // u fires once and leaves M0 for good; t and v keep firing in the bottom component.
        check(
            "a=1 b c=1 ; t: c -> c ; u: a -> b ; v: b -> b",
            "states 2 edges 4 max 1/2 bounds [1, 1, 1] safe true deadlock false trace [-] quasi-live true dead [] live Some(false) reversible Some(false) home Some(true)",
        );
    }

    #[test]
    fn special_arcs_capacities_and_inputs() {
        // b holds at most 2; u needs c empty; v reads a; i is an input place, so the inhibitor
        // arc from it always holds.
        check(
            "a=3 b<2 c i? ; t: a -> b ; u: b -> c !c !i ; v: c ?a -> a",
            "states 6 edges 8 max 3/3 bounds [3, 2, 1, 0] safe false deadlock true trace [t t u t] quasi-live true dead [] live Some(false) reversible Some(false) home Some(true)",
        );
    }

    #[test]
    fn no_transitions_is_one_deadlock_with_an_empty_trace() {
        check(
            "a=2",
            "states 1 edges 0 max 2/2 bounds [2] safe false deadlock true trace [] quasi-live true dead [] live Some(true) reversible Some(true) home Some(true)",
        );
    }

    #[test]
    fn liveness_needs_no_kept_graph_and_is_unknown_when_incomplete() {
        let net = parse("a=1 b ; t: a -> b ; u: b -> a");
        let p = properties(&net, &explore(&net, &ExploreOptions::default()).unwrap());
        assert_eq!(
            (p.live, p.reversible, p.home_marking),
            (Some(true), Some(true), Some(true))
        );
        assert!(p.complete && !p.deadlock && p.unknown.is_none());
        let net = parse("a=3 b ; t: a -> b ; u: b -> a");
        let opts = ExploreOptions {
            max_states: Some(1),
            ..Default::default()
        };
        let p = properties(&net, &explore(&net, &opts).unwrap());
        assert_eq!((p.live, p.reversible, p.home_marking), (None, None, None));
        assert!(!p.complete);
    }
}
