//! Property tests: `explore` against a brute-force breadth-first search written here over
//! `Net::is_enabled`/`Net::fire`, on small random nets with every arc kind, weights,
//! capacities and input places; and `coverability` against `explore` on nets built to be
//! bounded or unbounded.

use std::collections::{HashSet, VecDeque};

use petriplc_net::{ArcKind, ArcSpec, Marking, Net, NetBuilder, PlaceSpec, TransitionSpec};
use petriplc_reach::{coverability, explore, properties, ExploreOptions, StateId};
use proptest::prelude::*;

/// A place: initial tokens, capacity, whether it is an input place.
type PlaceGen = (u32, Option<u32>, bool);
/// An arc: place index, transition index, kind (0 consume, 1 produce, 2 read, 3 inhibit),
/// weight.
type ArcGen = (usize, usize, u8, u32);

fn build(places: &[PlaceGen], transitions: usize, arcs: &[ArcGen]) -> Option<Net> {
    let mut b = NetBuilder::new("net", "net");
    for (i, &(initial, capacity, input)) in places.iter().enumerate() {
        b.place(PlaceSpec {
            id: format!("p{i}"),
            name: format!("p{i}"),
            initial: if input { 0 } else { initial },
            capacity: capacity.map(|c| c.max(initial).max(1)).filter(|_| !input),
            input: input.then(|| format!("IN{i}")),
            ..Default::default()
        });
    }
    for t in 0..transitions {
        b.transition(TransitionSpec {
            id: format!("t{t}"),
            name: format!("t{t}"),
            guard: petriplc_net::guard::parse("").ok()?,
        });
    }
    for (n, &(p, t, kind, weight)) in arcs.iter().enumerate() {
        let (p, t) = (p % places.len(), t % transitions);
        let input = places[p].2;
        let (kind, out) = match kind {
            // Input places take read and inhibitor arcs only.
            0 | 1 if input => (ArcKind::Read, false),
            0 => (ArcKind::Normal, false),
            1 => (ArcKind::Normal, true),
            2 => (ArcKind::Read, false),
            _ => (ArcKind::Inhibitor, false),
        };
        let (source, target) = if out {
            (format!("t{t}"), format!("p{p}"))
        } else {
            (format!("p{p}"), format!("t{t}"))
        };
        b.arc(ArcSpec {
            id: format!("a{n}"),
            source,
            target,
            kind,
            weight,
            delay: None,
        });
    }
    b.build().ok()
}

/// Breadth-first search over the net's own rule: states, edges, deadlocks, max tokens; `None`
/// past `cap` states.
fn brute_force(net: &Net, cap: usize) -> Option<(u64, u64, u64, u64, u64)> {
    let m0 = net.initial_marking();
    let mut seen: HashSet<Marking> = HashSet::from([m0.clone()]);
    let mut queue = VecDeque::from([m0]);
    let (mut edges, mut deadlocks, mut max_place, mut max_sum) = (0u64, 0u64, 0u64, 0u64);
    while let Some(m) = queue.pop_front() {
        max_place = max_place.max(m.0.iter().copied().max().unwrap_or(0).into());
        max_sum = max_sum.max(m.0.iter().map(|&v| u64::from(v)).sum());
        let mut enabled = 0;
        for t in net.transition_ids() {
            if net.is_enabled(&m, t) {
                enabled += 1;
                let mut next = m.clone();
                net.fire(&mut next, t).ok()?;
                if seen.insert(next.clone()) {
                    if seen.len() > cap {
                        return None;
                    }
                    queue.push_back(next);
                }
            }
        }
        edges += enabled;
        deadlocks += u64::from(enabled == 0);
    }
    Some((seen.len() as u64, edges, deadlocks, max_place, max_sum))
}

fn places() -> impl Strategy<Value = Vec<PlaceGen>> {
    prop::collection::vec(
        (
            0u32..3,
            prop::option::weighted(0.3, 1u32..4),
            prop::bool::weighted(0.15),
        ),
        1..6,
    )
}

fn arcs() -> impl Strategy<Value = Vec<ArcGen>> {
    prop::collection::vec((0usize..6, 0usize..5, 0u8..4, 1u32..3), 0..14)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn explore_matches_brute_force(places in places(), transitions in 1usize..5, arcs in arcs(), threads in 1usize..3) {
        let Some(net) = build(&places, transitions, &arcs) else {
            return Ok(());
        };
        let opts = ExploreOptions { threads, keep_graph: true, max_states: Some(5_000), ..Default::default() };
        match brute_force(&net, 3_000) {
            Some((states, edges, deadlocks, max_place, max_sum)) => {
                let space = explore(&net, &opts).unwrap();
                let p = properties(&net, &space);
                prop_assert!(p.complete);
                prop_assert_eq!(p.states, states);
                prop_assert_eq!(p.edges, edges);
                prop_assert_eq!(p.deadlock, deadlocks > 0);
                prop_assert_eq!(p.max_tokens_place, max_place);
                prop_assert_eq!(p.max_tokens_marking, max_sum);
                // Liveness, reversibility and home markings against the kept graph's
                // components, by plain reachability.
                let n = space.states() as usize;
                let succ: Vec<Vec<usize>> = (0..n)
                    .map(|s| space.successors(StateId(s as u32)).map(|(_, d)| d.index()).collect())
                    .collect();
                let reach_from = |s: usize| {
                    let mut seen = vec![false; n];
                    let mut todo = vec![s];
                    seen[s] = true;
                    while let Some(v) = todo.pop() {
                        for &w in &succ[v] {
                            if !seen[w] {
                                seen[w] = true;
                                todo.push(w);
                            }
                        }
                    }
                    seen
                };
                let all: Vec<Vec<bool>> = (0..n).map(reach_from).collect();
                let reversible = (0..n).all(|s| all[s][0]);
                // A home marking: one every state can reach.
                let home = (0..n).any(|h| (0..n).all(|s| all[s][h]));
                // Live: from every state, every transition fires somewhere reachable.
                let live = (0..n).all(|s| {
                    net.transition_ids().all(|t| (0..n).any(|r| all[s][r] && space.successors(StateId(r as u32)).any(|(u, _)| u == t)))
                });
                prop_assert_eq!(p.reversible, Some(reversible));
                prop_assert_eq!(p.home_marking, Some(home));
                prop_assert_eq!(p.live, Some(live));
                // Every edge of the kept graph is a firing.
                for (s, m) in space.iter_markings() {
                    for (t, d) in space.successors(s) {
                        let mut next = m.clone();
                        prop_assert!(net.is_enabled(&m, t));
                        net.fire(&mut next, t).unwrap();
                        prop_assert_eq!(space.marking(d), next);
                    }
                }
                if let Some(trace) = p.deadlock_trace {
                    let mut m = net.initial_marking();
                    for t in trace {
                        prop_assert!(net.is_enabled(&m, t));
                        net.fire(&mut m, t).unwrap();
                    }
                    prop_assert!(net.transition_ids().all(|t| !net.is_enabled(&m, t)));
                }
            }
            None => {
                // Too big for the reference, or unbounded: explore must stop at its limit.
                if let Ok(space) = explore(&net, &opts) {
                    prop_assert!(!space.complete() || space.states() > 3_000);
                }
            }
        }
    }

}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn coverability_agrees_with_exploration(
        tokens in prop::collection::vec(0u32..3, 2..6),
        moves in prop::collection::vec((0usize..6, 0usize..6, 1u32..3), 1..6),
        pump in any::<bool>(),
    ) {
        // Conservative moves (w tokens from one place to another) keep the net bounded; a pump
        // (a transition that only adds tokens) makes its output place unbounded.
        let places: Vec<PlaceGen> = tokens.iter().map(|&t| (t, None, false)).collect();
        let n = places.len();
        let mut arcs: Vec<ArcGen> = Vec::new();
        for (t, &(from, to, w)) in moves.iter().enumerate() {
            arcs.push((from % n, t, 0, w));
            arcs.push((to % n, t, 1, w));
        }
        let mut transitions = moves.len();
        if pump {
            arcs.push((0, transitions, 2, 1));
            arcs.push((n - 1, transitions, 1, 1));
            transitions += 1;
        }
        let Some(net) = build(&places, transitions, &arcs) else {
            return Ok(());
        };
        let c = coverability(&net, 10_000, None);
        prop_assert!(c.complete);
        let opts = ExploreOptions { max_states: Some(20_000), ..Default::default() };
        let explored = explore(&net, &opts).ok().filter(|s| s.complete());
        // Bounded iff the exploration completes (a pump only pumps once place 0 is marked).
        prop_assert_eq!(c.bounded, explored.is_some());
        if let Some(space) = explored {
            let p = properties(&net, &space);
            let exact: Vec<Option<u64>> = p.place_bounds.iter().map(|&b| Some(b)).collect();
            prop_assert!(c.bounds_exact);
            prop_assert_eq!(c.place_bounds, exact);
        } else {
            prop_assert!(c.unbounded_places.iter().any(|p| p.index() == n - 1));
        }
    }
}
