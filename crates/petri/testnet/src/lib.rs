//! A compact text form for the small nets unit tests build, so each test shows its net at a
//! glance. Test-only (a dev-dependency); not published.
//!
//! ```text
//! p NAME INITIAL [>OUTPUT] [<INPUT] [cap=N]   a place, optionally driving an output / mirroring
//!                                             an input, with a capacity
//! t NAME PRE… -> POST… [if GUARD]        arcs: `p`, `p*2` (weight), `p@0.5` (delay), `?p` read, `!p` inhibitor;
//!                                        `within=0.6` anywhere among them: a deadline
//! s NAME in|out bool|int                 a signal declaration
//! step sequential | evolve until-stable  the net's scan options
//! ```
//!
//! [`data`] says where tests find their data files.

pub mod data;

use std::time::Duration;

use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, Net, NetBuilder, PlaceSpec, SignalDirection, SignalType, StepRule,
    TransitionSpec,
};

pub fn net(text: &str) -> Net {
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
                let t = b.transition(TransitionSpec {
                    id: id.clone(),
                    name: id.clone(),
                    guard: parse(guard).unwrap(),
                });
                let mut into = false;
                for w in words {
                    if let Some(d) = w.strip_prefix("within=") {
                        b.deadline(t, petriplc_net::time::parse_duration(d).unwrap());
                        continue;
                    }
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

/// An error and its causes joined by `: `, as the CLI prints them (`{:#}` in anyhow).
pub fn error_chain(e: &dyn std::error::Error) -> String {
    let mut out = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        out += &format!(": {c}");
        cause = c.source();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_every_kind_of_line() {
        let n = net("
            s Level in int
            step sequential
            evolve until-stable
            p a 2 >Lamp cap=3
            p b 0
            p lvl 0 <Level
            t go a*2 ?lvl !b -> b if Level > 3
            t back b@0.5 -> a within=1s
        ");
        assert_eq!(n.places().len(), 3);
        assert_eq!(n.transitions().len(), 2);
        assert_eq!(n.arcs().len(), 6);
        assert_eq!(n.place(petriplc_net::PlaceId(0)).capacity, Some(3));
        assert_eq!(n.guard_text(petriplc_net::TransitionId(0)), "Level > 3");
        assert_eq!(n.timed_arcs().len(), 1);
        assert_eq!(
            n.transition(petriplc_net::TransitionId(1)).deadline,
            Some(Duration::from_secs(1))
        );
    }
}
