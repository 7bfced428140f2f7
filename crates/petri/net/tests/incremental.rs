//! The incremental evaluator ([`Scanner::incremental`]) scans exactly as the reference
//! ([`Scanner::new`]) does, on random nets in every mode: both step rules, both evolution
//! modes, delayed arcs, capacities, read and inhibitor arcs, input places, guards of any
//! shape over boolean and integer inputs, boolean and integer outputs, time steps of any
//! length, scans after errors and after `set_marking`. Every scan is compared: the result
//! (errors included), marking, fired transitions, passes, every signal, the timers (through
//! `blockers`) and the change flags.

use std::time::Duration;

use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, FlatGuard, Guard, Marking, Net, NetBuilder, PlaceSpec,
    ScanOptions, Scanner, SignalDirection, SignalType, StepRule, TransitionSpec,
};
use proptest::collection::vec;
use proptest::prelude::*;

/// Boolean inputs B0..B2 and one integer input N.
const BOOLS: usize = 3;

#[derive(Clone, Debug)]
struct Desc {
    /// (initial, capacity, output: 0 none, 1 boolean, 2 integer)
    places: Vec<(u32, Option<u32>, u8)>,
    /// Input places mirroring B0, B1 (and N when 3).
    inputs: usize,
    transitions: Vec<(Vec<ArcDesc>, String)>,
}

/// (place index, kind 0..4 = consume, produce, read, inhibit; weight; delay in periods)
type ArcDesc = (usize, u8, u32, Option<u8>);

fn arb_guard() -> impl Strategy<Value = String> {
    let leaf = prop_oneof![
        3 => (0..BOOLS).prop_map(|k| format!("B{k}")),
        1 => Just("TRUE".to_string()),
        1 => Just("FALSE".to_string()),
        2 => (0usize..6, -1i64..4).prop_map(|(op, v)| {
            let op = ["=", "<>", "<", "<=", ">", ">="][op];
            format!("N {op} {v}")
        }),
    ];
    leaf.prop_recursive(4, 16, 2, |inner| {
        prop_oneof![
            inner.clone().prop_map(|e| format!("NOT ({e})")),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("({a}) AND ({b})")),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| format!("({a}) OR ({b})")),
            (inner.clone(), inner).prop_map(|(a, b)| format!("({a}) XOR ({b})")),
        ]
    })
}

fn arb_desc() -> impl Strategy<Value = Desc> {
    (2usize..=8, 0usize..=3, 1usize..=8).prop_flat_map(|(np, ni, nt)| {
        let arc = (
            0..np + ni,
            0u8..4,
            1u32..=3,
            proptest::option::weighted(0.3, 0u8..4),
        );
        let guard = prop_oneof![2 => Just(String::new()), 3 => arb_guard()];
        (
            vec((0u32..=3, proptest::option::of(1u32..=4), 0u8..3), np),
            Just(ni),
            vec((vec(arc, 0..=5), guard), nt),
        )
            .prop_map(|(places, inputs, transitions)| Desc {
                places: places
                    .into_iter()
                    .map(|(m, c, o)| (c.map_or(m, |c| m.min(c)), c, o))
                    .collect(),
                inputs,
                transitions,
            })
    })
}

fn build(d: &Desc, step: StepRule, evolve: Evolution) -> Net {
    let mut b = NetBuilder::new("random", "random");
    b.step(step).evolve(evolve);
    for k in 0..BOOLS {
        b.signal(format!("B{k}"), SignalDirection::Input, SignalType::Bool);
    }
    b.signal("N", SignalDirection::Input, SignalType::Int);
    for (i, &(initial, capacity, out)) in d.places.iter().enumerate() {
        let output = match out {
            1 => Some(format!("Y{i}")),
            2 => {
                b.signal(format!("C{i}"), SignalDirection::Output, SignalType::Int);
                Some(format!("C{i}"))
            }
            _ => None,
        };
        b.place(PlaceSpec {
            id: format!("p{i}"),
            name: format!("p{i}"),
            initial,
            capacity,
            output,
            ..Default::default()
        });
    }
    for k in 0..d.inputs {
        b.place(PlaceSpec {
            id: format!("in{k}"),
            name: format!("in{k}"),
            input: Some(if k < 2 { format!("B{k}") } else { "N".into() }),
            capacity: (k == 2).then_some(3),
            ..Default::default()
        });
    }
    for (t, (arcs, guard)) in d.transitions.iter().enumerate() {
        b.transition(TransitionSpec {
            id: format!("t{t}"),
            name: format!("t{t}"),
            guard: parse(guard).unwrap(),
        });
        for (i, &(p, kind, weight, delay)) in arcs.iter().enumerate() {
            let internal = p < d.places.len();
            let place = if internal {
                format!("p{p}")
            } else {
                format!("in{}", p - d.places.len())
            };
            // Input places take read and inhibitor arcs only; output arcs and inhibitor arcs
            // take no delay.
            let kind = match (kind, internal) {
                (0 | 2, false) => 2,
                (_, false) => 3,
                (k, true) => k,
            };
            let delay = delay
                .filter(|_| kind == 0 || kind == 2)
                .map(|d| Duration::from_millis(10 * u64::from(d)));
            let (source, target, kind) = match kind {
                0 => (place, format!("t{t}"), ArcKind::Normal),
                1 => (format!("t{t}"), place, ArcKind::Normal),
                2 => (place, format!("t{t}"), ArcKind::Read),
                _ => (place, format!("t{t}"), ArcKind::Inhibitor),
            };
            b.arc(ArcSpec {
                id: format!("a{t}_{i}"),
                source,
                target,
                kind,
                weight,
                delay,
            });
        }
    }
    b.build().expect("random nets are valid by construction")
}

/// One scan's inputs: boolean values, the integer input, the time step in periods, and
/// whether to put both scanners back to a marking first (`set_marking`).
type Step = ([bool; BOOLS], i64, u8, Option<u8>);

fn check(d: &Desc, step: StepRule, evolve: Evolution, steps: &[Step]) -> Result<(), TestCaseError> {
    let net = build(d, step, evolve);
    let options = ScanOptions {
        max_passes: 6,
        ..ScanOptions::of(&net)
    };
    let mut full = Scanner::new(&net, options);
    let mut inc = Scanner::incremental(&net, options);
    prop_assert!(inc.is_incremental() && !full.is_incremental());
    let mut sf = vec![0i64; net.signals().len()];
    let mut si = sf.clone();
    let mut now = Duration::ZERO;
    for (k, &(bools, n, dt, reset)) in steps.iter().enumerate() {
        now += Duration::from_millis(10 * u64::from(dt));
        for (b, &v) in bools.iter().enumerate() {
            let s = net.signal_by_name(&format!("B{b}")).unwrap();
            sf[s.index()] = i64::from(v);
            si[s.index()] = i64::from(v);
        }
        let s = net.signal_by_name("N").unwrap();
        sf[s.index()] = n;
        si[s.index()] = n;
        if let Some(r) = reset {
            let m = Marking(
                (0..net.places().len())
                    .map(|p| (u32::from(r) + p as u32) % 3)
                    .collect(),
            );
            let m = Marking(
                net.place_ids()
                    .map(|p| net.bound(p).map_or(m[p], |c| m[p].min(c)))
                    .collect(),
            );
            full.set_marking(&m);
            inc.set_marking(&m);
        }
        let rf = full.scan(now, &mut sf);
        let ri = inc.scan(now, &mut si);
        prop_assert_eq!(&rf, &ri, "scan {} result", k);
        prop_assert_eq!(full.marking(), inc.marking(), "scan {} marking", k);
        prop_assert_eq!(full.fired(), inc.fired(), "scan {} fired", k);
        prop_assert_eq!(full.passes(), inc.passes(), "scan {} passes", k);
        if rf.is_ok() {
            prop_assert_eq!(&sf, &si, "scan {} signals", k);
            prop_assert_eq!(
                full.marking_changed(),
                inc.marking_changed(),
                "scan {} marking changed",
                k
            );
            prop_assert_eq!(
                full.outputs_changed(),
                inc.outputs_changed(),
                "scan {} outputs changed",
                k
            );
        } else {
            // A failed scan writes no outputs; rewrite them as the next good scan does.
            si.copy_from_slice(&sf);
        }
        for t in net.transition_ids() {
            prop_assert_eq!(
                full.blockers(t, now, &sf),
                inc.blockers(t, now, &si),
                "scan {} blockers of {}",
                k,
                net.transition_label(t)
            );
        }
    }
    Ok(())
}

fn arb_steps() -> impl Strategy<Value = Vec<Step>> {
    vec(
        (
            any::<[bool; BOOLS]>(),
            -1i64..5,
            prop_oneof![3 => Just(1u8), 1 => Just(0u8), 1 => 2u8..6],
            proptest::option::weighted(0.05, any::<u8>()),
        ),
        1..25,
    )
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn incremental_scans_are_the_reference_scans(
        d in arb_desc(),
        sequential in any::<bool>(),
        stable in any::<bool>(),
        steps in arb_steps(),
    ) {
        let step = if sequential { StepRule::Sequential } else { StepRule::MaximalStep };
        let evolve = if stable { Evolution::UntilStable } else { Evolution::OnePass };
        check(&d, step, evolve, &steps)?;
    }

    #[test]
    fn flat_guards_mean_what_guards_mean(g in arb_guard(), bools in any::<[bool; BOOLS]>(), n in -2i64..6) {
        let names = ["B0", "B1", "B2", "N"];
        let expr = parse(&g).unwrap();
        let guard = Guard(expr.try_map(&mut |s: &String| {
            names.iter().position(|n| n == s).map(|i| petriplc_net::SignalId(i as u32)).ok_or(())
        }).unwrap());
        let mut values: Vec<i64> = bools.iter().map(|&b| i64::from(b)).collect();
        values.push(n);
        prop_assert_eq!(FlatGuard::new(&guard).eval(&values), guard.eval(&values), "{}", g);
    }
}

#[test]
fn deep_guards_fall_back_to_the_tree() {
    use petriplc_net::guard::Expr;
    use petriplc_net::SignalId;
    // 70 nested right operands: deeper than the 64-bit evaluation stack.
    let mut e = Expr::Signal(SignalId(0));
    for k in 0..70 {
        e = Expr::And(Box::new(Expr::Signal(SignalId(k % 2))), Box::new(e));
    }
    let guard = Guard(Expr::Or(Box::new(Expr::Const(false)), Box::new(e)));
    for values in [[1, 1], [1, 0], [0, 1]] {
        assert_eq!(FlatGuard::new(&guard).eval(&values), guard.eval(&values));
    }
}

/// The cases a maximal step decides on values its earlier firings changed, which the enabled
/// set alone does not show: an inhibitor arc freed by an earlier consumer, a capacity filled
/// by an earlier producer, tokens taken by an earlier transition.
#[test]
fn a_step_visits_what_its_earlier_firings_disturbed() {
    let d = Desc {
        places: vec![(1, None, 1), (0, Some(1), 1), (2, None, 0)],
        inputs: 0,
        transitions: vec![
            // t0 takes p0's token; t1, inhibited by p0, is enabled only after that.
            (vec![(0, 0, 1, None)], String::new()),
            (vec![(0, 3, 1, None), (1, 1, 1, None)], String::new()),
            // t2 fills p1 (capacity 1) only if t1 did not.
            (vec![(2, 0, 1, None), (1, 1, 1, None)], String::new()),
            // t3 needs p2's tokens, which t2 may have taken.
            (vec![(2, 0, 2, None)], String::new()),
        ],
    };
    let steps: Vec<Step> = (0..4).map(|_| ([false; BOOLS], 0, 1, None)).collect();
    for step in [StepRule::MaximalStep, StepRule::Sequential] {
        for evolve in [Evolution::OnePass, Evolution::UntilStable] {
            check(&d, step, evolve, &steps).unwrap();
        }
    }
}
