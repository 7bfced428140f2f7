//! Textual SFC: what the parser reads and lowers, and what it refuses, at which line.

use super::*;
use crate::source::SourceMap;

/// The diagnostics of `src`, one per line, and the lowered POUs' hidden variable names.
fn run(src: &str) -> (Vec<String>, Vec<String>) {
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = Diagnostics::new();
    let lib = parse(f, src, &mut d);
    let vars = lib
        .elements
        .iter()
        .filter_map(|e| match e {
            Element::Pou(p) => Some(p),
            _ => None,
        })
        .flat_map(|p| &p.var_blocks)
        .flat_map(|b| &b.vars)
        .flat_map(|v| &v.names)
        .map(|n| n.name.clone())
        .collect();
    (d.render(&map).lines().map(str::to_string).collect(), vars)
}

/// `src` in a PROGRAM with `go : BOOL` gives exactly `expect` (diagnostics, in order).
fn check(body: &str, expect: &[&str]) {
    let src = format!("PROGRAM p\nVAR go : BOOL; END_VAR\n{body}\nEND_PROGRAM\n");
    let (diags, _) = run(&src);
    assert_eq!(diags, expect, "{src}");
}

#[test]
fn a_chart_is_lowered_with_its_steps_transitions_and_actions() {
    let src = "PROGRAM p
VAR go, lamp : BOOL; n : INT; END_VAR
INITIAL_STEP s0 : count(N); END_STEP
TRANSITION t1 (PRIORITY := 3) FROM s0 TO (s1, s2) := go; END_TRANSITION
STEP s1 : lamp(L, T#2s); END_STEP
STEP s2 : END_STEP
TRANSITION done FROM (s1, s2) TO s0 : done := NOT go; END_TRANSITION
ACTION count : n := n + 1; END_ACTION
END_PROGRAM";
    let (diags, vars) = run(src);
    assert_eq!(diags, Vec::<String>::new());
    for v in [
        "s0",
        "s1",
        "s2",
        "__s0_t0",
        "__tt1",
        "done",
        "__tdone",
        "count",
        "__sfc_clock",
    ] {
        assert!(vars.iter().any(|x| x == v), "{v} not in {vars:?}");
    }
}

#[test]
fn chart_words_are_not_reserved_elsewhere() {
    let (diags, _) =
        run("PROGRAM p\nVAR step, action : INT; END_VAR\nstep := action + 1;\nEND_PROGRAM");
    assert_eq!(diags, Vec::<String>::new());
}

#[test]
fn a_transition_from_an_undeclared_step_is_told_at_its_name() {
    check(
        "INITIAL_STEP s0 : END_STEP\nTRANSITION FROM s0 TO s9 := go; END_TRANSITION",
        &["t.st:4:23: error[E030]: the transition goes to step s9, which the chart does not declare; declare it with `STEP s9 : END_STEP`"],
    );
}

#[test]
fn two_initial_steps_in_one_network_are_refused() {
    check(
        "INITIAL_STEP a : END_STEP\nINITIAL_STEP b : END_STEP\nTRANSITION FROM a TO b := go; END_TRANSITION\nTRANSITION FROM b TO a := go; END_TRANSITION",
        &["t.st:4:14: error[E030]: step b is a second initial step of the network of a (whose initial step is a); a network of steps has one INITIAL_STEP: make this a STEP"],
    );
}

#[test]
fn two_networks_each_with_its_initial_step_are_accepted() {
    check(
        "INITIAL_STEP a : END_STEP\nINITIAL_STEP b : END_STEP\nSTEP a2 : END_STEP\nTRANSITION FROM a TO a2 := go; END_TRANSITION\nTRANSITION FROM a2 TO a := go; END_TRANSITION",
        &[],
    );
}

#[test]
fn a_chart_without_initial_step_is_refused() {
    check(
        "STEP a : END_STEP\nSTEP b : END_STEP\nTRANSITION FROM a TO b := go; END_TRANSITION",
        &["t.st:3:6: error[E030]: the chart has no INITIAL_STEP, so no step is ever active; make the first step `INITIAL_STEP`"],
    );
}

#[test]
fn an_unreachable_step_and_an_unused_action_are_warned() {
    check(
        "INITIAL_STEP a : END_STEP\nSTEP b : END_STEP\nTRANSITION FROM b TO a := go; END_TRANSITION\nACTION x : go := TRUE; END_ACTION",
        &[
            "t.st:6:8: warning[W033]: action x is associated with no step, so it never runs; associate it with a step (`x(N);`) or remove it",
            "t.st:4:6: warning[W033]: step b can never become active: no transition from a step reachable from an INITIAL_STEP leads to it; add a TRANSITION … TO b or remove it",
        ],
    );
}

#[test]
fn statements_mixed_with_steps_are_refused_clearly() {
    check(
        "go := TRUE;\nINITIAL_STEP a : END_STEP",
        &["t.st:3:1: error[E031]: this body is a chart (it has steps), so it holds only STEP, TRANSITION and ACTION blocks; put these statements in an ACTION … END_ACTION and associate it with a step (`A(N);`)"],
    );
}

#[test]
fn qualifiers_are_checked() {
    check(
        "INITIAL_STEP a : go(X); go(L); END_STEP\nTRANSITION FROM a TO a := go; END_TRANSITION",
        &[
            "t.st:3:21: error[E030]: `X` is not an action qualifier; write one of N, R, S, L, D, P, P0, P1, SD, DS or SL",
            "t.st:3:28: error[E030]: qualifier L needs a duration: `go(L, T#2s);`",
        ],
    );
    check(
        "INITIAL_STEP a : go(SD); END_STEP",
        &["t.st:3:21: error[E030]: qualifier SD needs a duration: `go(SD, T#2s);`"],
    );
}

#[test]
fn a_transition_body_needs_the_transition_named() {
    check(
        "INITIAL_STEP a : END_STEP\nTRANSITION FROM a TO a : go := TRUE; END_TRANSITION",
        &["t.st:4:1: error[E030]: a transition whose condition is a body assigns its name, so it needs one: `TRANSITION t1 FROM s1 TO s2 : t1 := a; END_TRANSITION` (or write `:= condition;`)"],
    );
}

#[test]
fn a_step_declared_twice_names_the_first() {
    check(
        "INITIAL_STEP a : END_STEP\nSTEP A : END_STEP",
        &["t.st:4:6: error[E030]: step A is declared twice (first at 3:14); give each step its own name"],
    );
}

#[test]
fn unclosed_elements_are_told() {
    check(
        "INITIAL_STEP a : go(N);\nTRANSITION FROM a TO a := go; END_TRANSITION",
        &["t.st:4:1: error[E011]: STEP a has no END_STEP; found `TRANSITION`"],
    );
    check(
        "INITIAL_STEP a : END_STEP\nACTION x : go := TRUE;",
        &["t.st:4:12: error[E011]: ACTION x has no END_ACTION; close it with END_ACTION"],
    );
}

#[test]
fn an_il_condition_is_not_supported_yet() {
    check(
        "INITIAL_STEP a : END_STEP\nTRANSITION FROM a TO a : LD go END_TRANSITION",
        &["t.st:4:26: error[E190]: a transition condition in IL is not supported yet; write it in ST: `:= a AND b;`"],
    );
}

#[test]
fn a_function_cannot_hold_a_chart() {
    let (diags, _) = run("FUNCTION f : BOOL\nINITIAL_STEP a : END_STEP\nEND_FUNCTION");
    assert_eq!(
        diags,
        ["t.st:2:1: error[E030]: a FUNCTION cannot hold a chart: its steps would not be kept between calls; make it a FUNCTION_BLOCK or a PROGRAM"]
    );
}
