//! The checker's diagnostics on small sources.

use petriplc_iec_syntax::{parser, SourceMap};

use crate::{check, ir, Options, Overflow};

/// Checks `src` as the file `t.st` (it must parse); returns the project and the rendered
/// diagnostics. The other test modules of the checker call it too.
pub(crate) fn run(src: &str) -> (Option<ir::Project>, String) {
    run_in(src, Overflow::default())
}

/// The diagnostics of checking `src` (one a line), or `ok`, against `expect`: the
/// `check(input, expect)` of the checker's rule tests (OOP, interfaces).
pub(crate) fn check_src(src: &str, expect: &str) {
    let (p, rendered) = run(src);
    let got = if p.is_some() && rendered.is_empty() {
        "ok".to_string()
    } else {
        rendered
    };
    assert_eq!(got.trim_end(), expect.trim_end(), "{src}");
}

/// Checks `src`; every rendered diagnostic line must contain the fragment at its place in
/// `expect`, and there must be as many.
pub(crate) fn check_diags(src: &str, expect: &[&str]) {
    let (p, text) = run(src);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), expect.len(), "got:\n{text}");
    for (l, e) in lines.iter().zip(expect) {
        assert!(l.contains(e), "expected `{e}` in\n{l}\n(all:\n{text})");
    }
    assert_eq!(p.is_some(), !text.contains("error["), "{text}");
}

/// Checks `src` in a vendor's dialect.
pub(crate) fn run_dialect(
    src: &str,
    dialect: petriplc_iec_syntax::Dialect,
) -> (Option<ir::Project>, String) {
    run_with(
        src,
        Options {
            dialect,
            ..Options::default()
        },
    )
}

fn run_in(src: &str, overflow: Overflow) -> (Option<ir::Project>, String) {
    run_with(
        src,
        Options {
            overflow,
            ..Options::default()
        },
    )
}

fn run_with(src: &str, options: Options) -> (Option<ir::Project>, String) {
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, src, &mut d);
    assert!(!d.has_errors(), "syntax: {}", d.render(&map));
    let (p, diags) = check(&lib, &options);
    (p, diags.render(&map))
}

fn check_ok(src: &str) -> ir::Project {
    let (p, d) = run(src);
    assert!(p.is_some(), "{d}");
    assert!(!d.contains("error"), "{d}");
    p.unwrap()
}

/// `expect` lists fragments, one per expected diagnostic line, in order.
fn check_errors(src: &str, expect: &[&str]) {
    let (_, d) = run(src);
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), expect.len(), "got:\n{d}");
    for (l, e) in lines.iter().zip(expect) {
        assert!(l.contains(e), "expected `{e}` in\n{l}\n(all:\n{d})");
    }
}

fn prog(decls: &str, body: &str) -> String {
    format!("PROGRAM p\nVAR\n{decls}\nEND_VAR\n{body}\nEND_PROGRAM\n")
}

#[test]
fn a_valid_program() {
    let p = check_ok(&prog(
        "i : INT; r : REAL; b : BOOL; t : TON; s : STRING[10]; a : ARRAY[1..3] OF DINT := [1, 2, 3];",
        "i := i + 1; r := INT_TO_REAL(i) * 2.5; b := i > 3 AND NOT b;
         t(IN := b, PT := T#1s); b := t.Q; s := CONCAT(s, 'x'); a[i MOD 3 + 1] := a[1] + i;
         IF b THEN i := 0; END_IF; CASE i OF 1, 2: i := 3; 4..6: i := 7; ELSE i := 0; END_CASE;
         FOR i := 1 TO 10 BY 2 DO r := r + 1.0; END_FOR;",
    ));
    assert_eq!(p.pous.len(), 1);
}

#[test]
fn undeclared_and_types() {
    check_errors(
        &prog("i : INT; r : REAL;", "x := 1; i := r; i := 70000; r := i;"),
        &[
            "t.st:5:1: error[E100]: `x` is not declared",
            "t.st:5:14: error[E110]: the value assigned to `i` is REAL but INT is needed; convert explicitly: REAL_TO_INT(…) rounds, TRUNC(…) truncates",
            "t.st:5:22: error[E113]: 70000 does not fit INT",
        ],
    );
}

#[test]
fn constants_inputs_and_loop_variables() {
    check_errors(
        "PROGRAM p
VAR_INPUT go : BOOL; END_VAR
VAR CONSTANT k : INT := 3; END_VAR
VAR i : INT; END_VAR
k := 4;
go := TRUE;
FOR i := 1 TO k DO i := 2; END_FOR;
END_PROGRAM",
        &[
            "t.st:5:1: error[E121]: `k` is a CONSTANT",
            "t.st:6:1: warning[W020]: `go` is an input of this POU: assigning it changes this POU's copy",
            "t.st:7:20: warning[W031]: `i` controls the FOR loop",
        ],
    );
}

#[test]
fn case_labels() {
    check_errors(
        &prog(
            "i : SINT;",
            "CASE i OF 1..5: i := 0; 3: i := 1; 200: i := 2; 6, 6: i := 3; 9..7: ; END_CASE;",
        ),
        &[
            "E140]: this label is unreachable",
            "E140]: this label can never match: a SINT selector is -128..127",
            "E140]: this label is unreachable",
            "E140]: the range 9..7 is empty",
        ],
    );
}

#[test]
fn calls() {
    check_errors(
        "FUNCTION f : INT
VAR_INPUT a : INT; END_VAR
VAR_IN_OUT b : INT; END_VAR
f := a + b;
END_FUNCTION
PROGRAM p
VAR i : INT; t : TON; r : REAL; END_VAR
i := f(a := 1);
i := f(1, i, 3);
i := f(a := 1, c := 2, b := i);
t(IN := TRUE, Q := i);
i := g(1);
i := f(a := 1, i);
t(IN := r);
END_PROGRAM",
        &[
            "t.st:8:6: error[E130]: in-out `b` of f must be given in every call",
            "t.st:9:14: error[E130]: f takes 2 argument(s) (a, b), this is argument 3",
            "t.st:10:16: error[E130]: f has no parameter `c`",
            "t.st:11:15: error[E130]: `Q` is an output of TON: connect it with `=>`",
            "t.st:12:6: error[E102]: unknown function `g`",
            "t.st:13:6: error[E130]: the call of f mixes named",
            "t.st:14:9: error[E110]: argument `IN` is REAL but BOOL is needed",
        ],
    );
}

#[test]
fn externals_and_configuration() {
    let p = check_ok(
        "PROGRAM chase
VAR_EXTERNAL L : BYTE; END_VAR
L := ROL(L, 1);
END_PROGRAM
CONFIGURATION c
VAR_GLOBAL L AT %L : BYTE := 1; END_VAR
RESOURCE r ON PLC
TASK t (INTERVAL := T#300ms, PRIORITY := 1);
PROGRAM main WITH t : chase;
END_RESOURCE
END_CONFIGURATION",
    );
    let c = p.configuration.unwrap();
    assert_eq!(c.tasks[0].interval, Some(300_000_000));
    assert_eq!(p.globals[0].location.as_deref(), Some("L"));
    check_errors(
        "PROGRAM q VAR_EXTERNAL g : INT; END_VAR g := 1; END_PROGRAM
PROGRAM r VAR x : INT; END_VAR x := h; END_PROGRAM
CONFIGURATION c VAR_GLOBAL g : DINT; h : INT; END_VAR END_CONFIGURATION",
        &[
            "error[E106]: VAR_EXTERNAL g is INT but the global variable is DINT",
            "error[E100]: `h` is not declared; it is a global variable: declare it in the POU's VAR_EXTERNAL",
        ],
    );
}

#[test]
fn a_library_checked_alone_warns_of_its_missing_globals() {
    let src = "FUNCTION_BLOCK ticks VAR_EXTERNAL PLC_TICKS_PER_SEC : INT; g : DINT; END_VAR
VAR_OUTPUT t : INT; END_VAR
t := PLC_TICKS_PER_SEC;
END_FUNCTION_BLOCK
CONFIGURATION c VAR_GLOBAL g : INT; END_VAR END_CONFIGURATION";
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, src, &mut d);
    let library = Options {
        library: true,
        ..Options::default()
    };
    let (_, alone) = check(&lib, &library);
    let alone = alone.render(&map);
    // The missing global is a warning; a global of another type stays an error.
    let lines: Vec<&str> = alone.lines().collect();
    assert_eq!(lines.len(), 2, "{alone}");
    assert!(
        lines[0].contains("t.st:1:35: warning[W021]: VAR_EXTERNAL PLC_TICKS_PER_SEC has no VAR_GLOBAL of that name among these sources"),
        "{alone}"
    );
    assert!(
        lines[1].contains("error[E106]: VAR_EXTERNAL g is DINT but the global variable is INT"),
        "{alone}"
    );
    // Built to run, the missing global is an error.
    let (p, built) = check(&lib, &Options::default());
    assert!(p.is_none());
    assert!(
        built
            .render(&map)
            .contains("t.st:1:35: error[E106]: VAR_EXTERNAL PLC_TICKS_PER_SEC has no VAR_GLOBAL"),
        "{}",
        built.render(&map)
    );
}

#[test]
fn recursion_and_self_containment() {
    check_errors(
        "FUNCTION a : INT VAR_INPUT x : INT; END_VAR a := b(x); END_FUNCTION
FUNCTION b : INT VAR_INPUT x : INT; END_VAR b := a(x); END_FUNCTION
FUNCTION_BLOCK fb VAR inner : fb; END_VAR END_FUNCTION_BLOCK",
        &[
            "error[E107]: this call makes",
            "error[E107]: function block fb contains an instance of itself",
        ],
    );
}

#[test]
fn literals_adapt_and_fold() {
    let p = check_ok(&prog(
        "s : SINT := -128; w : WORD := 16#FFFF; u : USINT; l : LREAL := 1.5; t : TIME := T#1m30s + T#500ms;",
        "u := 255; s := -5 * 2; l := 2 ** 3;",
    ));
    let v = &p.pous[0].vars;
    assert_eq!(v[0].init, Some(crate::value::Value::Int(-128)));
    assert_eq!(v[4].init, Some(crate::value::Value::Int(90_500_000_000)));
    check_errors(
        &prog(
            "s : SINT; x : INT;",
            "s := 1 + 200; x := 10 / 0; x := INT#32767 + 1;",
        ),
        &[
            "E113]: 201 does not fit SINT",
            "E113]: this constant expression divides by zero",
            "E113]: this constant expression overflows INT",
        ],
    );
    // Written out, an overflowing constant expression is a mistake in both modes (matiec
    // refuses it too), though the same operation on variables wraps at run time.
    for mode in [Overflow::Wrap, Overflow::Fault] {
        let (_, d) = run_in(
            &prog("x : INT; u : UDINT;", "x := -INT#-32768; u := UDINT#0 - 1;"),
            mode,
        );
        assert_eq!(
            d.matches("this constant expression overflows").count(),
            2,
            "{d}"
        );
    }
    // REAL arithmetic gives Inf and NaN at run time; written as constants they are refused.
    check_errors(
        &prog(
            "r : REAL; l : LREAL;",
            "r := 1.0 / 0.0; r := 1.0E30 * 1.0E30; l := SQRT(-1.0); l := 1.0E300 * 1.0E300;",
        ),
        &[
            "E113]: this constant expression divides by zero",
            "E113]: this value does not fit REAL",
            "E113]: this constant expression has no value: the result is not a number (NaN)",
            "E113]: this constant expression overflows a real literal",
        ],
    );
}

#[test]
fn enumerations_and_structures() {
    check_ok(
        "TYPE Color : (Red, Green, Blue); Light : (Off, Red2, Green2); Pt : STRUCT x : INT; y : INT := 5; END_STRUCT; END_TYPE
PROGRAM p
VAR c : Color := Green; q : Pt := (x := 2); a : ARRAY[0..1] OF Pt; END_VAR
IF c = Red THEN c := Color#Blue; END_IF;
CASE c OF Red: q.x := 1; Green, Blue: q.y := a[1].x; END_CASE;
a[0] := q;
END_PROGRAM",
    );
    check_errors(
        "TYPE Color : (Red, Green); Pt : STRUCT x : INT; END_STRUCT; END_TYPE
PROGRAM p VAR c : Color; q : Pt; i : INT; END_VAR
c := 1; q.z := 1; i := c; i := q;
END_PROGRAM",
        &[
            "E110]: the value assigned to `c` is an integer literal but Color is needed",
            "E105]: structure Pt has no field `z`",
            "E110]: the value assigned to `i` is Color but INT is needed",
            "E110]: the value assigned to `i` is Pt but the target is INT",
        ],
    );
}

#[test]
fn statements_out_of_place() {
    check_errors(
        &prog(
            "i : INT;",
            "EXIT; IF i THEN CONTINUE; END_IF; WHILE i > 0 DO EXIT; END_WHILE;",
        ),
        &[
            "E142]: EXIT is only allowed inside FOR, WHILE or REPEAT",
            "E112]: a condition must be BOOL, not INT",
            "E142]: CONTINUE is only allowed",
        ],
    );
}

proptest::proptest! {
    /// No source the parser accepts makes the checker panic.
    #[test]
    fn never_panics(body in proptest::collection::vec(proptest::sample::select(vec![
        "x", "y", "a", "t", "s", ":=", ";", "+", "-", "*", "/", "MOD", "AND", "NOT", "(", ")",
        "[", "]", ",", "1", "0", "2.5", "T#1s", "'s'", "TRUE", "IF", "THEN", "END_IF", "CASE",
        "OF", ":", "END_CASE", "FOR", "TO", "DO", "END_FOR", ".", "Q", "IN", "=>", "MAX", "f",
        "INT_TO_REAL", "..", "EXIT", "RETURN", "WHILE", "END_WHILE", "ELSE",
    ]), 0..40)) {
        let src = format!(
            "FUNCTION f : INT VAR_INPUT i : INT; END_VAR f := i; END_FUNCTION
PROGRAM p VAR x : INT; y : REAL; a : ARRAY[1..3] OF INT; t : TON; s : STRING; END_VAR
{}
END_PROGRAM", body.join(" "));
        let mut map = SourceMap::new();
        let f = map.add("t.st", src.as_str());
        let mut d = petriplc_iec_syntax::Diagnostics::new();
        let lib = parser::parse(f, &src, &mut d);
        let _ = check(&lib, &Options::default());
    }
}

#[test]
fn constant_inputs_are_inputs() {
    // CODESYS and TwinCAT write VAR_INPUT CONSTANT and VAR_IN_OUT CONSTANT; the caller gives
    // the value, so it is an input, not a constant of the declaration.
    check_ok(
        "FUNCTION f : INT
VAR_INPUT CONSTANT k : INT := 2; END_VAR
VAR_IN_OUT CONSTANT r : INT; END_VAR
f := k * r;
END_FUNCTION
PROGRAM p
VAR x : INT := 3; y : INT; END_VAR
y := f(k := 5, r := x);
y := f(r := x);
END_PROGRAM",
    );
    // Its initial value is only the default of a call that omits it: never folded in.
    check_errors(
        "FUNCTION_BLOCK fb
VAR_INPUT CONSTANT n : INT := 3; END_VAR
VAR a : ARRAY[1..n] OF INT; END_VAR
END_FUNCTION_BLOCK
PROGRAM p
END_PROGRAM",
        &["E108]: `n` is a variable; only constants (VAR CONSTANT, literals) can be used here"],
    );
    check_errors(
        "PROGRAM p
VAR_OUTPUT CONSTANT o : INT := 1; END_VAR
END_PROGRAM",
        &["E109]: CONSTANT applies to VAR, VAR_INPUT, VAR_IN_OUT, VAR_EXTERNAL and VAR_GLOBAL blocks"],
    );
}

#[test]
fn typed_standard_functions_are_their_generic_with_typed_arguments() {
    check_ok(&prog(
        "d : DWORD; w : WORD; b : BYTE; i : INT; si : SINT; r : REAL; lr : LREAL; t : TIME;
         s : STRING[10]; x : BOOL; k : INT;",
        "d := SHR_DWORD(d, 3); d := SHL_DWORD(w, i); b := SHL_BYTE(b, 1); w := ROL_WORD(w, 4);
         d := ROR_DWORD(16#F, 4); i := LIMIT_INT(0, si, 100); r := LIMIT_REAL(0.0, r, 1.0);
         t := SEL_TIME(x, T#1s, t); r := SEL_REAL(x, 1, r); s := SEL_STRING(x, s, 'ab');
         i := MIN_INT(i, si, 3); i := MAX_INT(IN1 := i, IN2 := 7); x := EQ_STRING(s, 'ab');
         x := GT_REAL(r, 0.5, 0.25); i := ADD_INT(i, si, 1); r := MUL_REAL(r, 2);
         i := MOVE_INT(si); r := ABS_REAL(r); lr := SQRT_LREAL(r); i := MUX_INT(k, i, si);
         b := AND_BYTE(b, 16#0F); x := NOT_BOOL(x); i := MOD_INT(i, 3); lr := EXPT_LREAL(lr, 2);",
    ));
}

#[test]
fn typed_standard_functions_refuse_arguments_of_other_types() {
    check_errors(
        &prog(
            "d : DWORD; i : INT; di : DINT; r : REAL; s : STRING; x : BOOL;",
            "d := SHR_DWORD(i, 3);
i := LIMIT_INT(0, di, 10);
x := EQ_STRING(s, i);
r := SEL_REAL(x, r, 1.5, 2.0);
i := ADD_INT(i, r);
r := SQRT_INT(i);",
        ),
        &[
            "t.st:5:16: error[E110]: argument 1 of SHR_DWORD is INT but DWORD is needed; convert explicitly: INT_TO_DWORD(…)",
            "t.st:6:19: error[E110]: argument 2 of LIMIT_INT is DINT but INT is needed",
            "t.st:7:19: error[E110]: argument 2 of EQ_STRING is INT but STRING",
            "t.st:8:26: error[E130]: SEL_REAL takes 3 argument(s) (G, IN0, IN1)",
            "t.st:9:17: error[E110]: argument 2 of ADD_INT is REAL but INT is needed",
            "t.st:10:15: error[E110]: SQRT_INT takes REAL or LREAL, not INT",
        ],
    );
    // A function and a type that make no typed form stay unknown.
    check_errors(
        &prog("i : INT;", "i := LEN_FOO(i);"),
        &["t.st:5:6: error[E102]: unknown function `LEN_FOO`"],
    );
}

#[test]
fn bcd_conversions() {
    let p = check_ok(&prog(
        "w : WORD; b : BYTE; d : DWORD; i : INT; u : UINT; us : USINT; di : DINT;",
        "i := WORD_BCD_TO_INT(w); u := BCD_TO_UINT(w); us := BYTE_BCD_TO_USINT(b);
         w := INT_TO_BCD_WORD(i); b := USINT_TO_BCD(us); d := DINT_TO_BCD(di);
         w := UINT_TO_BCD(u); i := BCD_TO_INT(16#1234); w := INT_TO_BCD_WORD(1234);",
    ));
    // Constant arguments fold to their values.
    let body = format!("{:?}", p.pous[0].body);
    assert!(
        body.contains("Int(1234)") && body.contains("Int(4660)"),
        "{body}"
    );
    check_errors(
        &prog(
            "w : WORD; i : INT; r : REAL;",
            "i := INT_BCD_TO_WORD(i);
i := BCD_TO_INT(i);
w := REAL_TO_BCD(r);
i := BCD_TO_INT(16#12A4);",
        ),
        &[
            "t.st:5:6: error[E102]: unknown function `INT_BCD_TO_WORD`: INT has no place here",
            "t.st:6:17: error[E110]: BCD_TO_INT takes a bit string (BYTE, WORD, DWORD, LWORD) of BCD digits, not INT",
            "t.st:7:6: error[E102]: unknown function `REAL_TO_BCD`: REAL has no place here",
            "t.st:8:6: error[E113]",
        ],
    );
}

#[test]
fn a_constant_without_value_holds_its_default_with_a_warning() {
    // CODESYS's C0228 is a warning; OSCAT's global constant structures rely on it.
    let src = "TYPE pair : STRUCT a : INT := 4; b : INT := 5; END_STRUCT; END_TYPE
VAR_GLOBAL CONSTANT
  P : pair;
END_VAR
PROGRAM p
VAR CONSTANT k : INT; END_VAR
VAR_EXTERNAL CONSTANT P : pair; END_VAR
VAR a : ARRAY[0..k] OF INT; x : INT; END_VAR
x := k + P.a;
END_PROGRAM";
    let (p, d) = run(src);
    assert!(p.is_some(), "{d}");
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), 2, "{d}");
    assert!(
        lines[0].starts_with(
            "t.st:3:3: warning[W012]: a CONSTANT without a value holds its type's initial value"
        ),
        "{d}"
    );
    assert!(lines[1].starts_with("t.st:6:14: warning[W012]"), "{d}");
}

#[test]
fn and_or_xor_not_as_functions() {
    check_ok(&prog(
        "a, b, c : BOOL; w, v : WORD; i : INT;",
        "a := AND(a, b, c); b := OR(IN1 := a, IN2 := b); c := XOR(a, b) AND NOT(c);
         w := AND(w, v, 16#FF00); v := OR(w, 1); w := XOR(w, v); v := NOT(IN := w);
         i := MOD(i, 4) + 1;",
    ));
    check_errors(
        &prog("a : BOOL; i : INT;", "a := AND(a, i);"),
        &["t.st:5:6: error[E111]"],
    );
}

#[test]
fn arithmetic_on_bit_strings() {
    let p = check_ok(&prog(
        "b : BYTE; w : WORD; d : DWORD; l : LWORD; i : INT; si : SINT; di : DINT; u : UINT;
         c : BYTE := BYTE#255 + 1; e : DWORD := DWORD#16#10 - 16#20; k : BOOL;",
        "b := b + 1; w := w * 3 - b; d := d / 16#10 MOD 7; l := l + w; w := w * u;
         i := b + i; d := d - i; d := d + di; di := di + w; k := b < i; d := SHR(d, 2) * 10;",
    ));
    // Constants wrap around in the bit string's width.
    let init = format!("{:?}", p.pous[0].vars);
    assert!(
        init.contains("Int(0)") && init.contains("Int(4294967280)"),
        "{init}"
    );
    check_errors(
        &prog(
            "w : WORD; i : INT; r : REAL; b : BOOL; d : DWORD; t : TIME;",
            "i := w + i;\nb := w < i;\nr := d * r;\nt := t ** 2;",
        ),
        &[
            "t.st:5:6: error[E110]: the value assigned to `i` is WORD but INT is needed",
            "t.st:6:6: error[E111]",
            "t.st:7:6: error[E111]",
            "t.st:8:6: error[E111]",
        ],
    );
}

#[test]
fn bit_strings_convert_implicitly_to_numbers_that_hold_them() {
    check_errors(
        &prog(
            "b : BYTE; w : WORD; d : DWORD; i : INT; di : DINT; r : REAL; lr : LREAL; si : SINT;",
            "i := b;\ndi := w;\nr := r * b;\nlr := d;\nsi := b;\nr := d;",
        ),
        &[
            "t.st:5:6: warning[W022]: the value assigned to `i` is BYTE, converted to INT implicitly as CODESYS does; the standard wants BYTE_TO_INT(…) written",
            "t.st:6:7: warning[W022]: the value assigned to `di` is WORD, converted to DINT",
            "t.st:7:10: warning[W022]: this operand is BYTE, converted to REAL",
            "t.st:8:7: warning[W022]: the value assigned to `lr` is DWORD, converted to LREAL",
            "t.st:9:7: error[E110]: the value assigned to `si` is BYTE but SINT is needed",
            "t.st:10:6: error[E110]: the value assigned to `r` is DWORD but REAL is needed",
        ],
    );
}

#[test]
fn a_constant_may_be_used_above_its_declaration() {
    let p = check_ok(
        "FUNCTION_BLOCK fifo
VAR buf : ARRAY[0..n] OF DWORD; s : STRING[len * 2]; END_VAR
VAR CONSTANT n : INT := m + 1; m : INT := 15; len : INT := 4; END_VAR
buf[n] := 1;
END_FUNCTION_BLOCK
PROGRAM p VAR f : fifo; END_VAR f(); END_PROGRAM",
    );
    let fifo = &p.pous[0];
    let buf = p.types.name(fifo.vars[0].ty);
    assert_eq!(buf, "ARRAY[0..16] OF DWORD");
    assert_eq!(p.types.name(fifo.vars[1].ty), "STRING[8]");
    // Defined through itself, or not a constant: still refused, once.
    check_errors(
        "PROGRAM q
VAR a : ARRAY[0..k] OF INT; b : ARRAY[0..v] OF INT; END_VAR
VAR CONSTANT k : INT := k + 1; END_VAR
VAR v : INT := 3; END_VAR
END_PROGRAM",
        &[
            "t.st:2:18: error[E100]: `k` is not declared",
            "t.st:2:42: error[E100]: `v` is not declared",
            "t.st:3:25: error[E100]: `k` is not declared",
        ],
    );
}

/// Conversions and shift counts of constants fold by the project's overflow rule, so a
/// folded constant is what the run time computes: wrapped by default, an error with
/// overflow = fault (where the run time faults).
#[test]
fn constant_conversions_and_shifts_follow_the_overflow_rule() {
    let src = prog(
        "a : UDINT := REAL_TO_UDINT(-1.75); b : DWORD := REAL_TO_DWORD(-1.75);
         c : BYTE := ROL(BYTE#16#81, -1); d : WORD := SHL(WORD#1, -1);",
        "",
    );
    let p = run_in(&src, Overflow::Wrap)
        .0
        .expect("wrap mode folds them");
    let inits: Vec<_> = p.pous[0].vars.iter().map(|v| v.init.clone()).collect();
    use crate::value::Value::Int;
    assert_eq!(
        inits,
        [
            Some(Int(0xFFFF_FFFE)),
            Some(Int(0xFFFF_FFFE)),
            Some(Int(0xC0)),
            Some(Int(0))
        ]
    );
    assert_eq!(p.overflow, Overflow::Wrap);
    let (p, d) = run_in(&src, Overflow::Fault);
    assert!(p.is_none());
    assert_eq!(
        d.matches("E113]: this constant does not convert to")
            .count(),
        2,
        "{d}"
    );
    assert_eq!(
        d.matches("E113]: this constant expression has no value: a negative shift count")
            .count(),
        2,
        "{d}"
    );
}

#[test]
fn twincat_incomplete_locations_in_function_blocks_are_ordinary_variables() {
    let (p, d) = run("FUNCTION_BLOCK fb
VAR_INPUT raw AT %I* : INT; END_VAR
VAR_OUTPUT out AT %Q* : BOOL; END_VAR
out := raw > 3;
END_FUNCTION_BLOCK
PROGRAM p
VAR i : fb; END_VAR
i(raw := 4);
END_PROGRAM");
    assert!(p.is_some(), "{d}");
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), 2, "{d}");
    assert!(
        lines[0].starts_with("t.st:2:11: warning[W013]: TwinCAT's `AT %I*`/`%Q*`"),
        "{d}"
    );
    // A complete address in a function block is still refused.
    check_errors(
        "FUNCTION_BLOCK fb
VAR raw AT %IW3 : INT; END_VAR
END_FUNCTION_BLOCK
PROGRAM p
END_PROGRAM",
        &["E109]: located variables (AT) belong in programs and configurations"],
    );
}

#[test]
fn an_integer_base_raises_to_an_lreal() {
    let p = check_ok(&prog(
        "i : INT := 2; w : WORD := 3; lr : LREAL;",
        "lr := EXPT(i, 7); lr := w ** 2.5 + i ** i;",
    ));
    assert!(format!("{:?}", p.pous[0].body).contains("Power"));
    check_errors(
        &prog("i : INT; r : REAL;", "r := EXPT(i, 2);"),
        &["t.st:5:6: error[E110]: the value assigned to `r` is LREAL but REAL is needed"],
    );
}

/// SINGLE names a global BOOL, and a task has it or INTERVAL, not both.
#[test]
fn single_tasks() {
    let p = check_ok(
        "PROGRAM p END_PROGRAM
CONFIGURATION c VAR_GLOBAL b : BOOL; END_VAR
RESOURCE r ON PLC TASK t (SINGLE := b, PRIORITY := 2); PROGRAM i WITH t : p; END_RESOURCE
END_CONFIGURATION",
    );
    let c = p.configuration.expect("a configuration");
    assert_eq!(c.tasks[0].single, Some(0));
    assert_eq!(c.tasks[0].interval, None);
    check_errors(
        "PROGRAM p END_PROGRAM
CONFIGURATION c VAR_GLOBAL n : INT; b : BOOL; END_VAR
RESOURCE r ON PLC
TASK t1 (SINGLE := NOT b);
TASK t2 (SINGLE := b, INTERVAL := T#10ms);
PROGRAM i WITH t1 : p;
END_RESOURCE
END_CONFIGURATION",
        &[
            "4:20: error[E150]: SINGLE names a global BOOL variable",
            "5:35: error[E190]: a task with SINGLE runs on its rising edge and has no INTERVAL",
        ],
    );
}

/// Partial access beyond bits applies to bit strings, within their length.
#[test]
fn partial_access_bytes_and_words() {
    check_ok(&prog(
        "d : DWORD; b : BYTE; w : WORD;",
        "b := d.%B3; w := d.%W1; d.%B0 := b;",
    ));
    check_errors(
        &prog(
            "i : INT; b : BYTE; w : WORD; d : DWORD;",
            "b := i.%B0;\nw := b.%W0;\nd := d.%D1;",
        ),
        &[
            "error[E114]: partial access (.%B0) applies to bit strings (BYTE, WORD, DWORD, LWORD), not INT",
            "error[E114]: BYTE has no part of 16 bits",
            "error[E114]: DWORD has parts .%D0 to .%D0 of 32 bits; .%D1 does not exist",
        ],
    );
}

/// VAR_CONFIG paths name an instance's variable of the type written; errors say which part.
#[test]
fn var_config_paths() {
    let p = check_ok(
        "PROGRAM p VAR n : INT; END_VAR END_PROGRAM
CONFIGURATION c RESOURCE r ON PLC PROGRAM i : p; END_RESOURCE
VAR_CONFIG r.i.n : INT := 7; END_VAR
END_CONFIGURATION",
    );
    let vc = &p.configuration.expect("a configuration").var_config;
    assert_eq!(
        (vc[0].path.as_str(), &vc[0].value),
        ("i.n", &crate::value::Value::Int(7))
    );
    check_errors(
        "PROGRAM p VAR n : INT; END_VAR END_PROGRAM
CONFIGURATION c RESOURCE r ON PLC PROGRAM i : p; END_RESOURCE
VAR_CONFIG
r.j.n : INT := 1;
r.i.m : INT := 1;
r.i.n : BOOL := TRUE;
r.i.n AT %QW1 : INT;
END_VAR
END_CONFIGURATION",
        &[
            "4:3: error[E150]: no program instance j in this configuration",
            "5:5: error[E100]: `m` is not a variable of i",
            "6:1: error[E110]: i.n is INT; VAR_CONFIG declares it BOOL",
            "7:10: error[E190]: a location in VAR_CONFIG is not supported",
        ],
    );
}
