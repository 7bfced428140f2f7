//! The proleptic Gregorian calendar as day numbers since 1970-01-01 (Howard Hinnant's
//! `days_from_civil` and `civil_from_days`), shared by the IEC lexer (DATE literals), the
//! checker (constant DATE values shown back), `petriplc compile` (PLCopen timestamps) and the
//! retain file (times in messages).
//!
//! Our own rather than the `time` crate's: IEC literals may name any year, and `time` stops
//! at ±9999 (±999 999 with a feature); these functions are exact for every year whose day
//! number fits an i64 with room for the shift to 0000-03-01 ([`MAX_YEAR`]).

/// The largest year (in absolute value) [`days_from_civil`] computes without overflow; a
/// caller that reads years from a user checks against it first.
pub const MAX_YEAR: i64 = 25_000_000_000_000_000;

/// Days since 1970-01-01 of a proleptic Gregorian date; `m` is 1 to 12, `d` 1 to 31. A
/// year beyond ±[`MAX_YEAR`] overflows.
pub fn days_from_civil(y: i64, m: u32, d: u32) -> i64 {
    let y = if m <= 2 { y - 1 } else { y };
    let era = if y >= 0 { y } else { y - 399 } / 400;
    let yoe = y - era * 400;
    let m = m as i64;
    let doy = (153 * (if m > 2 { m - 3 } else { m + 9 }) + 2) / 5 + d as i64 - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    era * 146_097 + doe - 719_468
}

/// The date (year, month 1–12, day 1–31) of a day number: the inverse of
/// [`days_from_civil`]. Exact for every day number up to `i64::MAX - 719_468`.
pub fn civil_from_days(z: i64) -> (i64, u32, u32) {
    let z = z + 719_468;
    let era = if z >= 0 { z } else { z - 146_096 } / 146_097;
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let y = yoe + era * 400;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (if m <= 2 { y + 1 } else { y }, m, d)
}

/// Whether `y` has a 29 February.
pub fn is_leap(y: i64) -> bool {
    (y % 4 == 0 && y % 100 != 0) || y % 400 == 0
}

/// How many days month `m` (1–12) of year `y` has.
pub fn days_in_month(y: i64, m: u32) -> u32 {
    match m {
        1 | 3 | 5 | 7 | 8 | 10 | 12 => 31,
        4 | 6 | 9 | 11 => 30,
        _ if is_leap(y) => 29,
        _ => 28,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn civil_dates_round_trip() {
        for days in [-800_000, -1, 0, 1, 59, 365, 11_016, 2_932_896] {
            let (y, m, d) = civil_from_days(days);
            assert_eq!(days_from_civil(y, m, d), days);
        }
        assert_eq!(days_from_civil(2000, 3, 1), 11_017);
    }

    #[test]
    fn days_map_to_dates() {
        assert_eq!(civil_from_days(0), (1970, 1, 1));
        assert_eq!(civil_from_days(20_454), (2026, 1, 1));
        assert_eq!(civil_from_days(11_016), (2000, 2, 29));
        assert_eq!(civil_from_days(-1), (1969, 12, 31));
        assert_eq!(civil_from_days(-719_528), (0, 1, 1));
        assert_eq!(civil_from_days(-719_529), (-1, 12, 31));
    }

    #[test]
    fn the_extremes_do_not_overflow() {
        let (y, m, d) = civil_from_days(i64::MAX - 719_468);
        assert_eq!(days_from_civil(y, m, d), i64::MAX - 719_468);
        for y in [MAX_YEAR, -MAX_YEAR] {
            let days = days_from_civil(y, 12, 31);
            assert_eq!(civil_from_days(days), (y, 12, 31));
        }
    }

    #[test]
    fn months_and_leap_years() {
        assert!(is_leap(2000) && is_leap(2024) && is_leap(-4) && is_leap(0));
        assert!(!is_leap(1900) && !is_leap(2023) && !is_leap(-1));
        assert_eq!(days_in_month(2024, 2), 29);
        assert_eq!(days_in_month(1900, 2), 28);
        assert_eq!(days_in_month(2023, 4), 30);
        assert_eq!(days_in_month(2023, 12), 31);
    }

    proptest! {
        /// Every day of ±25 000 million years maps to a date of the calendar and back.
        #[test]
        fn every_day_round_trips(days in -9_000_000_000_000i64..9_000_000_000_000) {
            let (y, m, d) = civil_from_days(days);
            prop_assert!((1..=12).contains(&m));
            prop_assert!(d >= 1 && d <= days_in_month(y, m));
            prop_assert_eq!(days_from_civil(y, m, d), days);
        }

        /// The next day is the next date: the day after the last of a month is the 1st.
        #[test]
        fn consecutive_days_are_consecutive_dates(days in -100_000_000i64..100_000_000) {
            let (y, m, d) = civil_from_days(days);
            let next = civil_from_days(days + 1);
            let expect = if d < days_in_month(y, m) {
                (y, m, d + 1)
            } else if m < 12 {
                (y, m + 1, 1)
            } else {
                (y + 1, 1, 1)
            };
            prop_assert_eq!(next, expect);
        }

        #[test]
        fn every_date_round_trips(y in -MAX_YEAR..=MAX_YEAR, m in 1u32..=12, d in 1u32..=28) {
            prop_assert_eq!(civil_from_days(days_from_civil(y, m, d)), (y, m, d));
        }
    }
}
