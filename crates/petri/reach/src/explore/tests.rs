//! Unit tests of `explore.rs`.

use std::sync::Arc;

use super::*;
use crate::testnet::parse;
use crate::{explore, properties};
use petriplc_net::{Marking, TransitionId};

/// `back_intervals` against its definition, for every marking in a box: `y` passes for
/// `t` exactly when `x = y - C(·, t)` is within the fields and enables `t`.
#[test]
fn back_intervals_are_the_predecessor_rule() {
    let nets = [
        "a=2 b c ; t: a*2 -> b ; u: b -> a c ; v: c -> c*2",
        "a=1 b<2 c ; t: a -> b ; u: b ?c -> a ; v: !c*2 a -> c",
        "a=1 b c? ; t: a ?c -> b ; u: b !c -> a ; v: a !b -> a b",
        "a=3 b<3 c<1 ; t: a*2 -> b*3 ; u: b -> c ; v: c b*2 -> a ; w: a -> a",
    ];
    for text in nets {
        let net = parse(text);
        let rules = Rules::new(&net);
        let layout = Layout::new(&net);
        let back = rules.back_intervals(&layout);
        let n = net.places().len();
        let max: Vec<u32> = layout.fields.iter().map(|f| f.max).collect();
        let mut y = vec![0u32; n];
        loop {
            for (t, b) in back.iter().enumerate() {
                let tid = TransitionId(t as u32);
                let x: Option<Vec<u32>> = net
                    .place_ids()
                    .map(|p| {
                        let v = i64::from(y[p.index()]) - net.incidence(p, tid);
                        (0..=i64::from(max[p.index()]))
                            .contains(&v)
                            .then_some(v as u32)
                    })
                    .collect();
                let expect = x.is_some_and(|x| rules.enabled(t, &x));
                let got = b.as_ref().is_some_and(|b| {
                    b.iter()
                        .all(|&(p, lo, hi)| (lo..=hi).contains(&y[p as usize]))
                });
                assert_eq!(got, expect, "{text}: y {y:?} t {t}");
            }
            // Next marking of the box 0..=top per place: every stored marking fits the
            // fields (up to 6 tokens where a field is wide).
            let mut i = 0;
            while i < n {
                y[i] += 1;
                if y[i] <= max[i].min(6) {
                    break;
                }
                y[i] = 0;
                i += 1;
            }
            if i == n {
                break;
            }
        }
    }
}

/// `n` independent copies of a two-place counter with `k` tokens: (k+1)^n states, levels
/// wide enough for parallel rounds, fields that must widen.
fn counters(n: usize, k: u32) -> String {
    let places: Vec<String> = (0..n).map(|i| format!("a{i}={k} b{i}")).collect();
    let trs: Vec<String> = (0..n)
        .map(|i| format!("t{i}: a{i} -> b{i} ; u{i}: b{i} -> a{i}"))
        .collect();
    format!("{} ; {}", places.join(" "), trs.join(" ; "))
}

/// Explores with each thread count and renders the figures, checking that states, their
/// numbering and the graph do not depend on the thread count.
fn check(net_text: &str, opts: ExploreOptions, expect: &str) {
    let net = parse(net_text);
    type Graph = Vec<Vec<(TransitionId, crate::StateId)>>;
    let mut seen: Option<(Vec<Marking>, Graph)> = None;
    let mut got = String::new();
    for threads in [1, 2, 3] {
        let o = ExploreOptions {
            threads,
            keep_graph: true,
            ..opts.clone()
        };
        let space = explore(&net, &o).unwrap();
        let marks: Vec<Marking> = space.iter_markings().map(|(_, m)| m).collect();
        let edges = space
            .iter_markings()
            .map(|(s, _)| space.successors(s).collect())
            .collect();
        let p = properties(&net, &space);
        let text = format!(
            "states {} edges {} complete {} expanded {} levels {} max {}/{} deadlocks {}",
            p.states,
            p.edges,
            p.complete,
            space.expanded(),
            space.levels(),
            p.max_tokens_place,
            p.max_tokens_marking,
            p.deadlock
        );
        match &seen {
            None => {
                seen = Some((marks, edges));
                got = text;
            }
            Some((m, e)) => {
                assert_eq!(&marks, m, "numbering differs with {threads} threads");
                assert_eq!(&edges, e, "graph differs with {threads} threads");
                assert_eq!(text, got, "figures differ with {threads} threads");
            }
        }
    }
    assert_eq!(got, expect);
}

#[test]
fn same_states_and_numbering_for_any_thread_count() {
    check(
        &counters(7, 3),
        ExploreOptions::default(),
        "states 16384 edges 172032 complete true expanded 16384 levels 22 max 3/21 deadlocks false",
    );
}

#[test]
fn max_states_stops_cleanly_between_rounds() {
    check(
        &counters(7, 3),
        ExploreOptions {
            max_states: Some(2000),
            ..Default::default()
        },
        "states 2592 edges 14616 complete false expanded 1464 levels 8 max 3/21 deadlocks false",
    );
}

#[test]
fn cancel_stops_at_once() {
    let net = parse(&counters(7, 3));
    let opts = ExploreOptions {
        cancel: Some(Arc::new(AtomicBool::new(true))),
        ..Default::default()
    };
    let space = explore(&net, &opts).unwrap();
    assert!(!space.complete());
    assert_eq!((space.states(), space.expanded()), (1, 0));
}

#[test]
fn progress_reports_growing_counts() {
    let net = parse(&counters(7, 3));
    let calls = Arc::new(Mutex::new(Vec::new()));
    let log = calls.clone();
    let opts = ExploreOptions {
        progress: Some(Arc::new(move |p: Progress| lock(&log).push(p.states))),
        ..Default::default()
    };
    explore(&net, &opts).unwrap();
    let calls = lock(&calls);
    assert!(calls.windows(2).all(|w| w[0] <= w[1]));
}

#[test]
fn token_overflow_is_an_error() {
    let net = parse("a=1 b ; t: a -> a b*2000000000");
    let err = explore(&net, &ExploreOptions::default()).err();
    assert!(
        matches!(err, Some(ReachError::TokenOverflow { ref place }) if place == "b"),
        "{err:?}"
    );
}
