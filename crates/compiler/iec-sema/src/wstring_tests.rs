//! WSTRING, CHAR and WCHAR in the checker: their types, literals and sizes, and the mixes of
//! STRING and WSTRING the standard refuses (each with the conversion to write).

use crate::memory::size_align;
use crate::tests::run;

fn errors(src: &str, expect: &[&str]) {
    let (p, d) = run(src);
    let lines: Vec<&str> = d.lines().collect();
    assert_eq!(lines.len(), expect.len(), "got:\n{d}");
    for (l, e) in lines.iter().zip(expect) {
        assert!(l.contains(e), "expected `{e}` in\n{l}\n(all:\n{d})");
    }
    assert!(p.is_none() || expect.is_empty());
}

#[test]
fn wide_strings_are_types_of_their_own() {
    let (p, d) = run("PROGRAM p
VAR s : STRING(10); w : WSTRING; w2 : WSTRING(5); w3 : WSTRING[7] := \"$0041b\"; END_VAR
w2 := w3;
END_PROGRAM");
    assert!(!d.contains("error"), "{d}");
    let p = p.unwrap();
    let vars = &p.pou(p.pous.len() as u32 - 1).vars;
    let name = |i: usize| p.types.name(vars[i].ty);
    assert_eq!(
        [name(0), name(1), name(2), name(3)],
        ["STRING[10]", "WSTRING", "WSTRING[5]", "WSTRING[7]"]
    );
    // SIZEOF: two bytes a character and a zero unit, aligned to 2 (CODESYS, TwinCAT).
    assert_eq!(size_align(&p.types, vars[2].ty), Some((12, 2)));
}

#[test]
fn strings_and_wide_strings_do_not_mix() {
    errors(
        "PROGRAM p
VAR s : STRING; w : WSTRING; b : BOOL; i : INT; END_VAR
s := w;
w := 'abc';
b := s = w;
w := CONCAT(w, s);
i := FIND(s, w);
w := WSTRING#'x';
s := STRING#\"x\";
s := STRING_TO_WSTRING(w);
w := WSTRING_TO_WSTRING(w);
END_PROGRAM",
        &[
            "3:6: error[E110]: the value assigned to `s` is WSTRING but STRING is needed; STRING and WSTRING do not mix implicitly: convert with WSTRING_TO_STRING(…)",
            "4:6: error[E110]: the value assigned to `w` is STRING[3] but WSTRING is needed; STRING and WSTRING do not mix implicitly: convert with STRING_TO_WSTRING(…), or write the literal in double quotes",
            "5:6: error[E111]: `=` cannot combine STRING and WSTRING; STRING and WSTRING do not mix implicitly",
            "6:16: error[E110]: CONCAT takes strings of one kind: this is STRING, its first string WSTRING; convert it with STRING_TO_WSTRING(…)",
            "7:14: error[E110]: FIND takes strings of one kind: this is WSTRING, its first string STRING; convert it with WSTRING_TO_STRING(…)",
            "8:6: error[E110]: `WSTRING#` does not type this literal; a WSTRING literal is in double quotes: WSTRING#\"…\"",
            "9:6: error[E110]: `STRING#` does not type this literal; a STRING literal is in single quotes: STRING#'…'",
            "10:24: error[E110]: STRING_TO_WSTRING converts STRING, and this argument is WSTRING; it is WSTRING already: leave the conversion out",
        ],
    );
}

#[test]
fn a_wide_literal_too_long_for_its_variable_is_refused() {
    errors(
        "PROGRAM p
VAR w : WSTRING(3) := \"Grüße\"; END_VAR
END_PROGRAM",
        &["error[E113]: this string has 5 characters; WSTRING[3] holds 3"],
    );
}

#[test]
fn characters_are_one_character_of_their_string_type() {
    errors(
        "PROGRAM p
VAR c : CHAR; w : WCHAR; b : BYTE; r : REAL; END_VAR
c := \"a\";
w := 'ab';
c := c + c;
b := c;
c := CHAR#65;
w := WCHAR#'a';
r := CHAR_TO_REAL(c);
END_PROGRAM",
        &[
            "3:6: error[E110]: the value assigned to `c` is WSTRING[1] but CHAR is needed; a CHAR literal is one character in single quotes ('a'), a WCHAR's in double quotes (\"a\")",
            "4:6: error[E110]: the value assigned to `w` is STRING[2] but WCHAR is needed",
            "5:6: error[E111]: `+` applies to numbers and durations, not CHAR",
            "6:6: error[E110]: the value assigned to `b` is CHAR but BYTE is needed; convert explicitly: CHAR_TO_BYTE(…)",
            "7:6: error[E110]: CHAR# types a character: write CHAR#'A'; a code converts with BYTE_TO_CHAR(65)",
            "8:6: error[E110]: `WCHAR#` types one character: write WCHAR#\"a\" (one character in double quotes)",
            "9:6: error[E110]: CHAR cannot be converted to REAL",
        ],
    );
    // Bytes and alignment as CODESYS's BYTE and WORD.
    let t = crate::types::TypeTable::new();
    assert_eq!(size_align(&t, crate::types::ids::CHAR), Some((1, 1)));
    assert_eq!(size_align(&t, crate::types::ids::WCHAR), Some((2, 2)));
}
