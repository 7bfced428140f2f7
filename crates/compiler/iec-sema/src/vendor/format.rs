//! PCWorx's `X_TO_STRING(value, format)`: the value written by a C `printf` format (PCWorx's
//! runtime formats with C's sprintf; OSCAT writes `'%02X'`, `'%c'`, `'%u'`, `'%02dm'`).
//! The subset: flags `- + space 0 #`, a width, a precision, length letters (`h l ll L`,
//! ignored: the value's own type decides), conversions `d i u x X o c s f F e E g G %`.
//! Anything else (`%*d`, `%n`, `%k`) is copied as it is written, as C libraries print an
//! unknown conversion. Nothing here can fail or overflow: the caller truncates the text to
//! its string's capacity.

use crate::ops;
use crate::types::Elem;
use crate::value::Value;

#[derive(Default)]
struct Spec {
    left: bool,
    plus: bool,
    space: bool,
    zero: bool,
    alt: bool,
    width: usize,
    precision: Option<usize>,
}

/// `value` (of type `e`) written by the C format `fmt`.
pub fn printf(fmt: &[u8], value: &Value, e: Elem) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < fmt.len() {
        if fmt[i] != b'%' {
            out.push(fmt[i]);
            i += 1;
            continue;
        }
        let start = i;
        i += 1;
        let mut spec = Spec::default();
        while let Some(&c) = fmt.get(i) {
            match c {
                b'-' => spec.left = true,
                b'+' => spec.plus = true,
                b' ' => spec.space = true,
                b'0' => spec.zero = true,
                b'#' => spec.alt = true,
                _ => break,
            }
            i += 1;
        }
        spec.width = digits(fmt, &mut i).unwrap_or(0);
        if fmt.get(i) == Some(&b'.') {
            i += 1;
            spec.precision = Some(digits(fmt, &mut i).unwrap_or(0));
        }
        while matches!(
            fmt.get(i),
            Some(b'h' | b'l' | b'L' | b'q' | b'j' | b'z' | b't')
        ) {
            i += 1;
        }
        let Some(&conv) = fmt.get(i) else {
            out.extend_from_slice(&fmt[start..]);
            break;
        };
        i += 1;
        match conversion(conv, &spec, value, e) {
            Some(text) => out.extend(text),
            None => out.extend_from_slice(&fmt[start..i]),
        }
    }
    out
}

/// A run of decimal digits (at most 4 kept: a width beyond any string is pointless).
fn digits(fmt: &[u8], i: &mut usize) -> Option<usize> {
    let start = *i;
    let mut n: usize = 0;
    while let Some(d) = fmt.get(*i).filter(|c| c.is_ascii_digit()) {
        n = (n * 10 + usize::from(d - b'0')).min(9_999);
        *i += 1;
    }
    (*i > start).then_some(n)
}

/// The value as a signed integer: reals truncated toward zero (saturating, NaN 0), durations
/// and dates in the units of TIME_TO_LINT (milliseconds, seconds).
fn as_int(v: &Value, e: Elem) -> i128 {
    match v {
        Value::Int(i) if e.is_duration() || e.is_date() => {
            match ops::convert_elem(v, e, Elem::Lint, ops::Overflow::Wrap) {
                Ok(Value::Int(x)) => x,
                _ => *i,
            }
        }
        Value::Int(i) => *i,
        Value::Real(f) => *f as i64 as i128,
        _ => 0,
    }
}

/// The value as C's unsigned conversions see it: smaller integers promoted to 32 bits (so
/// INT#-1 is 4294967295, as a C `int` passed to `%u`), 64-bit ones kept.
fn as_unsigned(v: &Value, e: Elem) -> u128 {
    let i = as_int(v, e);
    let bits = if e.is_real() { 64 } else { e.bits().max(32) };
    (i as u128) & ((1u128 << bits) - 1)
}

fn as_real(v: &Value, e: Elem) -> f64 {
    match v {
        Value::Real(f) => *f,
        _ => as_int(v, e) as f64,
    }
}

fn conversion(conv: u8, spec: &Spec, v: &Value, e: Elem) -> Option<Vec<u8>> {
    let (sign, body, zero_ok): (&str, Vec<u8>, bool) = match conv {
        b'%' => return Some(b"%".to_vec()),
        b'd' | b'i' => {
            let n = as_int(v, e);
            let digits = min_digits(n.unsigned_abs().to_string(), spec.precision);
            (
                sign_of(n < 0, spec),
                digits.into_bytes(),
                spec.precision.is_none(),
            )
        }
        b'u' | b'x' | b'X' | b'o' => {
            let n = as_unsigned(v, e);
            let text = match conv {
                b'u' => n.to_string(),
                b'x' => format!("{n:x}"),
                b'X' => format!("{n:X}"),
                _ => format!("{n:o}"),
            };
            let mut text = min_digits(text, spec.precision);
            let prefix = match conv {
                b'x' if spec.alt && n != 0 => "0x",
                b'X' if spec.alt && n != 0 => "0X",
                b'o' if spec.alt && !text.starts_with('0') => "0",
                _ => "",
            };
            text.insert_str(0, prefix);
            ("", text.into_bytes(), spec.precision.is_none())
        }
        b'c' => ("", vec![as_int(v, e) as u8], false),
        b's' => {
            let mut text = ops::to_text(v, e);
            if let Some(p) = spec.precision {
                text.truncate(p);
            }
            ("", text, false)
        }
        b'f' | b'F' | b'e' | b'E' | b'g' | b'G' => {
            let x = as_real(v, e);
            let text = real(conv, x.abs(), spec);
            let finite = x.is_finite();
            (
                sign_of(x.is_sign_negative() && !x.is_nan(), spec),
                text.into_bytes(),
                finite,
            )
        }
        _ => return None,
    };
    Some(pad(sign, body, spec, zero_ok))
}

fn sign_of(negative: bool, spec: &Spec) -> &'static str {
    if negative {
        "-"
    } else if spec.plus {
        "+"
    } else if spec.space {
        " "
    } else {
        ""
    }
}

/// At least `precision` digits (leading zeros); precision 0 writes 0 as nothing, as C does.
fn min_digits(text: String, precision: Option<usize>) -> String {
    match precision {
        Some(0) if text == "0" => String::new(),
        Some(p) if text.len() < p => format!("{}{text}", "0".repeat(p - text.len())),
        _ => text,
    }
}

/// The sign and body in the field's width: left-justified, zero-filled after the sign
/// (`zero_ok`: a conversion where `0` applies), or right-justified with spaces.
fn pad(sign: &str, body: Vec<u8>, spec: &Spec, zero_ok: bool) -> Vec<u8> {
    let len = sign.len() + body.len();
    let fill = spec.width.saturating_sub(len);
    let mut out = Vec::with_capacity(len + fill);
    if spec.left {
        out.extend_from_slice(sign.as_bytes());
        out.extend(body);
        out.extend(std::iter::repeat_n(b' ', fill));
    } else if spec.zero && zero_ok {
        out.extend_from_slice(sign.as_bytes());
        out.extend(std::iter::repeat_n(b'0', fill));
        out.extend(body);
    } else {
        out.extend(std::iter::repeat_n(b' ', fill));
        out.extend_from_slice(sign.as_bytes());
        out.extend(body);
    }
    out
}

/// A non-negative real by `%f`, `%e` or `%g` (upper-case letters for `F E G`).
fn real(conv: u8, x: f64, spec: &Spec) -> String {
    let upper = conv.is_ascii_uppercase();
    if !x.is_finite() {
        let s = if x.is_nan() { "nan" } else { "inf" };
        return if upper { s.to_uppercase() } else { s.into() };
    }
    let p = spec.precision.unwrap_or(6).min(60);
    let s = match conv.to_ascii_lowercase() {
        b'f' => fixed(x, p, spec.alt),
        b'e' => exponent(x, p, spec.alt),
        _ => {
            // C's %g: the style of %e's exponent X with precision P (0 counts as 1): fixed
            // with P-1-X decimals when P > X >= -4, else exponent; trailing zeros removed
            // unless `#`.
            let p = p.max(1);
            let x_exp = exponent_of(x, p - 1);
            let s = if x_exp >= -4 && x_exp < p as i32 {
                fixed(x, (p as i32 - 1 - x_exp) as usize, spec.alt)
            } else {
                exponent(x, p - 1, spec.alt)
            };
            if spec.alt {
                s
            } else {
                strip_zeros(&s)
            }
        }
    };
    if upper {
        s.to_uppercase()
    } else {
        s
    }
}

fn fixed(x: f64, p: usize, alt: bool) -> String {
    let s = format!("{x:.p$}");
    if alt && p == 0 {
        s + "."
    } else {
        s
    }
}

/// The decimal exponent of `x` once rounded to `p` decimals in exponent form.
fn exponent_of(x: f64, p: usize) -> i32 {
    let s = format!("{x:.p$e}");
    s.split_once('e')
        .and_then(|(_, e)| e.parse().ok())
        .unwrap_or(0)
}

/// `d.ddde+XX`: C writes the exponent's sign and at least two digits.
fn exponent(x: f64, p: usize, alt: bool) -> String {
    let s = format!("{x:.p$e}");
    let (mantissa, exp) = s.split_once('e').unwrap_or((&s, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    let dot = if alt && p == 0 { "." } else { "" };
    format!(
        "{mantissa}{dot}e{}{:02}",
        if exp < 0 { '-' } else { '+' },
        exp.unsigned_abs()
    )
}

/// `1.500000` → `1.5`, `2.000e+03` → `2e+03`.
fn strip_zeros(s: &str) -> String {
    let (mantissa, exp) = match s.find('e') {
        Some(i) => (&s[..i], &s[i..]),
        None => (s, ""),
    };
    let mantissa = if mantissa.contains('.') {
        mantissa.trim_end_matches('0').trim_end_matches('.')
    } else {
        mantissa
    };
    format!("{mantissa}{exp}")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(fmt: &str, v: Value, e: Elem) -> String {
        String::from_utf8(printf(fmt.as_bytes(), &v, e)).unwrap()
    }

    fn i(fmt: &str, n: i128, e: Elem) -> String {
        f(fmt, Value::Int(n), e)
    }

    #[test]
    fn integers_as_c_writes_them() {
        assert_eq!(i("%02X", 10, Elem::Byte), "0A");
        assert_eq!(i("%02X", 255, Elem::Byte), "FF");
        assert_eq!(i("%x", 255, Elem::Byte), "ff");
        assert_eq!(i("%#x", 255, Elem::Byte), "0xff");
        assert_eq!(i("%#o", 8, Elem::Byte), "010");
        assert_eq!(i("%o", 8, Elem::Byte), "10");
        assert_eq!(i("%c", 65, Elem::Byte), "A");
        assert_eq!(i("%u", 4_000_000_000, Elem::Dword), "4000000000");
        assert_eq!(i("%u", -1, Elem::Int), "4294967295");
        assert_eq!(i("%u", -1, Elem::Lint), "18446744073709551615");
        assert_eq!(i("%d", -42, Elem::Int), "-42");
        assert_eq!(i("%5d|", -42, Elem::Int), "  -42|");
        assert_eq!(i("%-5d|", 42, Elem::Int), "42   |");
        assert_eq!(i("%05d", -42, Elem::Int), "-0042");
        assert_eq!(i("%+d", 42, Elem::Int), "+42");
        assert_eq!(i("% d", 42, Elem::Int), " 42");
        assert_eq!(i("%.3d", 7, Elem::Int), "007");
        assert_eq!(i("%06.3d", 7, Elem::Int), "   007");
        assert_eq!(i("%.0d", 0, Elem::Int), "");
        assert_eq!(i("%ld", 7, Elem::Dint), "7");
        // Text around the conversion, as OSCAT's TOD_TO_STRING writes it.
        assert_eq!(i("%02dm", 5, Elem::Int), "05m");
        assert_eq!(i("%02us", 7, Elem::Udint), "07s");
        assert_eq!(i("100%%", 0, Elem::Int), "100%");
    }

    #[test]
    fn reals_as_c_writes_them() {
        let r = |fmt: &str, x: f64| f(fmt, Value::Real(x), Elem::Lreal);
        assert_eq!(r("%f", 1.5), "1.500000");
        assert_eq!(r("%.2f", 2.675), "2.67"); // 2.675 is 2.67499999… in binary, as in C
        assert_eq!(r("%8.3f|", -3.25159), "  -3.252|");
        assert_eq!(r("%08.3f", -3.25159), "-003.252");
        assert_eq!(r("%.0f", 2.5), "2");
        assert_eq!(r("%#.0f", 3.0), "3.");
        assert_eq!(r("%e", 12345.678), "1.234568e+04");
        assert_eq!(r("%E", 0.000123), "1.230000E-04");
        assert_eq!(r("%.2e", 0.0), "0.00e+00");
        assert_eq!(r("%g", 100000.0), "100000");
        assert_eq!(r("%g", 1000000.0), "1e+06");
        assert_eq!(r("%g", 0.0001), "0.0001");
        assert_eq!(r("%g", 0.00001), "1e-05");
        assert_eq!(r("%g", 1.5), "1.5");
        assert_eq!(r("%G", 1.0e-10), "1E-10");
        assert_eq!(r("%.3g", 3.25159), "3.25");
        assert_eq!(r("%g", 0.0), "0");
        assert_eq!(r("%f", f64::INFINITY), "inf");
        assert_eq!(r("%F", f64::NEG_INFINITY), "-INF");
        assert_eq!(r("%5.1f", f64::NAN), "  nan");
        // An integer by a real conversion, a real by an integer one (truncated).
        assert_eq!(i("%.1f", 3, Elem::Int), "3.0");
        assert_eq!(r("%d", -2.9), "-2");
    }

    #[test]
    fn strings_times_and_what_is_not_a_conversion() {
        assert_eq!(i("%s", 12, Elem::Int), "12");
        assert_eq!(i("[%4s]", 1, Elem::Bool), "[TRUE]");
        assert_eq!(i("%.2s", 1, Elem::Bool), "TR");
        assert_eq!(f("%s!", Value::Str(b"abc".to_vec()), Elem::Int), "abc!");
        // TIME by %d: milliseconds, as TIME_TO_DINT gives them.
        assert_eq!(i("%d ms", 1_500_000_000, Elem::Time), "1500 ms");
        assert_eq!(i("%k%", 1, Elem::Int), "%k%");
        assert_eq!(i("%*d", 1, Elem::Int), "%*d");
        assert_eq!(i("no format", 1, Elem::Int), "no format");
        assert_eq!(i("%99999999999d", 1, Elem::Int).len(), 9_999);
    }
}
