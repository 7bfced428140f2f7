use super::*;
use crate::source::SourceMap;

/// Parses `src` and renders its diagnostics, one per line (empty when it parses).
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

fn check_errors(src: &str, expect: &[&str]) {
    let (_, d) = diags_of(src);
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines, expect, "{src}");
}

/// An expression rendered with full parentheses.
fn sexpr(e: &Expr) -> String {
    match &e.kind {
        ExprKind::Literal(Literal::Int { value, .. }) => value.to_string(),
        ExprKind::Literal(l) => format!("{l:?}"),
        ExprKind::Name(i) => i.name.clone(),
        ExprKind::Field(b, f) => format!("{}.{}", sexpr(b), f.name),
        ExprKind::Bit(b, n) => format!("{}.{n}", sexpr(b)),
        ExprKind::Part(b, size, n) => format!("{}.%{size}:{n}", sexpr(b)),
        ExprKind::Index(b, i) => format!(
            "{}[{}]",
            sexpr(b),
            i.iter().map(sexpr).collect::<Vec<_>>().join(",")
        ),
        ExprKind::Call(c) => format!(
            "{}({})",
            sexpr(&c.callee),
            c.args
                .iter()
                .map(|a| format!(
                    "{}{}{}",
                    a.name.as_ref().map_or(String::new(), |n| n.name.clone()),
                    if a.name.is_none() {
                        ""
                    } else if a.output {
                        "=>"
                    } else {
                        ":="
                    },
                    a.value.as_ref().map_or(String::new(), sexpr)
                ))
                .collect::<Vec<_>>()
                .join(",")
        ),
        ExprKind::Unary(op, e) => format!("({op:?} {})", sexpr(e)),
        ExprKind::Binary(op, a, b) => format!("({} {} {})", sexpr(a), op.text(), sexpr(b)),
        ExprKind::Paren(e) => sexpr(e),
        ExprKind::Direct(t) => format!("%{t}"),
        ExprKind::Deref(e) => format!("{}^", sexpr(e)),
        ExprKind::Error => "?".into(),
    }
}

fn check_expr(src: &str, expect: &str) {
    let mut d = Diagnostics::new();
    let e = parse_expression(FileId(0), src, &mut d).expect(src);
    assert!(d.is_empty(), "{src}: {d:?}");
    assert_eq!(sexpr(&e), expect, "{src}");
}

#[test]
fn precedence() {
    check_expr("a OR b AND c", "(a OR (b AND c))");
    check_expr("a XOR b OR c", "((a XOR b) OR c)");
    check_expr("a = b AND c < d", "((a = b) AND (c < d))");
    check_expr("a + b * c - d", "((a + (b * c)) - d)");
    check_expr("a - b - c", "((a - b) - c)");
    check_expr("NOT a AND b", "((Not a) AND b)");
    check_expr("-a * b", "((Neg a) * b)");
    check_expr("a ** b ** c", "((a ** b) ** c)");
    check_expr("2 * a ** 2", "(2 * (a ** 2))");
    check_expr("a MOD b + c", "((a MOD b) + c)");
    check_expr("(a + b) * c", "((a + b) * c)");
    check_expr("a < b = c > d", "((a < b) = (c > d))");
    check_expr("a & b OR c", "((a AND b) OR c)");
}

#[test]
fn postfix_forms() {
    check_expr("a.b[i, j + 1].c", "a.b[i,(j + 1)].c");
    check_expr("w.3", "w.3");
    check_expr("w.%X5", "w.5");
    check_expr("MAX(1, x)", "MAX(1,x)");
    check_expr(
        "LIMIT(MN := 0, IN := x, MX := 10)",
        "LIMIT(MN:=0,IN:=x,MX:=10)",
    );
    check_expr("f(q => y, r =>)", "f(q=>y,r=>)");
    check_expr("INT#-5", "-5");
    check_expr("r^", "r^");
    check_expr("p^[i].x^.y", "p^[i].x^.y");
    check_expr("r^ + 1 = REF(a)", "((r^ + 1) = REF(a))");
}

#[test]
fn references_and_pointers() {
    let lib = check_ok(
        "TYPE P : REF_TO INT; END_TYPE\n\
         PROGRAM p\n\
         VAR r : REF_TO INT; q : POINTER TO ARRAY[0..3] OF BYTE; c : REFERENCE TO REAL; END_VAR\n\
         r^ := 1; q^[2] := r^; r := NULL;\n\
         END_PROGRAM",
    );
    let Element::Pou(p) = &lib.elements[1] else {
        panic!("not a POU")
    };
    let kinds: Vec<String> = p.var_blocks[0]
        .vars
        .iter()
        .map(|d| match &d.ty {
            TypeSpec::Ref { kind, target, .. } => format!("{} {:?}", kind.text(), target.span()),
            other => format!("{other:?}"),
        })
        .collect();
    assert_eq!(kinds.len(), 3);
    assert!(kinds[0].starts_with("REF_TO"), "{kinds:?}");
    assert!(kinds[1].starts_with("POINTER TO"), "{kinds:?}");
    assert!(kinds[2].starts_with("REFERENCE TO"), "{kinds:?}");
    // `POINTER` alone is a name (a variable or type called so), not the start of a type.
    check_errors("PROGRAM p\nVAR x : POINTER; END_VAR\nEND_PROGRAM", &[]);
}

#[test]
fn and_or_xor_mod_called_as_functions() {
    check_expr("AND(a, b, c)", "AND(a,b,c)");
    check_expr("x OR XOR(IN1 := a, IN2 := b)", "(x OR XOR(IN1:=a,IN2:=b))");
    check_expr("MOD(a, 3) + OR(a, b)", "(MOD(a,3) + OR(a,b))");
    // Between operands they stay operators, parenthesised or not.
    check_expr("a AND (b)", "(a AND b)");
    check_expr("a MOD(b)", "(a MOD b)");
    check_expr("NOT(IN := a) OR NOT(b)", "(NOT(IN:=a) OR (Not b))");
}

#[test]
fn a_program_with_every_statement() {
    let lib = check_ok(
        "PROGRAM main
VAR_INPUT go : BOOL; END_VAR
VAR_OUTPUT n : INT; END_VAR
VAR i : INT; a : ARRAY[1..3, -1..1] OF INT := [1, 2, 7(0)]; t : TON; s : STRING[10] := 'x'; END_VAR
VAR CONSTANT k : INT := 3; END_VAR
IF go THEN n := 1; ELSIF NOT go THEN n := 2; ELSE n := 3; END_IF;
CASE n OF
  1, 2: n := 0;
  3..5, k: n := 1; n := 2;
ELSE n := -1;
END_CASE;
FOR i := 10 TO 1 BY -1 DO IF i = 3 THEN CONTINUE; END_IF; EXIT; END_FOR;
WHILE i < 10 DO i := i + 1; END_WHILE;
REPEAT i := i - 1; UNTIL i <= 0 END_REPEAT;
t(IN := go, PT := T#1s, Q => go);
a[1, 0] := t.ET > T#0s;
;
RETURN;
END_PROGRAM",
    );
    let Element::Pou(p) = &lib.elements[0] else {
        panic!()
    };
    assert_eq!(p.var_blocks.len(), 4);
    let Body::St(b) = &p.body else { panic!() };
    assert_eq!(b.len(), 9);
    let StmtKind::Case {
        arms, else_body, ..
    } = &b[1].kind
    else {
        panic!()
    };
    assert_eq!(arms.len(), 2);
    assert_eq!(arms[1].labels.len(), 2);
    assert_eq!(arms[1].body.len(), 2);
    assert!(else_body.is_some());
}

#[test]
fn types_functions_and_configurations() {
    let lib = check_ok(
        "TYPE
  Color : (Red, Green := 5, Blue) := Green;
  Level : INT (0..100);
  Pt : STRUCT x : REAL; y : REAL := 1.0; END_STRUCT;
  Grid : ARRAY[0..2] OF Pt;
  Code : WORD (Start := 1, Stop := 2);
END_TYPE
FUNCTION Inc : INT
VAR_IN_OUT v : INT; END_VAR
VAR_INPUT d : INT := 1; END_VAR
v := v + d; Inc := v;
END_FUNCTION
FUNCTION_BLOCK Edge
VAR_INPUT x : BOOL R_EDGE; END_VAR
END_FUNCTION_BLOCK
CONFIGURATION cfg
  VAR_GLOBAL L AT %L : BYTE; g : INT; END_VAR
  RESOURCE r ON PLC
    TASK fast (INTERVAL := T#10ms, PRIORITY := 1);
    PROGRAM p WITH fast : main (go := g, n => g);
  END_RESOURCE
END_CONFIGURATION",
    );
    assert_eq!(lib.elements.len(), 4);
    let Element::Configuration(c) = &lib.elements[3] else {
        panic!()
    };
    assert_eq!(c.resources[0].tasks.len(), 1);
    assert_eq!(c.resources[0].programs[0].args.len(), 2);
    assert_eq!(c.globals[0].vars[0].location.as_ref().unwrap().text, "L");
}

#[test]
fn configuration_without_resource() {
    let lib = check_ok(
        "CONFIGURATION c TASK t (INTERVAL := T#5ms); PROGRAM p WITH t : main; END_CONFIGURATION",
    );
    let Element::Configuration(c) = &lib.elements[0] else {
        panic!()
    };
    assert_eq!(c.resources.len(), 1);
    assert_eq!(c.resources[0].programs[0].type_name.name, "main");
}

#[test]
fn every_error_is_reported_with_its_position() {
    check_errors(
        "PROGRAM p
VAR x : INT; END_VAR
x := ;
x = 1;
IF x THEN x := 1; END_WHILE;
x := 2
END_PROGRAM",
        &[
            "t.st:3:6: error[E010]: expected an expression, found `;`",
            "t.st:4:3: error[E010]: `=` compares; an assignment is written `x := …;`",
            "t.st:5:1: error[E011]: this IF has no END_IF; found `END_WHILE`",
            "t.st:6:7: error[E012]: expected `;` after this, found `END_PROGRAM`",
        ],
    );
    check_errors(
        "PROGRAM p VAR x : INT END_VAR END_PROGRAM",
        &["t.st:1:22: error[E012]: expected `;` after this, found `END_VAR`"],
    );
    check_errors(
        "PROGRAM p x := 1;",
        &["t.st:1:18: error[E011]: PROGRAM p has no END_PROGRAM; found the end of the source"],
    );
    check_errors("", &["t.st:1:1: error[E013]: no declaration here; a source holds PROGRAM, FUNCTION, FUNCTION_BLOCK, TYPE or CONFIGURATION declarations"]);
    // A FUNCTION without a result type parses (CODESYS, TwinCAT); the checker refuses it
    // in the standard's dialect (iec-sema's codesys_tests).
    check_errors("FUNCTION f VAR x : INT; END_VAR END_FUNCTION", &[]);
    check_errors(
        "PROGRAM IF END_PROGRAM",
        &["t.st:1:9: error[E010]: `IF` is a reserved word and cannot be the POU's name; choose another name"],
    );
}

#[test]
fn deep_nesting_is_refused_not_a_crash() {
    let src = format!(
        "PROGRAM p x := {}1{}; END_PROGRAM",
        "(".repeat(5000),
        ")".repeat(5000)
    );
    let (_, d) = diags_of(&src);
    assert!(d.contains("nesting deeper than"), "{d}");
    let src = format!("PROGRAM p {} END_PROGRAM", "IF x THEN ".repeat(5000));
    let (_, d) = diags_of(&src);
    assert!(d.contains("nesting deeper than"), "{d}");
    let src = format!("PROGRAM p x := {}1; END_PROGRAM", "-".repeat(5000));
    let (_, d) = diags_of(&src);
    assert!(d.contains("nesting deeper than"), "{d}");
}

/// The one diagnostic of `src`, which must be the nesting limit's.
fn only_too_deep(src: &str) -> String {
    let (_, d) = diags_of(src);
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), 1, "{}", lines[..lines.len().min(5)].join("\n"));
    assert!(lines[0].contains("error[E014]"), "{d}");
    d
}

#[test]
fn every_kind_of_nesting_is_bounded() {
    let n = 20_000;
    // ARRAY OF ARRAY OF …
    let d = only_too_deep(&format!(
        "PROGRAM p VAR v : {}INT; END_VAR END_PROGRAM",
        "ARRAY[0..1] OF ".repeat(n)
    ));
    assert!(d.contains("nesting deeper than 100 levels"), "{d}");
    // STRUCT in STRUCT: each one refused (E109), then the limit.
    let (_, d) = diags_of(&format!("TYPE s : {}END_TYPE", "STRUCT a : ".repeat(n)));
    assert!(d.lines().count() <= 100, "{d}");
    assert!(d.lines().last().unwrap().contains("error[E014]"), "{d}");
    // Initial values of arrays and structures.
    only_too_deep(&format!(
        "PROGRAM p VAR v : INT := {}1{}; END_VAR END_PROGRAM",
        "[".repeat(n),
        "]".repeat(n)
    ));
    only_too_deep(&format!(
        "PROGRAM p VAR v : s := {}1{}; END_VAR END_PROGRAM",
        "(a := ".repeat(n),
        ")".repeat(n)
    ));
    // Arguments of calls in calls.
    only_too_deep(&format!(
        "PROGRAM p x := {}1{}; END_PROGRAM",
        "f(".repeat(n),
        ")".repeat(n)
    ));
}

#[test]
fn long_chains_of_operators_and_accesses_are_bounded() {
    let n = 100_000;
    let d = only_too_deep(&format!(
        "PROGRAM p x := {}; END_PROGRAM",
        vec!["x"; n].join(" + ")
    ));
    assert!(d.contains("more than 1000 levels deep"), "{d}");
    only_too_deep(&format!("PROGRAM p x := x{}; END_PROGRAM", ".a".repeat(n)));
    only_too_deep(&format!("PROGRAM p x := x{}; END_PROGRAM", "[1]".repeat(n)));
    only_too_deep(&format!(
        "PROGRAM p x := x{}; END_PROGRAM",
        ".a[1]".repeat(n)
    ));
    // Near the limit a chain is read: `x + … + x` with 989 operators.
    check_ok(&format!(
        "PROGRAM p x := {}; END_PROGRAM",
        vec!["x"; 990].join(" + ")
    ));
    check_ok(&format!(
        "PROGRAM p x := {}1{}; END_PROGRAM",
        "(".repeat(98),
        ")".repeat(98)
    ));
}

#[test]
fn too_deep_is_reported_first_and_alone() {
    // 150 nested IFs: the cause, not 99 IFs "without END_IF" before it.
    let src = format!(
        "PROGRAM p\n{}x := 1;\n{}END_PROGRAM\n",
        "IF x THEN\n".repeat(150),
        "END_IF;\n".repeat(150)
    );
    let d = only_too_deep(&src);
    assert!(
        d.starts_with("t.st:101:4: error[E014]: nesting deeper than 100 levels"),
        "{d}"
    );
    // Errors before the limit are still reported.
    let src = format!(
        "PROGRAM p\nx := ;\n{}END_PROGRAM\n",
        "IF x THEN\n".repeat(150)
    );
    let (_, d) = diags_of(&src);
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), 2, "{d}");
    assert!(lines[0].starts_with("t.st:2:6: error[E010]"), "{d}");
    assert!(lines[1].contains("error[E014]"), "{d}");
}

/// Found by fuzzing `check_st`: a statement's target written across lines was quoted with its
/// line break, splitting one diagnostic over two lines.
#[test]
fn a_message_quoting_several_lines_is_one_line() {
    check_errors(
        "PROGRAM p x\n   .y 1; END_PROGRAM",
        &["t.st:2:7: error[E010]: expected `:=` (an assignment) or `(` (a call) after `x    .y`, found the number `1`"],
    );
}

#[test]
fn a_byte_order_mark_is_accepted_and_columns_stay_right() {
    check_ok("\u{feff}PROGRAM p VAR x : INT; END_VAR x := 1; END_PROGRAM");
    check_errors(
        "\u{feff}PROGRAM p x := ; END_PROGRAM",
        &["t.st:1:16: error[E010]: expected an expression, found `;`"],
    );
    let mut map = SourceMap::new();
    let text = "\u{feff}PROGRAM p\nVAR x : INT; END_VAR\nLD 1\nST x\nEND_PROGRAM\n";
    let f = map.add("t.il", text);
    let mut d = Diagnostics::new();
    parse_il(f, text, &mut d);
    assert_eq!(d.render(&map), "");
}

proptest::proptest! {
    #[test]
    fn never_panics(src in "[A-Za-z0-9_:=;().,\\[\\]#%'\"*+/<>&^ \n-]{0,200}") {
        let mut d = Diagnostics::new();
        parse(FileId(0), &src, &mut d);
    }

    #[test]
    fn never_panics_on_keyword_soup(words in proptest::collection::vec(proptest::sample::select(vec![
        "PROGRAM", "END_PROGRAM", "VAR", "END_VAR", "IF", "THEN", "ELSE", "END_IF", "CASE", "OF",
        "END_CASE", "FOR", "TO", "DO", "END_FOR", "x", ":=", ";", ":", "1", "(", ")", "INT",
        "FUNCTION", "END_FUNCTION", "CONFIGURATION", "RESOURCE", "TASK", "END_RESOURCE",
        "END_CONFIGURATION", "TYPE", "END_TYPE", "STRUCT", "END_STRUCT", "ARRAY", "[", "]", "..",
        ",", "=>", "REPEAT", "UNTIL", "END_REPEAT", "WHILE", "END_WHILE", "WITH", "T#1s",
        "ON", "R_EDGE", "BOOL", "CONSTANT", "VAR_INPUT", "{attribute 'x'}", "{warning 'w'}",
        "{IF defined(x)}", "{END_IF}", "{error 'e'}", "^", "STRING(2)",
    ]), 0..60)) {
        let src = words.join(" ");
        let mut d = Diagnostics::new();
        parse(FileId(0), &src, &mut d);
    }
}

#[test]
fn variable_length_arrays() {
    let lib = check_ok(
        "FUNCTION f : BOOL\n\
         VAR_IN_OUT a : ARRAY[*] OF INT; m : ARRAY[*, *, *] OF STRING[4]; END_VAR\n\
         END_FUNCTION",
    );
    let Element::Pou(p) = &lib.elements[0] else {
        panic!("not a POU")
    };
    let dims: Vec<u32> = p.var_blocks[0]
        .vars
        .iter()
        .map(|d| match &d.ty {
            TypeSpec::ArrayStar { dims, .. } => *dims,
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(dims, [1, 3]);
    // Every dimension is `*`, or none is.
    let (_, d) =
        diags_of("FUNCTION f : BOOL\nVAR_IN_OUT a : ARRAY[*, 1..2] OF INT; END_VAR\nEND_FUNCTION");
    assert!(d.starts_with("t.st:2:25: error[E010]: expected `*`"), "{d}");
}

#[test]
fn a_for_loop_over_an_element() {
    let lib = check_ok("PROGRAM p\nFOR Offset[1] := 0 TO 3 DO END_FOR;\nFOR s.k := 1 TO 2 DO END_FOR;\nEND_PROGRAM");
    let Element::Pou(p) = &lib.elements[0] else {
        panic!("not a POU")
    };
    let Body::St(stmts) = &p.body else {
        panic!("not ST")
    };
    let vars: Vec<String> = stmts
        .iter()
        .filter_map(|s| match &s.kind {
            StmtKind::For { var, .. } => Some(sexpr(var)),
            _ => None,
        })
        .collect();
    assert_eq!(vars, ["Offset[1]", "s.k"]);
}
