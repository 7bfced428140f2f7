//! What other compilers (matiec, CODESYS, TwinCAT, PCWorx) accept and the standard does not:
//! accepted with a warning, and where it stays refused.

use petriplc_iec_syntax::{parser, SourceMap};

use crate::{check, Options};

/// Checks `src`; every rendered diagnostic line must contain the fragment at its place in
/// `expect`, and there must be as many.
fn check_diags(src: &str, expect: &[&str]) {
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, src, &mut d);
    assert!(!d.has_errors(), "syntax: {}", d.render(&map));
    let (p, diags) = check(&lib, &Options::default());
    let text = diags.render(&map);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), expect.len(), "got:\n{text}");
    for (l, e) in lines.iter().zip(expect) {
        assert!(l.contains(e), "expected `{e}` in\n{l}\n(all:\n{text})");
    }
    assert_eq!(p.is_some(), !text.contains("error["), "{text}");
}

const FB: &str = "FUNCTION_BLOCK fb\nVAR n : INT; END_VAR\nVAR CONSTANT k : INT := 3; END_VAR\nVAR_TEMP t : INT; END_VAR\nn := n + 1;\nEND_FUNCTION_BLOCK\n";

#[test]
fn an_instance_internal_variable_is_read_and_set_with_a_warning() {
    check_diags(
        &format!("{FB}PROGRAM p\nVAR f : fb; x : INT; END_VAR\nf.n := 5;\nf();\nx := f.n + f.k;\nEND_PROGRAM\n"),
        &[
            "t.st:9:3: warning[W030]: `n` is internal to fb (its VAR)",
            "t.st:11:8: warning[W030]: `n` is internal to fb",
            "t.st:11:14: warning[W030]: `k` is internal to fb",
        ],
    );
}

#[test]
fn an_instance_constant_or_temporary_stays_out_of_reach() {
    check_diags(
        &format!(
            "{FB}PROGRAM p\nVAR f : fb; x : INT; END_VAR\nf.k := 5;\nx := f.t;\nEND_PROGRAM\n"
        ),
        &[
            "t.st:9:1: error[E121]: `k` is a CONSTANT of fb and cannot be assigned",
            "t.st:10:8: error[E105]: `t` is internal to fb; only its inputs and outputs",
        ],
    );
}

#[test]
fn a_for_variable_assigned_in_the_body_is_a_warning() {
    check_diags(
        "PROGRAM p\nVAR i : INT; n : INT; END_VAR\nFOR i := 1 TO 10 DO\n  i := i + 1;\n  n := n + 1;\nEND_FOR;\nEND_PROGRAM\n",
        &["t.st:4:3: warning[W031]: `i` controls the FOR loop around this statement"],
    );
}
