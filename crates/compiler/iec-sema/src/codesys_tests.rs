//! CODESYS and TwinCAT forms beyond the standard: the short-circuit `AND_THEN` and `OR_ELSE`,
//! `REFERENCE TO`, `UNION` and `STRUCT EXTENDS`; what is accepted and the errors around them.

use crate::tests::run;

/// Checks `src`; every rendered diagnostic line must contain the fragment at its place in
/// `expect`, and there must be as many.
fn check_diags(src: &str, expect: &[&str]) {
    let (p, text) = run(src);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), expect.len(), "got:\n{text}");
    for (l, e) in lines.iter().zip(expect) {
        assert!(l.contains(e), "expected `{e}` in\n{l}\n(all:\n{text})");
    }
    assert_eq!(p.is_some(), !text.contains("error["), "{text}");
}

#[test]
fn and_then_and_or_else_take_bool_only() {
    check_diags(
        "PROGRAM p\nVAR a, b : BOOL; w : WORD; END_VAR\na := a AND_THEN b OR_ELSE NOT a;\nEND_PROGRAM\n",
        &[],
    );
    check_diags(
        "PROGRAM p\nVAR a : BOOL; w : WORD; END_VAR\na := a AND_THEN w;\nw := w OR_ELSE w;\nEND_PROGRAM\n",
        &[
            "t.st:3:17: error[E111]: `AND_THEN` applies to BOOL only, not WORD; for bit strings use `AND`",
            "t.st:4:6: error[E111]: `OR_ELSE` applies to BOOL only, not WORD; for bit strings use `OR`",
        ],
    );
    // Not reserved: a variable may still be called so.
    check_diags(
        "PROGRAM p\nVAR and_then : BOOL; END_VAR\nand_then := TRUE;\nEND_PROGRAM\n",
        &[],
    );
}

#[test]
fn a_constant_left_operand_decides_at_compile_time() {
    let (p, text) = run(
        "PROGRAM p\nVAR a : BOOL; END_VAR\na := FALSE AND_THEN a;\na := TRUE OR_ELSE a;\nEND_PROGRAM\n",
    );
    let p = p.unwrap_or_else(|| panic!("{text}"));
    let body = format!("{:?}", p.pous.last().map(|u| &u.body));
    assert!(
        !body.contains("AndThen") && !body.contains("OrElse"),
        "{body}"
    );
}

#[test]
fn a_structure_extends_a_structure_only() {
    check_diags(
        "TYPE B : STRUCT a : INT; END_STRUCT END_TYPE\nTYPE E : (X, Y); END_TYPE\n\
         TYPE S EXTENDS E : STRUCT c : INT; END_STRUCT END_TYPE\n\
         TYPE S2 EXTENDS Nope : STRUCT c : INT; END_STRUCT END_TYPE\n\
         TYPE S3 EXTENDS B : STRUCT a : INT; END_STRUCT END_TYPE\n\
         TYPE S4 EXTENDS S4 : STRUCT a : INT; END_STRUCT END_TYPE\n\
         PROGRAM p\nVAR s : S; s2 : S2; s3 : S3; s4 : S4; END_VAR\nEND_PROGRAM\n",
        &[
            "t.st:3:16: error[E109]: a structure extends a structure; E is not one",
            "t.st:4:17: error[E101]: unknown type `Nope`",
            "t.st:5:28: error[E103]: field `a` is declared twice in S3",
            "t.st:6:17: error[E107]: type S4 contains itself",
        ],
    );
    // The base's fields first: a field of the base is reached by its name.
    check_diags(
        "TYPE S EXTENDS B : STRUCT c : INT; END_STRUCT END_TYPE\nTYPE B : STRUCT a : INT; END_STRUCT END_TYPE\n\
         PROGRAM p\nVAR s : S; END_VAR\ns.a := s.c;\nEND_PROGRAM\n",
        &[],
    );
}
