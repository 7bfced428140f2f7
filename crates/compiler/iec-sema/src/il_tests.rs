//! The Instruction List front end's diagnostics, with their positions.

use petriplc_iec_syntax::{parser, SourceMap};

use crate::{check, ir, Options};

/// Parses `src` as a `.il` source and checks it; every diagnostic rendered (the EN/ENO tests
/// call it too).
pub(crate) fn run(src: &str) -> (Option<ir::Project>, String) {
    let mut map = SourceMap::new();
    let f = map.add("t.il", src);
    let mut d = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse_il(f, src, &mut d);
    let (p, diags) = check(&lib, &Options::default());
    d.extend(diags);
    (p.filter(|_| !d.has_errors()), d.render(&map))
}

fn prog(decls: &str, body: &str) -> String {
    format!("PROGRAM p\nVAR\n{decls}\nEND_VAR\n{body}\nEND_PROGRAM\n")
}

/// `expect` lists fragments, one per diagnostic line, in order (an empty list: no problem).
fn check_il(decls: &str, body: &str, expect: &[&str]) {
    let (p, d) = run(&prog(decls, body));
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), expect.len(), "got:\n{d}");
    for (l, e) in lines.iter().zip(expect) {
        assert!(l.contains(e), "expected `{e}` in\n{l}\n(all:\n{d})");
    }
    assert_eq!(p.is_some(), expect.is_empty(), "{d}");
}

#[test]
fn a_valid_body() {
    check_il(
        "a, b, x : BOOL; n : INT; t : TON;",
        "start: LD a\n  AND( b\n  OR x\n  )\n  ST x\n  JMPC start\n  CAL t(IN := x, PT := T#1s)\n  LD n\n  ADD 1\n  ST n\n  RET",
        &[],
    );
}

#[test]
fn syntax_errors_are_placed_and_the_rest_is_read() {
    check_il(
        "x : INT;",
        "  LD\n  LD 1 2\n  ST( x\n  IF x\n  LD 3\n  ST x",
        &[
            "t.il:5:3: error[E020]: LD needs an operand",
            "t.il:6:8: error[E020]: the number `2` after the instruction",
            "t.il:7:5: error[E020]: ST takes no parenthesised operand",
            "t.il:8:3: error[E020]: expected an IL instruction",
        ],
    );
}

#[test]
fn parentheses_must_match() {
    check_il(
        "x : BOOL;",
        "  LD x\n  )\n  AND( x\n  ST x",
        &[
            "t.il:6:3: error[E021]: `)` without an open operation",
            "t.il:7:3: error[E021]: AND( is never closed",
        ],
    );
}

#[test]
fn labels_must_exist_once() {
    check_il(
        "x : BOOL;",
        "a: LD x\n  JMPC b\na: ST x",
        &[
            "t.il:6:8: error[E160]: no label `b` in this body",
            "t.il:7:1: error[E160]: label `a` is defined twice",
        ],
    );
}

#[test]
fn the_current_result_must_exist() {
    check_il(
        "x : BOOL; t : TON;",
        "  ST x\n  CAL t\n  AND x\n  CAL t\n  JMP l\nl: ST x",
        &[
            "t.il:5:3: error[E161]: ST needs the current result, but there is none here (at the start of the body)",
            "t.il:7:3: error[E161]: AND needs the current result, but there is none here (after CAL)",
            "t.il:9:3: error[E161]: the code after label `l` uses the current result, but there is none at this jump (after CAL)",
        ],
    );
}

#[test]
fn no_jump_inside_parentheses() {
    check_il(
        "x : BOOL;",
        "  LD x\n  AND( x\n  JMPC l\n  )\nl: ST x",
        &["t.il:7:3: error[E162]: a jump inside a parenthesised operation"],
    );
}

#[test]
fn operands_are_typed_as_in_st() {
    check_il(
        "x : BOOL; n : INT; r : REAL;",
        "  LD n\n  ADD r\n  ST n\n  LD n\n  JMPC l\nl: LD x\n  S n",
        &[
            "t.il:7:3: error[E110]: the value assigned to `n` is REAL but INT is needed",
            "t.il:9:3: error[E112]: JMPC needs a BOOL current result, not INT",
            "t.il:11:5: error[E110]: S sets or resets a BOOL, not INT",
        ],
    );
}

proptest::proptest! {
    /// No Instruction List body makes the parser or the checker panic.
    #[test]
    fn never_panics(lines in proptest::collection::vec(proptest::collection::vec(proptest::sample::select(vec![
        "LD", "LDN", "ST", "STN", "S", "R", "AND", "ANDN", "OR", "XOR", "NOT", "ADD", "SUB",
        "MUL", "DIV", "MOD", "GT", "EQ", "LT", "JMP", "JMPC", "JMPCN", "CAL", "CALC", "RET",
        "RETCN", "PT", "CU", "MAX", "f", "l:", "m:", "l", "m", "x", "b", "n", "t", "c", "t.Q",
        "(", ")", ",", ":=", "=>", "IN", "1", "2.5", "TRUE", "T#1s", "'s'", "&", "(* c *)",
    ]), 0..5), 0..20)) {
        let body: Vec<String> = lines.iter().map(|l| l.join(" ")).collect();
        let src = format!(
            "FUNCTION f : INT\nVAR_INPUT i : INT; END_VAR\n  LD i\n  ST f\nEND_FUNCTION\n\
             PROGRAM p\nVAR x : INT; b : BOOL; n : REAL; t : TON; c : CTU; END_VAR\n{}\nEND_PROGRAM\n",
            body.join("\n")
        );
        let _ = run(&src);
    }
}

/// The deepest expression and the deepest IF nesting of a lowered body.
fn measure(body: &[ir::Stmt]) -> (usize, usize) {
    let mut most = (0, 0);
    let mut todo: Vec<(&ir::Stmt, usize)> = body.iter().map(|s| (s, 0)).collect();
    while let Some((s, d)) = todo.pop() {
        match &s.kind {
            ir::StmtKind::Assign { value, .. } => most.0 = most.0.max(value.depth()),
            ir::StmtKind::If {
                branches,
                else_body,
            } => {
                most.1 = most.1.max(d + 1);
                for (c, b) in branches {
                    most.0 = most.0.max(c.depth());
                    todo.extend(b.iter().map(|s| (s, d + 1)));
                }
                todo.extend(else_body.iter().map(|s| (s, d + 1)));
            }
            _ => {}
        }
    }
    most
}

#[test]
fn long_bodies_lower_to_shallow_trees() {
    // 100 000 operations on the current result: folded in steps, not one tree 100 000 deep
    // (the input's size bounds the work; a quadratic lowering would not end in a test run).
    let body = format!("LD x\n{}ST x", "ADD 1\nMUL x\n".repeat(50_000));
    let (p, d) = run(&prog("x : INT;", &body));
    assert_eq!(d, "");
    let p = p.unwrap();
    let (expr, ifs) = measure(&p.pous[0].body);
    assert!(expr <= crate::il::FOLD_DEPTH + 2, "{expr}");
    assert_eq!(ifs, 0);
    // Jumps over jumps 300 deep: IFs 100 deep, the rest stay jumps.
    let n = 300;
    let mut body = String::new();
    for i in 0..n {
        body.push_str(&format!("LD c\nJMPCN l{i}\n"));
    }
    body.push_str("LD 1\nST x\n");
    for i in (0..n).rev() {
        body.push_str(&format!("l{i}:\n"));
    }
    body.push_str("LD x\nST x");
    let (p, d) = run(&prog("x : INT; c : BOOL;", &body));
    assert_eq!(d, "");
    let (_, ifs) = measure(&p.unwrap().pous[0].body);
    assert_eq!(ifs, petriplc_iec_syntax::depth::MAX_NESTING);
}

#[test]
fn parenthesised_operations_nest_100_deep() {
    let ok = 100;
    check_il(
        "x : INT;",
        &format!("LD x\n{}{}ST x", "ADD( x\n".repeat(ok), ")\n".repeat(ok)),
        &[],
    );
    let n = 20_000;
    check_il(
        "x : INT;",
        &format!("LD x\n{}{}ST x", "ADD( x\n".repeat(n), ")\n".repeat(n)),
        &["t.il:106:1: error[E014]: parenthesised operations nested more than 100 deep"],
    );
}

#[test]
fn typed_and_bcd_functions_and_bit_string_arithmetic_in_il() {
    check_il(
        "d : DWORD; w : WORD; i : INT; b : BYTE;",
        "LD d\n  SHR_DWORD 3\n  ADD 16#10\n  ST d\n  LD i\n  LIMIT_INT 0, 100\n  ST i\n  LD w\n  WORD_BCD_TO_INT\n  ST i\n  LD b\n  MUL 3\n  ST b",
        &[],
    );
    check_il(
        "d : DWORD; i : INT;",
        "LD i\n  SHR_DWORD 3\n  ST d",
        &["error[E110]: argument 1 of SHR_DWORD is INT but DWORD is needed"],
    );
}
