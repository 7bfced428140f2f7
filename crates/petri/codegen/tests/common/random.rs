//! Random nets for property tests: places with optional capacities, two boolean inputs and
//! one integer input (each mirrored by an input place), transitions with guards, and arcs of
//! every kind with weights and delays; half of them safe (capacity 1, weight 1) so that BOOL
//! markings are exercised too.

use std::time::Duration;

use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Net, NetBuilder, PlaceSpec, SignalDirection, SignalType, TransitionSpec,
};
use proptest::prelude::*;

/// The shape of a random net.
/// An arc of a random transition: (place, kind, weight, delay in 10 ms).
pub type RandomArc = (usize, u8, u32, u64);

#[derive(Clone, Debug)]
pub struct Desc {
    pub places: Vec<(u32, Option<u32>)>,
    pub transitions: Vec<(Vec<RandomArc>, u8)>,
    /// Rows of (time in 10 ms, I0, I1, N).
    pub timeline: Vec<(u64, bool, bool, i64)>,
    pub safe: bool,
}

pub fn arb_desc() -> impl Strategy<Value = Desc> {
    let safe = any::<bool>();
    safe.prop_flat_map(|safe| {
        let place = if safe {
            (0..=1u32, Just(Some(1))).boxed()
        } else {
            (0..4u32, prop::option::of(1..5u32)).boxed()
        };
        let weight = if safe { 1..2u32 } else { 1..4u32 };
        let arc = (
            0..9usize,
            0..4u8,
            weight,
            prop_oneof![3 => Just(0u64), 1 => 1..6u64],
        );
        let transition = (prop::collection::vec(arc, 1..5), 0..8u8);
        let row = (0..60u64, any::<bool>(), any::<bool>(), -2..6i64);
        (
            prop::collection::vec(place, 2..7),
            prop::collection::vec(transition, 1..6),
            prop::collection::vec(row, 0..6),
            Just(safe),
        )
            .prop_map(|(places, transitions, mut timeline, safe)| {
                timeline.sort_by_key(|r| r.0);
                Desc {
                    places,
                    transitions,
                    timeline,
                    safe,
                }
            })
    })
}

const GUARDS: [&str; 8] = [
    "",
    "I0",
    "NOT I1",
    "I0 AND I1",
    "I0 XOR I1",
    "N >= 2",
    "N < 1 OR I1",
    "N <> 3",
];

pub fn build(d: &Desc) -> Net {
    let mut b = NetBuilder::new("random", "random");
    for (name, ty) in [
        ("I0", SignalType::Bool),
        ("I1", SignalType::Bool),
        ("N", SignalType::Int),
    ] {
        b.signal(name, SignalDirection::Input, ty);
    }
    b.signal("Q", SignalDirection::Output, SignalType::Bool);
    b.signal("Count", SignalDirection::Output, SignalType::Int);
    let n = d.places.len();
    for (i, &(initial, capacity)) in d.places.iter().enumerate() {
        b.place(PlaceSpec {
            id: format!("p{i}"),
            name: format!("p{i}"),
            initial,
            capacity: capacity.map(|c| c.max(initial)),
            output: match i {
                0 | 2 => Some("Q".into()),
                1 if !d.safe => Some("Count".into()),
                _ => None,
            },
            ..Default::default()
        });
    }
    for (k, s) in ["I0", "I1", "N"].iter().enumerate() {
        b.place(PlaceSpec {
            id: format!("in{k}"),
            name: format!("in{k}"),
            input: Some(s.to_string()),
            capacity: (k == 2).then_some(4),
            ..Default::default()
        });
    }
    for (t, (arcs, g)) in d.transitions.iter().enumerate() {
        b.transition(TransitionSpec {
            id: format!("t{t}"),
            name: format!("t{t}"),
            guard: parse(GUARDS[*g as usize]).unwrap(),
        });
        let mut seen = Vec::new();
        for (i, &(p, kind, weight, delay)) in arcs.iter().enumerate() {
            let p = p % (n + 3);
            let input = p >= n;
            let place = if input {
                format!("in{}", p - n)
            } else {
                format!("p{p}")
            };
            // One arc per place and direction; input places only by read and inhibitor arcs.
            let kind = match (kind, input) {
                (0 | 2, true) => 2,
                (_, true) => 3,
                (k, false) => k,
            };
            let outgoing = kind == 1;
            if seen.contains(&(p, outgoing)) {
                continue;
            }
            seen.push((p, outgoing));
            let (source, target, kind) = match kind {
                0 => (place, format!("t{t}"), ArcKind::Normal),
                1 => (format!("t{t}"), place, ArcKind::Normal),
                2 => (place, format!("t{t}"), ArcKind::Read),
                _ => (place, format!("t{t}"), ArcKind::Inhibitor),
            };
            let delay = (delay > 0 && !outgoing && kind != ArcKind::Inhibitor)
                .then(|| Duration::from_millis(10 * delay));
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

pub fn timeline_text(d: &Desc) -> String {
    let mut s = String::from("time,I0,I1,N\n");
    for &(t, a, b, n) in &d.timeline {
        s.push_str(&format!(
            "{}ms,{},{},{n}\n",
            t * 10,
            u8::from(a),
            u8::from(b)
        ));
    }
    s
}
