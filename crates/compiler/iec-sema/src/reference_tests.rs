//! The checker's rules for references and pointers (docs/iec.md, "References and pointers").

use petriplc_iec_syntax::{parser, SourceMap};

use crate::types::Type;
use crate::{check, Options};

fn run(src: &str) -> (bool, String) {
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, src, &mut d);
    assert!(!d.has_errors(), "syntax: {}", d.render(&map));
    let (p, diags) = check(&lib, &Options::default());
    (p.is_some() && !diags.has_errors(), diags.render(&map))
}

fn prog(decls: &str, body: &str) -> String {
    format!("PROGRAM p\nVAR\n{decls}\nEND_VAR\n{body}\nEND_PROGRAM\n")
}

fn errors(src: &str, expect: &[&str]) {
    let (_, d) = run(src);
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), expect.len(), "got:\n{d}");
    for (l, e) in lines.iter().zip(expect) {
        assert!(l.contains(e), "expected `{e}` in\n{l}\n(all:\n{d})");
    }
}

#[test]
fn references_type_and_compare() {
    let src = prog(
        "a : INT; r : REF_TO INT; p : POINTER TO INT; b : BOOL;",
        "r := REF(a); p := ADR(a); r := p; p := NULL; b := r = p; b := NULL <> r; r^ := r^ + 1;",
    );
    let (ok, d) = run(&src);
    assert!(ok, "{d}");
    let mut map = SourceMap::new();
    let f = map.add("t.st", &src);
    let mut diags = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, &src, &mut diags);
    let (p, _) = check(&lib, &Options::default());
    let p = p.unwrap();
    let r = &p.pous[0].vars[1];
    assert!(matches!(p.types.get(r.ty), Type::Ref { .. }));
    assert_eq!(p.types.name(r.ty), "REF_TO INT");
}

#[test]
fn dereferencing_something_else_is_refused() {
    errors(
        &prog("x : INT;", "x^ := 1;"),
        &["t.st:5:1: error[E200]: `^` dereferences a REF_TO or POINTER TO; this is INT"],
    );
}

#[test]
fn references_to_other_types_do_not_mix() {
    errors(
        &prog("a : INT; r : REF_TO DINT; q : REF_TO INT; b : BOOL;", "r := REF(a); b := r = q; b := q < q; q := q + 1;"),
        &[
            "error[E110]: the value assigned to `r` is REF_TO INT but REF_TO DINT is needed",
            "error[E111]: `=` cannot combine REF_TO DINT and REF_TO INT",
            "error[E111]: `<` applies to elementary values and strings (references compare with = and <> only), not REF_TO INT",
            "error[E110]: this operand is an integer literal but REF_TO INT is needed",
        ],
    );
}

#[test]
fn only_variables_with_a_lasting_address_are_referenced() {
    errors(
        "FUNCTION f : INT\nVAR_INPUT i : INT; END_VAR\nVAR x : INT; r : REF_TO INT; END_VAR\nr := REF(x);\nr := REF(i);\nf := 0;\nEND_FUNCTION\n",
        &[
            "t.st:4:10: error[E201]: REF: `x` is a variable of a FUNCTION, gone when it returns",
            "t.st:5:10: error[E201]: REF: `i` is a variable of a FUNCTION",
        ],
    );
    errors(
        &prog(
            "w : WORD; c : INT; r : REF_TO INT; rb : REF_TO BOOL; END_VAR\nVAR CONSTANT k : INT := 1; END_VAR\nVAR_TEMP t : INT;",
            "r := REF(t); r := REF(k); rb := REF(w.3); r := REF(c + 1); r := ADR(c, c);",
        ),
        &[
            "error[E201]: REF: `t` is a VAR_TEMP",
            "error[E201]: REF: `k` is a CONSTANT",
            "error[E201]: REF: a single bit has no address",
            "error[E201]: REF takes a variable, not an expression",
            "error[E130]: ADR takes one variable: ADR(x)",
        ],
    );
}

#[test]
fn a_reference_is_not_retained() {
    errors(
        "TYPE S : STRUCT r : REF_TO INT; END_STRUCT; END_TYPE\nPROGRAM p\nVAR RETAIN r : REF_TO INT; s : S; n : INT; END_VAR\nVAR RETAIN c : REFERENCE TO INT; END_VAR\nVAR q AT %MD0 : POINTER TO INT; END_VAR\nEND_PROGRAM\n",
        &[
            "t.st:3:12: error[E202]: `r` holds a reference, which cannot be RETAIN",
            "t.st:3:28: error[E202]: `s` holds a reference",
            "t.st:4:12: error[E202]: `c` holds a reference, which cannot be RETAIN",
            "t.st:5:5: error[E202]: `q` holds a reference, which cannot be located (AT %…)",
        ],
    );
}

#[test]
fn adr_of_a_functions_variables_stays_in_the_function() {
    let ok = "FUNCTION f : DINT\nVAR_INPUT s : STRING(10); END_VAR\nVAR p : POINTER TO BYTE; q : POINTER TO BYTE; END_VAR\np := ADR(s);\nq := p + 1;\nIF q <> p THEN f := BYTE_TO_DINT(q^); END_IF;\nEND_FUNCTION\n";
    let (good, d) = run(ok);
    assert!(good, "{d}");
    // `h` keeps nothing (it reads through its input and passes it to `k`, which keeps
    // nothing either): a frame pointer may go to it. `keep` stores its input in a global.
    errors(
        "VAR_GLOBAL g : POINTER TO BYTE; END_VAR\nFUNCTION h : BOOL\nVAR_INPUT p : POINTER TO BYTE; END_VAR\nVAR q : POINTER TO BYTE; END_VAR\nq := p + 1;\nh := q^ = 0 AND k(q);\nEND_FUNCTION\n\
         FUNCTION k : BOOL\nVAR_INPUT p : POINTER TO BYTE; END_VAR\nk := p <> NULL;\nEND_FUNCTION\n\
         FUNCTION keep : BOOL\nVAR_INPUT p : POINTER TO BYTE; END_VAR\nVAR_EXTERNAL g : POINTER TO BYTE; END_VAR\ng := p;\nEND_FUNCTION\n\
         FUNCTION f : POINTER TO BYTE\nVAR_EXTERNAL g : POINTER TO BYTE; END_VAR\nVAR s : STRING; p : POINTER TO BYTE; b : BOOL; END_VAR\np := ADR(s);\ng := p;\nf := ADR(s) + 1;\nb := h(p);\nb := keep(p);\nEND_FUNCTION\n",
        &[
            "t.st:21:6: error[E201]: a pointer to this FUNCTION's own variables is stored in `g`, which outlives the call",
            "t.st:22:6: error[E201]: a pointer to this FUNCTION's own variables is stored in `f`",
            "t.st:24:11: error[E201]: a pointer to this FUNCTION's own variables may only be kept in its VAR or VAR_TEMP pointers",
        ],
    );
}

#[test]
fn pointers_move_by_bytes_and_sizeof_is_the_byte_image() {
    let src = "TYPE S : STRUCT a : BYTE; b : DINT; END_STRUCT; END_TYPE\nPROGRAM p\nVAR s : S; a : ARRAY[1..3] OF REAL; n : UDINT; m : UDINT; k : UDINT; pb : POINTER TO BYTE; pr : POINTER TO REAL; r : REF_TO BYTE; END_VAR\nn := SIZEOF(s);\nm := SIZEOF(a);\nk := SIZEOF(LREAL);\npb := ADR(a);\npb := pb + n;\npb := 2 + pb - 1;\npr := pb;\nEND_PROGRAM\n";
    let (ok, d) = run(src);
    assert!(ok, "{d}");
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut diags = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, src, &mut diags);
    let (p, _) = check(&lib, &Options::default());
    let body = &p.unwrap().pous[0].body;
    let consts: Vec<i128> = body[..3]
        .iter()
        .filter_map(|s| match &s.kind {
            crate::ir::StmtKind::Assign { value, .. } => value.const_int(),
            _ => None,
        })
        .collect();
    assert_eq!(consts, vec![8, 12, 8]);
    errors(
        &prog(
            "a : INT; r : REF_TO BYTE; p : POINTER TO INT; x : REAL;",
            "r := ADR(a); p := p + x; r := r + 1;",
        ),
        &[
            "error[E110]: the value assigned to `r` is POINTER TO INT but REF_TO BYTE is needed",
            "error[E111]: a pointer moves by a whole number of bytes, not REAL",
            "error[E110]",
        ],
    );
}

#[test]
fn memcpy_memset_memcmp_take_pointers_and_a_count() {
    let (ok, d) = run(&prog(
        "a : ARRAY[1..2] OF INT; b : ARRAY[1..2] OF INT; r : DINT;",
        "MEMCPY(ADR(a), ADR(b), SIZEOF(a)); MEMSET(ADR(a), 16#FF, 4); r := MEMCMP(ADR(a), ADR(b), 4);",
    ));
    assert!(ok && !d.contains("W003"), "{d}");
    errors(
        &prog(
            "a : INT; r : UDINT;",
            "r := MEMCPY(a, ADR(a), 2); r := MEMSET(ADR(a), 0); r := MEMSET(ADR(a), 0, 1.5);",
        ),
        &[
            "error[E130]: MEMCPY: argument 1 is a pointer (ADR(x)), not INT",
            "error[E130]: MEMSET takes a pointer, the fill BYTE and a byte count",
            "error[E111]: a pointer moves by a whole number of bytes, not",
        ],
    );
}

#[test]
fn zero_is_null_for_a_pointer_only() {
    let ok = prog(
        "a : INT; p : POINTER TO INT; b : BOOL;",
        "p := 0; b := p = 0; b := 0 <> p; p := ADR(a);",
    );
    let (accepted, d) = run(&ok);
    assert!(accepted, "{d}");
    errors(
        &prog("p : POINTER TO INT; r : REF_TO INT;", "p := 1;\nr := 0;"),
        &[
            "error[E110]: the value assigned to `p` is an integer literal but POINTER TO INT is needed",
            "error[E110]: the value assigned to `r` is an integer literal but REF_TO INT is needed",
        ],
    );
}

#[test]
fn pointer_indexing_takes_one_integer_subscript_of_a_pointer_to() {
    errors(
        &prog(
            "a : ARRAY[0..3] OF INT; p : POINTER TO INT; r : REF_TO INT; x : INT;",
            "p := ADR(a); x := p[1]; p[0] := 1; x := p[1, 2]; x := p[1.5]; r := REF(a[0]); x := r[1];",
        ),
        &[
            "t.st:5:41: error[E114]: a pointer takes one subscript",
            "t.st:5:57: error[E114]: a subscript is an integer; this is a real literal",
            "t.st:5:84: error[E114]: only arrays are indexed; this is REF_TO INT",
        ],
    );
}

#[test]
fn a_structure_may_point_at_its_own_type_but_not_hold_it() {
    let ok = "TYPE N : STRUCT v : INT; next : POINTER TO N; kids : ARRAY[0..1] OF REF_TO N; END_STRUCT; END_TYPE\n\
              PROGRAM p\nVAR a, b : N; END_VAR\na.next := ADR(b);\nb.v := a.next^.v + 1;\nEND_PROGRAM\n";
    let (good, d) = run(ok);
    assert!(good, "{d}");
    // B, reached through A's pointer, still may not hold itself.
    errors(
        "TYPE A : STRUCT p : POINTER TO B; END_STRUCT; END_TYPE\nTYPE B : STRUCT b : B; END_STRUCT; END_TYPE\n\
         PROGRAM p\nVAR a : A; END_VAR\nEND_PROGRAM\n",
        &["t.st:2:21: error[E107]: type B contains itself"],
    );
}
