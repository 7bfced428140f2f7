//! The bodies of duration and date literals (`T#…`, `D#…`, `TOD#…`, `DT#…`) as numbers:
//! nanoseconds, or days since 1970-01-01 on the calendar of petriplc-calendar.

use petriplc_calendar::days_in_month;
pub use petriplc_calendar::{civil_from_days, days_from_civil};

pub const NANOS_PER_DAY: i128 = 86_400_000_000_000;

/// `1d2h3m4s5ms6us7ns`, `1.5s`, `-250ms`, `1h_30m`: nanoseconds.
pub fn parse_duration(body: &str) -> Result<i128, String> {
    const HINT: &str = "write a duration as numbers with units d, h, m, s, ms, us, ns (e.g. T#1m30s, T#250ms, T#1.5s)";
    let (neg, rest) = match body.as_bytes().first() {
        Some(b'-') => (true, &body[1..]),
        Some(b'+') => (false, &body[1..]),
        _ => (false, body),
    };
    let rest = rest.replace('_', "");
    if rest.is_empty() {
        return Err(HINT.into());
    }
    let bytes = rest.as_bytes();
    let mut i = 0;
    let mut total: f64 = 0.0;
    let mut exact: i128 = 0;
    let mut any_fraction = false;
    let mut last_rank = 0usize;
    while i < bytes.len() {
        let num_start = i;
        while i < bytes.len() && (bytes[i].is_ascii_digit() || bytes[i] == b'.') {
            i += 1;
        }
        let num = &rest[num_start..i];
        if num.is_empty() {
            return Err(HINT.into());
        }
        let unit_start = i;
        while i < bytes.len() && bytes[i].is_ascii_alphabetic() {
            i += 1;
        }
        let unit = rest[unit_start..i].to_ascii_lowercase();
        let (scale, rank): (i128, usize) = match unit.as_str() {
            "d" => (NANOS_PER_DAY, 1),
            "h" => (3_600_000_000_000, 2),
            "m" => (60_000_000_000, 3),
            "s" => (1_000_000_000, 4),
            "ms" => (1_000_000, 5),
            "us" => (1_000, 6),
            "ns" => (1, 7),
            _ => return Err(HINT.into()),
        };
        if rank <= last_rank {
            return Err(
                "units of a duration go from the largest to the smallest (T#1h30m, not T#30m1h)"
                    .into(),
            );
        }
        last_rank = rank;
        if num.contains('.') {
            if i < bytes.len() {
                return Err(
                    "only the last unit of a duration may have a fraction (T#1m30.5s)".into(),
                );
            }
            let v: f64 = num.parse().map_err(|_| HINT.to_string())?;
            total += v * scale as f64;
            any_fraction = true;
        } else {
            let v: i128 = num.parse().map_err(|_| HINT.to_string())?;
            exact = v
                .checked_mul(scale)
                .and_then(|x| x.checked_add(exact))
                .ok_or("this duration is too long")?;
        }
    }
    let mut n = exact;
    if any_fraction {
        n += total.round() as i128;
    }
    Ok(if neg { -n } else { n })
}

/// `yyyy-mm-dd`: days since 1970-01-01.
pub fn parse_date(body: &str) -> Result<i64, String> {
    const HINT: &str = "write a date as yyyy-mm-dd (e.g. D#2024-03-01)";
    let parts: Vec<&str> = body.split('-').collect();
    if parts.len() != 3 {
        return Err(HINT.into());
    }
    let y: i64 = parts[0].replace('_', "").parse().map_err(|_| HINT)?;
    let m: u32 = parts[1].parse().map_err(|_| HINT)?;
    let d: u32 = parts[2].parse().map_err(|_| HINT)?;
    if y.abs() > petriplc_calendar::MAX_YEAR {
        return Err(format!(
            "year {y} is beyond the calendar (years -{max} to {max}); write a year in range",
            max = petriplc_calendar::MAX_YEAR
        ));
    }
    if !(1..=12).contains(&m) || d < 1 || d > days_in_month(y, m) {
        return Err(format!("{y:04}-{m:02}-{d:02} is not a day of the calendar"));
    }
    Ok(days_from_civil(y, m, d))
}

/// `hh:mm:ss[.fff]`: nanoseconds since midnight.
pub fn parse_tod(body: &str) -> Result<i128, String> {
    const HINT: &str =
        "write a time of day as hh:mm:ss with optional fraction (e.g. TOD#14:30:00.5), or hh:mm";
    let mut parts: Vec<&str> = body.split(':').collect();
    // `hh:mm` without seconds, as CODESYS and TwinCAT (and blark's grammar) accept.
    if parts.len() == 2 {
        parts.push("0");
    }
    if parts.len() != 3 {
        return Err(HINT.into());
    }
    let h: i128 = parts[0].parse().map_err(|_| HINT)?;
    let m: i128 = parts[1].parse().map_err(|_| HINT)?;
    let (s_int, frac) = match parts[2].split_once('.') {
        Some((a, b)) => (a, b),
        None => (parts[2], ""),
    };
    let s: i128 = s_int.parse().map_err(|_| HINT)?;
    if h > 23 || m > 59 || s > 59 || !frac.chars().all(|c| c.is_ascii_digit()) || frac.len() > 9 {
        return Err(format!(
            "{body} is not a time of day (00:00:00 to 23:59:59.999999999)"
        ));
    }
    let frac_ns: i128 = if frac.is_empty() {
        0
    } else {
        format!("{frac:0<9}").parse().map_err(|_| HINT)?
    };
    Ok(((h * 60 + m) * 60 + s) * 1_000_000_000 + frac_ns)
}

/// `yyyy-mm-dd-hh:mm:ss[.fff]`: nanoseconds since 1970-01-01T00:00.
pub fn parse_dt(body: &str) -> Result<i128, String> {
    const HINT: &str = "write a date and time as yyyy-mm-dd-hh:mm:ss (e.g. DT#2024-03-01-14:30:00)";
    let mut it = body.splitn(4, '-');
    let (Some(y), Some(m), Some(d), Some(t)) = (it.next(), it.next(), it.next(), it.next()) else {
        return Err(HINT.into());
    };
    let days = parse_date(&format!("{y}-{m}-{d}"))?;
    let tod = parse_tod(t)?;
    Ok(days as i128 * NANOS_PER_DAY + tod)
}
