//! A compact text form for the small nets the tests build, so each test shows its net at a
//! glance (the same as petriplc-sim's test nets, plus capacities).
//!
//! ```text
//! p NAME INITIAL [>OUTPUT] [<INPUT] [cap=N]   a place, optionally driving an output / mirroring
//!                                             an input, with a capacity
//! t NAME PRE… -> POST… [if GUARD]        arcs: `p`, `p*2` (weight), `p@0.5` (delay), `?p` read, `!p` inhibitor
//! s NAME in|out bool|int                 a signal declaration
//! step sequential | evolve until-stable  the net's scan options
//! ```

use std::time::Duration;

use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, Net, NetBuilder, PlaceSpec, SignalDirection, SignalType, StepRule,
    TransitionSpec,
};

pub(crate) fn net(text: &str) -> Net {
    let mut b = NetBuilder::new("test", "test");
    let mut arcs = 0;
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let (kind, rest) = line.split_once(' ').unwrap_or((line, ""));
        let words: Vec<&str> = rest.split_whitespace().collect();
        match kind {
            "p" => {
                let mut p = PlaceSpec {
                    id: words[0].into(),
                    name: words[0].into(),
                    initial: words[1].parse().unwrap(),
                    ..Default::default()
                };
                for w in &words[2..] {
                    if let Some(o) = w.strip_prefix('>') {
                        p.output = Some(o.into());
                    } else if let Some(i) = w.strip_prefix('<') {
                        p.input = Some(i.into());
                    } else if let Some(c) = w.strip_prefix("cap=") {
                        p.capacity = Some(c.parse().unwrap());
                    }
                }
                b.place(p);
            }
            "t" => {
                let (arcs_text, guard) = rest.split_once(" if ").unwrap_or((rest, ""));
                let mut words = arcs_text.split_whitespace();
                let id = words.next().unwrap().to_string();
                b.transition(TransitionSpec {
                    id: id.clone(),
                    name: id.clone(),
                    guard: parse(guard).unwrap(),
                });
                let mut into = false;
                for w in words {
                    if w == "->" {
                        into = true;
                        continue;
                    }
                    let (kind, w) = match w.as_bytes()[0] {
                        b'?' => (ArcKind::Read, &w[1..]),
                        b'!' => (ArcKind::Inhibitor, &w[1..]),
                        _ => (ArcKind::Normal, w),
                    };
                    let (w, delay) = match w.split_once('@') {
                        Some((w, d)) => (w, Some(petriplc_net::time::parse_duration(d).unwrap())),
                        None => (w, None::<Duration>),
                    };
                    let (place, weight) = match w.split_once('*') {
                        Some((p, n)) => (p, n.parse().unwrap()),
                        None => (w, 1),
                    };
                    arcs += 1;
                    let (source, target) = if into {
                        (id.clone(), place.to_string())
                    } else {
                        (place.to_string(), id.clone())
                    };
                    b.arc(ArcSpec {
                        id: format!("arc{arcs}"),
                        source,
                        target,
                        kind,
                        weight,
                        delay,
                    });
                }
            }
            "s" => {
                let dir = match words[1] {
                    "in" => SignalDirection::Input,
                    _ => SignalDirection::Output,
                };
                let ty = match words[2] {
                    "int" => SignalType::Int,
                    _ => SignalType::Bool,
                };
                b.signal(words[0], dir, ty);
            }
            "step" => {
                b.step(StepRule::parse(rest).unwrap());
            }
            "evolve" => {
                b.evolve(Evolution::parse(rest).unwrap());
            }
            other => panic!("unknown test-net line kind {other:?}"),
        }
    }
    b.build()
        .unwrap_or_else(|e| panic!("test net does not build: {e:?}"))
}
