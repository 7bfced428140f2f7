//! What petriplc writes validates against the PNML grammars with xmllint: ptnet.pntd for
//! normal nets, the inhibitorptnet extension for inhibitor nets, and petriplc's
//! readinhibitorptnet.pntd for nets with read arcs, all with every petriplc feature.

mod common;

use std::time::Duration;

use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, Net, NetBuilder, PlaceSpec, SignalDirection, SignalType, StepRule,
    TransitionSpec,
};
use petriplc_pnml::{read_str, write_string, ReadOptions};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

use common::{nets, xmllint, READ_SCHEMA, SCHEMAS};

fn ptnet() -> String {
    format!("{SCHEMAS}/ptnet.pntd")
}

fn inhibitor() -> String {
    format!("{SCHEMAS}/extensions/inhibitorptnet.pntd")
}

/// A net using every petriplc feature, with arcs of the kinds given besides normal ones.
fn featured(special: &[ArcKind]) -> Net {
    let mut b = NetBuilder::new("mixer", "Mixer & <tank>");
    b.step(StepRule::Sequential).evolve(Evolution::UntilStable);
    b.signal("Level", SignalDirection::Input, SignalType::Int);
    b.signal("Count", SignalDirection::Output, SignalType::Int);
    b.place(PlaceSpec {
        id: "idle".into(),
        name: "Idle".into(),
        initial: 1,
        capacity: Some(1),
        output: Some("L1".into()),
        input: None,
    });
    b.place(PlaceSpec {
        id: "busy".into(),
        output: Some("Count".into()),
        ..Default::default()
    });
    b.place(PlaceSpec {
        id: "sensor".into(),
        input: Some("B1".into()),
        ..Default::default()
    });
    b.transition(TransitionSpec {
        id: "start".into(),
        name: "start".into(),
        guard: parse("B1 AND NOT (Level >= 3) OR N2 XOR TRUE").unwrap(),
    });
    let stop = b.transition(TransitionSpec {
        id: "stop".into(),
        name: String::new(),
        guard: parse("").unwrap(),
    });
    b.deadline(stop, Duration::from_secs(2));
    let arc = |id: &str, source: &str, target: &str, kind, weight, delay| ArcSpec {
        id: id.into(),
        source: source.into(),
        target: target.into(),
        kind,
        weight,
        delay,
    };
    b.arc(arc(
        "a1",
        "idle",
        "start",
        ArcKind::Normal,
        1,
        Some(Duration::from_millis(500)),
    ));
    b.arc(arc("a2", "start", "busy", ArcKind::Normal, 2, None));
    b.arc(arc("a3", "busy", "stop", ArcKind::Normal, 2, None));
    b.arc(arc("a4", "stop", "idle", ArcKind::Normal, 1, None));
    for (i, kind) in special.iter().enumerate() {
        let delay = (*kind == ArcKind::Read).then(|| Duration::from_secs(2));
        b.arc(arc(&format!("s{i}"), "sensor", "start", *kind, 1, delay));
        b.arc(arc(&format!("b{i}"), "busy", "start", *kind, 3, None));
    }
    b.build().expect("the featured net is valid")
}

/// Writes `net`, checks it validates against `schema` and reads back equal.
fn check(net: &Net, schema: &str) -> String {
    let text = write_string(net, None);
    if let Err(e) = xmllint(schema, &text) {
        panic!("{e}\n--- written ---\n{text}");
    }
    let back = read_str(&text, "w.pnml", &ReadOptions::default()).expect("reads back");
    assert_eq!(&back.net, net);
    text
}

#[test]
fn normal_nets_validate_against_ptnet() {
    let text = check(&featured(&[]), &ptnet());
    assert!(text.contains("type=\"http://www.pnml.org/version-2009/grammar/ptnet\""));
    assert!(!text.contains("arctype"));
}

#[test]
fn inhibitor_nets_validate_against_the_inhibitor_extension() {
    let net = featured(&[ArcKind::Inhibitor]);
    let text = check(&net, &inhibitor());
    assert_eq!(text.matches("<arctype>").count(), net.arcs().len());
    assert!(
        xmllint(&ptnet(), &text).is_err(),
        "ptnet.pntd must refuse arc types"
    );
    // Our grammar is a superset, so it takes inhibitor nets too.
    check(&net, READ_SCHEMA);
}

#[test]
fn read_arcs_validate_against_petriplcs_grammar() {
    let net = featured(&[ArcKind::Read, ArcKind::Inhibitor]);
    let text = check(&net, READ_SCHEMA);
    assert!(text.contains("<arctype>read</arctype>"));
    assert!(
        xmllint(&inhibitor(), &text).is_err(),
        "the shipped inhibitor grammar must refuse read arcs, or ours is not needed"
    );
    let reset = text.replacen("<arctype>read</arctype>", "<arctype>reset</arctype>", 1);
    assert!(
        xmllint(READ_SCHEMA, &reset).is_err(),
        "our grammar must refuse reset arcs"
    );
}

#[test]
fn random_nets_validate_against_their_grammar() {
    let mut runner = TestRunner::new(Config {
        cases: 24,
        ..Config::default()
    });
    runner
        .run(&nets::plan(), |plan| {
            let net = nets::build(&plan);
            let kinds: Vec<ArcKind> = net.arcs().iter().map(|a| a.kind).collect();
            let schema = if kinds.contains(&ArcKind::Read) {
                READ_SCHEMA.to_string()
            } else if kinds.contains(&ArcKind::Inhibitor) {
                inhibitor()
            } else {
                ptnet()
            };
            let text = write_string(&net, None);
            prop_assert!(
                xmllint(&schema, &text).is_ok(),
                "{:?}\n{}",
                xmllint(&schema, &text),
                text
            );
            Ok(())
        })
        .unwrap();
}
