//! A one-line net notation for unit tests, so each test states its net next to its answer.
//!
//! `a=2 b c<1 i? ; t: a -> b*2 ?c !i ; u: b -> a` declares places (`=` initial tokens, `<`
//! capacity, a trailing `?` an input place) and then transitions: arcs before `->` consume,
//! after it produce, `?p` is a read arc and `!p*2` an inhibitor arc wherever they stand.

use petriplc_net::{ArcKind, ArcSpec, Net, NetBuilder, PlaceSpec, TransitionSpec};

fn weighted(s: &str) -> (&str, u32) {
    match s.split_once('*') {
        Some((p, w)) => (p, w.parse().expect("weight")),
        None => (s, 1),
    }
}

/// Builds the net `text` describes; panics on a typo (tests only).
pub(crate) fn parse(text: &str) -> Net {
    let mut b = NetBuilder::new("net", "net");
    let mut sections = text.split(';');
    for decl in sections.next().unwrap_or("").split_whitespace() {
        let (decl, input) = match decl.strip_suffix('?') {
            Some(d) => (d, true),
            None => (decl, false),
        };
        let (decl, capacity) = match decl.split_once('<') {
            Some((d, c)) => (d, Some(c.parse().expect("capacity"))),
            None => (decl, None),
        };
        let (name, initial) = match decl.split_once('=') {
            Some((n, v)) => (n, v.parse().expect("initial")),
            None => (decl, 0),
        };
        b.place(PlaceSpec {
            id: name.into(),
            name: name.into(),
            initial,
            capacity,
            input: input.then(|| name.to_uppercase()),
            ..Default::default()
        });
    }
    let mut arcs = 0;
    for tr in sections {
        let (name, body) = tr.split_once(':').expect("transition `name: ...`");
        let name = name.trim();
        b.transition(TransitionSpec {
            id: name.into(),
            name: name.into(),
            guard: petriplc_net::guard::parse("").expect("empty guard"),
        });
        let mut after = false;
        for tok in body.split_whitespace() {
            if tok == "->" {
                after = true;
                continue;
            }
            let (kind, tok) = if let Some(r) = tok.strip_prefix('?') {
                (ArcKind::Read, r)
            } else if let Some(r) = tok.strip_prefix('!') {
                (ArcKind::Inhibitor, r)
            } else {
                (ArcKind::Normal, tok)
            };
            let (place, weight) = weighted(tok);
            let (source, target) = if after && kind == ArcKind::Normal {
                (name.to_string(), place.to_string())
            } else {
                (place.to_string(), name.to_string())
            };
            arcs += 1;
            b.arc(ArcSpec {
                id: format!("arc{arcs}"),
                source,
                target,
                kind,
                weight,
                delay: None,
            });
        }
    }
    b.build()
        .unwrap_or_else(|e| panic!("bad test net {text:?}: {e:?}"))
}
