//! `point NAME "description" OWNER [at W[.B]] [i|u|f][bits] [init V] [retain]` rows: the
//! optional clauses may come in any order, each at most once.
//!
//! Defaults follow MatPLC: the length is 1 bit without `at`, 32 bits with `at W`, 1 bit with
//! `at W.B`, and 32 bits for `f`. Without an `i`/`u`/`f` letter the kind follows the
//! initial value as MatPLC reads it: a float literal (`1.5`, `1e9`) makes an `f` point, a
//! leading sign an `i` point, anything else a `u` point.

use crate::error::{self, Diagnostic};
use crate::model::{Origin, PointDecl, PointKind, PointValue};

/// Words in the global map a point may be placed at (`at 0` to `at 65535`): far more than
/// any PLC needs, small enough that a typo cannot make the runtime allocate gigabytes.
pub const MAX_WORDS: u32 = 65_536;

const SYNTAX: &str = "`point NAME \"description\" OWNER [at W.B] [i|u|f][bits] [init V] [retain]`";

/// The point a row declares, or `None` after pushing what is wrong with it.
pub(crate) fn parse_point(
    cells: &[String],
    origin: &Origin,
    diags: &mut Vec<Diagnostic>,
) -> Option<PointDecl> {
    let before = diags.len();
    let mut err = |code, msg: String| diags.push(error::diagnostic(origin, code, msg));
    let [name, description, owner, rest @ ..] = cells else {
        err(
            error::POINT_SHAPE,
            format!("a point needs a name, a description and an owner: {SYNTAX}"),
        );
        return None;
    };
    if name.is_empty() || owner.is_empty() {
        err(
            error::POINT_SHAPE,
            format!("a point's name and owner must not be empty: {SYNTAX}"),
        );
        return None;
    }
    let mut at: Option<(u32, Option<u8>)> = None;
    let mut kind: Option<PointKind> = None;
    let mut len: Option<u32> = None;
    let mut init: Option<&str> = None;
    let mut retain = false;
    let mut seen = Vec::new();
    let mut i = 0;
    while i < rest.len() {
        let cell = rest[i].as_str();
        let clause = match cell {
            "at" | "init" | "retain" => cell,
            _ => "type",
        };
        if seen.contains(&clause) {
            let msg = if clause == "type" {
                format!("point {name} has a second type/length `{cell}`: keep one")
            } else {
                format!("point {name} has `{clause}` twice: keep one")
            };
            err(error::BAD_POINT_TYPE, msg);
            return None;
        }
        seen.push(clause);
        match clause {
            "retain" => {
                retain = true;
                i += 1;
            }
            "at" | "init" => {
                let Some(value) = rest.get(i + 1) else {
                    let example = if clause == "at" { "at 3.0" } else { "init 0" };
                    err(
                        error::BAD_POINT_TYPE,
                        format!(
                            "`{clause}` at the end of point {name} needs a value, e.g. `{example}`"
                        ),
                    );
                    return None;
                };
                if clause == "at" {
                    match parse_at(value) {
                        Ok(a) => at = Some(a),
                        Err(why) => err(error::BAD_AT, format!("point {name}: {why}")),
                    }
                } else {
                    init = Some(value);
                }
                i += 2;
            }
            _ => {
                match parse_type(cell) {
                    Some((k, l)) => {
                        kind = k;
                        len = l;
                    }
                    None => err(
                        error::BAD_POINT_TYPE,
                        format!(
                            "unexpected `{cell}` in point {name}: after the owner come \
                             `at W.B`, a type and length such as `1`, `u8`, `i16` or `f32`, \
                             `init V` and `retain`"
                        ),
                    ),
                }
                i += 1;
            }
        }
    }
    if diags.len() > before {
        return None;
    }
    let mut err = |code, msg: String| diags.push(error::diagnostic(origin, code, msg));

    let literal = match init.map(parse_literal).transpose() {
        Ok(l) => l,
        Err(why) => {
            err(
                error::BAD_INIT,
                format!("point {name}: `init {}` {why}", init.unwrap_or_default()),
            );
            return None;
        }
    };
    let kind_written = kind.is_some();
    let kind = kind.unwrap_or(match literal {
        Some(Literal::Float(_)) => PointKind::Float,
        Some(Literal::Int { signed: true, .. }) => PointKind::Signed,
        _ => PointKind::Unsigned,
    });
    let bits = len.unwrap_or(match (kind, at) {
        (PointKind::Float, _) | (_, Some((_, None))) => 32,
        _ => 1,
    });
    let bit = at.and_then(|(_, b)| b).unwrap_or(0);
    if kind == PointKind::Float && bits != 32 {
        let why = if !kind_written {
            format!("`init {}` is a float", init.unwrap_or_default())
        } else {
            "it is `f`".to_string()
        };
        err(
            error::FLOAT_NOT_32_BITS,
            format!(
                "point {name} is {bits} bits, but {why} and floats are 32 bits: write `f32` \
                 and place it at bit 0 (`at W` or `at W.0`)"
            ),
        );
        return None;
    }
    if !(1..=32).contains(&bits) {
        err(
            error::BAD_POINT_TYPE,
            format!("point {name} is {bits} bits: a point is 1 to 32 bits"),
        );
        return None;
    }
    if u32::from(bit) + bits > 32 {
        let word = at.map_or(0, |(w, _)| w);
        err(
            error::POINT_OVERFLOWS_WORD,
            format!(
                "point {name} at {word}.{bit} is {bits} bits and would run past bit 31 of word \
                 {word} (bit + length = {} > 32): start it at bit {} or lower, or make it shorter",
                u32::from(bit) + bits,
                32 - bits
            ),
        );
        return None;
    }
    let value = match literal {
        None => Ok(match kind {
            PointKind::Unsigned => PointValue::Unsigned(0),
            PointKind::Signed => PointValue::Signed(0),
            PointKind::Float => PointValue::Float(0.0),
        }),
        Some(lit) => fit(lit, kind, bits),
    };
    let init = match value {
        Ok(v) => v,
        Err(why) => {
            err(
                error::BAD_INIT,
                format!("point {name}: `init {}` {why}", init.unwrap_or_default()),
            );
            return None;
        }
    };
    Some(PointDecl {
        name: name.clone(),
        description: description.clone(),
        owner: owner.clone(),
        at: at.map(|(w, b)| (w, b.unwrap_or(0))),
        kind,
        bits: bits as u8,
        init,
        retain,
        origin: origin.clone(),
    })
}

/// `W` or `W.B`, both decimal.
fn parse_at(text: &str) -> Result<(u32, Option<u8>), String> {
    let usage = "write `at WORD` or `at WORD.BIT` (decimal, bit 0 to 31)";
    let (w, b) = match text.split_once('.') {
        Some((w, b)) => (w, Some(b)),
        None => (text, None),
    };
    let decimal = |s: &str| !s.is_empty() && s.bytes().all(|c| c.is_ascii_digit());
    if !decimal(w) || !b.is_none_or(decimal) {
        return Err(format!("`at {text}` is not a place in the map: {usage}"));
    }
    let word = w
        .parse::<u32>()
        .ok()
        .filter(|&w| w < MAX_WORDS)
        .ok_or_else(|| {
            format!(
                "word {w} is beyond the map: use a word from 0 to {}",
                MAX_WORDS - 1
            )
        })?;
    let bit = match b {
        None => None,
        Some(b) => Some(
            b.parse::<u8>()
                .ok()
                .filter(|&b| b < 32)
                .ok_or_else(|| format!("bit {b} does not exist: a word has bits 0 to 31"))?,
        ),
    };
    Ok((word, bit))
}

/// `u8`, `i16`, `f32`, `f`, `u`, `7`: the kind letter and the length, each optional.
fn parse_type(cell: &str) -> Option<(Option<PointKind>, Option<u32>)> {
    let (kind, digits) = match cell.as_bytes().first()? {
        b'u' => (Some(PointKind::Unsigned), &cell[1..]),
        b'i' => (Some(PointKind::Signed), &cell[1..]),
        b'f' => (Some(PointKind::Float), &cell[1..]),
        _ => (None, cell),
    };
    if !digits.bytes().all(|c| c.is_ascii_digit()) {
        return None;
    }
    let len = if digits.is_empty() {
        None
    } else {
        // Anything past u32 is as wrong as 33: report it as a length out of range.
        Some(digits.parse().unwrap_or(u32::MAX))
    };
    Some((kind, len))
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Literal {
    Float(f64),
    /// `signed`: written with a leading `+` or `-`.
    Int {
        value: i128,
        signed: bool,
    },
}

/// A number as MatPLC writes them: decimal, `0x` hex, leading-`0` octal, or a float.
fn parse_literal(text: &str) -> Result<Literal, String> {
    let not_number =
        || "is not a number: write e.g. `init 0`, `init -5`, `init 0x1F` or `init 1.5`".to_string();
    let (neg, signed, body) = match text.as_bytes().first() {
        Some(b'-') => (true, true, &text[1..]),
        Some(b'+') => (false, true, &text[1..]),
        _ => (false, false, text),
    };
    let lower = body.to_ascii_lowercase();
    if let Some(hex) = lower.strip_prefix("0x") {
        return int(hex, 16, neg, signed).ok_or_else(not_number);
    }
    if lower.contains(['.', 'e']) {
        let ok = body.starts_with(|c: char| c.is_ascii_digit() || c == '.')
            && body
                .bytes()
                .all(|c| c.is_ascii_digit() || b".eE+-".contains(&c));
        let v: f64 = if ok {
            text.parse().map_err(|_| not_number())?
        } else {
            return Err(not_number());
        };
        if !(v as f32).is_finite() {
            return Err("is too large for a 32-bit float".into());
        }
        return Ok(Literal::Float(v));
    }
    if body.len() > 1 && body.starts_with('0') {
        return int(&body[1..], 8, neg, signed).ok_or_else(not_number);
    }
    int(body, 10, neg, signed).ok_or_else(not_number)
}

fn int(digits: &str, radix: u32, neg: bool, signed: bool) -> Option<Literal> {
    if digits.is_empty() || !digits.chars().all(|c| c.is_digit(radix)) {
        return None;
    }
    // Saturating keeps absurdly long numbers an "out of range" error rather than "not a number".
    let v = i128::from_str_radix(digits, radix).unwrap_or(i128::MAX / 2);
    Some(Literal::Int {
        value: if neg { -v } else { v },
        signed,
    })
}

fn fit(lit: Literal, kind: PointKind, bits: u32) -> Result<PointValue, String> {
    let letter = match kind {
        PointKind::Unsigned => 'u',
        PointKind::Signed => 'i',
        PointKind::Float => 'f',
    };
    match (lit, kind) {
        (Literal::Float(v), PointKind::Float) => Ok(PointValue::Float(v as f32)),
        (Literal::Int { value, .. }, PointKind::Float) => Ok(PointValue::Float(value as f32)),
        (Literal::Float(_), _) => Err(format!(
            "is not an integer, but the point is `{letter}{bits}`: write an integer, or make the \
             point `f32`"
        )),
        (Literal::Int { value, .. }, PointKind::Unsigned) => {
            let max = (1i128 << bits) - 1;
            if (0..=max).contains(&value) {
                Ok(PointValue::Unsigned(value as u32))
            } else {
                let hint = if value < 0 {
                    format!(" or make the point signed (`i{bits}`)")
                } else {
                    " or make the point longer".into()
                };
                Err(format!(
                    "does not fit the point's {bits} unsigned bits: write a value from 0 to {max}{hint}"
                ))
            }
        }
        (Literal::Int { value, .. }, PointKind::Signed) => {
            let min = -(1i128 << (bits - 1));
            let max = (1i128 << (bits - 1)) - 1;
            if (min..=max).contains(&value) {
                Ok(PointValue::Signed(value as i32))
            } else {
                Err(format!(
                    "does not fit the point's {bits} signed bits: write a value from {min} to {max} \
                     or make the point longer"
                ))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parses the cells of `input` (split on spaces; `_` stands for an empty description)
    /// and renders the point or the messages.
    fn check(input: &str, expect: &str) {
        let cells: Vec<String> = input
            .split_whitespace()
            .map(|c| {
                if c == "_" {
                    String::new()
                } else {
                    c.to_string()
                }
            })
            .collect();
        let origin = Origin {
            file: "t.conf".into(),
            line: 1,
        };
        let mut diags = Vec::new();
        let got = match parse_point(&cells, &origin, &mut diags) {
            Some(p) => {
                assert!(diags.is_empty());
                let at = p.at.map_or("-".into(), |(w, b)| format!("{w}.{b}"));
                format!(
                    "{} {} {at} {:?}{} {:?}{}",
                    p.name,
                    p.owner,
                    p.kind,
                    p.bits,
                    p.init,
                    if p.retain { " retain" } else { "" }
                )
            }
            None => diags
                .iter()
                .map(|d| format!("{} {}", d.code, d.message))
                .collect::<Vec<_>>()
                .join("\n"),
        };
        assert_eq!(got, expect, "point {input}");
    }

    #[test]
    fn length_defaults() {
        check("L1 _ m", "L1 m - Unsigned1 Unsigned(0)");
        check("P0.0 _ m at 0.0", "P0.0 m 0.0 Unsigned1 Unsigned(0)");
        check("P0.1 _ m at 0.1 5", "P0.1 m 0.1 Unsigned5 Unsigned(0)");
        check("P1 _ m at 1", "P1 m 1.0 Unsigned32 Unsigned(0)");
        check("L _ m 4", "L m - Unsigned4 Unsigned(0)");
        check("T _ m f32 init 20.0", "T m - Float32 Float(20.0)");
        check("T _ m f", "T m - Float32 Float(0.0)");
        check("T _ m at 3 f init 2", "T m 3.0 Float32 Float(2.0)");
        check("S _ m i16 init -300", "S m - Signed16 Signed(-300)");
        check("S _ m init 1 at 2.4 u4", "S m 2.4 Unsigned4 Unsigned(1)");
    }

    #[test]
    fn retain_anywhere_after_the_owner() {
        check("c _ m u32 retain", "c m - Unsigned32 Unsigned(0) retain");
        check(
            "c _ m retain at 4 i16 init -2",
            "c m 4.0 Signed16 Signed(-2) retain",
        );
        check(
            "c _ m retain u8 retain",
            "C024 point c has `retain` twice: keep one",
        );
        check(
            "c _ m retained",
            "C024 unexpected `retained` in point c: after the owner come `at W.B`, a type and \
             length such as `1`, `u8`, `i16` or `f32`, `init V` and `retain`",
        );
    }

    #[test]
    fn init_interpretation() {
        check("a _ m 32 init 0xFF", "a m - Unsigned32 Unsigned(255)");
        check("a _ m 32 init 017", "a m - Unsigned32 Unsigned(15)");
        check(
            "a _ m 32 init 4294967295",
            "a m - Unsigned32 Unsigned(4294967295)",
        );
        check("a _ m 8 init -1", "a m - Signed8 Signed(-1)");
        check("a _ m 32 init 1.1", "a m - Float32 Float(1.1)");
        check("a _ m 32 init 1e9", "a m - Float32 Float(1000000000.0)");
        check("a _ m init 1.5", "a m - Float32 Float(1.5)");
        check(
            "a _ m i32 init -2147483648",
            "a m - Signed32 Signed(-2147483648)",
        );
        check("a _ m init 1", "a m - Unsigned1 Unsigned(1)");
    }

    #[test]
    fn init_errors() {
        check(
            "a _ m init 2",
            "C027 point a: `init 2` does not fit the point's 1 unsigned bits: write a value from \
             0 to 1 or make the point longer",
        );
        check(
            "a _ m u8 init -1",
            "C027 point a: `init -1` does not fit the point's 8 unsigned bits: write a value \
             from 0 to 255 or make the point signed (`i8`)",
        );
        check(
            "a _ m i8 init 128",
            "C027 point a: `init 128` does not fit the point's 8 signed bits: write a value from \
             -128 to 127 or make the point longer",
        );
        check(
            "a _ m u8 init 1.5",
            "C027 point a: `init 1.5` is not an integer, but the point is `u8`: write an \
             integer, or make the point `f32`",
        );
        for bad in ["x", "0x", "1.2.3", "inf", "nan", "09", "1e", "--1", "0xG"] {
            check(
                &format!("a _ m 32 init {bad}"),
                &format!(
                    "C027 point a: `init {bad}` is not a number: write e.g. `init 0`, `init -5`, \
                     `init 0x1F` or `init 1.5`"
                ),
            );
        }
        check(
            "a _ m init 1e39",
            "C027 point a: `init 1e39` is too large for a 32-bit float",
        );
        check(
            "a _ m 8 init 1.5",
            "C026 point a is 8 bits, but `init 1.5` is a float and floats are 32 bits: write \
             `f32` and place it at bit 0 (`at W` or `at W.0`)",
        );
    }

    #[test]
    fn shape_and_placement_errors() {
        check(
            "a _",
            "C020 a point needs a name, a description and an owner: `point NAME \
             \"description\" OWNER [at W.B] [i|u|f][bits] [init V] [retain]`",
        );
        check(
            "a x _",
            "C020 a point's name and owner must not be empty: `point NAME \"description\" \
             OWNER [at W.B] [i|u|f][bits] [init V] [retain]`",
        );
        check(
            "a _ m at 1.",
            "C023 point a: `at 1.` is not a place in the map: write `at WORD` or `at WORD.BIT` \
             (decimal, bit 0 to 31)",
        );
        check(
            "a _ m at 0.32",
            "C023 point a: bit 32 does not exist: a word has bits 0 to 31",
        );
        check(
            "a _ m at 65536",
            "C023 point a: word 65536 is beyond the map: use a word from 0 to 65535",
        );
        check(
            "a _ m at 0.30 5",
            "C025 point a at 0.30 is 5 bits and would run past bit 31 of word 0 (bit + length \
             = 35 > 32): start it at bit 27 or lower, or make it shorter",
        );
        check("a _ m 0", "C024 point a is 0 bits: a point is 1 to 32 bits");
        check(
            "a _ m u33",
            "C024 point a is 33 bits: a point is 1 to 32 bits",
        );
        check(
            "a _ m f16",
            "C026 point a is 16 bits, but it is `f` and floats are 32 bits: write `f32` and \
             place it at bit 0 (`at W` or `at W.0`)",
        );
        check(
            "a _ m at 0.1 f",
            "C025 point a at 0.1 is 32 bits and would run past bit 31 of word 0 (bit + length = \
             33 > 32): start it at bit 0 or lower, or make it shorter",
        );
        check(
            "a _ m bool",
            "C024 unexpected `bool` in point a: after the owner come `at W.B`, a type and length \
             such as `1`, `u8`, `i16` or `f32`, `init V` and `retain`",
        );
        check("a _ m at 1 at 2", "C024 point a has `at` twice: keep one");
        check(
            "a _ m u8 i8",
            "C024 point a has a second type/length `i8`: keep one",
        );
        check(
            "a _ m 8 init",
            "C024 `init` at the end of point a needs a value, e.g. `init 0`",
        );
    }
}
