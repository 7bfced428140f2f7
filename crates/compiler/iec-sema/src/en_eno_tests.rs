//! EN/ENO on calls: what is accepted, and the diagnostics of misused EN and ENO.

use crate::ir;
use crate::tests::run;

/// `expect` has one entry per diagnostic line, in order: fragments of the line separated by
/// `|` (empty: no diagnostic, and a project).
fn check(src: &str, expect: &[&str]) -> Option<ir::Project> {
    let (p, d) = run(src);
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), expect.len(), "got:\n{d}");
    for (l, e) in lines.iter().zip(expect) {
        for f in e.split('|') {
            assert!(l.contains(f), "expected `{f}` in\n{l}\n(all:\n{d})");
        }
    }
    assert_eq!(p.is_some(), expect.is_empty(), "{d}");
    p
}

const FNS: &str = "FUNCTION twice : INT VAR_INPUT x : INT; END_VAR twice := 2 * x; END_FUNCTION
FUNCTION guarded : INT VAR_INPUT x : INT; END_VAR
IF x < 0 THEN ENO := FALSE; END_IF; guarded := x + 1; END_FUNCTION
FUNCTION_BLOCK count VAR_INPUT up : BOOL; END_VAR VAR_OUTPUT n : INT; END_VAR
IF up THEN n := n + 1; END_IF; END_FUNCTION_BLOCK
";

fn prog(decls: &str, body: &str) -> String {
    format!("{FNS}PROGRAM p\nVAR\n{decls}\nEND_VAR\n{body}\nEND_PROGRAM\n")
}

const VARS: &str = "c, ok : BOOL; i : INT; r : REAL; k : count; t : TON;";

#[test]
fn accepted_forms() {
    check(
        &prog(
            VARS,
            "i := twice(EN := c, x := 3, ENO => ok);
             r := (ADD(EN := c, IN1 := 1.5, IN2 := r, ENO => ok));
             twice(EN := c, x := 1);
             k(EN := c, up := TRUE, ENO => ok, n => i);
             t(EN := NOT c, IN := TRUE, PT := T#1s, NOT ENO => ok);
             i := twice(x := 1, ENO => ok);
             i := 1 + guarded(EN := c, x := i, ENO => ok);
             i := guarded(i);",
        ),
        &[],
    );
}

#[test]
fn implicit_en_eno_are_parameters_of_the_pou() {
    let p = check(&prog(VARS, "i := guarded(x := 1);"), &[]).unwrap();
    let g = p.pous.iter().find(|q| q.name == "guarded").unwrap();
    let en = g.var_by_name("EN").unwrap() as usize;
    let eno = g.var_by_name("ENO").unwrap() as usize;
    assert_eq!(g.vars[en].class, ir::VarClass::Input);
    assert_eq!(g.vars[eno].class, ir::VarClass::Output);
    // A POU that never names EN/ENO gets neither.
    let t = p.pous.iter().find(|q| q.name == "twice").unwrap();
    assert!(t.var_by_name("EN").is_none());
}

#[test]
fn en_misused() {
    check(
        &prog(VARS, "i := twice(EN => ok, x := 3);"),
        &["error[E130]: EN is an input"],
    );
    check(
        &prog(VARS, "i := twice(EN := i, x := 3);"),
        &["error[E112]|condition must be BOOL"],
    );
    check(
        &prog(VARS, "i := twice(EN := c, EN := ok, x := 3);"),
        &["error[E130]|once each"],
    );
    check(
        &prog(VARS, "k(EN := c, TRUE);"),
        &["error[E130]|names all its arguments"],
    );
}

#[test]
fn eno_misused() {
    check(
        &prog(VARS, "i := twice(ENO := ok, x := 3);"),
        &["error[E130]: ENO is an output"],
    );
    check(
        &prog(VARS, "i := twice(EN := c, x := 3, ENO => i);"),
        &["error[E110]|ENO is BOOL and cannot be stored in INT"],
    );
}

#[test]
fn en_inside_an_expression_runs_before_the_statement() {
    check(
        &prog(
            VARS,
            "i := 1 + twice(EN := c, x := 3, ENO => ok);
             r := 2.0 * ADD(EN := c, IN1 := 1.5, IN2 := r);
             k(up := twice(EN := c, x := 1) > 0);
             i := twice(EN := c, x := twice(EN := ok, x := 2));",
        ),
        &[],
    );
}

#[test]
fn en_inside_a_condition_is_refused() {
    check(
        &prog(VARS, "IF twice(EN := c, x := 3) > 0 THEN i := 1; END_IF;"),
        &["error[E190]|twice has no EN/ENO of its own|not in a condition"],
    );
    check(
        &prog(
            VARS,
            "WHILE ADD(EN := c, IN1 := i, IN2 := 1) < 3 DO i := i + 1; END_WHILE;",
        ),
        &["error[E190]|ADD has no EN/ENO of its own"],
    );
    check(
        &prog(VARS, "i := 1 + twice(EN := i, x := 3);"),
        &["error[E112]|condition must be BOOL"],
    );
}

/// Instruction List: `CAL` with EN and ENO; a function given EN in IL's current result has
/// nothing to run before it.
#[test]
fn il_cal_with_en_and_a_function_given_en() {
    let run_il = |body: &str| {
        let src = format!(
            "PROGRAM p\nVAR\nc, ok : BOOL; i : INT; k : CTU;\nEND_VAR\n{body}\nEND_PROGRAM\n"
        );
        crate::il_tests::run(&src)
    };
    let (p, d) = run_il("  CAL k(EN := c, CU := TRUE, PV := 3, ENO => ok, CV => i)");
    assert!(p.is_some() && d.is_empty(), "{d}");
    let (p, d) = run_il("  LIMIT(EN := c, MN := 0, IN := i, MX := 9)\n  ST i");
    assert!(p.is_none(), "{d}");
    assert!(
        d.contains("error[E190]") && d.contains("LIMIT has no EN/ENO of its own"),
        "{d}"
    );
}
