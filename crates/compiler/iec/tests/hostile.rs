//! Generated hostile sources through the whole pipeline (parse, check, compile, scan), in
//! Structured Text, Instruction List and PLCopen XML: nesting far past every limit (parentheses,
//! operators in a row, IF/CASE/FOR/WHILE/REPEAT, calls in calls, function blocks, structures and
//! arrays inside each other, declared in either order), huge names, numbers and strings, and
//! literals a REAL cannot hold. Nothing panics or overflows the stack; a refused source has
//! only coded, positioned diagnostics (a limit passed is E014/E116), and not a flood of them;
//! a program that builds scans without an internal fault. The work is bounded by the inputs'
//! sizes (at most a few hundred kilobytes each), never by a clock.

use petriplc_iec::vm::{FaultKind, Machine};
use petriplc_iec::{build, IecError, Natives, Select, Sources};
use proptest::prelude::*;

/// One statement (or declaration) shape, repeated `n` times inside itself or in a row.
#[derive(Clone, Debug)]
enum Piece {
    Parens(usize),
    Unary(usize),
    Chain(&'static str, usize),
    Fields(usize),
    Subscripts(usize),
    Calls(usize),
    /// Pointer indexing inside its own subscript: `p[p[p[0]]]`.
    PtrIndex(usize),
    /// A pointer moved and dereferenced, `(((p + 1) + 1))^`, as a statement's target.
    Computed(usize),
    Block(&'static str, usize),
    LongName(usize),
    LongNumber(usize),
    LongString(usize),
    Literal(&'static str),
}

/// Deep enough to pass every limit many times over, small enough to stay quick.
fn depth() -> impl Strategy<Value = usize> {
    prop_oneof![1usize..120, 900usize..1100, 5_000usize..20_000]
}

fn piece() -> impl Strategy<Value = Piece> {
    prop_oneof![
        depth().prop_map(Piece::Parens),
        depth().prop_map(Piece::Unary),
        (
            prop::sample::select(vec!["+", "*", "AND", "OR", "-", "<", "**", ":="]),
            depth()
        )
            .prop_map(|(op, n)| Piece::Chain(op, n)),
        depth().prop_map(Piece::Fields),
        depth().prop_map(Piece::Subscripts),
        depth().prop_map(Piece::Calls),
        depth().prop_map(Piece::PtrIndex),
        depth().prop_map(Piece::Computed),
        (
            prop::sample::select(vec!["IF", "CASE", "FOR", "WHILE", "REPEAT"]),
            depth()
        )
            .prop_map(|(b, n)| Piece::Block(b, n)),
        (1usize..20_000).prop_map(Piece::LongName),
        (1usize..20_000).prop_map(Piece::LongNumber),
        (1usize..20_000).prop_map(Piece::LongString),
        prop::sample::select(vec![
            "NaN",
            "INF",
            "-INF",
            "1.0E400",
            "-1.0E400",
            "1.0E-400",
            "REAL#1.0E39",
            "LREAL#1.8E308",
            "REAL#NaN",
            "16#FFFFFFFFFFFFFFFFFFFFFFFF",
            "DINT#-2147483649",
            "LINT#9223372036854775808",
            "T#99999999999999999999d",
            "0.0 / 0.0",
            "1.0 / 0.0",
            "SQRT(-1.0)",
            "LN(0.0)",
            "REAL_TO_INT(1.0E30)",
            "EXPT(10.0, 400)",
        ])
        .prop_map(Piece::Literal),
    ]
}

/// The statement of a piece, assigning the program's variables (`x : DINT`, `r : REAL`,
/// `b : BOOL`, `s : S`, a structure holding itself by name `s`, `a`: arrays of arrays).
fn statement(p: &Piece) -> String {
    match p {
        Piece::Parens(n) => format!("x := {}x{};", "(".repeat(*n), ")".repeat(*n)),
        Piece::Unary(n) => format!("x := {}x;", "- ".repeat(*n)),
        Piece::Chain(op, n) => {
            let (target, term) = match *op {
                "AND" | "OR" => ("b", "b"),
                "<" => ("b", "x"),
                _ => ("x", "x"),
            };
            format!(
                "{target} := {};",
                vec![term; n + 1].join(&format!(" {op} "))
            )
        }
        Piece::Fields(n) => format!("x := s{}.x;", ".s".repeat(*n)),
        Piece::Subscripts(n) => format!("x := a{};", "[1]".repeat(*n)),
        Piece::Calls(n) => format!("x := {}x{};", "ABS(".repeat(*n), ")".repeat(*n)),
        Piece::PtrIndex(n) => format!("p := ADR(x); x := {}0{};", "p[".repeat(*n), "]".repeat(*n)),
        Piece::Computed(n) => format!(
            "p := ADR(x); {}p{}^ := 1;",
            "(".repeat(*n),
            " + 1)".repeat(*n)
        ),
        Piece::Block(kind, n) => {
            let (open, close) = match *kind {
                "IF" => ("IF b THEN\n", "END_IF;\n"),
                "CASE" => ("CASE x OF 1:\n", "END_CASE;\n"),
                "FOR" => ("FOR x := 1 TO 2 DO\n", "END_FOR;\n"),
                "WHILE" => ("WHILE b DO\n", "END_WHILE;\n"),
                _ => ("REPEAT\n", "UNTIL b END_REPEAT;\n"),
            };
            format!("{}x := 1;\n{}", open.repeat(*n), close.repeat(*n))
        }
        Piece::LongName(n) => format!("x := {};", "y".repeat(*n)),
        Piece::LongNumber(n) => format!("x := {};", "9".repeat(*n)),
        Piece::LongString(n) => format!("x := LEN('{}');", "z".repeat(*n)),
        Piece::Literal(l) => format!("r := {l};"),
    }
}

/// Declarations of types `n` deep: structures, arrays or function blocks, each holding the
/// next, outermost or innermost first; the program's `s`, `a` and `f` use them.
fn declarations(kind: u8, n: usize, outer_first: bool) -> String {
    let mut decls: Vec<String> = (0..n)
        .map(|i| {
            let last = i + 1 == n;
            match kind {
                0 => {
                    let inner = if last {
                        "DINT".into()
                    } else {
                        format!("T{}", i + 1)
                    };
                    format!("TYPE T{i} : STRUCT s : {inner}; x : DINT; END_STRUCT; END_TYPE")
                }
                1 => {
                    let inner = if last {
                        "DINT".into()
                    } else {
                        format!("T{}", i + 1)
                    };
                    format!("TYPE T{i} : ARRAY[0..1] OF {inner}; END_TYPE")
                }
                _ => {
                    let var = if last {
                        "x : DINT;".into()
                    } else {
                        format!("c : T{};", i + 1)
                    };
                    let call = if last { "x := x + 1;" } else { "c();" };
                    format!("FUNCTION_BLOCK T{i} VAR {var} END_VAR {call} END_FUNCTION_BLOCK")
                }
            }
        })
        .collect();
    if !outer_first {
        decls.reverse();
    }
    let s =
        "TYPE S : STRUCT s : S2; x : DINT; END_STRUCT; S2 : STRUCT x : DINT; END_STRUCT; END_TYPE";
    decls.push(s.into());
    decls.join("\n")
}

fn program(decls: &str, uses_t0: bool, body: &str) -> String {
    let t0 = if uses_t0 { "t : T0;" } else { "" };
    format!(
        "{decls}\nPROGRAM main\nVAR x : DINT; r : REAL; b : BOOL; s : S; p : POINTER TO DINT; \
         a : ARRAY[0..2] OF ARRAY[0..2] OF DINT; {t0} END_VAR\n{body}\nEND_PROGRAM\n"
    )
}

/// A diagnostic line: `WHERE: error[E014]: …` with a code of the IEC front end.
fn is_coded(line: &str) -> bool {
    ["error[E", "warning[W"].iter().any(|tag| {
        line.split_once(&format!(": {tag}"))
            .and_then(|(_, rest)| rest.get(..4))
            .is_some_and(|code| code[..3].bytes().all(|b| b.is_ascii_digit()) && &code[3..] == "]")
    })
}

/// Builds the source and scans what builds; returns the diagnostics of a refused one.
fn run(name: &str, text: &str) -> Option<String> {
    let mut s = Sources::new();
    s.add_text(name, text);
    match build(&s, &Select::Auto, Natives::default()) {
        Ok(b) => {
            let mut m = Machine::new(b.engine.clone());
            m.iterations = 10_000;
            for k in 0..2 {
                if let Err(f) = m.scan(k * 10_000_000, &mut || true) {
                    assert_ne!(f.kind, FaultKind::Internal, "{f}");
                    break;
                }
            }
            None
        }
        Err(IecError::Invalid(d)) => Some(d),
        Err(e) => Some(e.to_string()),
    }
}

/// Refused sources: every line a coded diagnostic of reasonable length, at most one or two
/// per line of source (a limit passed ends the reading: no cascade after it), and a limit
/// passed named by its code (E014 and E116 for depth, E109 for size).
fn check_refusal(diags: &str, source: &str, too_deep: bool) {
    let lines: Vec<&str> = diags.lines().collect();
    assert!(!lines.is_empty());
    for l in &lines {
        assert!(
            is_coded(l),
            "not a coded diagnostic: {}",
            &l[..l.len().min(300)]
        );
        assert!(l.len() < 1000, "a message of {} bytes", l.len());
    }
    let most = 2 * source.lines().count() + 2;
    assert!(
        lines.len() <= most,
        "{} diagnostics for {most}",
        lines.len()
    );
    if too_deep {
        // Too deep, or (arrays of two elements 27 deep) too large first.
        assert!(
            ["error[E014]", "error[E116]", "error[E109]"]
                .iter()
                .any(|c| diags.contains(c)),
            "{}",
            &diags[..diags.len().min(2000)]
        );
    }
}

fn too_deep(p: &Piece) -> bool {
    match p {
        Piece::Parens(n)
        | Piece::Unary(n)
        | Piece::Calls(n)
        | Piece::Computed(n)
        | Piece::Block(_, n) => *n >= 100,
        Piece::PtrIndex(n) => *n >= 1000,
        // A chained assignment is read in a loop: no depth to pass.
        Piece::Chain(":=", _) => false,
        Piece::Chain(_, n) | Piece::Fields(n) | Piece::Subscripts(n) => *n >= 1000,
        _ => false,
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    /// Structured Text, and the same program in a PLCopen project's `<ST>` body.
    #[test]
    fn hostile_structured_text(
        pieces in prop::collection::vec(piece(), 1..4),
        kind in 0u8..3,
        n in depth(),
        outer_first in any::<bool>(),
    ) {
        let body: String = pieces.iter().map(statement).collect::<Vec<_>>().join("\n");
        let decls = declarations(kind, n, outer_first);
        let src = program(&decls, true, &body);
        let deep_syntax = pieces.iter().any(too_deep);
        let deep_types = n > 100;
        if let Some(d) = run("t.st", &src) {
            // A source with syntax errors is not checked: its types are not measured.
            let checked = !d.contains(": error[E0");
            check_refusal(&d, &src, deep_syntax || (deep_types && checked));
        } else {
            prop_assert!(!deep_syntax && !deep_types, "accepted past a limit");
        }
        let xml = format!(
            r#"<project xmlns="http://www.plcopen.org/xml/tc6_0201"><fileHeader companyName="t" productName="t" productVersion="1" creationDateTime="2026-01-01T00:00:00"/><contentHeader name="t"><coordinateInfo><fbd><scaling x="1" y="1"/></fbd><ld><scaling x="1" y="1"/></ld><sfc><scaling x="1" y="1"/></sfc></coordinateInfo></contentHeader><types><dataTypes/><pous><pou name="main" pouType="program"><interface><localVars><variable name="x"><type><DINT/></type></variable><variable name="r"><type><REAL/></type></variable><variable name="b"><type><BOOL/></type></variable></localVars></interface><body><ST><xhtml xmlns="http://www.w3.org/1999/xhtml">{}</xhtml></ST></body></pou></pous></types><instances><configurations/></instances></project>"#,
            body.replace('&', "&amp;").replace('<', "&lt;")
        );
        if let Some(d) = run("t.xml", &xml) {
            check_refusal(&d, &xml, false);
        }
    }

    /// Instruction List: current results folded over long runs, parentheses nested deep,
    /// operands as hostile as ST's.
    #[test]
    fn hostile_instruction_list(
        runs in prop::collection::vec((prop::sample::select(vec!["ADD 1", "MUL x", "AND b", "ADD( x", ")", "NOT", "GT 0", "JMPCN l"]), 1usize..20_000), 1..4),
        operand in piece(),
    ) {
        let mut body = String::from("LD x\n");
        for (ins, n) in &runs {
            body.push_str(&format!("{ins}\n").repeat(*n));
        }
        let operand = statement(&operand);
        let operand = operand
            .split_once(":=")
            .map_or("x", |(_, v)| v.trim_end_matches(';').trim());
        body.push_str(&format!("ST x\nLD {operand}\nST x\nl:\nLD x\nST x\n"));
        let src = format!(
            "PROGRAM main\nVAR x : DINT; r : REAL; b : BOOL; END_VAR\n{body}END_PROGRAM\n"
        );
        if let Some(d) = run("t.il", &src) {
            check_refusal(&d, &src, false);
        }
    }
}
