//! A tiny text format for nets in unit tests, one element a line:
//!
//! ```text
//! int Level                         an integer input signal (undeclared ones are boolean)
//! place idle 2 cap=3                a place with 2 tokens and capacity 3
//! place lvl in=Level                an input place mirroring signal Level
//! trans go: idle*2 -> busy ? lvl*3 ! stop if Level > 3
//! ```
//!
//! A transition lists its preset, `->`, its postset, then optionally read arcs after `?`,
//! inhibitor arcs after `!`, and a guard after `if`; `p*w` gives weight w.

use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Marking, Net, NetBuilder, PlaceSpec, SignalDirection, SignalType,
    TransitionSpec,
};

pub fn net(text: &str) -> Net {
    let mut b = NetBuilder::new("net", "net");
    let mut arcs = 0;
    let mut arc = |b: &mut NetBuilder, source: &str, target: &str, kind: ArcKind, item: &str| {
        let (place, w) = item.split_once('*').unwrap_or((item, "1"));
        let (source, target) = if source.is_empty() {
            (place, target)
        } else {
            (source, place)
        };
        arcs += 1;
        b.arc(ArcSpec {
            id: format!("arc#{arcs}"),
            source: source.into(),
            target: target.into(),
            kind,
            weight: w.parse().unwrap(),
            delay: None,
        });
    };
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let (kw, rest) = line.split_once(' ').unwrap();
        match kw {
            "int" => {
                b.signal(rest.trim(), SignalDirection::Input, SignalType::Int);
            }
            "place" => {
                let mut words = rest.split_whitespace();
                let name = words.next().unwrap();
                let mut spec = PlaceSpec {
                    id: name.into(),
                    name: name.into(),
                    ..Default::default()
                };
                for w in words {
                    if let Some(c) = w.strip_prefix("cap=") {
                        spec.capacity = Some(c.parse().unwrap());
                    } else if let Some(s) = w.strip_prefix("in=") {
                        spec.input = Some(s.into());
                    } else {
                        spec.initial = w.parse().unwrap();
                    }
                }
                b.place(spec);
            }
            "trans" => {
                let (body, guard) = rest.split_once(" if ").unwrap_or((rest, ""));
                let (name, body) = body.split_once(':').unwrap();
                let (pre, post) = body.split_once("->").unwrap();
                b.transition(TransitionSpec {
                    id: name.into(),
                    name: name.into(),
                    guard: parse(guard).unwrap(),
                });
                for item in pre.split_whitespace() {
                    arc(&mut b, "", name, ArcKind::Normal, item);
                }
                let mut kind = None;
                for item in post.split_whitespace() {
                    match item {
                        "?" => kind = Some(ArcKind::Read),
                        "!" => kind = Some(ArcKind::Inhibitor),
                        _ => match kind {
                            None => arc(&mut b, name, "", ArcKind::Normal, item),
                            Some(k) => arc(&mut b, "", name, k, item),
                        },
                    }
                }
            }
            _ => panic!("unknown line {line:?}"),
        }
    }
    b.build().unwrap()
}

/// Every marking reachable under interleaving (`Net::is_enabled`/`fire`), breadth first.
pub fn reachable(net: &Net) -> Vec<Marking> {
    let mut seen = vec![net.initial_marking()];
    let mut i = 0;
    while i < seen.len() {
        for t in net.transition_ids() {
            let mut m = seen[i].clone();
            if net.is_enabled(&m, t) {
                net.fire(&mut m, t).unwrap();
                if !seen.contains(&m) {
                    seen.push(m);
                }
            }
        }
        i += 1;
        assert!(seen.len() < 10_000, "test nets are small");
    }
    seen
}
