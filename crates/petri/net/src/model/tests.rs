//! Tests of the model: the firing rule's enabling bounds, building nets and every error
//! the builder reports.

use super::*;
use crate::guard::parse;

/// `enabling_bounds` is `allow` on one marking: every marking of 3 places with 0..=5
/// tokens, for transitions with every arc kind, capacities and a free place.
#[test]
fn enabling_bounds_are_the_firing_rule() {
    let (a, b, c) = (PlaceId(0), PlaceId(1), PlaceId(2));
    let arcs = |consume: &[(PlaceId, u32)],
                produce: &[(PlaceId, u32)],
                read: &[(PlaceId, u32)],
                inhibit: &[(PlaceId, u32)]| TransitionArcs {
        consume: consume.to_vec(),
        produce: produce.to_vec(),
        read: read.to_vec(),
        inhibit: inhibit.to_vec(),
        timed: Vec::new(),
    };
    let cases = [
        arcs(&[(a, 2)], &[(b, 1)], &[], &[]),
        arcs(&[(a, 1)], &[(a, 2), (b, 3)], &[(c, 2)], &[]),
        arcs(&[(b, 1)], &[(c, 1)], &[], &[(a, 3), (c, 2)]),
        arcs(&[], &[(b, 2)], &[(a, 1)], &[(b, 1)]),
        arcs(&[(a, 1), (b, 2)], &[(b, 1)], &[(a, 2)], &[(c, 1)]),
        arcs(&[], &[(c, 4)], &[], &[]),
    ];
    let limits: [fn(PlaceId) -> u64; 3] = [
        |_| u64::MAX,
        |p| if p.0 == 1 { 3 } else { u64::MAX },
        |p| if p.0 == 2 { 2 } else { 4 },
    ];
    let frees: [fn(PlaceId) -> bool; 2] = [|_| false, |p| p.0 == 2];
    for t in &cases {
        for limit in limits {
            for free in frees {
                let bounds = t.enabling_bounds(limit, free);
                for m in 0..6u32.pow(3) {
                    let m = [m % 6, m / 6 % 6, m / 36];
                    let tokens = |p: PlaceId| m[p.index()];
                    let expect = t.allow(tokens, |p| u64::from(tokens(p)), limit, free);
                    let got = bounds.as_ref().is_some_and(|bs| {
                        bs.iter()
                            .all(|&(p, lo, hi)| (lo..=hi).contains(&u64::from(tokens(p))))
                    });
                    assert_eq!(got, expect, "{t:?} m {m:?}");
                }
            }
        }
    }
}

fn place(id: &str, initial: u32) -> PlaceSpec {
    PlaceSpec {
        id: id.into(),
        name: id.into(),
        initial,
        ..Default::default()
    }
}
fn transition(id: &str, guard: &str) -> TransitionSpec {
    TransitionSpec {
        id: id.into(),
        name: id.into(),
        guard: parse(guard).unwrap(),
    }
}
fn arc(id: &str, s: &str, t: &str, w: u32) -> ArcSpec {
    ArcSpec {
        id: id.into(),
        source: s.into(),
        target: t.into(),
        kind: ArcKind::Normal,
        weight: w,
        delay: None,
    }
}

/// Builds a net and renders either its errors or a summary.
fn check(build: impl FnOnce(&mut NetBuilder), expect: &[&str]) {
    let mut b = NetBuilder::new("n", "n");
    build(&mut b);
    let got: Vec<String> = match b.build() {
        Ok(net) => vec![format!(
            "ok: {} places, {} transitions, {} arcs, signals {:?}",
            net.places().len(),
            net.transitions().len(),
            net.arcs().len(),
            net.signals()
                .iter()
                .map(|s| format!("{} {} {}", s.direction, s.ty, s.name))
                .collect::<Vec<_>>()
        )],
        Err(es) => es.iter().map(|e| format!("{}: {e}", e.element())).collect(),
    };
    assert_eq!(got, expect);
}

#[test]
fn builds_and_collects_signals() {
    check(
        |b| {
            b.place(PlaceSpec { output: Some("L1".into()), ..place("p1", 1) });
            b.place(place("p2", 0));
            b.transition(transition("t1", "B1 AND NOT N2"));
            b.arc(arc("a1", "p1", "t1", 1));
            b.arc(arc("a2", "t1", "p2", 2));
        },
        &["ok: 2 places, 1 transitions, 2 arcs, signals [\"output bool L1\", \"input bool B1\", \"input bool N2\"]"],
    );
}

#[test]
fn reports_every_structural_error() {
    check(
        |b| {
            b.place(PlaceSpec { capacity: Some(1), ..place("p1", 2) });
            b.place(place("p1", 0));
            b.place(place("p3", 0));
            b.transition(transition("t1", ""));
            b.arc(arc("a1", "p1", "nowhere", 1));
            b.arc(arc("a2", "p1", "p3", 1));
            b.arc(arc("a3", "t1", "t1", 1));
            b.arc(arc("a4", "p3", "t1", 0));
            b.arc(ArcSpec { kind: ArcKind::Inhibitor, ..arc("a5", "t1", "p3", 1) });
            b.arc(ArcSpec { kind: ArcKind::Inhibitor, delay: Some(Duration::from_secs(1)), ..arc("a6", "p3", "t1", 1) });
        },
        &[
            "p1: id `p1` is used twice; every place, transition and arc needs its own id",
            "p1: place `p1` starts with 2 tokens but its capacity is 1",
            "a1: arc `a1`: its target `nowhere` is not a place or transition of this net",
            "a2: arc `a2` joins two places (`p1` → `p3`); an arc joins a place and a transition",
            "a3: arc `a3` joins two transitions (`t1` → `t1`); an arc joins a place and a transition",
            "a4: arc `a4` has weight 0; weights are whole numbers from 1",
            "a5: arc `a5` goes from a transition to a place but is marked inhibitor; read and inhibitor arcs go from a place to a transition",
            "a6: arc `a6` has a delay but is an inhibitor arc; delays go on normal or read arcs from a place",
        ],
    );
}

#[test]
fn deadlines_are_checked_against_delays() {
    let build = |deadline: u64, delay: u64| {
        move |b: &mut NetBuilder| {
            b.place(place("p", 1));
            let t = b.transition(transition("t", ""));
            b.deadline(t, Duration::from_millis(deadline));
            b.arc(ArcSpec {
                delay: Some(Duration::from_millis(delay)),
                ..arc("a", "p", "t", 1)
            });
        }
    };
    let ok = "ok: 1 places, 1 transitions, 1 arcs, signals []";
    check(build(600, 100), &[ok]);
    check(build(100, 100), &[ok]);
    check(
        build(100, 600),
        &[
            "t: transition `t` has a deadline of T#100ms but its arc `a` waits T#600ms; a \
           transition cannot have to fire before its delays let it (make the deadline at \
           least the longest delay)",
        ],
    );
    check(
        build(0, 0),
        &["t: transition `t` has deadline 0; a deadline is a time greater than 0 (leave it out for none)"],
    );
    let mut b = NetBuilder::new("n", "n");
    build(600, 100)(&mut b);
    let net = b.build().unwrap();
    assert_eq!(
        net.transition(TransitionId(0)).deadline,
        Some(Duration::from_millis(600))
    );
}

#[test]
fn interleaving_abstracts_inputs() {
    let mut b = NetBuilder::new("n", "n");
    b.place(PlaceSpec {
        input: Some("Go".into()),
        ..place("go", 0)
    });
    b.place(PlaceSpec {
        input: Some("Stop".into()),
        ..place("stop", 0)
    });
    b.place(place("a", 1));
    b.transition(transition("t", "Other"));
    b.arc(ArcSpec {
        kind: ArcKind::Read,
        ..arc("r", "go", "t", 1)
    });
    b.arc(ArcSpec {
        kind: ArcKind::Inhibitor,
        ..arc("i", "stop", "t", 1)
    });
    b.arc(arc("x", "a", "t", 1));
    let net = b.build().unwrap();
    let t = TransitionId(0);
    // Whatever the input places hold, their arcs hold; the guard is not looked at.
    for m in [vec![0, 0, 1], vec![1, 1, 1], vec![0, 1, 1]] {
        assert!(net.is_enabled(&Marking(m.clone()), t), "{m:?}");
    }
    assert!(
        !net.is_enabled(&Marking(vec![1, 0, 0]), t),
        "the flow arc still counts"
    );
}

#[test]
fn net_id_must_differ_from_element_ids() {
    let mut b = NetBuilder::new("p1", "n");
    b.place(place("p1", 0));
    let errors = b.build().unwrap_err();
    assert_eq!(errors, vec![ModelError::DuplicateId { id: "p1".into() }]);
}

#[test]
fn reports_signal_misuse() {
    check(
        |b| {
            b.signal("Level", SignalDirection::Output, SignalType::Int);
            b.place(PlaceSpec { output: Some("Level".into()), ..place("p1", 0) });
            b.place(PlaceSpec { output: Some("Level".into()), ..place("p2", 0) });
            b.place(PlaceSpec { input: Some("I1".into()), ..place("in", 1) });
            b.transition(transition("t1", "Level"));
            b.arc(arc("a1", "in", "t1", 1));
        },
        &[
            "in: input place `in` has an initial marking (1); it mirrors its input signal, so leave the marking out",
            "t1: transition `t1`: its guard reads output `Level`; guards read input signals only",
            "p1: integer output `Level` is bound to places `p1` and `p2`; an integer output shows one place's marking",
            "a1: arc `a1` is a normal arc on input place `in`; an input place mirrors its signal, so only read and inhibitor arcs may leave it",
        ],
    );
}

#[test]
fn interleaving_firing_respects_capacity_and_special_arcs() {
    let mut b = NetBuilder::new("n", "n");
    b.place(place("a", 2));
    b.place(PlaceSpec {
        capacity: Some(1),
        ..place("b", 0)
    });
    b.place(place("c", 0));
    b.transition(transition("t", ""));
    b.arc(arc("x", "a", "t", 1));
    b.arc(arc("y", "t", "b", 1));
    b.arc(ArcSpec {
        kind: ArcKind::Inhibitor,
        ..arc("z", "c", "t", 1)
    });
    let net = b.build().unwrap();
    let t = TransitionId(0);
    let mut m = net.initial_marking();
    assert!(net.is_enabled(&m, t));
    net.fire(&mut m, t).unwrap();
    assert_eq!(m.0, vec![1, 1, 0]);
    assert!(!net.is_enabled(&m, t), "capacity of b is reached");
    m.0[1] = 0;
    m.0[2] = 1;
    assert!(!net.is_enabled(&m, t), "inhibitor on c");
    assert_eq!(net.incidence(PlaceId(0), t), -1);
    assert_eq!(net.incidence(PlaceId(1), t), 1);
    assert_eq!(net.incidence(PlaceId(2), t), 0);
}
