//! Exact durations: IEC 61131-3 `TIME` literals (`T#1m30s`, `t#500ms`) and decimal seconds
//! (`1.5`), parsed without floating point so simulated time never drifts.

use std::fmt::Write as _;
use std::time::Duration;

/// Why a duration did not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TimeError {
    #[error("empty duration")]
    Empty,
    #[error("`{0}` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)")]
    Syntax(String),
    #[error("`{0}` has a unit twice or units out of order (d, h, m, s, ms, us, ns)")]
    UnitOrder(String),
    #[error("`{0}` is too large: durations go up to about 584 years")]
    Overflow(String),
    #[error("`{0}` is finer than a nanosecond")]
    TooFine(String),
}

const UNITS: [(&str, u128); 7] = [
    ("d", 86_400_000_000_000),
    ("h", 3_600_000_000_000),
    ("ms", 1_000_000),
    ("us", 1_000),
    ("ns", 1),
    ("m", 60_000_000_000),
    ("s", 1_000_000_000),
];

/// The rank of a unit from the largest (0) to the smallest, for checking their order.
fn rank(unit: &str) -> usize {
    match unit {
        "d" => 0,
        "h" => 1,
        "m" => 2,
        "s" => 3,
        "ms" => 4,
        "us" => 5,
        _ => 6,
    }
}

/// Parses an IEC `TIME` literal (`T#…`, `TIME#…`, any case, `_` separators, an optional
/// fraction on the last component), the same without its prefix (`10ms`, `1m30s`), or plain
/// decimal seconds (`0.01`).
pub fn parse_duration(text: &str) -> Result<Duration, TimeError> {
    let t = text.trim();
    if t.is_empty() {
        return Err(TimeError::Empty);
    }
    let lower = t.to_ascii_lowercase();
    let body = lower
        .strip_prefix("time#")
        .or_else(|| lower.strip_prefix("t#"))
        .map(|b| b.replace('_', ""));
    let nanos = match body {
        Some(body) => iec_nanos(&body, text)?,
        None if lower.ends_with(|c: char| c.is_ascii_alphabetic()) => {
            iec_nanos(&lower.replace('_', ""), text)?
        }
        None => decimal_nanos(&lower, 1_000_000_000, text)?,
    };
    let secs =
        u64::try_from(nanos / 1_000_000_000).map_err(|_| TimeError::Overflow(text.into()))?;
    Ok(Duration::new(secs, (nanos % 1_000_000_000) as u32))
}

fn iec_nanos(body: &str, original: &str) -> Result<u128, TimeError> {
    if body.is_empty() {
        return Err(TimeError::Syntax(original.into()));
    }
    let mut rest = body;
    let mut total: u128 = 0;
    let mut last_rank: Option<usize> = None;
    let mut saw_fraction = false;
    while !rest.is_empty() {
        let num_len = rest
            .find(|c: char| !(c.is_ascii_digit() || c == '.'))
            .ok_or_else(|| TimeError::Syntax(original.into()))?;
        if num_len == 0 || saw_fraction {
            // A fraction is only allowed on the last component (IEC 61131-3 §6.3.3).
            return Err(TimeError::Syntax(original.into()));
        }
        let (num, after) = rest.split_at(num_len);
        let (unit, scale) = UNITS
            .iter()
            .find(|(u, _)| after.starts_with(u))
            .ok_or_else(|| TimeError::Syntax(original.into()))?;
        let r = rank(unit);
        if last_rank.is_some_and(|l| r <= l) {
            return Err(TimeError::UnitOrder(original.into()));
        }
        last_rank = Some(r);
        saw_fraction = num.contains('.');
        total = total
            .checked_add(decimal_nanos(num, *scale, original)?)
            .ok_or_else(|| TimeError::Overflow(original.into()))?;
        rest = &after[unit.len()..];
    }
    Ok(total)
}

/// `digits[.digits]` times `scale` nanoseconds, exactly.
fn decimal_nanos(num: &str, scale: u128, original: &str) -> Result<u128, TimeError> {
    let (int, frac) = num.split_once('.').unwrap_or((num, ""));
    let digits_ok = |s: &str| s.bytes().all(|b| b.is_ascii_digit());
    if (int.is_empty() && frac.is_empty()) || !digits_ok(int) || !digits_ok(frac) {
        return Err(TimeError::Syntax(original.into()));
    }
    let overflow = || TimeError::Overflow(original.into());
    let int_val: u128 = if int.is_empty() {
        0
    } else {
        int.parse().map_err(|_| overflow())?
    };
    let mut total = int_val.checked_mul(scale).ok_or_else(overflow)?;
    let mut place = scale;
    for b in frac.bytes() {
        let d = u128::from(b - b'0');
        if place % 10 != 0 {
            if d != 0 || frac.bytes().skip_while(|&c| c != b).any(|c| c != b'0') {
                return Err(TimeError::TooFine(original.into()));
            }
            break;
        }
        place /= 10;
        total = total.checked_add(d * place).ok_or_else(overflow)?;
    }
    if total > u128::from(u64::MAX) * 1_000_000_000 {
        return Err(overflow());
    }
    Ok(total)
}

/// Seconds with as many decimals as needed and no trailing zeros: `0.01`, `1.5`, `2`.
pub fn format_seconds(d: Duration) -> String {
    let mut s = d.as_secs().to_string();
    let nanos = d.subsec_nanos();
    if nanos != 0 {
        let frac = format!("{nanos:09}");
        let _ = write!(s, ".{}", frac.trim_end_matches('0'));
    }
    s
}

/// The shortest IEC literal for `d`: `T#500ms`, `T#1s500ms`, `T#0s`.
pub fn format_iec(d: Duration) -> String {
    let mut nanos = d.as_nanos();
    if nanos == 0 {
        return "T#0s".to_string();
    }
    let mut out = String::from("T#");
    for (unit, scale) in [
        ("d", 86_400_000_000_000u128),
        ("h", 3_600_000_000_000),
        ("m", 60_000_000_000),
        ("s", 1_000_000_000),
        ("ms", 1_000_000),
        ("us", 1_000),
        ("ns", 1),
    ] {
        let n = nanos / scale;
        if n > 0 {
            let _ = write!(out, "{n}{unit}");
            nanos %= scale;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(input: &str, expect_nanos: u128) {
        assert_eq!(
            parse_duration(input).unwrap().as_nanos(),
            expect_nanos,
            "{input}"
        );
    }

    #[test]
    fn parses_seconds_and_iec_literals() {
        check("0", 0);
        check("1.5", 1_500_000_000);
        check(".25", 250_000_000);
        check("0.010", 10_000_000);
        check("T#500ms", 500_000_000);
        check("t#1.5s", 1_500_000_000);
        check("TIME#1m30s", 90_000_000_000);
        check("T#1h_2m", 3_720_000_000_000);
        check("T#1d2h3m4s5ms6us7ns", 93_784_005_006_007);
        check("T#0.5ms", 500_000);
        check("10ms", 10_000_000);
        check("1m30s", 90_000_000_000);
        check("2.5s", 2_500_000_000);
    }

    #[test]
    fn rejects_bad_durations() {
        for bad in [
            "",
            "abc",
            "T#",
            "T#5",
            "T#1s1m",
            "T#1s1s",
            "1.2.3",
            "T#1.5s3ms",
            "-1",
            "T#5x",
            "ms",
            "5 s",
        ] {
            assert!(parse_duration(bad).is_err(), "{bad:?} should not parse");
        }
        assert!(matches!(
            parse_duration("0.0000000001"),
            Err(TimeError::TooFine(_))
        ));
        assert!(matches!(
            parse_duration("T#99999999999999999999999d"),
            Err(TimeError::Overflow(_))
        ));
    }

    #[test]
    fn formats_round_trip() {
        for ns in [
            0u64,
            1,
            10_000_000,
            500_000_000,
            1_500_000_000,
            93_784_005_006_007,
        ] {
            let d = Duration::from_nanos(ns);
            assert_eq!(parse_duration(&format_iec(d)).unwrap(), d);
            assert_eq!(parse_duration(&format_seconds(d)).unwrap(), d);
        }
        assert_eq!(format_seconds(Duration::from_millis(10)), "0.01");
        assert_eq!(format_iec(Duration::from_millis(1500)), "T#1s500ms");
    }
}
