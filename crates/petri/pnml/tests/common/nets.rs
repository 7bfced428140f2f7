//! Random valid nets for property tests: a plan of raw random choices (which shrinks well)
//! turned into a net through `NetBuilder`, bending every choice into one the model accepts.

use std::time::Duration;

use petriplc_net::guard::{CmpOp, Expr, Operand};
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, Net, NetBuilder, PlaceSpec, SignalDirection, SignalType, StepRule,
    TransitionSpec,
};
use proptest::prelude::*;

/// Signal names by position in the plan.
const SIGNALS: [&str; 6] = ["B1", "N2", "Level", "L1", "Out_2", "Cnt"];

/// Names: spaces at the ends, markup characters, `\r`, `\t`, non-ASCII.
const NAME: &str = "[ a-zA-Z0-9_<>&\"'!()é\t\r\n-]{0,10}";

#[derive(Clone, Debug)]
pub struct Plan {
    id: String,
    name: String,
    sequential: bool,
    until_stable: bool,
    /// (input?, int?, declared?) for SIGNALS[i].
    signals: Vec<(bool, bool, bool)>,
    /// (name, initial, extra capacity, role: 0 plain, 1 output, 2 input; which signal).
    places: Vec<(String, u32, Option<u32>, u8, usize)>,
    transitions: Vec<(String, Expr<usize>)>,
    /// (place, transition, from place?, kind, weight, delay in µs).
    arcs: Vec<(usize, usize, bool, u8, u32, Option<u64>)>,
}

fn guard() -> impl Strategy<Value = Expr<usize>> {
    let ops = prop_oneof![
        Just(CmpOp::Eq),
        Just(CmpOp::Ne),
        Just(CmpOp::Lt),
        Just(CmpOp::Le),
        Just(CmpOp::Gt),
        Just(CmpOp::Ge)
    ];
    let leaf = prop_oneof![
        any::<bool>().prop_map(Expr::Const),
        (0..6usize).prop_map(Expr::Signal),
        (0..6usize, ops, 0..100i64).prop_map(|(s, op, v)| Expr::Cmp(
            Operand::Signal(s),
            op,
            Operand::Literal(v)
        )),
    ];
    leaf.prop_recursive(4, 16, 2, |inner| {
        prop_oneof![
            inner.clone().prop_map(|e| Expr::Not(Box::new(e))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| Expr::And(Box::new(a), Box::new(b))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| Expr::Or(Box::new(a), Box::new(b))),
            (inner.clone(), inner).prop_map(|(a, b)| Expr::Xor(Box::new(a), Box::new(b))),
        ]
    })
}

pub fn plan() -> impl Strategy<Value = Plan> {
    (
        "[a-zA-Z_][a-zA-Z0-9_.-]{0,6}",
        NAME,
        any::<bool>(),
        any::<bool>(),
        prop::collection::vec(any::<(bool, bool, bool)>(), 0..=6),
        prop::collection::vec(
            (NAME, 0..4u32, prop::option::of(0..3u32), 0..3u8, 0..6usize),
            0..=6,
        ),
        prop::collection::vec((NAME, guard()), 0..=4),
        prop::collection::vec(
            (
                0..6usize,
                0..4usize,
                any::<bool>(),
                0..3u8,
                1..5u32,
                prop::option::of(0..3_000_000u64),
            ),
            0..=10,
        ),
    )
        .prop_map(
            |(id, name, sequential, until_stable, signals, places, transitions, arcs)| Plan {
                id,
                name,
                sequential,
                until_stable,
                signals,
                places,
                transitions,
                arcs,
            },
        )
}

/// A valid net following `plan` as closely as the model allows.
pub fn build(plan: &Plan) -> Net {
    // The `n` prefix keeps the net's id apart from the element ids p0, t0, a0...: PNML ids
    // are unique across the whole document.
    let mut b = NetBuilder::new(format!("n{}", plan.id), plan.name.clone());
    if plan.sequential {
        b.step(StepRule::Sequential);
    }
    if plan.until_stable {
        b.evolve(Evolution::UntilStable);
    }
    let mut inputs = Vec::new();
    let mut outputs = Vec::new();
    for (i, &(input, int, declared)) in plan.signals.iter().enumerate() {
        let name = SIGNALS[i];
        let direction = if input {
            SignalDirection::Input
        } else {
            SignalDirection::Output
        };
        let ty = if int {
            SignalType::Int
        } else {
            SignalType::Bool
        };
        // An undeclared signal is a boolean, so integers are always declared.
        if declared || int {
            b.signal(name, direction, ty);
        }
        if input {
            inputs.push(name);
        } else {
            outputs.push((name, int));
        }
    }
    let mut input_places = Vec::new();
    let mut bound_int_outputs = Vec::new();
    for (i, (name, initial, extra, role, which)) in plan.places.iter().enumerate() {
        let mut p = PlaceSpec {
            id: format!("p{i}"),
            name: name.clone(),
            initial: *initial,
            capacity: extra.map(|x| (*initial).max(1) + x),
            ..Default::default()
        };
        match role {
            1 if !outputs.is_empty() => {
                let (signal, int) = outputs[which % outputs.len()];
                // An integer output shows one place's marking.
                if !int || !bound_int_outputs.contains(&signal) {
                    bound_int_outputs.push(signal);
                    p.output = Some(signal.to_string());
                }
            }
            2 if !inputs.is_empty() => {
                p.input = Some(inputs[which % inputs.len()].to_string());
                p.initial = 0;
                input_places.push(i);
            }
            _ => {}
        }
        b.place(p);
    }
    for (i, (name, g)) in plan.transitions.iter().enumerate() {
        let guard = g
            .try_map(&mut |s: &usize| {
                inputs
                    .get(s % inputs.len().max(1))
                    .map(|n| n.to_string())
                    .ok_or(())
            })
            .unwrap_or(Expr::Const(true));
        b.transition(TransitionSpec {
            id: format!("t{i}"),
            name: name.clone(),
            guard,
        });
    }
    let (np, nt) = (plan.places.len(), plan.transitions.len());
    for (i, &(p, t, from_place, kind, weight, delay)) in plan.arcs.iter().enumerate() {
        if np == 0 || nt == 0 {
            break;
        }
        let (p, t) = (p % np, t % nt);
        let input_place = input_places.contains(&p);
        // Only read and inhibitor arcs may touch an input place, and only from it.
        let from_place = from_place || input_place;
        let kind = match (from_place, input_place, kind) {
            (false, _, _) => ArcKind::Normal,
            (true, true, k) => [ArcKind::Read, ArcKind::Inhibitor][usize::from(k % 2)],
            (true, false, k) => {
                [ArcKind::Normal, ArcKind::Read, ArcKind::Inhibitor][usize::from(k)]
            }
        };
        let delay = delay
            .filter(|_| from_place && kind != ArcKind::Inhibitor)
            .map(Duration::from_micros);
        let (pid, tid) = (format!("p{p}"), format!("t{t}"));
        let (source, target) = if from_place { (pid, tid) } else { (tid, pid) };
        b.arc(ArcSpec {
            id: format!("a{i}"),
            source,
            target,
            kind,
            weight,
            delay,
        });
    }
    match b.build() {
        Ok(net) => net,
        Err(e) => panic!("the generator built an invalid net: {e:?}\nfrom {plan:?}"),
    }
}
