//! The checker on vendor library calls: accepted with their library, refused naming it
//! without, and every argument error with its message.

use petriplc_iec_syntax::{parser, SourceMap};

use crate::ir::{self, Builtin, ExprKind, StmtKind};
use crate::{check, Options};

/// Checks `body` in a program with `decls`, `libs` loaded: the project, or the diagnostics.
fn run(libs: &[&str], decls: &str, body: &str) -> Result<ir::Project, String> {
    let src = format!(
        "TYPE pair : STRUCT a : BYTE; b : LREAL; END_STRUCT; END_TYPE\n\
         FUNCTION_BLOCK fb\nVAR x : INT; END_VAR\nEND_FUNCTION_BLOCK\n\
         PROGRAM p\nVAR\n{decls}\nEND_VAR\n{body}\nEND_PROGRAM\n"
    );
    let mut map = SourceMap::new();
    let f = map.add("t.st", &src);
    let mut d = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, &src, &mut d);
    assert!(!d.has_errors(), "syntax: {}", d.render(&map));
    let libs: Vec<String> = libs.iter().map(|s| s.to_string()).collect();
    let options = Options {
        natives: crate::vendor::signatures(&libs),
        libs,
        ..Options::default()
    };
    match check(&lib, &options) {
        (Some(p), d) if !d.has_errors() => Ok(p),
        (_, d) => Err(d.render(&map)),
    }
}

fn refused(libs: &[&str], decls: &str, body: &str, expect: &str) {
    match run(libs, decls, body) {
        Ok(_) => panic!("accepted: {body}"),
        Err(d) => assert!(d.contains(expect), "expected `{expect}` in\n{d}"),
    }
}

/// The value assigned by the program's first statement, when it is a constant.
fn first_const(p: &ir::Project) -> Option<i128> {
    let body = &p.pous.iter().find(|x| x.name == "p")?.body;
    match &body.first()?.kind {
        StmtKind::Assign { value, .. } => match &value.kind {
            ExprKind::Const(v) => v.as_int(),
            _ => None,
        },
        _ => None,
    }
}

#[test]
fn without_its_library_a_call_names_the_library() {
    refused(
        &[],
        "c : INT;",
        "c := GET_CHAR('abc', 1);",
        "t.st:9:6: error[E180]: GET_CHAR is a PCWorx function: add --lib pcworx (`libs = pcworx` on `module NAME iec`), or declare a FUNCTION of that name",
    );
    refused(
        &["pcworx"],
        "t : TIME;",
        "t := TIME();",
        "error[E180]: TIME is a CODESYS/TwinCAT function: add --lib codesys",
    );
    refused(
        &["codesys"],
        "s : STRING;",
        "s := BYTE_TO_STRING(BYTE#10, '%02X');",
        "error[E180]: BYTE_TO_STRING(value, format) is a PCWorx function: add --lib pcworx",
    );
    // The standard's one-argument conversion needs no library.
    assert!(run(&[], "s : STRING;", "s := BYTE_TO_STRING(BYTE#10);").is_ok());
}

#[test]
fn a_users_function_of_that_name_wins() {
    let src_fn = "c := GET_CHAR('abc', 1);";
    let mut map = SourceMap::new();
    let text = format!(
        "FUNCTION GET_CHAR : INT\nVAR_INPUT s : STRING; i : INT; END_VAR\nGET_CHAR := i;\nEND_FUNCTION\n\
         PROGRAM p\nVAR c : INT; END_VAR\n{src_fn}\nEND_PROGRAM\n"
    );
    let f = map.add("t.st", &text);
    let mut d = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, &text, &mut d);
    let (p, d) = check(&lib, &Options::default());
    assert!(p.is_some(), "{}", d.render(&map));
}

#[test]
fn typed_with_the_library() {
    let p = run(&["twincat"], "t : TIME;", "t := TIME();").unwrap();
    let body = &p.pous.iter().find(|x| x.name == "p").unwrap().body;
    assert!(matches!(
        body.first().map(|s| &s.kind),
        Some(StmtKind::Assign { value, .. }) if matches!(value.kind, ExprKind::Builtin(Builtin::Time, _))
    ));
    refused(
        &["codesys"],
        "t : TIME;",
        "t := TIME(1);",
        "error[E130]: TIME() takes no argument",
    );
    refused(&["codesys"], "d : DINT;", "d := TIME();", "error[E110]");
    assert!(run(
        &["pcworx"],
        "c : INT; s : STRING[5]; i : USINT;",
        "c := GET_CHAR(s, i);"
    )
    .is_ok());
    refused(
        &["pcworx"],
        "c : INT;",
        "c := GET_CHAR(5, 1);",
        "error[E110]: GET_CHAR reads a STRING, not",
    );
    refused(
        &["pcworx"],
        "c : INT;",
        "c := GET_CHAR('a', 1.5);",
        "GET_CHAR's position is an integer",
    );
    refused(
        &["pcworx"],
        "c : INT;",
        "c := GET_CHAR('a');",
        "error[E130]: GET_CHAR takes 2 argument(s)",
    );
    refused(
        &["pcworx"],
        "c : BYTE;",
        "c := GET_CHAR('a', 1);",
        "error[E110]",
    );
    assert!(run(
        &["pcworx"],
        "t : TIME; i : INT;",
        "t := MUL_T_AI(t, i); t := DIV_T_AI(t, 2);"
    )
    .is_ok());
    refused(
        &["pcworx"],
        "t : TIME;",
        "t := MUL_T_AI(t, 2.5);",
        "MUL_T_AI takes a TIME and an integer, not TIME and",
    );
    refused(
        &["pcworx"],
        "t : TIME; i : INT;",
        "t := MUL_T_AI(i, i);",
        "MUL_T_AI takes a TIME and an integer, not INT and INT",
    );
}

#[test]
fn formats_with_the_library() {
    let ok = run(
        &["pcworx"],
        "s : STRING; f : STRING[8] := '%d'; b : BYTE; r : REAL; e : (red, green);",
        "s := BYTE_TO_STRING(b, '%02X'); s := INT_TO_STRING(7, f); s := REAL_TO_STRING(r, '%f');
         s := TO_STRING(b, '%x'); s := DINT_TO_STRING(IN := 5, FORMAT := '%d');",
    );
    assert!(ok.is_ok(), "{:?}", ok.err());
    refused(
        &["pcworx"],
        "s : STRING; r : REAL;",
        "s := INT_TO_STRING(r, '%d');",
        "INT_TO_STRING converts INT, and this argument is REAL",
    );
    refused(
        &["pcworx"],
        "s : STRING;",
        "s := INT_TO_STRING(1, 2);",
        "error[E181]: the format of INT_TO_STRING(value, format) is a STRING",
    );
    refused(
        &["pcworx"],
        "s : STRING;",
        "s := INT_TO_STRING(1, '%d', 3);",
        "error[E130]",
    );
}

#[test]
fn sizeof_and_xsizeof_need_no_library_and_give_the_byte_image() {
    // One SIZEOF, the pointers' byte image (memory.rs), so that `p + SIZEOF(T)` steps over
    // exactly one T; XSIZEOF is its newer CODESYS name.
    let size = |decls: &str, f: &str, arg: &str| {
        let p = run(
            &[],
            &format!("n : UDINT; {decls}"),
            &format!("n := {f}({arg});"),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        first_const(&p)
    };
    assert_eq!(size("a : ARRAY[0..4] OF INT;", "SIZEOF", "a"), Some(10));
    assert_eq!(
        size("x : pair;", "SIZEOF", "x"),
        size("x : pair;", "XSIZEOF", "x")
    );
    assert_eq!(size("s : STRING[20];", "XSIZEOF", "s"), Some(21));
    // petriplc's durations are 64-bit nanoseconds: 8 bytes (CODESYS's 32-bit TIME takes 4).
    assert_eq!(size("", "SIZEOF", "TIME"), Some(8));
}

#[test]
fn twincat_character_functions() {
    assert!(run(
        &["twincat"],
        "b : BYTE; s : STRING[1];",
        "b := F_ToASC('A'); s := F_ToCHR(b); s := F_ToCHR(c := 66);"
    )
    .is_ok());
    // TwinCAT's own functions need `twincat`, CODESYS's alone do not give them.
    refused(
        &["codesys"],
        "b : BYTE;",
        "b := F_ToASC('A');",
        "error[E180]: F_TOASC is a TwinCAT function: add --lib twincat",
    );
    refused(
        &["twincat"],
        "b : BYTE;",
        "b := F_ToASC(65);",
        "error[E110]: F_ToASC reads a STRING, not",
    );
    refused(
        &["twincat"],
        "s : STRING; r : REAL;",
        "s := F_ToCHR(r);",
        "error[E110]",
    );
    // Its BYTE converts to INT implicitly, as CODESYS does (W022), not to SINT.
    refused(
        &["twincat"],
        "i : SINT;",
        "i := F_ToASC('A');",
        "error[E110]",
    );
}

#[test]
fn function_blocks_with_their_library() {
    assert!(run(
        &["codesys"],
        "h : HYSTERESIS; a : LIMITALARM; q : BOOL;",
        "h(IN := 5, HIGH := 10, LOW := 2); q := h.OUT; a(IN := 5, HIGH := 10, LOW := 2); q := a.O OR a.U OR a.IL;"
    )
    .is_ok());
    refused(
        &[],
        "h : HYSTERESIS;",
        "h(IN := 5);",
        "t.st:7:5: error[E180]: HYSTERESIS is a CODESYS/TwinCAT function block: add --lib codesys (`libs = codesys` on `module NAME iec`), or declare a FUNCTION_BLOCK of that name",
    );
    refused(
        &["codesys"],
        "h : HYSTERESIS;",
        "h(IN := 5.5);",
        "error[E110]",
    );
}

#[test]
fn twincat_declarations_in_structured_text() {
    // The library's types and functions are there with `twincat` only.
    assert!(run(
        &["twincat"],
        "s : T_MaxString; n : UDINT;",
        "n := LEN2(ADR(s));"
    )
    .is_ok());
    refused(&[], "s : T_MaxString;", "", "`T_MaxString`");
    // `E.Value` of a library's enumeration and of an alias of one.
    let p = run(
        &["twincat"],
        "t : TYPE_CLASS;",
        "t := TYPE_CLASS.TYPE_LREAL;",
    )
    .unwrap();
    assert!(!p.pous.is_empty());
    refused(
        &["twincat"],
        "t : TYPE_CLASS;",
        "t := TYPE_CLASS.TYPE_NOTHING;",
        "enumeration TYPE_CLASS has no value `TYPE_NOTHING`",
    );
    // A variable of the enumeration's name is the variable.
    refused(
        &["twincat"],
        "TYPE_CLASS : INT; t : INT;",
        "t := TYPE_CLASS.TYPE_LREAL;",
        "",
    );
}

#[test]
fn a_project_declaration_replaces_the_library_one() {
    let src = "TYPE T_MaxString : STRING(10); END_TYPE\n\
               FUNCTION LEN2 : DINT\nVAR_INPUT x : INT; END_VAR\nLEN2 := x * 2;\nEND_FUNCTION\n\
               PROGRAM p\nVAR s : T_MaxString; n : DINT; END_VAR\nn := LEN2(3) + SIZEOF(s);\nEND_PROGRAM\n";
    let mut map = SourceMap::new();
    let f = map.add("t.st", src);
    let mut d = petriplc_iec_syntax::Diagnostics::new();
    let lib = parser::parse(f, src, &mut d);
    let options = Options {
        libs: vec!["twincat".into()],
        ..Options::default()
    };
    let (p, d) = check(&lib, &options);
    assert!(!d.has_errors(), "{}", d.render(&map));
    assert!(p.is_some());
}

#[test]
fn codesys_stores_an_enumeration_value_in_an_integer() {
    let src = "TYPE E : (A := 1, B := 300) UDINT; END_TYPE\n\
               PROGRAM p\nVAR d : DINT := E.B; x : E := E.A; w : WORD; s : SINT; END_VAR\n\
               d := x;\nw := E.B;\nEND_PROGRAM\n";
    let check_in = |dialect, src: &str| {
        let mut map = SourceMap::new();
        let f = map.add("t.st", src);
        let mut d = petriplc_iec_syntax::Diagnostics::new();
        let lib = parser::parse(f, src, &mut d);
        let options = Options {
            dialect,
            ..Options::default()
        };
        let (_, d) = check(&lib, &options);
        d.render(&map)
    };
    use petriplc_iec_syntax::Dialect;
    let ok = check_in(Dialect::Twincat, src);
    assert!(!ok.contains("error"), "{ok}");
    let iec = check_in(Dialect::Iec, src);
    assert!(iec.contains("is E but DINT is needed"), "{iec}");
    // A constant that does not fit is still refused.
    let narrow = check_in(Dialect::Codesys, &src.replace("w := E.B;", "s := E.B;"));
    assert!(narrow.contains("300 does not fit SINT"), "{narrow}");
}

#[test]
fn the_libraries_check_without_a_warning() {
    // A library's own functions (`BYTE_TO_HEXSTR`) are not taken for standard ones.
    for lib in ["codesys", "twincat", "pcworx"] {
        let src = "PROGRAM p\nVAR x : INT; END_VAR\nx := 1;\nEND_PROGRAM\n";
        let mut map = SourceMap::new();
        let f = map.add("t.st", src);
        let mut d = petriplc_iec_syntax::Diagnostics::new();
        let parsed = parser::parse(f, src, &mut d);
        let libs = vec![lib.to_string()];
        let options = Options {
            natives: crate::vendor::signatures(&libs),
            libs,
            ..Options::default()
        };
        let (p, d) = check(&parsed, &options);
        assert!(p.is_some() && d.is_empty(), "{lib}: {}", d.render(&map));
    }
}
