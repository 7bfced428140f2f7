//! CODESYS and TwinCAT forms beyond the standard: the short-circuit `AND_THEN` and `OR_ELSE`,
//! `REFERENCE TO` and `STRUCT EXTENDS` (`UNION`: union_tests.rs); what is accepted and the errors around them.

use crate::tests::{check_diags, run};

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

#[test]
fn reference_to_binds_with_ref_assign_and_is_refused_where_it_cannot_work() {
    check_diags(
        "FUNCTION_BLOCK fb\nVAR_INPUT x : INT; END_VAR\nEND_FUNCTION_BLOCK\n\
         FUNCTION f : REFERENCE TO INT\nVAR_INPUT i : INT; END_VAR\nEND_FUNCTION\n\
         PROGRAM p\nVAR x, y : INT; z : REAL; r : REFERENCE TO INT; rf : REFERENCE TO fb; rr : REFERENCE TO REFERENCE TO INT; END_VAR\n\
         VAR_TEMP t : INT; END_VAR\n\
         r REF= x + 1;\nr REF= z;\nx REF= y;\nr REF= t;\ny := __ISVALIDREF(x);\nEND_PROGRAM\n",
        &[
            "t.st:8:76: error[E190]: a REFERENCE TO cannot designate another REFERENCE TO",
            "t.st:10:8: error[E220]: `REF=` binds a REFERENCE TO to a variable, not to an expression's value",
            "t.st:11:8: error[E220]: `REF=` binds a REFERENCE TO INT to a variable of that type; this is REAL",
            "t.st:12:1: error[E220]: `REF=` binds a REFERENCE TO; this is INT: assign it with `:=`",
            "t.st:13:8: error[E201]: a pointer to this PROGRAM's own variables is stored in `r`",
            "t.st:14:19: error[E200]: __ISVALIDREF tests a REFERENCE TO; this is INT",
        ],
    );
    // A REFERENCE TO result: bound inside, passed on by a call of the same type only; a
    // FUNCTION's own variable does not outlive the call; a call's result is not a target.
    check_diags(
        "FUNCTION f : REFERENCE TO INT\nVAR i : INT; END_VAR\nf REF= i;\nEND_FUNCTION\n\
         FUNCTION g : REFERENCE TO REAL\nEND_FUNCTION\n\
         FUNCTION h : INT\nEND_FUNCTION\n\
         PROGRAM p\nVAR x : INT; r : REFERENCE TO INT; END_VAR\n\
         r REF= f();\nx := f() + 1;\nr REF= g();\nr REF= h();\nf() REF= x;\nEND_PROGRAM\n",
        &[
            "t.st:3:8: error[E201]",
            "t.st:13:8: error[E220]: `REF=` binds a REFERENCE TO INT to a variable of that type, or to a call giving a REFERENCE TO INT; this call gives REFERENCE TO REAL",
            "t.st:14:8: error[E220]: `REF=` binds a REFERENCE TO INT to a variable of that type, or to a call giving a REFERENCE TO INT; this call gives INT",
            "t.st:15:1: error[E220]: `REF=` binds a REFERENCE TO variable; a call's result is bound inside the call",
        ],
    );
    // An input binds to the variable given; an expression cannot be bound.
    check_diags(
        "FUNCTION_BLOCK fb\nVAR_INPUT r : REFERENCE TO INT; END_VAR\nr := r + 1;\nEND_FUNCTION_BLOCK\n\
         PROGRAM p\nVAR x : INT; f : fb; END_VAR\nf(r := x);\nf(r := x + 1);\nEND_PROGRAM\n",
        &["t.st:8:8: error[E220]: argument `r` binds a REFERENCE TO to a variable, not to an expression's value"],
    );
}

#[test]
fn a_caret_after_a_reference_is_redundant_and_warned() {
    check_diags(
        "PROGRAM p\nVAR x, y : INT; r : REFERENCE TO INT; END_VAR\nr REF= x;\ny := r^;\nr := y;\nEND_PROGRAM\n",
        &["t.st:4:6: warning[W040]: this is a REFERENCE TO INT, dereferenced where it is used: the `^` is redundant"],
    );
}

#[test]
fn a_function_without_a_result_type_is_codesys_and_twincat_only() {
    let src = "FUNCTION F_Set\nVAR_IN_OUT x : INT; END_VAR\nx := 1;\nEND_FUNCTION\n\
               PROGRAM p\nVAR v : INT; END_VAR\nF_Set(x := v);\nEND_PROGRAM\n";
    check_diags(
        src,
        &["t.st:1:10: error[E010]: a FUNCTION declares its result type: FUNCTION F_Set : INT (CODESYS and TwinCAT take one without"],
    );
    let twincat = format!("{{attribute 'TcTypeSystem'}}\n{src}");
    let (p, text) = crate::tests::run_dialect(&twincat, petriplc_iec_syntax::Dialect::Twincat);
    assert!(p.is_some() && !text.contains("error["), "{text}");
    // It has no value to use: assigned, the call runs and the variable stays (W052).
    let (p, text) = crate::tests::run_dialect(
        "FUNCTION F_Set\nEND_FUNCTION\nPROGRAM p\nVAR v : INT; END_VAR\nv := F_Set();\nEND_PROGRAM\n",
        petriplc_iec_syntax::Dialect::Codesys,
    );
    assert!(p.is_some() && text.contains("warning[W052]"), "{text}");
}

#[test]
fn var_stat_is_one_variable_for_every_instance() {
    check_diags(
        "FUNCTION_BLOCK FB_A\nVAR_STAT n : INT; END_VAR\nn := n + 1;\nEND_FUNCTION_BLOCK\n\
         PROGRAM p\nVAR a, b : FB_A; END_VAR\na(); b();\nEND_PROGRAM\n",
        &[],
    );
    let (p, text) = run(
        "FUNCTION_BLOCK FB_A\nVAR_STAT n : INT; END_VAR\nn := n + 1;\nEND_FUNCTION_BLOCK\nPROGRAM p\nVAR a : FB_A; END_VAR\na();\nEND_PROGRAM\n",
    );
    let p = p.unwrap_or_else(|| panic!("{text}"));
    let names: Vec<&str> = p.globals.iter().map(|g| g.name.as_str()).collect();
    assert_eq!(names, ["FB_A.$stat.n"]);
    // A static is no instance member: the instance does not name it.
    check_diags(
        "FUNCTION_BLOCK FB_A\nVAR_STAT n : INT; END_VAR\nEND_FUNCTION_BLOCK\n\
         PROGRAM p\nVAR a : FB_A; x : INT; END_VAR\nx := a.n;\nEND_PROGRAM\n",
        &["error[E1"],
    );
}

#[test]
fn a_block_with_an_instance_in_a_function_keeps_no_pointer_to_itself_beyond_the_call() {
    let leak = "FUNCTION_BLOCK FB_L\nVAR k : INT; END_VAR\nVAR_EXTERNAL gp : POINTER TO INT; END_VAR\ngp := ADR(k);\nEND_FUNCTION_BLOCK\n\
                VAR_GLOBAL gp : POINTER TO INT; END_VAR\n";
    // Instantiated in a program only: the instance lasts, the pointer may be kept.
    let (p, text) = crate::tests::run_dialect(
        &format!("{leak}PROGRAM main\nVAR l : FB_L; END_VAR\nl();\nEND_PROGRAM\n"),
        petriplc_iec_syntax::Dialect::Twincat,
    );
    assert!(p.is_some(), "{text}");
    // In a FUNCTION's frame (or a METHOD's), directly or in an array: E201.
    for decl in ["l : FB_L;", "ls : ARRAY[1..2] OF FB_L;"] {
        let (p, text) = crate::tests::run_dialect(
            &format!("{leak}FUNCTION F : INT\nVAR {decl} END_VAR\nF := 1;\nEND_FUNCTION\nPROGRAM main\nVAR x : INT; END_VAR\nx := F();\nEND_PROGRAM\n"),
            petriplc_iec_syntax::Dialect::Twincat,
        );
        assert!(
            p.is_none()
                && text.contains("t.st:4:7: error[E201]")
                && text.contains("an instance of this block is a FUNCTION's or METHOD's variable"),
            "{decl}: {text}"
        );
    }
    // A METHOD keeps pointers to its block's variables in the block (THIS lasts).
    let (p, text) = crate::tests::run_dialect(
        "FUNCTION_BLOCK FB_M\nVAR k : INT; p : POINTER TO INT; END_VAR\nMETHOD Bind\np := ADR(k);\nEND_METHOD\nEND_FUNCTION_BLOCK\n\
         PROGRAM main\nVAR m : FB_M; END_VAR\nm.Bind();\nEND_PROGRAM\n",
        petriplc_iec_syntax::Dialect::Twincat,
    );
    assert!(p.is_some(), "{text}");
}

#[test]
fn named_and_positional_arguments_mix_in_the_codesys_family() {
    use petriplc_iec_syntax::Dialect;
    let src = "FUNCTION f : INT\nVAR_INPUT a, b : INT; END_VAR\nf := a * 10 + b;\nEND_FUNCTION\n\
               PROGRAM p\nVAR x : INT; END_VAR\nx := f(a := 1, 2);\nx := f(1, a := 2);\nEND_PROGRAM\n";
    let (_, text) = crate::tests::run_dialect(src, Dialect::Codesys);
    // The second call gives `a` twice: its first argument is parameter 1, `a`.
    assert_eq!(
        text.trim(),
        "t.st:8:11: error[E130]: parameter `a` is given twice",
        "{text}"
    );
    let (_, text) = crate::tests::run_dialect(src, Dialect::Iec);
    assert!(
        text.contains("t.st:7:6: error[E130]: the call of f mixes named (x := …) and positional arguments; name them all (CODESYS and TwinCAT take argument k without a name as parameter k"),
        "{text}"
    );
}

#[test]
fn a_function_returns_an_instance_in_the_codesys_family_only() {
    use petriplc_iec_syntax::Dialect;
    let src = "FUNCTION_BLOCK fb\nVAR_OUTPUT q : INT; END_VAR\nEND_FUNCTION_BLOCK\n\
               FUNCTION f : fb\nEND_FUNCTION\n\
               PROGRAM p\nVAR x : fb; END_VAR\nx := f();\nEND_PROGRAM\n";
    let (p, text) = crate::tests::run_dialect(src, Dialect::Codesys);
    assert!(p.is_some(), "{text}");
    let (_, text) = crate::tests::run_dialect(src, Dialect::Iec);
    assert!(
        text.contains("t.st:4:10: error[E109]: a function cannot return a function block instance (CODESYS and TwinCAT return a copy of one"),
        "{text}"
    );
}
