//! The syntax CODESYS 3, TwinCAT 3, matiec and PCWorx accept beyond the standard's letter
//! (docs/iec.md, "Dialects and vendor code"), and recovery that invents no second error.

use super::*;
use crate::source::SourceMap;

fn diags_of(src: &str) -> (Library, String) {
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = Diagnostics::new();
    let lib = parse(f, src, &mut d);
    (lib, d.render(&map))
}

fn check_ok(src: &str) -> Library {
    let (lib, d) = diags_of(src);
    assert_eq!(d, "", "{src}");
    lib
}

fn body(lib: &Library) -> &[Stmt] {
    for e in &lib.elements {
        if let Element::Pou(p) = e {
            if let Body::St(b) = &p.body {
                return b;
            }
        }
    }
    panic!("no ST body")
}

#[test]
fn end_struct_and_the_last_type_need_no_semicolon_before_end_type() {
    let lib = check_ok(
        "TYPE pt :\nSTRUCT\n  x : INT;\n  y : INT;\nEND_STRUCT\nEND_TYPE\n\
         TYPE n : INT END_TYPE\n\
         TYPE a : STRUCT x : INT; END_STRUCT b : INT; END_TYPE",
    );
    let names: Vec<String> = lib
        .elements
        .iter()
        .flat_map(|e| match e {
            Element::Types(t) => t.iter().map(|d| d.name.name.clone()).collect(),
            _ => vec![],
        })
        .collect();
    assert_eq!(names, ["pt", "n", "a", "b"]);
    // Between two declarations that are not STRUCTs, the `;` is still required.
    let (_, d) = diags_of("TYPE a : INT b : INT; END_TYPE");
    assert_eq!(
        d,
        "t.st:1:13: error[E012]: expected `;` after this, found `b`\n"
    );
}

#[test]
fn end_of_a_compound_statement_needs_no_semicolon() {
    let lib = check_ok(
        "PROGRAM p\nVAR x : INT; END_VAR\n\
         IF x > 0 THEN x := 1; END_IF\n\
         FOR x := 1 TO 3 DO x := x; END_FOR\n\
         WHILE x < 3 DO x := x + 1; END_WHILE\n\
         REPEAT x := x + 1; UNTIL x > 5 END_REPEAT\n\
         CASE x OF 1: x := 2; END_CASE\n\
         IF x > 0 THEN IF x > 1 THEN x := 0; END_IF END_IF;\n\
         END_PROGRAM",
    );
    assert_eq!(body(&lib).len(), 6);
    // A simple statement still needs its `;`, as in CODESYS and TwinCAT.
    let (_, d) =
        diags_of("PROGRAM p\nVAR x : INT; END_VAR\nIF x > 0 THEN x := 1 END_IF\nEND_PROGRAM");
    assert_eq!(
        d,
        "t.st:3:21: error[E012]: expected `;` after this, found `END_IF`\n"
    );
}

#[test]
fn words_twincat_does_not_reserve_name_variables() {
    let lib = check_ok(
        "FUNCTION_BLOCK fb\nVAR_INPUT ON : BOOL; R_EDGE : BOOL; f_edge : BOOL R_EDGE; END_VAR\n\
         VAR_OUTPUT task, with : INT; END_VAR\n\
         IF ON AND R_EDGE THEN task := 1; END_IF;\n\
         ON := NOT ON;\n\
         CASE task OF ON: with := 1; END_CASE;\n\
         END_FUNCTION_BLOCK\n\
         PROGRAM p VAR i : fb; b : BOOL; END_VAR\n\
         i(ON := TRUE, R_EDGE := b, task => b);\n\
         b := i.ON;\n\
         END_PROGRAM\n\
         CONFIGURATION c RESOURCE r ON PLC TASK t(INTERVAL := T#10ms); PROGRAM q WITH t : p; END_RESOURCE END_CONFIGURATION",
    );
    let Element::Pou(fb) = &lib.elements[0] else {
        panic!()
    };
    let names: Vec<&str> = fb.var_blocks[0]
        .vars
        .iter()
        .map(|d| d.names[0].name.as_str())
        .collect();
    assert_eq!(names, ["ON", "R_EDGE", "f_edge"]);
    assert_eq!(fb.var_blocks[0].vars[2].edge, Some(Edge::Rising));
    // The words TwinCAT reserves stay reserved.
    let (_, d) = diags_of("PROGRAM p VAR THEN : INT; END_VAR END_PROGRAM");
    assert_eq!(d, "t.st:1:15: error[E010]: `THEN` is a reserved word and cannot be a variable name; choose another name\n");
}

#[test]
fn an_error_in_a_header_does_not_leave_its_block_unclosed() {
    // One error each, at the stray name in the header: not also "this FOR has no END_FOR".
    for (src, col) in [
        (
            "FOR i := 1 TO n DO\n  IF p q = 1 THEN n := 1; END_IF;\nEND_FOR;",
            7,
        ),
        (
            "FOR i := 1 TO n DO\n  WHILE p q DO n := 1; END_WHILE;\nEND_FOR;",
            10,
        ),
        (
            "FOR i := 1 TO n DO\n  CASE p q OF 1: n := 1; END_CASE;\nEND_FOR;",
            9,
        ),
        (
            "FOR i := 1 TO n DO\n  FOR n := 1 TO p q DO n := 1; END_FOR;\nEND_FOR;",
            18,
        ),
        (
            "FOR i := 1 TO n DO\n  IF n = 1 THEN n := 1; ELSIF p q THEN n := 2; END_IF;\nEND_FOR;",
            32,
        ),
    ] {
        let src = format!("PROGRAM p\nVAR i, n : INT; END_VAR\n{src}\nEND_PROGRAM");
        let (_, d) = diags_of(&src);
        assert!(
            d.starts_with(&format!("t.st:4:{}: error[E010]", col + 1)),
            "{src}\n{d}"
        );
        assert!(!d.contains("has no END_"), "{src}\n{d}");
    }
    // Any error in a header: the block is still read to its END_IF.
    let (_, d) =
        diags_of("PROGRAM p\nVAR n : INT; END_VAR\nIF n = THEN n := 1; END_IF;\nEND_PROGRAM");
    assert_eq!(
        d,
        "t.st:3:8: error[E010]: expected an expression, found `THEN`\n"
    );
}

#[test]
fn an_enumeration_takes_its_base_type_after_the_values_as_codesys_writes_it() {
    let lib = check_ok(
        "TYPE e : (a := 1, b) BYTE; END_TYPE\nTYPE f : (x, y); END_TYPE\n\
         PROGRAM p\nVAR v : (r, s) DINT := s; END_VAR\nEND_PROGRAM",
    );
    let mut bases = Vec::new();
    for e in &lib.elements {
        if let Element::Types(ts) = e {
            for t in ts {
                if let TypeSpec::Enum { base, .. } = &t.spec {
                    bases.push(base.as_ref().map(|b| b.name.clone()));
                }
            }
        }
    }
    assert_eq!(bases, vec![Some("BYTE".to_string()), None]);
    // Only an integer type's name: anything else after `)` is still an error.
    let (_, d) = diags_of("TYPE e : (a, b) REAL; END_TYPE");
    assert!(d.contains("error[E012]"), "{d}");
}

#[test]
fn a_syntax_error_in_until_is_the_only_error() {
    for until in ["x >= ", "(x > 1", "x = = 1", "x > 1)", "x > 1 y", "x >"] {
        let (_, d) = diags_of(&format!(
            "PROGRAM p\nVAR x : INT; END_VAR\nREPEAT\n  x := x + 1;\nUNTIL {until}\nEND_REPEAT;\nx := 2;\nEND_PROGRAM\n"
        ));
        assert_eq!(
            d.lines().filter(|l| l.contains("error[")).count(),
            1,
            "{until}: {d}"
        );
    }
    // A REPEAT left unclosed is still that one error.
    let (_, d) = diags_of(
        "PROGRAM p\nVAR x : INT; END_VAR\nREPEAT\n  x := x + 1;\nUNTIL x > 1\nx := 2;\nEND_PROGRAM\n",
    );
    assert_eq!(d.lines().filter(|l| l.contains("error[")).count(), 1, "{d}");
}

/// A statement list written back as `target := value` pairs, to see what it stands for.
fn assignments(stmts: &[Stmt], text: &str) -> Vec<String> {
    stmts
        .iter()
        .map(|s| match &s.kind {
            StmtKind::Assign { target, value } => format!(
                "{} := {}",
                &text[target.span.start as usize..target.span.end as usize],
                &text[value.span.start as usize..value.span.end as usize]
            ),
            other => format!("{other:?}"),
        })
        .collect()
}

#[test]
fn a_chained_assignment_reads_right_to_left() {
    let src = "PROGRAM p\nVAR a, b : INT; c : ARRAY[1..2] OF INT; END_VAR\n\
               a := b := c[1] := 3 + a;\na := 1;\nEND_PROGRAM";
    let lib = check_ok(src);
    assert_eq!(
        assignments(body(&lib), src),
        ["c[1] := 3 + a", "b := c[1]", "a := b", "a := 1"]
    );
    // The value before the last `:=` must be a place.
    let (_, d) = diags_of("PROGRAM p\nVAR a, b : INT; END_VAR\na := b + 1 := 3;\nEND_PROGRAM");
    assert_eq!(
        d,
        "t.st:3:11: error[E012]: expected `;` after this, found `:=`\n"
    );
}

#[test]
fn a_for_loop_counts_with_any_place() {
    let lib = check_ok(
        "PROGRAM p\nVAR o : ARRAY[1..2] OF INT; s : ST; END_VAR\n\
         FOR o[1] := 1 TO 3 DO ; END_FOR\nFOR s.n := 1 TO 3 DO ; END_FOR\nEND_PROGRAM",
    );
    let kinds: Vec<bool> = body(&lib)
        .iter()
        .map(|s| matches!(&s.kind, StmtKind::For { var, .. } if !matches!(var.kind, ExprKind::Name(_))))
        .collect();
    assert_eq!(kinds, [true, true]);
    let (_, d) = diags_of("PROGRAM p\nFOR 1 := 1 TO 3 DO ; END_FOR\nEND_PROGRAM");
    assert!(
        d.contains("error[E010]: expected the FOR loop's control variable"),
        "{d}"
    );
}

#[test]
fn a_block_name_takes_fb_init_arguments_an_elementary_name_a_subrange() {
    let lib = check_ok(
        "PROGRAM p\nVAR a : FB_X(10, b := 2); r : INT (1..5); e : INT (A, B); s : STRING(8); END_VAR\nEND_PROGRAM",
    );
    let Element::Pou(p) = &lib.elements[0] else {
        panic!("a POU")
    };
    let v = &p.var_blocks[0].vars;
    assert!(matches!(&v[0].ty, TypeSpec::Named(n) if n.is("FB_X")));
    assert_eq!(v[0].fb_init.as_ref().map(Vec::len), Some(2));
    assert!(matches!(v[1].ty, TypeSpec::Subrange { .. }) && v[1].fb_init.is_none());
    assert!(matches!(v[2].ty, TypeSpec::Enum { .. }));
    assert!(matches!(v[3].ty, TypeSpec::String { .. }));
}
