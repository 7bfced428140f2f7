//! Properties of both semantics on random small nets (2–8 places, up to 2 boolean input
//! places, 1–8 transitions, normal/read/inhibitor arcs of weight 1–3, optional capacities,
//! guards over three input signals): the marking equation, capacities, no token taken twice,
//! and the highest-priority enabled transition always firing.

use std::time::Duration;

use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, Marking, Net, NetBuilder, PlaceSpec, ScanError, ScanOptions,
    Scanner, StepRule, TransitionId, TransitionSpec,
};
use proptest::collection::vec;
use proptest::prelude::*;

/// A random net before building: places (initial, capacity), the number of input places,
/// and per transition its arcs (place index, kind, weight) and guard.
#[derive(Clone, Debug)]
struct Desc {
    places: Vec<(u32, Option<u32>)>,
    inputs: usize,
    transitions: Vec<(Arcs, Guard)>,
}

/// A transition's arcs: (place index, kind, weight); places past the internal ones are the
/// input places.
type Arcs = Vec<(usize, Kind, u32)>;

#[derive(Clone, Copy, Debug)]
enum Kind {
    Consume,
    Produce,
    Read,
    Inhibit,
}

#[derive(Clone, Copy, Debug)]
enum Guard {
    True,
    Signal(usize),
    NotSignal(usize),
}

const SIGNALS: usize = 3;

fn arb_desc() -> impl Strategy<Value = Desc> {
    (2usize..=8, 0usize..=2, 1usize..=8).prop_flat_map(|(np, ni, nt)| {
        let kind = prop_oneof![
            Just(Kind::Consume),
            Just(Kind::Produce),
            Just(Kind::Read),
            Just(Kind::Inhibit)
        ];
        let guard = prop_oneof![
            2 => Just(Guard::True),
            1 => (0..SIGNALS).prop_map(Guard::Signal),
            1 => (0..SIGNALS).prop_map(Guard::NotSignal),
        ];
        let arcs = vec((0..np + ni, kind, 1u32..=3), 0..=4);
        (
            vec((0u32..=3, proptest::option::of(1u32..=4)), np),
            Just(ni),
            vec((arcs, guard), nt),
        )
            .prop_map(|(places, inputs, transitions)| {
                // An initial marking above the capacity is a model error, not a case to run.
                let places = places
                    .into_iter()
                    .map(|(m, c)| (c.map_or(m, |c| m.min(c)), c))
                    .collect();
                Desc {
                    places,
                    inputs,
                    transitions,
                }
            })
    })
}

fn build(d: &Desc, step: StepRule, evolve: Evolution) -> Net {
    let mut b = NetBuilder::new("random", "random");
    b.step(step).evolve(evolve);
    for (i, &(initial, capacity)) in d.places.iter().enumerate() {
        b.place(PlaceSpec {
            id: format!("p{i}"),
            name: format!("p{i}"),
            initial,
            capacity,
            ..Default::default()
        });
    }
    // Input place k mirrors signal Ik, which guards read too.
    for k in 0..d.inputs {
        b.place(PlaceSpec {
            id: format!("in{k}"),
            name: format!("in{k}"),
            input: Some(format!("I{k}")),
            ..Default::default()
        });
    }
    for (t, (arcs, guard)) in d.transitions.iter().enumerate() {
        let guard = match guard {
            Guard::True => String::new(),
            Guard::Signal(k) => format!("I{k}"),
            Guard::NotSignal(k) => format!("NOT I{k}"),
        };
        b.transition(TransitionSpec {
            id: format!("t{t}"),
            name: format!("t{t}"),
            guard: parse(&guard).unwrap(),
        });
        for (i, &(p, kind, weight)) in arcs.iter().enumerate() {
            let place = if p < d.places.len() {
                format!("p{p}")
            } else {
                format!("in{}", p - d.places.len())
            };
            // Only read and inhibitor arcs may touch an input place.
            let kind = match (kind, p < d.places.len()) {
                (Kind::Consume | Kind::Read, false) => Kind::Read,
                (Kind::Produce | Kind::Inhibit, false) => Kind::Inhibit,
                (k, true) => k,
            };
            let (source, target, kind) = match kind {
                Kind::Consume => (place, format!("t{t}"), ArcKind::Normal),
                Kind::Produce => (format!("t{t}"), place, ArcKind::Normal),
                Kind::Read => (place, format!("t{t}"), ArcKind::Read),
                Kind::Inhibit => (place, format!("t{t}"), ArcKind::Inhibitor),
            };
            b.arc(ArcSpec {
                id: format!("a{t}_{i}"),
                source,
                target,
                kind,
                weight,
                delay: None,
            });
        }
    }
    b.build().expect("random nets are valid by construction")
}

/// Whether `t` could fire alone in `m` under these signals: the interleaving rule plus the
/// guard (the random nets have no delays).
/// Whether `t` could fire alone in a scan from `m`: the interleaving rule, plus what it
/// abstracts away (guards, and read/inhibitor arcs on input places, which hold the input's
/// value during a scan).
fn fireable(net: &Net, m: &Marking, t: TransitionId, signals: &[i64]) -> bool {
    let a = net.arcs_of(t);
    let inputs_hold = a
        .read
        .iter()
        .all(|&(p, w)| net.place(p).input.is_none() || m[p] >= w)
        && a.inhibit
            .iter()
            .all(|&(p, w)| net.place(p).input.is_none() || m[p] < w);
    net.is_enabled(m, t) && inputs_hold && net.transition(t).guard.eval(signals)
}

fn assert_within_capacities(net: &Net, m: &Marking) -> Result<(), TestCaseError> {
    for p in net.place_ids() {
        if let Some(cap) = net.bound(p) {
            prop_assert!(
                m[p] <= cap,
                "{} holds {} > capacity {cap}",
                net.place_label(p),
                m[p]
            );
        }
    }
    Ok(())
}

/// Sets the input signals; returns the marking the scan starts from: `before` with each
/// input place mirroring its (boolean) signal.
fn apply_inputs(
    net: &Net,
    before: &Marking,
    inputs: &[bool; SIGNALS],
    signals: &mut [i64],
) -> Marking {
    for (k, &v) in inputs.iter().enumerate() {
        if let Some(s) = net.signal_by_name(&format!("I{k}")) {
            signals[s.index()] = i64::from(v);
        }
    }
    let mut start = before.clone();
    for p in net.place_ids() {
        if let Some(s) = net.place(p).input {
            start[p] = signals[s.index()] as u32;
        }
    }
    start
}

/// Checks one-pass scans of either step rule against the properties both share, plus
/// `extra` for the rule's own.
fn check_scans(
    d: &Desc,
    step: StepRule,
    inputs: &[[bool; SIGNALS]],
    extra: impl Fn(&Net, &Marking, &[TransitionId]) -> Result<(), TestCaseError>,
) -> Result<(), TestCaseError> {
    let net = build(d, step, Evolution::OnePass);
    let mut scanner = Scanner::new(&net, ScanOptions::of(&net));
    let mut signals = vec![0i64; net.signals().len()];
    for (k, inp) in inputs.iter().enumerate() {
        let start = apply_inputs(&net, scanner.marking(), inp, &mut signals);
        scanner
            .scan(Duration::from_millis(10 * k as u64), &mut signals)
            .unwrap();
        let fired = scanner.fired();
        let after = scanner.marking();

        // The marking equation for the whole pass: M' = M + C·σ.
        for p in net.place_ids() {
            let expect =
                i64::from(start[p]) + fired.iter().map(|&t| net.incidence(p, t)).sum::<i64>();
            prop_assert_eq!(i64::from(after[p]), expect, "place {}", net.place_label(p));
        }
        assert_within_capacities(&net, after)?;
        // One pass tries each transition once, in priority order.
        prop_assert!(fired.windows(2).all(|w| w[0] < w[1]), "fired {:?}", fired);
        // Every fired transition's guard held.
        for &t in fired {
            prop_assert!(net.transition(t).guard.eval(&signals));
        }
        // The highest-priority transition that could fire alone does fire: nothing before it
        // can take its tokens, so a pass never stays idle while something is enabled.
        if let Some(first) = net
            .transition_ids()
            .find(|&t| fireable(&net, &start, t, &signals))
        {
            prop_assert_eq!(fired.first(), Some(&first));
        } else {
            prop_assert!(fired.is_empty());
        }
        extra(&net, &start, fired)?;
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn interleaving_runs_obey_the_marking_equation(d in arb_desc(), choices in vec(any::<u32>(), 0..40)) {
        let net = build(&d, StepRule::MaximalStep, Evolution::OnePass);
        let m0 = net.initial_marking();
        let mut m = m0.clone();
        let mut sigma = vec![0i64; net.transitions().len()];
        for c in choices {
            let enabled: Vec<TransitionId> = net.transition_ids().filter(|&t| net.is_enabled(&m, t)).collect();
            if enabled.is_empty() {
                break;
            }
            let t = enabled[c as usize % enabled.len()];
            net.fire(&mut m, t).unwrap();
            sigma[t.index()] += 1;
            for p in net.place_ids() {
                let expect = i64::from(m0[p])
                    + net.transition_ids().map(|t| net.incidence(p, t) * sigma[t.index()]).sum::<i64>();
                prop_assert_eq!(i64::from(m[p]), expect, "place {} after σ = {:?}", net.place_label(p), sigma);
            }
            assert_within_capacities(&net, &m)?;
        }
    }

    #[test]
    fn maximal_step_takes_no_token_twice(d in arb_desc(), inputs in vec(any::<[bool; SIGNALS]>(), 1..12)) {
        check_scans(&d, StepRule::MaximalStep, &inputs, |net, start, fired| {
            // The consumption of the whole step fits in the start marking, per place.
            for p in net.place_ids() {
                let taken: u64 = fired
                    .iter()
                    .flat_map(|&t| net.arcs_of(t).consume.iter())
                    .filter(|(q, _)| *q == p)
                    .map(|&(_, w)| u64::from(w))
                    .sum();
                prop_assert!(taken <= u64::from(start[p]), "step takes {taken} from {} holding {}", net.place_label(p), start[p]);
            }
            // Without inhibitor arcs the step is also an interleaving run in priority order:
            // tokens only grow from the reduced marking the step judged each transition on.
            if fired.iter().all(|&t| net.arcs_of(t).inhibit.is_empty()) {
                let mut m = start.clone();
                for &t in fired {
                    prop_assert!(
                        net.is_enabled(&m, t),
                        "{} in the step but not enabled in {:?}",
                        net.transition_label(t),
                        m
                    );
                    net.fire(&mut m, t).unwrap();
                }
            }
            Ok(())
        })?;
    }

    #[test]
    fn sequential_pass_is_an_interleaving_run(d in arb_desc(), inputs in vec(any::<[bool; SIGNALS]>(), 1..12)) {
        check_scans(&d, StepRule::Sequential, &inputs, |net, start, fired| {
            // Replaying the pass one transition at a time is a valid interleaving run: each
            // transition was enabled in the marking its predecessors left.
            let mut m = start.clone();
            for &t in fired {
                prop_assert!(net.is_enabled(&m, t), "{} fired but was not enabled in {:?}", net.transition_label(t), m);
                net.fire(&mut m, t).unwrap();
            }
            Ok(())
        })?;
    }

    #[test]
    fn until_stable_ends_stable_or_reports_unstable(
        d in arb_desc(),
        sequential in any::<bool>(),
        inputs in vec(any::<[bool; SIGNALS]>(), 1..6),
    ) {
        let step = if sequential { StepRule::Sequential } else { StepRule::MaximalStep };
        let net = build(&d, step, Evolution::UntilStable);
        let options = ScanOptions { max_passes: 30, ..ScanOptions::of(&net) };
        let mut scanner = Scanner::new(&net, options);
        let mut signals = vec![0i64; net.signals().len()];
        for (k, inp) in inputs.iter().enumerate() {
            apply_inputs(&net, scanner.marking(), inp, &mut signals);
            match scanner.scan(Duration::from_millis(10 * k as u64), &mut signals) {
                Ok(()) => {
                    let m = scanner.marking();
                    prop_assert!(net.transition_ids().all(|t| !fireable(&net, m, t, &signals)), "not stable: {:?}", m);
                    prop_assert!(scanner.passes() <= 30);
                    assert_within_capacities(&net, m)?;
                }
                Err(ScanError::Unstable { passes, transitions, .. }) => {
                    prop_assert_eq!(passes, 30);
                    prop_assert!(!transitions.is_empty());
                    break;
                }
                Err(e) => prop_assert!(false, "unexpected error {e}"),
            }
        }
    }
}
