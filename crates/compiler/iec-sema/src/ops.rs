//! The meaning of operators, conversions and standard functions on values, shared by the
//! checker's constant folding and the VM, so a folded constant and a computed value can
//! never differ.
//!
//! Rules (docs/iec.md): integer arithmetic whose result leaves the type's range wraps around
//! (two's complement in the result's type, as CODESYS, TwinCAT, matiec and OpenPLC do), or is
//! an overflow fault when the project chose [`Overflow::Fault`] (the standard: "it shall be an
//! error"); a constant expression that overflows is a compile error either way. Integer
//! division by zero is an error and `MOD` by zero gives 0 (the standard's definition); REAL
//! and LREAL arithmetic is IEC 60559's (IEEE 754): a result too large is ±Inf, one without a
//! value (0.0 / 0.0, SQRT(-1.0)) is NaN, and both propagate, as on every other PLC;
//! conversions between integer types keep the low bits (wrap-around), REAL/LREAL to integers
//! round half to even, fail for NaN and ±Inf (an integer has no value to stand for them) and,
//! out of the target's range, wrap (or fail in fault mode); TIME ⇄ integers count
//! milliseconds, LTIME nanoseconds, DATE and DT seconds since 1970-01-01, TOD milliseconds
//! since midnight.

use std::fmt;

use petriplc_iec_syntax::ast::BinaryOp;
use petriplc_iec_syntax::lexer::{self, NANOS_PER_DAY};

use crate::types::{fits, wrap, Elem};
use crate::value::{to_real, Value};

/// Why an operation has no value.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum OpError {
    DivisionByZero,
    /// The result does not fit the type.
    Overflow,
    /// A conversion whose value does not fit the target, or a string that does not spell one.
    Conversion,
    /// An argument outside the function's domain (SQRT(-1), a string position).
    Domain(&'static str),
}

impl fmt::Display for OpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OpError::DivisionByZero => f.write_str("division by zero"),
            OpError::Overflow => f.write_str("overflow"),
            OpError::Conversion => f.write_str("conversion error"),
            OpError::Domain(w) => f.write_str(w),
        }
    }
}

pub type OpResult<T> = Result<T, OpError>;

pub use crate::ir::Overflow;

/// An integer operator on values of an integral type (integers, bit strings, BOOL,
/// durations, dates). Comparisons give 0/1.
pub fn int_binary(op: BinaryOp, a: i128, b: i128, e: Elem) -> OpResult<i128> {
    use BinaryOp::*;
    let r = match op {
        Add => a.checked_add(b).ok_or(OpError::Overflow)?,
        Sub => a.checked_sub(b).ok_or(OpError::Overflow)?,
        Mul => a.checked_mul(b).ok_or(OpError::Overflow)?,
        Div => {
            if b == 0 {
                return Err(OpError::DivisionByZero);
            }
            a / b
        }
        Mod => {
            if b == 0 {
                0
            } else {
                a % b
            }
        }
        And | AndThen => return Ok(a & b),
        Or | OrElse => return Ok(a | b),
        Xor => return Ok(a ^ b),
        Eq => return Ok((a == b) as i128),
        Ne => return Ok((a != b) as i128),
        Lt => return Ok((a < b) as i128),
        Le => return Ok((a <= b) as i128),
        Gt => return Ok((a > b) as i128),
        Ge => return Ok((a >= b) as i128),
        Power => return Err(OpError::Domain("`**` needs a REAL base")),
    };
    if fits(r, e) {
        Ok(r)
    } else {
        Err(OpError::Overflow)
    }
}

/// The integer that BCD digits spell (four bits a decimal digit, the lowest first), in the
/// integer type `to`. A group above 9 spells no digit, and a number too large for `to` has no
/// value: both are conversion errors (CODESYS's BCD_TO_INT returns -1 instead, a value the
/// program could take for a reading).
pub fn from_bcd(bits: i128, to: Elem) -> OpResult<i128> {
    let (mut x, mut r, mut scale) = (bits, 0i128, 1i128);
    if x < 0 {
        return Err(OpError::Conversion);
    }
    while x != 0 {
        let digit = x & 15;
        if digit > 9 {
            return Err(OpError::Conversion);
        }
        r += digit * scale;
        scale *= 10;
        x >>= 4;
    }
    if fits(r, to) {
        Ok(r)
    } else {
        Err(OpError::Conversion)
    }
}

/// The BCD digits of an integer in the bit string `to`: a negative number, or one with more
/// digits than `to` holds (2 a BYTE … 16 an LWORD), is a conversion error.
pub fn to_bcd(v: i128, to: Elem) -> OpResult<i128> {
    if v < 0 {
        return Err(OpError::Conversion);
    }
    let (mut x, mut r, mut shift) = (v, 0i128, 0u32);
    while x != 0 {
        if shift >= 64 {
            return Err(OpError::Conversion);
        }
        r |= (x % 10) << shift;
        x /= 10;
        shift += 4;
    }
    if fits(r, to) {
        Ok(r)
    } else {
        Err(OpError::Conversion)
    }
}

/// An integer operator at run time: [`int_binary`], except that in [`Overflow::Wrap`] a
/// result outside the type keeps its low bits (128-bit arithmetic cannot itself overflow on
/// 64-bit operands but for a product, whose low 64 bits wrapping keeps exact).
pub fn int_binary_in(op: BinaryOp, a: i128, b: i128, e: Elem, mode: Overflow) -> OpResult<i128> {
    match int_binary(op, a, b, e) {
        Err(OpError::Overflow) if mode == Overflow::Wrap => {
            let r = match op {
                BinaryOp::Add => a.wrapping_add(b),
                BinaryOp::Sub => a.wrapping_sub(b),
                BinaryOp::Mul => a.wrapping_mul(b),
                BinaryOp::Div => a.wrapping_div(b),
                _ => return Err(OpError::Overflow),
            };
            Ok(wrap(r, e))
        }
        r => r,
    }
}

/// Rounds to the type's precision: REAL is single precision, so an LREAL beyond its range
/// becomes ±Inf, as IEC 60559 rounds.
pub fn real_result(v: f64, e: Elem) -> f64 {
    if e == Elem::Real {
        to_real(v)
    } else {
        v
    }
}

/// Why a real has no place in an integer, or `None` when it is a finite number: for fault
/// messages.
pub fn non_finite(v: f64) -> Option<&'static str> {
    if v.is_nan() {
        Some("NaN (not a number)")
    } else if v.is_infinite() {
        Some(if v > 0.0 { "+Inf" } else { "-Inf" })
    } else {
        None
    }
}

/// A real operator, by IEC 60559: division by zero gives ±Inf (NaN for 0.0 / 0.0).
/// Comparisons give 0.0/1.0 (every comparison with NaN is false but `<>`).
pub fn real_binary(op: BinaryOp, a: f64, b: f64, e: Elem) -> OpResult<f64> {
    use BinaryOp::*;
    let r = match op {
        Add => a + b,
        Sub => a - b,
        Mul => a * b,
        Div => a / b,
        Power => a.powf(b),
        Eq => return Ok((a == b) as i32 as f64),
        Ne => return Ok((a != b) as i32 as f64),
        Lt => return Ok((a < b) as i32 as f64),
        Le => return Ok((a <= b) as i32 as f64),
        Gt => return Ok((a > b) as i32 as f64),
        Ge => return Ok((a >= b) as i32 as f64),
        Mod | And | Or | Xor | AndThen | OrElse => {
            return Err(OpError::Domain("not an operator of reals"))
        }
    };
    Ok(real_result(r, e))
}

/// `**` with an integer exponent (powi is exact for small exponents).
pub fn real_power_int(a: f64, n: i128, e: Elem) -> f64 {
    let r = if let Ok(n) = i32::try_from(n) {
        a.powi(n)
    } else {
        a.powf(n as f64)
    };
    real_result(r, e)
}

/// Round half to even, as IEC 60559 and the standard's REAL_TO_INT.
pub fn round_even(v: f64) -> f64 {
    let r = v.round();
    if (v - v.trunc()).abs() == 0.5 {
        2.0 * (v / 2.0).round()
    } else {
        r
    }
}

/// A real converted to an integral type, rounded half to even.
pub fn real_to_int(v: f64, e: Elem, mode: Overflow) -> OpResult<i128> {
    if e == Elem::Bool {
        return Ok((v != 0.0) as i128);
    }
    integral(round_even(v), e, mode)
}

/// TRUNC: toward zero.
pub fn trunc_to_int(v: f64, e: Elem, mode: Overflow) -> OpResult<i128> {
    integral(v.trunc(), e, mode)
}

/// A whole real as a value of `e`: NaN and ±Inf fail in both modes (no integer stands for
/// them, and a made-up one would reach an actuator as a plausible number); a finite value
/// outside the range fails in fault mode and keeps its low bits (modulo 2^64, then the
/// type's width) in wrap mode, as integer conversions do.
fn integral(r: f64, e: Elem, mode: Overflow) -> OpResult<i128> {
    if !r.is_finite() {
        return Err(OpError::Conversion);
    }
    if r.abs() < 1.8e19 {
        let i = r as i128;
        if fits(i, e) {
            return Ok(i);
        }
    }
    match mode {
        Overflow::Fault => Err(OpError::Conversion),
        Overflow::Wrap => {
            // `%` of floats is exact, and so is a whole value below 2^64 as u64.
            let m = (r.abs() % 18_446_744_073_709_551_616.0) as u64;
            let bits = if r < 0.0 { m.wrapping_neg() } else { m };
            Ok(wrap(bits as i128, e))
        }
    }
}

const NS_PER_MS: i128 = 1_000_000;
const NS_PER_S: i128 = 1_000_000_000;

/// The integer a duration or date stands for in conversions: TIME and TOD in milliseconds,
/// LTIME in nanoseconds, DATE and DT in seconds.
fn time_units(e: Elem) -> i128 {
    match e {
        Elem::Time | Elem::Tod => NS_PER_MS,
        Elem::Date | Elem::Dt => NS_PER_S,
        _ => 1,
    }
}

fn is_time_like(e: Elem) -> bool {
    e.is_duration() || e.is_date()
}

/// Converts a scalar between elementary types.
pub fn convert_elem(v: &Value, from: Elem, to: Elem, mode: Overflow) -> OpResult<Value> {
    if from == to {
        return Ok(v.clone());
    }
    match v {
        // CHAR is Windows-1252, WCHAR UTF-16: between them a character keeps its meaning
        // ('?' where the code page lacks it), not its code.
        Value::Int(i) if from == Elem::Char && to == Elem::Wchar => {
            Ok(Value::Int(i128::from(widen(&[*i as u8])[0])))
        }
        Value::Int(i) if from == Elem::Wchar && to == Elem::Char => {
            Ok(Value::Int(i128::from(narrow(&[*i as u16])[0])))
        }
        Value::Int(i) => {
            let i = *i;
            if is_time_like(from) && is_time_like(to) {
                let ns = match (from, to) {
                    (Elem::Dt, Elem::Date) => i.div_euclid(NANOS_PER_DAY) * NANOS_PER_DAY,
                    (Elem::Dt, Elem::Tod) => i.rem_euclid(NANOS_PER_DAY),
                    _ => i,
                };
                return Ok(Value::Int(ns));
            }
            if is_time_like(from) {
                let units = i / time_units(from);
                if to.is_real() {
                    let f = i as f64 / time_units(from) as f64;
                    return Ok(Value::Real(real_result(f, to)));
                }
                return Ok(Value::Int(wrap(units, to)));
            }
            if is_time_like(to) {
                // 64-bit operands times at most 10^9 cannot leave i128.
                let ns = i * time_units(to);
                if !fits(ns, Elem::Lint) && mode == Overflow::Fault {
                    return Err(OpError::Conversion);
                }
                return Ok(Value::Int(wrap(ns, Elem::Lint)));
            }
            if to.is_real() {
                return Ok(Value::Real(real_result(i as f64, to)));
            }
            Ok(Value::Int(wrap(i, to)))
        }
        Value::Real(f) => {
            let f = *f;
            if to.is_real() {
                return Ok(Value::Real(real_result(f, to)));
            }
            if is_time_like(to) {
                let ns = round_even(f * time_units(to) as f64);
                return Ok(Value::Int(integral(ns, Elem::Lint, mode)?));
            }
            Ok(Value::Int(real_to_int(f, to, mode)?))
        }
        _ => Err(OpError::Conversion),
    }
}

/// The text a value converts to (`*_TO_STRING`): the standard's literal forms.
pub fn to_text(v: &Value, from: Elem) -> Vec<u8> {
    let s = match (v, from) {
        // A character is its text (CHAR_TO_STRING); NUL ends a string, so it is ''.
        (Value::Int(0), Elem::Char | Elem::Wchar) => return Vec::new(),
        (Value::Int(i), Elem::Char) => return vec![*i as u8],
        (Value::Int(i), Elem::Wchar) => return narrow(&[*i as u16]),
        (Value::Int(i), Elem::Bool) => if *i != 0 { "TRUE" } else { "FALSE" }.to_string(),
        (Value::Int(i), Elem::Time) => format!("T#{}", format_duration(*i)),
        (Value::Int(i), Elem::Ltime) => format!("LTIME#{}", format_duration(*i)),
        (Value::Int(i), Elem::Date) => format!("D#{}", format_date(*i)),
        (Value::Int(i), Elem::Tod) => format!("TOD#{}", format_tod(*i)),
        (Value::Int(i), Elem::Dt) => format!(
            "DT#{}-{}",
            format_date(*i),
            format_tod(i.rem_euclid(NANOS_PER_DAY))
        ),
        (Value::Int(i), _) => i.to_string(),
        (Value::Real(f), e) => format_real(*f, e),
        (Value::Str(s), _) => return s.clone(),
        _ => String::new(),
    };
    s.into_bytes()
}

/// A real as an IEC literal: `1.5`, `100.0`, `1.5E-07`.
pub fn format_real(f: f64, e: Elem) -> String {
    if !f.is_finite() {
        return f.to_string();
    }
    let s = if e == Elem::Real {
        format!("{:?}", f as f32)
    } else {
        format!("{f:?}")
    };
    // Rust writes 1e20 / 1.5e-7; IEC wants a digit after the point and an upper-case E.
    match s.split_once('e') {
        Some((m, x)) => {
            let m = if m.contains('.') {
                m.to_string()
            } else {
                format!("{m}.0")
            };
            format!("{m}E{x}")
        }
        None => s,
    }
}

/// `1h2m3s4ms`, `-250ms`, `0s`.
pub fn format_duration(ns: i128) -> String {
    if ns == 0 {
        return "0s".into();
    }
    let mut out = String::new();
    if ns < 0 {
        out.push('-');
    }
    let mut r = ns.unsigned_abs();
    for (unit, size) in [
        ("d", NANOS_PER_DAY as u128),
        ("h", 3_600_000_000_000),
        ("m", 60_000_000_000),
        ("s", 1_000_000_000),
        ("ms", 1_000_000),
        ("us", 1_000),
        ("ns", 1),
    ] {
        let q = r / size;
        if q > 0 {
            out.push_str(&format!("{q}{unit}"));
            r %= size;
        }
    }
    out
}

pub fn format_date(ns: i128) -> String {
    let days = ns.div_euclid(NANOS_PER_DAY) as i64;
    let (y, m, d) = lexer::civil_from_days(days);
    format!("{y:04}-{m:02}-{d:02}")
}

pub fn format_tod(ns: i128) -> String {
    let ns = ns.rem_euclid(NANOS_PER_DAY);
    let (s, frac) = (ns / NS_PER_S, ns % NS_PER_S);
    let (h, m, s) = (s / 3600, s / 60 % 60, s % 60);
    if frac == 0 {
        format!("{h:02}:{m:02}:{s:02}")
    } else {
        let f = format!("{frac:09}");
        format!("{h:02}:{m:02}:{s:02}.{}", f.trim_end_matches('0'))
    }
}

/// Reads a value of `to` from text (`STRING_TO_*`): the literal forms, with or without
/// their type prefix; surrounding spaces are ignored.
/// The WSTRING text of a value (`*_TO_WSTRING`): a WCHAR is its own unit, everything else
/// its STRING text.
pub fn to_wide_text(v: &Value, from: Elem) -> Vec<u16> {
    match (v, from) {
        (Value::Int(0), Elem::Wchar) => Vec::new(),
        (Value::Int(i), Elem::Wchar) => vec![*i as u16],
        _ => widen(&to_text(v, from)),
    }
}

/// `WSTRING_TO_*`: WCHAR is the first unit (0 for ""), every other type reads the text.
pub fn from_wide_text(w: &[u16], to: Elem) -> OpResult<Value> {
    match to {
        Elem::Wchar => Ok(Value::Int(i128::from(w.first().copied().unwrap_or(0)))),
        _ => from_text(&narrow(w), to),
    }
}

pub fn from_text(s: &[u8], to: Elem) -> OpResult<Value> {
    if to.is_char() {
        // STRING_TO_CHAR: the first character (0 for '').
        let b = s.first().copied().unwrap_or(0);
        let v = if to == Elem::Char {
            i128::from(b)
        } else {
            i128::from(widen(&[b])[0])
        };
        return Ok(Value::Int(v));
    }
    let text = std::str::from_utf8(s)
        .map_err(|_| OpError::Conversion)?
        .trim();
    let upper = text.to_ascii_uppercase();
    let body = match upper.split_once('#') {
        Some((prefix, rest))
            if Elem::from_name(prefix).is_some()
                || ["T", "LT", "D", "TOD", "DT"].contains(&prefix) =>
        {
            rest.to_string()
        }
        _ => upper.clone(),
    };
    match to {
        // Any text but TRUE (any case) and 1 is FALSE, as matiec and CODESYS convert it
        // (Beremiz's language test checks STRING_TO_BOOL('42') = FALSE).
        Elem::Bool => Ok(Value::Int(i128::from(matches!(
            body.as_str(),
            "TRUE" | "1"
        )))),
        Elem::Real | Elem::Lreal => {
            let f: f64 = body
                .replace('_', "")
                .parse()
                .map_err(|_| OpError::Conversion)?;
            // IEC 60559 has no literal for NaN or Inf: text that spells one (`nan`, `inf`),
            // or a number beyond the type's range, does not spell a REAL.
            let r = real_result(f, to);
            if !r.is_finite() {
                return Err(OpError::Conversion);
            }
            Ok(Value::Real(r))
        }
        Elem::Time | Elem::Ltime => lexer::parse_duration(&body)
            .map(Value::Int)
            .map_err(|_| OpError::Conversion),
        Elem::Date => lexer::parse_date(&body)
            .map(|d| Value::Int(d as i128 * NANOS_PER_DAY))
            .map_err(|_| OpError::Conversion),
        Elem::Tod => lexer::parse_tod(&body)
            .map(Value::Int)
            .map_err(|_| OpError::Conversion),
        Elem::Dt => lexer::parse_dt(&body)
            .map(Value::Int)
            .map_err(|_| OpError::Conversion),
        _ => {
            let (neg, digits) = match body.strip_prefix('-') {
                Some(d) => (true, d),
                None => (false, body.strip_prefix('+').unwrap_or(&body)),
            };
            let digits = digits.replace('_', "");
            let v = match digits.split_once('#') {
                Some((base, d)) => {
                    let radix: u32 = base.parse().map_err(|_| OpError::Conversion)?;
                    if ![2, 8, 16].contains(&radix) {
                        return Err(OpError::Conversion);
                    }
                    i128::from_str_radix(d, radix).map_err(|_| OpError::Conversion)?
                }
                None => digits.parse::<i128>().map_err(|_| OpError::Conversion)?,
            };
            let v = if neg { -v } else { v };
            if fits(v, to) {
                Ok(Value::Int(v))
            } else {
                Err(OpError::Conversion)
            }
        }
    }
}

/// Width mask of a bit string or integer type.
pub fn mask(e: Elem) -> u64 {
    match e.bits() {
        64 => u64::MAX,
        b => (1u64 << b) - 1,
    }
}

/// SHL, SHR, ROL, ROR on the bit pattern of `v` (its type's width). A count at least the
/// width shifts every bit out (0); a rotation turns by the count modulo the width. A negative
/// count is a fault in fault mode; in wrap mode it is read as unsigned, as CODESYS passes a
/// count (a BYTE or UDINT): past the width, so SHL and SHR give 0, and ROL by -1 is ROR by 1.
pub fn shift(
    kind: crate::ir::Builtin,
    v: i128,
    n: i128,
    e: Elem,
    mode: Overflow,
) -> OpResult<i128> {
    use crate::ir::Builtin::*;
    if n < 0 && mode == Overflow::Fault {
        return Err(OpError::Domain("a negative shift count"));
    }
    let bits = e.bits() as i128;
    let m = mask(e);
    let x = (v as u64) & m;
    let r = match kind {
        Shl => {
            if n >= bits || n < 0 {
                0
            } else {
                (x << n) & m
            }
        }
        Shr => {
            if n >= bits || n < 0 {
                0
            } else {
                x >> n
            }
        }
        Rol | Ror => {
            let k = n.rem_euclid(bits) as u32;
            if k == 0 {
                x
            } else {
                let b = bits as u32;
                let (l, r) = if kind == Rol { (k, b - k) } else { (b - k, k) };
                ((x << l) | (x >> r)) & m
            }
        }
        _ => x,
    };
    Ok(wrap(r as i128, e))
}

/// Positions of the string functions are 1-based; returns an error for one outside.
fn check_len(l: i128) -> OpResult<usize> {
    if l < 0 {
        return Err(OpError::Domain("a negative length"));
    }
    Ok(l.min(u32::MAX as i128) as usize)
}

/// STRING_TO_WSTRING: each Windows-1252 byte as its character's UTF-16 code unit.
pub fn widen(s: &[u8]) -> Vec<u16> {
    s.iter().map(|&b| lexer::cp1252_char(b) as u16).collect()
}

/// WSTRING_TO_STRING: each character as its Windows-1252 byte, `?` for the characters the
/// code page lacks (as TwinCAT converts); a surrogate pair is one character.
pub fn narrow(s: &[u16]) -> Vec<u8> {
    char::decode_utf16(s.iter().copied())
        .map(|c| c.ok().and_then(lexer::single_byte).unwrap_or(b'?'))
        .collect()
}

/// A WSTRING's text as UTF-8 (lone surrogates as U+FFFD), for messages and display.
pub fn wide_text(s: &[u16]) -> String {
    String::from_utf16_lossy(s)
}

pub fn left<T: Clone>(s: &[T], l: i128) -> OpResult<Vec<T>> {
    let l = check_len(l)?;
    Ok(s[..l.min(s.len())].to_vec())
}

pub fn right<T: Clone>(s: &[T], l: i128) -> OpResult<Vec<T>> {
    let l = check_len(l)?.min(s.len());
    Ok(s[s.len() - l..].to_vec())
}

pub fn mid<T: Clone>(s: &[T], l: i128, p: i128) -> OpResult<Vec<T>> {
    let l = check_len(l)?;
    if p < 1 || p > s.len() as i128 + 1 {
        return Err(OpError::Domain("a character position outside the string"));
    }
    let start = (p - 1) as usize;
    let end = (start + l).min(s.len());
    Ok(s[start..end].to_vec())
}

pub fn insert<T: Clone>(a: &[T], b: &[T], p: i128) -> OpResult<Vec<T>> {
    if p < 0 || p > a.len() as i128 {
        return Err(OpError::Domain("a character position outside the string"));
    }
    let p = p as usize;
    let mut out = a[..p].to_vec();
    out.extend_from_slice(b);
    out.extend_from_slice(&a[p..]);
    Ok(out)
}

pub fn delete<T: Clone>(s: &[T], l: i128, p: i128) -> OpResult<Vec<T>> {
    let l = check_len(l)?;
    if p < 1 || p > s.len() as i128 + 1 {
        return Err(OpError::Domain("a character position outside the string"));
    }
    let start = (p - 1) as usize;
    let end = (start + l).min(s.len());
    let mut out = s[..start].to_vec();
    out.extend_from_slice(&s[end..]);
    Ok(out)
}

pub fn replace<T: Clone>(a: &[T], b: &[T], l: i128, p: i128) -> OpResult<Vec<T>> {
    let l = check_len(l)?;
    if p < 1 || p > a.len() as i128 + 1 {
        return Err(OpError::Domain("a character position outside the string"));
    }
    let start = (p - 1) as usize;
    let end = (start + l).min(a.len());
    let mut out = a[..start].to_vec();
    out.extend_from_slice(b);
    out.extend_from_slice(&a[end..]);
    Ok(out)
}

pub fn find<T: PartialEq>(a: &[T], b: &[T]) -> i128 {
    if b.is_empty() || b.len() > a.len() {
        return 0;
    }
    a.windows(b.len())
        .position(|w| w == b)
        .map_or(0, |i| i as i128 + 1)
}

/// The real functions of one argument, by IEC 60559: outside its domain a function gives
/// NaN (SQRT(-1.0), ASIN(2.0)) or -Inf (LN(0.0)), as C's `<math.h>` does.
pub fn real_fn(b: crate::ir::Builtin, x: f64, e: Elem) -> f64 {
    use crate::ir::Builtin::*;
    let r = match b {
        Sqrt => x.sqrt(),
        Ln => x.ln(),
        Log => x.log10(),
        Exp => x.exp(),
        Sin => x.sin(),
        Cos => x.cos(),
        Tan => x.tan(),
        Asin => x.asin(),
        Acos => x.acos(),
        Atan => x.atan(),
        Abs => x.abs(),
        _ => x,
    };
    real_result(r, e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ir::Builtin;

    #[test]
    fn bcd_digits() {
        assert_eq!(from_bcd(0x1234, Elem::Int), Ok(1234));
        assert_eq!(from_bcd(0x99, Elem::Usint), Ok(99));
        assert_eq!(from_bcd(0, Elem::Int), Ok(0));
        assert_eq!(
            from_bcd(0x9999_9999_9999_9999, Elem::Ulint),
            Ok(9_999_999_999_999_999)
        );
        // A group above 9, or a number the target cannot hold.
        assert_eq!(from_bcd(0x12A4, Elem::Int), Err(OpError::Conversion));
        assert_eq!(from_bcd(0x0010_0000, Elem::Int), Err(OpError::Conversion));
        assert_eq!(to_bcd(1234, Elem::Word), Ok(0x1234));
        assert_eq!(to_bcd(99, Elem::Byte), Ok(0x99));
        assert_eq!(to_bcd(0, Elem::Byte), Ok(0));
        assert_eq!(to_bcd(100, Elem::Byte), Err(OpError::Conversion));
        assert_eq!(to_bcd(-1, Elem::Word), Err(OpError::Conversion));
        assert_eq!(
            to_bcd(9_999_999_999_999_999, Elem::Lword),
            Ok(0x9999_9999_9999_9999)
        );
        assert_eq!(
            to_bcd(10_000_000_000_000_000, Elem::Lword),
            Err(OpError::Conversion)
        );
    }

    #[test]
    fn integer_rules() {
        assert_eq!(
            int_binary(BinaryOp::Add, 127, 1, Elem::Sint),
            Err(OpError::Overflow)
        );
        assert_eq!(
            int_binary(BinaryOp::Sub, 0, 1, Elem::Usint),
            Err(OpError::Overflow)
        );
        assert_eq!(
            int_binary(BinaryOp::Div, -128, -1, Elem::Sint),
            Err(OpError::Overflow)
        );
        assert_eq!(
            int_binary(BinaryOp::Div, 7, 0, Elem::Int),
            Err(OpError::DivisionByZero)
        );
        assert_eq!(int_binary(BinaryOp::Mod, 7, 0, Elem::Int), Ok(0));
        assert_eq!(int_binary(BinaryOp::Mod, -7, 2, Elem::Int), Ok(-1));
        assert_eq!(int_binary(BinaryOp::Div, -7, 2, Elem::Int), Ok(-3));
        assert_eq!(
            int_binary(BinaryOp::Mul, u64::MAX as i128, 2, Elem::Ulint),
            Err(OpError::Overflow)
        );
    }

    #[test]
    fn rounding_is_half_to_even() {
        let r = |v| real_to_int(v, Elem::Int, Overflow::Fault).unwrap();
        assert_eq!(
            [
                r(1.6),
                r(-1.6),
                r(1.5),
                r(-1.5),
                r(1.4),
                r(-1.4),
                r(2.5),
                r(-2.5)
            ],
            [2, -2, 2, -2, 1, -1, 2, -2]
        );
        assert_eq!(
            real_to_int(40000.0, Elem::Int, Overflow::Fault),
            Err(OpError::Conversion)
        );
        assert_eq!(trunc_to_int(-1.6, Elem::Int, Overflow::Fault), Ok(-1));
    }

    #[test]
    fn conversions() {
        let c = |v: Value, f, t| convert_elem(&v, f, t, Overflow::Fault).unwrap();
        assert_eq!(c(Value::Int(300), Elem::Int, Elem::Sint), Value::Int(44));
        assert_eq!(c(Value::Int(-1), Elem::Dint, Elem::Word), Value::Int(65535));
        assert_eq!(
            c(Value::Int(1_500_000_000), Elem::Time, Elem::Dint),
            Value::Int(1500)
        );
        assert_eq!(
            c(Value::Int(1500), Elem::Dint, Elem::Time),
            Value::Int(1_500_000_000)
        );
        assert_eq!(c(Value::Int(2), Elem::Int, Elem::Bool), Value::Int(1));
        assert_eq!(c(Value::Real(2.5), Elem::Real, Elem::Int), Value::Int(2));
        assert_eq!(
            c(Value::Int(NANOS_PER_DAY + 5), Elem::Dt, Elem::Tod),
            Value::Int(5)
        );
    }

    #[test]
    fn text() {
        assert_eq!(to_text(&Value::Int(90_000_000_000), Elem::Time), b"T#1m30s");
        assert_eq!(to_text(&Value::Real(1.5), Elem::Real), b"1.5");
        assert_eq!(to_text(&Value::Real(100.0), Elem::Lreal), b"100.0");
        assert_eq!(to_text(&Value::Real(1e20), Elem::Lreal), b"1.0E20");
        assert_eq!(to_text(&Value::Int(1), Elem::Bool), b"TRUE");
        assert_eq!(from_text(b" 42 ", Elem::Int), Ok(Value::Int(42)));
        assert_eq!(from_text(b"16#FF", Elem::Word), Ok(Value::Int(255)));
        assert_eq!(from_text(b"INT#-5", Elem::Int), Ok(Value::Int(-5)));
        assert_eq!(from_text(b"x", Elem::Int), Err(OpError::Conversion));
        assert_eq!(
            from_text(b"T#1s", Elem::Time),
            Ok(Value::Int(1_000_000_000))
        );
        assert_eq!(from_text(b"300", Elem::Sint), Err(OpError::Conversion));
    }

    #[test]
    fn strings_and_bits() {
        assert_eq!(insert(b"ABC", b"XY", 2).unwrap(), b"ABXYC");
        assert_eq!(delete(b"ABXYC", 2, 3).unwrap(), b"ABC");
        assert_eq!(replace(b"ABCDE", b"X", 2, 3).unwrap(), b"ABXE");
        assert_eq!(find(b"ABCBC", b"BC"), 2);
        assert_eq!(mid(b"ABCDE", 2, 2).unwrap(), b"BC");
        assert!(mid(b"ABC", 1, 0).is_err());
        assert_eq!(left(b"ABC", 5).unwrap(), b"ABC");
        assert_eq!(right(b"ABC", 2).unwrap(), b"BC");
        assert_eq!(
            shift(Builtin::Rol, 0x81, 1, Elem::Byte, Overflow::Fault),
            Ok(0x03)
        );
        assert_eq!(
            shift(Builtin::Ror, 0x81, 1, Elem::Byte, Overflow::Fault),
            Ok(0xC0)
        );
        assert_eq!(
            shift(Builtin::Shl, 0x81, 1, Elem::Byte, Overflow::Fault),
            Ok(0x02)
        );
        assert_eq!(
            shift(Builtin::Shr, 0x81, 9, Elem::Byte, Overflow::Fault),
            Ok(0)
        );
    }

    #[test]
    fn wrap_mode_keeps_the_low_bits() {
        let w = |op, a, b, e| int_binary_in(op, a, b, e, Overflow::Wrap);
        assert_eq!(w(BinaryOp::Add, 127, 1, Elem::Sint), Ok(-128));
        assert_eq!(w(BinaryOp::Sub, 0, 1, Elem::Usint), Ok(255));
        assert_eq!(w(BinaryOp::Sub, 0, 1, Elem::Dword), Ok(0xFFFF_FFFF));
        assert_eq!(w(BinaryOp::Div, -128, -1, Elem::Sint), Ok(-128));
        assert_eq!(w(BinaryOp::Mul, 1 << 30, 4, Elem::Dint), Ok(0));
        assert_eq!(
            w(
                BinaryOp::Mul,
                u64::MAX as i128,
                u64::MAX as i128,
                Elem::Ulint
            ),
            Ok(1)
        );
        assert_eq!(
            w(BinaryOp::Add, i64::MAX as i128, 1, Elem::Time),
            Ok(i64::MIN as i128)
        );
        // Division by zero stays a fault in both modes.
        assert_eq!(
            w(BinaryOp::Div, 7, 0, Elem::Int),
            Err(OpError::DivisionByZero)
        );
        assert_eq!(
            int_binary_in(BinaryOp::Add, 127, 1, Elem::Sint, Overflow::Fault),
            Err(OpError::Overflow)
        );
    }

    #[test]
    fn real_to_integers_one_rule_for_every_target() {
        use Overflow::*;
        // Unsigned and bit-string targets alike: a fault in fault mode, the low bits of the
        // rounded value in wrap mode.
        for e in [Elem::Udint, Elem::Dword] {
            assert_eq!(real_to_int(-1.75, e, Fault), Err(OpError::Conversion));
            assert_eq!(real_to_int(-1.75, e, Wrap), Ok(0xFFFF_FFFE));
        }
        assert_eq!(real_to_int(40000.0, Elem::Int, Wrap), Ok(-25536));
        assert_eq!(real_to_int(-2.5, Elem::Usint, Wrap), Ok(254));
        assert_eq!(
            real_to_int(1e19, Elem::Lint, Wrap),
            Ok(1e19 as u64 as i64 as i128)
        );
        let two64 = 2f64.powi(64);
        assert_eq!(real_to_int(two64 + 4096.0, Elem::Ulint, Wrap), Ok(4096));
        assert_eq!(
            real_to_int(-two64 - 4096.0, Elem::Ulint, Wrap),
            Ok(u64::MAX as i128 - 4095)
        );
        assert_eq!(trunc_to_int(-1.75, Elem::Uint, Wrap), Ok(65535));
        for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            for mode in [Wrap, Fault] {
                assert_eq!(
                    real_to_int(bad, Elem::Dword, mode),
                    Err(OpError::Conversion)
                );
                assert_eq!(
                    trunc_to_int(bad, Elem::Dint, mode),
                    Err(OpError::Conversion)
                );
            }
        }
        assert_eq!(
            convert_elem(&Value::Real(1e300), Elem::Lreal, Elem::Time, Fault),
            Err(OpError::Conversion)
        );
        assert!(convert_elem(&Value::Real(1e300), Elem::Lreal, Elem::Time, Wrap).is_ok());
    }

    #[test]
    fn shift_counts_past_the_width_or_negative() {
        use Builtin::*;
        use Overflow::*;
        for mode in [Wrap, Fault] {
            assert_eq!(shift(Shl, 0x81, 8, Elem::Byte, mode), Ok(0));
            assert_eq!(shift(Shr, 0x81, 200, Elem::Byte, mode), Ok(0));
            assert_eq!(shift(Rol, 0x81, 9, Elem::Byte, mode), Ok(0x03));
            assert_eq!(shift(Ror, 0x8001, 17, Elem::Word, mode), Ok(0xC000));
        }
        assert_eq!(
            shift(Shl, 1, -1, Elem::Dword, Fault),
            Err(OpError::Domain("a negative shift count"))
        );
        assert_eq!(shift(Shl, 1, -1, Elem::Dword, Wrap), Ok(0));
        assert_eq!(shift(Shr, -1, -3, Elem::Dint, Wrap), Ok(0));
        assert_eq!(shift(Rol, 0x81, -1, Elem::Byte, Wrap), Ok(0xC0));
        assert_eq!(shift(Ror, 0x81, -1, Elem::Byte, Wrap), Ok(0x03));
    }

    #[test]
    fn overflow_names() {
        assert_eq!(Overflow::parse("Fault"), Some(Overflow::Fault));
        assert_eq!(Overflow::parse("wrap"), Some(Overflow::Wrap));
        assert_eq!(Overflow::parse("saturate"), None);
        assert_eq!(Overflow::default().name(), "wrap");
    }
}
