//! The ST backend writes no empty statement list (IEC 61131-3 has none, and matiec refuses
//! `IF … THEN END_IF;`): for every example, every degenerate net (no places, transitions,
//! inputs or outputs) and random nets, under every step rule, evolution and marking
//! representation.

mod common;

use petriplc_codegen::{generate, Form, Language, Markings, Options, Request};
use petriplc_net::{Evolution, Net, StepRule};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::TestRunner;

const RULES: [(StepRule, Evolution); 4] = [
    (StepRule::MaximalStep, Evolution::OnePass),
    (StepRule::MaximalStep, Evolution::UntilStable),
    (StepRule::Sequential, Evolution::OnePass),
    (StepRule::Sequential, Evolution::UntilStable),
];

/// Every ST program of `net`: each step rule and evolution, BOOL markings when the net
/// allows them, and integer markings.
fn programs(net: &Net) -> Vec<(String, String)> {
    let mut out = Vec::new();
    for (step, evolve) in RULES {
        for markings in [Markings::Bool, Markings::Int] {
            let mut options = Options::of(net);
            (options.step, options.evolve, options.markings) = (step, evolve, markings);
            let request = Request {
                language: Language::St,
                form: Form::Plain,
                options,
                created: common::CREATED.into(),
            };
            if let Ok(g) = generate(net, &request) {
                out.push((format!("{step:?} {evolve:?} {markings:?}"), g.text));
            }
        }
    }
    out
}

/// The ST's words and `;`, upper-cased, comments removed.
fn tokens(st: &str) -> Vec<String> {
    let mut text = String::new();
    let mut rest = st;
    while let Some(i) = rest.find("(*") {
        text.push_str(&rest[..i]);
        let end = rest[i..].find("*)").expect("comment is closed");
        rest = &rest[i + end + 2..];
    }
    text.push_str(rest);
    text.replace(';', " ; ")
        .split_whitespace()
        .map(str::to_ascii_uppercase)
        .collect()
}

/// Fails when a statement list in `st` is empty: a keyword that opens one directly followed
/// by the keyword that closes it, an empty statement (`;;`), or a program with no statement.
fn check(what: &str, st: &str) {
    let t = tokens(st);
    let opens_list = |w: &str| matches!(w, "THEN" | "ELSE" | "REPEAT" | "DO" | "OF");
    let closes_list = |w: &str| {
        matches!(
            w,
            "ELSIF" | "ELSE" | "END_IF" | "UNTIL" | "END_WHILE" | "END_FOR" | "END_CASE"
        )
    };
    for pair in t.windows(2) {
        let (a, b) = (pair[0].as_str(), pair[1].as_str());
        assert!(
            !(opens_list(a) && closes_list(b)),
            "{what}: empty statement list `{a} {b}`\n{st}"
        );
        assert!(!(a == ";" && b == ";"), "{what}: empty statement\n{st}");
    }
    let body = t.iter().rposition(|w| w == "END_VAR").map_or(0, |i| i + 1);
    assert_ne!(
        t.get(body).map(String::as_str),
        Some("END_PROGRAM"),
        "{what}: a program with no statement\n{st}"
    );
}

#[test]
fn the_check_finds_empty_lists() {
    for bad in [
        "PROGRAM p\nIF NOT Unstable THEN END_IF;\nEND_PROGRAM",
        "PROGRAM p\nIF a THEN (* nothing *)\nELSE b := 1; END_IF;\nEND_PROGRAM",
        "PROGRAM p\nREPEAT UNTIL TRUE END_REPEAT;\nEND_PROGRAM",
        "PROGRAM p\nVAR a : BOOL; END_VAR\nEND_PROGRAM",
        "PROGRAM p\na := 1;;\nEND_PROGRAM",
    ] {
        let caught = std::panic::catch_unwind(|| check("bad", bad)).is_err();
        assert!(caught, "not caught: {bad}");
    }
    check(
        "good",
        "PROGRAM p\nIF a THEN b := 1; ELSE b := 2; END_IF;\nEND_PROGRAM",
    );
}

#[test]
fn no_statement_list_is_empty() {
    let mut nets: Vec<(String, Net)> = common::EXAMPLE_NETS
        .iter()
        .map(|(name, _, _)| (name.to_string(), common::example(name)))
        .collect();
    nets.extend(
        common::degenerate_nets()
            .into_iter()
            .map(|(n, net)| (n.to_string(), net)),
    );
    let mut runner = TestRunner::deterministic();
    for i in 0..16 {
        let d = common::random::arb_desc()
            .new_tree(&mut runner)
            .unwrap()
            .current();
        nets.push((format!("random {i}: {d:?}"), common::random::build(&d)));
    }
    for (name, net) in &nets {
        let all = programs(net);
        assert!(!all.is_empty(), "{name}: no ST at all");
        for (mode, st) in all {
            check(&format!("{name} ({mode})"), &st);
        }
    }
}
