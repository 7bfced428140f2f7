//! Tests of the lexer: tokens of every kind, literal bodies and each lexical error.

use super::*;

/// The tokens of `src` without their spans (`Eof` last), its diagnostics in `d`.
fn kinds(src: &str, d: &mut Diagnostics) -> Vec<Tok> {
    lex(FileId(0), src, d).into_iter().map(|t| t.tok).collect()
}

fn check(src: &str, expect: &[Tok]) {
    let mut d = Diagnostics::new();
    let toks = kinds(src, &mut d);
    assert!(d.is_empty(), "{src}: {d:?}");
    let mut want = expect.to_vec();
    want.push(Tok::Eof);
    assert_eq!(toks, want, "{src}");
}

fn check_error(src: &str, code: diag::Code) {
    let mut d = Diagnostics::new();
    lex(FileId(0), src, &mut d);
    assert!(
        d.items.iter().any(|x| x.code == code),
        "{src}: expected {code}, got {d:?}"
    );
}

#[test]
fn numbers() {
    check(
        "16#FF 2#1010_1010 8#17 1_000",
        &[Tok::Int(255), Tok::Int(170), Tok::Int(15), Tok::Int(1000)],
    );
    check(
        "1.5 1.0E3 2.5e-1",
        &[Tok::Real(1.5), Tok::Real(1000.0), Tok::Real(0.25)],
    );
    check("1..10", &[Tok::Int(1), Tok::DotDot, Tok::Int(10)]);
    check_error("2#102", diag::BAD_NUMBER);
    check_error("3#1", diag::BAD_NUMBER);
    check_error("99999999999999999999999", diag::BAD_NUMBER);
    check_error("12ab", diag::BAD_NUMBER);
}

#[test]
fn keywords_are_case_insensitive() {
    check(
        "if Then END_if x",
        &[
            Tok::Kw(Kw::If),
            Tok::Kw(Kw::Then),
            Tok::Kw(Kw::EndIf),
            Tok::Ident,
        ],
    );
}

#[test]
fn times_and_dates() {
    let t = |kind, nanos| Tok::Time { kind, nanos };
    check("T#1m30s", &[t(TimeKind::Time, 90_000_000_000)]);
    check("time#1.5s", &[t(TimeKind::Time, 1_500_000_000)]);
    check("T#-250ms", &[t(TimeKind::Time, -250_000_000)]);
    check("LTIME#1h_2m", &[t(TimeKind::LTime, 3_720_000_000_000)]);
    check("D#1970-01-02", &[t(TimeKind::Date, NANOS_PER_DAY)]);
    check("TOD#00:00:01.5", &[t(TimeKind::Tod, 1_500_000_000)]);
    // Seconds may be left out (CODESYS, TwinCAT): OSCAT writes `TOD#12:00`.
    check("TOD#12:00", &[t(TimeKind::Tod, 12 * 3_600_000_000_000)]);
    check(
        "DT#1970-01-02-00:01",
        &[t(TimeKind::Dt, 86_400_000_000_000 + 60_000_000_000)],
    );
    check(
        "DT#1970-01-02-00:00:01",
        &[t(TimeKind::Dt, NANOS_PER_DAY + 1_000_000_000)],
    );
    check("T#1s)", &[t(TimeKind::Time, 1_000_000_000), Tok::RParen]);
    check_error("T#1x", diag::BAD_TIME);
    check_error("T#30m1h", diag::BAD_TIME);
    check_error("D#2023-02-29", diag::BAD_TIME);
    check_error("TOD#24:00:00", diag::BAD_TIME);
}

#[test]
fn strings_and_escapes() {
    check(
        "'a$'b$$c$N$41'",
        &[Tok::Str {
            bytes: b"a'b$c\nA".to_vec(),
            wide: false,
        }],
    );
    check_error("'abc", diag::UNTERMINATED_STRING);
    check_error("'a$Qb'", diag::BAD_ESCAPE);
}

/// A nested reading that leaves the comment open falls back to the standard's and matiec's:
/// the comment ends at its first close, the inner opening is text (W045).
#[test]
fn an_unclosed_inner_comment_ends_at_the_first_close() {
    let src = "a (* x (* y *)\nb (* z *) c";
    let mut d = Diagnostics::new();
    let toks = kinds(src, &mut d);
    assert_eq!(toks, [Tok::Ident, Tok::Ident, Tok::Ident, Tok::Eof]);
    assert_eq!(d.items.len(), 1, "{d:?}");
    assert_eq!(d.items[0].code, diag::COMMENT_NOT_NESTED);
    assert!(d.items[0].message.contains("(line 1)"), "{d:?}");
    assert!(!d.has_errors());
}

#[test]
fn wide_strings_and_their_escapes() {
    // `$"` and `$$`, four hex digits a character (`$0041`, `$20AC`); `$'` is allowed too.
    // The text is kept as UTF-8, which the checker makes UTF-16 code units.
    check(
        "\"a$\"b$$c$N$0041$20AC$'x'\"",
        &[Tok::Str {
            bytes: "a\"b$c\nA\u{20ac}'x'".as_bytes().to_vec(),
            wide: true,
        }],
    );
    // Two hex digits are STRING's form: in a WSTRING `$41` is an unknown escape.
    check_error("\"$41\"", diag::BAD_ESCAPE);
    check_error("\"abc", diag::UNTERMINATED_STRING);
    // A `"` inside '…' is a plain character.
    check(
        "'say \"hi\"'",
        &[Tok::Str {
            bytes: b"say \"hi\"".to_vec(),
            wide: false,
        }],
    );
}

#[test]
fn comments_nest_and_pragmas_vanish() {
    check(
        "a (* x (* y *) z *) b // c\n(* {pragma} *) e",
        &[Tok::Ident, Tok::Ident, Tok::Ident],
    );
    check_error("(* abc", diag::UNTERMINATED_COMMENT);
    check_error("(* (* x", diag::UNTERMINATED_COMMENT);
    check_error("/* /* x", diag::UNTERMINATED_COMMENT);
    // Pragmas leave no token; what they would change is said once (docs/iec.md, "Pragmas").
    let src = "a (* x *) b\n{pragma} /* d */ {{ C { code } }} e {attribute 'hide'}";
    let mut d = Diagnostics::new();
    let toks = kinds(src, &mut d);
    assert_eq!(toks, [Tok::Ident, Tok::Ident, Tok::Ident, Tok::Eof]);
    let got: Vec<(diag::Code, &str)> = d
        .items
        .iter()
        .map(|x| (x.code, x.message.as_str()))
        .collect();
    assert_eq!(
        got,
        [(
            diag::PRAGMA_IGNORED,
            "3 pragmas ignored here ({pragma}, {{ C { code } }}, {attribute 'hide'}): petriplc does not model them"
        )]
    );
    assert_eq!(d.items[0].span, Span::new(FileId(0), 12, 20));
}

#[test]
fn warning_error_and_conditional_pragmas() {
    let src =
        "{warning 'check the scaling'} a {error 'not for this PLC'} {IF defined(x)} b {END_IF}";
    let mut d = Diagnostics::new();
    lex(FileId(0), src, &mut d);
    let got: Vec<String> = d
        .items
        .iter()
        .map(|x| format!("{}: {}", x.code, x.message))
        .collect();
    assert_eq!(
        got,
        [
            "W011: the source's own warning: check the scaling",
            "E015: the source's own error: not for this PLC",
            "E190: conditional compilation ({IF …} … {END_IF}) is not supported; keep the branch meant for this PLC and remove the pragmas",
        ]
    );
}

#[test]
fn typed_prefixes_and_direct_variables() {
    check(
        "INT#5 Color#Red %IX0.1 %lamp",
        &[
            Tok::TypedPrefix,
            Tok::Int(5),
            Tok::TypedPrefix,
            Tok::Ident,
            Tok::Direct("IX0.1".into()),
            Tok::Direct("lamp".into()),
        ],
    );
}

#[test]
fn operators() {
    check(
        ":= => .. ** <= >= <> < > = & ^",
        &[
            Tok::Assign,
            Tok::Arrow,
            Tok::DotDot,
            Tok::Power,
            Tok::Le,
            Tok::Ge,
            Tok::Ne,
            Tok::Lt,
            Tok::Gt,
            Tok::Eq,
            Tok::Amp,
            Tok::Caret,
        ],
    );
    let mut d = Diagnostics::new();
    let toks = kinds("a ? b", &mut d);
    assert_eq!(toks, [Tok::Ident, Tok::Error, Tok::Ident, Tok::Eof]);
    assert_eq!(d.items[0].code, diag::BAD_CHAR);
}

#[test]
fn a_date_beyond_the_calendar_is_an_error_not_an_overflow() {
    let mut d = Diagnostics::new();
    lex(FileId(0), "D#99999999999999999-01-01", &mut d);
    assert_eq!(d.items.len(), 1, "{:?}", d.items);
    assert_eq!(d.items[0].code, diag::BAD_TIME);
    assert!(
        d.items[0].message.contains("beyond the calendar"),
        "{}",
        d.items[0].message
    );
    assert!(parse_date("25000000000000000-12-31").is_ok());
}

#[test]
fn a_string_literal_holds_one_latin1_byte_per_character_whatever_the_encoding() {
    let strs = |text: &str, d: &mut Diagnostics| -> Vec<Tok> {
        lex(FileId(0), text, d)
            .into_iter()
            .map(|t| t.tok)
            .filter(|t| *t != Tok::Eof)
            .collect()
    };
    let string = |bytes: &[u8]| Tok::Str {
        bytes: bytes.to_vec(),
        wide: false,
    };
    // The text as decoded from a Latin-1 file (each byte one character) and the same text
    // from a UTF-8 file (TwinCAT's XML) give the same STRING bytes.
    let latin1: String = b"'\xe4\xf6\xfc\xff'".iter().map(|&b| b as char).collect();
    let mut d = Diagnostics::new();
    assert_eq!(
        strs(&latin1, &mut d),
        vec![string(&[0xe4, 0xf6, 0xfc, 0xff])]
    );
    assert_eq!(
        strs("'\u{e4}\u{f6}\u{fc}\u{ff}'", &mut d),
        vec![string(&[0xe4, 0xf6, 0xfc, 0xff])]
    );
    assert_eq!(
        strs("'a\u{b0}C$E4'", &mut d),
        vec![string(&[b'a', 0xb0, b'C', 0xe4])]
    );
    assert!(d.is_empty(), "{d:?}");
    // A WSTRING holds characters (UTF-8), whatever the file's encoding.
    assert_eq!(
        strs("\"\u{e4}\u{20ac}\"", &mut d),
        vec![Tok::Str {
            bytes: "\u{e4}\u{20ac}".as_bytes().to_vec(),
            wide: true
        }]
    );
    assert!(d.is_empty(), "{d:?}");
    // Windows-1252's own characters are their byte of the code page (TwinCAT's XML holds
    // OSCAT's `€` so), as a byte-for-byte read of a file in the code page gives.
    assert_eq!(
        strs("'\u{20ac}\u{2122}\u{178}'", &mut d),
        vec![string(&[0x80, 0x99, 0x9f])]
    );
    assert!(d.is_empty(), "{d:?}");
    // Any other character has no STRING byte: E009 at that character, and the rest of the
    // literal and of the line is still read.
    let toks = strs("'a\u{3a9}b' x", &mut d);
    assert_eq!(toks[0], string(b"a?b"));
    assert_eq!(toks[1], Tok::Ident);
    assert_eq!(d.items.len(), 1, "{d:?}");
    assert_eq!(d.items[0].code.0, "E009");
    assert_eq!((d.items[0].span.start, d.items[0].span.end), (2, 4));
    assert!(
        d.items[0].message.contains("WSTRING"),
        "{}",
        d.items[0].message
    );
}

#[test]
fn a_replacement_character_in_a_string_is_a_warning() {
    // ironplc's strings.st holds U+FFFD where a byte was lost on the way to UTF-8: the
    // character meant is unknown, so STRING gets '?' and W043 says why.
    let mut d = Diagnostics::new();
    let toks = kinds("'\u{fffd}'", &mut d);
    assert_eq!(
        toks[0],
        Tok::Str {
            bytes: b"?".to_vec(),
            wide: false
        }
    );
    assert_eq!(d.items.len(), 1, "{d:?}");
    assert_eq!(d.items[0].code.0, "W043");
    assert!(!d.has_errors());
}
