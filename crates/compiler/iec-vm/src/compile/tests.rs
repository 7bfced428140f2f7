//! The compiler and the VM together: small Structured Text programs compiled, run for some
//! scans and their variables compared with what IEC 61131-3 says they hold.

use std::sync::Arc;

use petriplc_iec_sema::{Options, Overflow};
use petriplc_iec_syntax::{Diagnostics, SourceMap};

use crate::op::Op;
use crate::{display, native, Backend, Engine, InstanceSpec, Machine};

/// `source` checked and compiled for its only PROGRAM, with the standard function blocks;
/// the diagnostics rendered in the panic when it does not compile.
fn engine(source: &str) -> Arc<Engine> {
    engine_in(source, Overflow::default())
}

/// [`engine`] with an overflow rule.
fn engine_in(source: &str, overflow: Overflow) -> Arc<Engine> {
    let mut map = SourceMap::new();
    let f = map.add("t.st", source);
    let mut diags = Diagnostics::new();
    let lib = petriplc_iec_syntax::parse(f, source, &mut diags);
    assert!(!diags.has_errors(), "{}", diags.render(&map));
    let options = Options {
        overflow,
        ..Options::default()
    };
    let (project, diags) = petriplc_iec_sema::check(&lib, &options);
    let project = project.unwrap_or_else(|| panic!("{}", diags.render(&map)));
    let (pou, program) = project
        .programs()
        .next()
        .unwrap_or_else(|| panic!("no PROGRAM in {source}"));
    let spec = InstanceSpec {
        name: program.name.clone(),
        pou,
        task: None,
        inputs: Vec::new(),
        outputs: Vec::new(),
    };
    Engine::new(project, &[spec], native::standard(), &map).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `scans` scans, 10 ms apart, on the VM alone; then `paths` as `path=value`, one
/// space between them, or `fault: …` from the first scan that faults.
fn run(source: &str, scans: usize, paths: &[&str]) -> String {
    run_in(source, scans, paths, Overflow::default())
}

fn run_in(source: &str, scans: usize, paths: &[&str], overflow: Overflow) -> String {
    let engine = engine_in(source, overflow);
    let mut m = Machine::new(engine.clone());
    m.set_backend(Backend::Vm);
    for k in 0..scans {
        if let Err(f) = m.scan(k as i64 * 10_000_000, &mut || true) {
            return format!("fault: {}", f.message);
        }
    }
    paths
        .iter()
        .map(|p| {
            let r = engine
                .lookup(p)
                .unwrap_or_else(|| panic!("no variable {p}"));
            let v = m.get(r).unwrap_or_else(|| panic!("no value for {p}"));
            format!("{p}={}", display(&engine.project, r.ty, &v))
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// `PROGRAM main` with `vars` and `body` (after the POUs in `pous`) run for `scans` scans:
/// `expect` lists `name=value` of main's variables.
fn check(pous: &str, vars: &str, body: &str, scans: usize, expect: &str) {
    let source = format!("{pous}\nPROGRAM main\nVAR\n{vars}\nEND_VAR\n{body}\nEND_PROGRAM\n");
    let paths: Vec<String> = expect
        .split_whitespace()
        .map(|kv| format!("main.{}", kv.split('=').next().unwrap_or(kv)))
        .collect();
    let paths: Vec<&str> = paths.iter().map(String::as_str).collect();
    let want = expect
        .split_whitespace()
        .map(|kv| format!("main.{kv}"))
        .collect::<Vec<_>>()
        .join(" ");
    assert_eq!(run(&source, scans, &paths), want, "{source}");
}

/// As [`check`], for a program that faults: the fault's message contains `expect`.
fn check_fault(vars: &str, body: &str, scans: usize, expect: &str) {
    check_fault_in(vars, body, scans, expect, Overflow::default());
}

fn check_fault_in(vars: &str, body: &str, scans: usize, expect: &str, overflow: Overflow) {
    let source = format!("PROGRAM main\nVAR\n{vars}\nEND_VAR\n{body}\nEND_PROGRAM\n");
    let got = run_in(&source, scans, &[], overflow);
    assert!(
        got.starts_with("fault: ") && got.contains(expect),
        "{got}\nwanted a fault with {expect} from\n{source}"
    );
}

#[test]
fn integer_arithmetic_and_precedence() {
    check(
        "",
        "a, b, c, d, f : DINT; e : LREAL;",
        "a := 2 + 3 * 4; b := (2 + 3) * 4; c := 17 MOD 5; d := -7 / 2; e := 2 ** 10;
         f := -a;",
        1,
        "a=14 b=20 c=2 d=-3 e=1024.0 f=-14",
    );
}

#[test]
fn reals_and_conversions() {
    check(
        "",
        "r : REAL; l : LREAL; i : INT; j : DINT; w : WORD;",
        "r := 1.0 / 4.0; l := INT_TO_LREAL(7) / 2.0; i := REAL_TO_INT(2.75);
         j := TRUNC(-2.75); w := INT_TO_WORD(-1);",
        1,
        "r=0.25 l=3.5 i=3 j=-2 w=65535",
    );
}

#[test]
fn bool_chains_and_negated_terms() {
    // Three or more terms become one instruction over literals; `a AND NOT b` another.
    check(
        "",
        "x : BOOL := TRUE; y : BOOL := TRUE; z : BOOL; p, q, r, s, t : BOOL;",
        "p := x AND y AND NOT z; q := x AND y AND z; r := z OR z OR NOT x;
         s := x AND NOT z; t := z OR NOT y;",
        1,
        "p=1 q=0 r=0 s=1 t=0",
    );
}

/// The superinstructions are what the compiler emits for these shapes (the VM and the JIT
/// run them on their fast paths).
#[test]
fn superinstructions_for_bool_code() {
    let e = engine(
        "PROGRAM main VAR x, y, z, p, q, r, s, d, f : BOOL; END_VAR
         p := x AND y AND NOT z; q := x OR y OR z; r := x AND NOT y; s := x OR NOT y;
         IF x THEN d := TRUE; f := FALSE; END_IF;
         END_PROGRAM",
    );
    let ops = &e.code.ops;
    let lits = &e.code.lits;
    assert!(
        ops.iter()
            .any(|o| matches!(*o, Op::AndLits { start, len: 3, .. }
            if lits[start as usize + 2].1 == 1)),
        "{ops:?}"
    );
    assert!(
        ops.iter().any(|o| matches!(o, Op::OrLits { len: 3, .. })),
        "{ops:?}"
    );
    assert!(ops.iter().any(|o| matches!(o, Op::AndN { .. })), "{ops:?}");
    assert!(ops.iter().any(|o| matches!(o, Op::OrN { .. })), "{ops:?}");
    assert!(
        ops.iter()
            .any(|o| matches!(o, Op::CondStore { len: 2, .. })),
        "{ops:?}"
    );
}

#[test]
fn fused_bool_statements() {
    // Runs of BOOL assignments and IFs over BOOL literals are fused into one instruction.
    check(
        "",
        "a : BOOL := TRUE; b, c, d : BOOL;",
        "b := a; c := NOT a; IF a THEN d := TRUE; END_IF;",
        1,
        "b=1 c=0 d=1",
    );
}

#[test]
fn comparisons_of_every_kind() {
    check(
        "",
        "i, u, f, s, t : BOOL; w : UDINT := 4000000000;",
        "i := -1 < 1; u := w > UDINT#1; f := 1.5 >= 1.5; s := 'abc' < 'abd'; t := T#1s = T#1000ms;",
        1,
        "i=1 u=1 f=1 s=1 t=1",
    );
}

#[test]
fn time_and_date_arithmetic() {
    check(
        "",
        "t : TIME; u : TIME; d : TOD; e : TIME;",
        "t := T#1s + T#500ms; u := T#2s * 3; d := TOD#10:00:00 + T#90m; e := TOD#12:00:00 - TOD#11:30:00;",
        1,
        "t=T#1s500ms u=T#6s d=TOD#11:30:00 e=T#30m",
    );
}

#[test]
fn if_case_and_loops() {
    check(
        "",
        "k : INT := 7; c, s, n, w, r : INT; i : INT;",
        "IF k < 5 THEN c := 1; ELSIF k < 10 THEN c := 2; ELSE c := 3; END_IF;
         CASE k OF 1, 2: s := 10; 5..8: s := 20; ELSE s := 30; END_CASE;
         FOR i := 10 TO 1 BY -3 DO n := n + i; END_FOR;
         WHILE w < 100 DO w := w + 30; IF w > 50 THEN EXIT; END_IF; END_WHILE;
         REPEAT r := r + 1; UNTIL r >= 3 END_REPEAT;",
        1,
        "c=2 s=20 n=22 w=60 r=3 i=-2",
    );
}

#[test]
fn state_persists_across_scans() {
    check(
        "",
        "n : DINT; t : TON; q : BOOL; e : TIME;",
        "n := n + 1; t(IN := TRUE, PT := T#25ms); q := t.Q; e := t.ET;",
        4,
        "n=4 q=1 e=T#25ms",
    );
}

#[test]
fn calls_of_functions_and_function_blocks() {
    check(
        "FUNCTION add3 : INT VAR_INPUT a, b, c : INT; END_VAR add3 := a + b + c; END_FUNCTION
         FUNCTION_BLOCK counter
           VAR_INPUT step : INT; END_VAR VAR_OUTPUT total : INT; END_VAR
           VAR_IN_OUT seen : INT; END_VAR
           total := total + step; seen := seen + 1;
         END_FUNCTION_BLOCK",
        "x, y, seen : INT; c : counter; cs : ARRAY[1..2] OF counter;",
        "x := add3(a := 1, b := 2, c := 4) + add3(1, 1, 1); c(step := 5, seen := seen); y := c.total;
         cs[2](step := 2, seen := seen);",
        3,
        "x=10 y=15 seen=6 cs[2].total=6 cs[1].total=0",
    );
}

#[test]
fn standard_functions() {
    check(
        "",
        "a, b, c, d, e : INT; f : BYTE; g : REAL; h : DINT;",
        "a := MAX(3, 9, 4); b := MIN(3, -9); c := LIMIT(0, 12, 10); d := SEL(TRUE, 1, 2);
         e := MUX(2, 10, 20, 30); f := ROL(BYTE#16#81, 1); g := SQRT(16.0); h := ABS(-5);",
        1,
        "a=9 b=-9 c=10 d=2 e=30 f=3 g=4.0 h=5",
    );
}

#[test]
fn string_functions() {
    check(
        "",
        "s : STRING[20]; l, p : INT; m, r, c : STRING[20];",
        "s := CONCAT('abc', 'def', 'g'); l := LEN(s); m := MID(s, 3, 2); p := FIND(s, 'de');
         r := REPLACE(s, 'XY', 2, 1); c := LEFT(s, 2);",
        1,
        "s='abcdefg' l=7 m='bcd' p=4 r='XYcdefg' c='ab'",
    );
}

#[test]
fn structures_and_arrays() {
    check(
        "TYPE pt : STRUCT x, y : INT; END_STRUCT; END_TYPE",
        "p : pt; ps : ARRAY[0..2] OF pt; a : ARRAY[1..3] OF INT := [1, 2, 3]; i : INT := 2; s : INT;",
        "p.x := 4; ps[i].y := p.x * 2; a[i + 1] := 10; s := a[1] + a[2] + a[3] + ps[2].y;",
        1,
        "p.x=4 ps[2].y=8 a[3]=10 s=21",
    );
}

#[test]
fn faults_stop_the_scan_with_the_values() {
    check_fault("d, z : DINT;", "d := 5 / z;", 1, "division by zero: 5 / 0");
    check_fault(
        "a : ARRAY[1..3] OF INT; i : INT := 4;",
        "a[i] := 1;",
        1,
        "index 4 is outside the array's bounds 1..3",
    );
    check_fault_in(
        "i : SINT := 120;",
        "i := i + 10;",
        1,
        "overflow: 120 + 10 = 130 leaves -128..127",
        Overflow::Fault,
    );
    // Wrapping, the default, changes no other fault.
    check_fault(
        "i : SINT := 120; d : SINT;",
        "i := i + 10; d := i / 0;",
        1,
        "division by zero",
    );
    check(
        "",
        "i : SINT := 120; j : SINT;",
        "i := i + 10; j := -i;",
        1,
        "i=-126 j=126",
    );
    check_fault(
        "n : DINT;",
        "WHILE TRUE DO n := n + 1; END_WHILE;",
        1,
        "watchdog: a loop ran out of the scan's iteration budget",
    );
}

#[test]
fn a_reference_in_a_retained_instance_is_not_retained() {
    let e = engine(
        "FUNCTION_BLOCK Keep\nVAR_INPUT n : INT; END_VAR\nVAR p : POINTER TO INT; s : INT; END_VAR\np := ADR(s);\nEND_FUNCTION_BLOCK\n\
         PROGRAM main\nVAR RETAIN k : Keep; END_VAR\nk(n := 1);\nEND_PROGRAM\n",
    );
    let paths: Vec<String> = e.retained().into_iter().map(|r| r.path).collect();
    assert_eq!(paths, vec!["main.k.n", "main.k.s"]);
}

/// ARRAY[*] in-outs of a FUNCTION and of a FUNCTION_BLOCK: elements read and written in
/// the caller's array through the descriptor, an instance's in-out passed on to a function,
/// bounds read at run time.
#[test]
fn array_star_in_outs_compute_on_the_callers_array() {
    check(
        "FUNCTION Fill : DINT VAR_IN_OUT xs : ARRAY[*, *] OF DINT; END_VAR VAR i, j : DINT; END_VAR
           FOR i := LOWER_BOUND(xs, 1) TO UPPER_BOUND(xs, 1) DO
             FOR j := LOWER_BOUND(xs, 2) TO UPPER_BOUND(xs, 2) DO xs[i, j] := i * 10 + j; END_FOR;
           END_FOR;
           Fill := UPPER_BOUND(xs, 2) - LOWER_BOUND(xs, 1);
         END_FUNCTION
         FUNCTION Last : DINT VAR_IN_OUT xs : ARRAY[*, *] OF DINT; END_VAR
           Last := xs[UPPER_BOUND(xs, 1), UPPER_BOUND(xs, 2)];
         END_FUNCTION
         FUNCTION_BLOCK Keep VAR_IN_OUT xs : ARRAY[*, *] OF DINT; END_VAR VAR_OUTPUT l : DINT; END_VAR
           l := Last(xs);
         END_FUNCTION_BLOCK",
        "m : ARRAY[1..2, 3..5] OF DINT; r, l : DINT; k : Keep;",
        "r := Fill(m); k(xs := m, l => l);",
        1,
        "m[1,3]=13 m[2,4]=24 m[2,5]=25 r=4 l=25",
    );
}

/// A subscript outside the caller's array is the ordinary index fault, at the line of the
/// access in the callee.
#[test]
fn an_array_star_subscript_outside_the_callers_array_faults_where_it_is() {
    let src = "FUNCTION Get : INT\nVAR_IN_OUT xs : ARRAY[*] OF INT; END_VAR\nVAR_INPUT i : DINT; END_VAR\nGet := xs[i];\nEND_FUNCTION\n\
               PROGRAM main\nVAR a : ARRAY[0..2] OF INT; n : DINT := 2; r : INT; END_VAR\nr := Get(a, n); n := n + 1;\nEND_PROGRAM\n";
    let engine = engine(src);
    let mut m = Machine::new(engine);
    m.set_backend(Backend::Vm);
    assert!(m.scan(0, &mut || true).is_ok());
    let f = m.scan(10_000_000, &mut || true).unwrap_err();
    assert_eq!(
        (f.pou.as_str(), f.line, f.message.as_str()),
        (
            "FUNCTION Get",
            4,
            "array index out of range: index 3 is outside the array's bounds 0..2"
        ),
        "{f}"
    );
}

/// A METHOD and an ACTION of a block reading the block's own ARRAY[*] in-out (through the
/// instance), with the bounds the last call passed.
#[test]
fn a_blocks_array_star_in_out_is_seen_by_its_methods() {
    check(
        "FUNCTION_BLOCK Hold VAR_IN_OUT xs : ARRAY[*] OF INT; END_VAR VAR_OUTPUT n, top : DINT; END_VAR
           n := Width();
           Peek();
         METHOD Width : DINT
           Width := UPPER_BOUND(xs, 1) - LOWER_BOUND(xs, 1) + 1;
         END_METHOD
         ACTION Peek:
           top := xs[UPPER_BOUND(xs, 1)];
         END_ACTION
         END_FUNCTION_BLOCK",
        "a : ARRAY[-1..2] OF INT := [4, 3, 2, 1]; h : Hold; n, top : DINT;",
        "h(xs := a, n => n, top => top);",
        1,
        "n=4 top=1",
    );
}

/// A function with an ARRAY[*] in-out called as a statement, with EN/ENO, and in a larger
/// expression: the array and its bounds are passed each time.
#[test]
fn array_star_calls_as_statements_and_with_en() {
    check(
        "FUNCTION Bump : INT VAR_IN_OUT xs : ARRAY[*] OF INT; END_VAR VAR i : DINT; END_VAR
           FOR i := LOWER_BOUND(xs, 1) TO UPPER_BOUND(xs, 1) DO xs[i] := xs[i] + 1; END_FOR;
           Bump := xs[LOWER_BOUND(xs, 1)];
         END_FUNCTION",
        "a : ARRAY[2..3] OF INT; b : ARRAY[0..0] OF INT; go : BOOL; e : BOOL := TRUE; r : INT;",
        "Bump(xs := a);
         r := Bump(EN := go, xs := b, ENO => e);
         r := r + 10 * Bump(a);",
        1,
        "a[2]=2 a[3]=2 b[0]=0 e=0 r=20",
    );
}
