//! Point values as MQTT payloads: plain decimal text (`1`, `0`, `-12`, `3.5`) or JSON
//! (`{"value":3.5,"ts":1764057600123}`), and back.

use petriplc_config::{PointKind, PointValue};

/// How published values are written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// The value as decimal text.
    Plain,
    /// `{"value": V, "ts": MILLISECONDS_SINCE_1970}`.
    Json,
}

impl Format {
    pub fn parse(text: &str) -> Option<Format> {
        match text {
            "plain" | "text" => Some(Format::Plain),
            "json" => Some(Format::Json),
            _ => None,
        }
    }
}

/// The decimal text of a value: integers as integers, floats in Rust's shortest form that
/// reads back to the same `f32` (never an exponent: `0.0000001`).
pub fn decimal(v: PointValue) -> String {
    match v {
        PointValue::Unsigned(u) => u.to_string(),
        PointValue::Signed(i) => i.to_string(),
        PointValue::Float(f) => f.to_string(),
    }
}

/// The payload of a published value; `ts_ms` is the wall-clock time for JSON.
pub fn encode(v: PointValue, format: Format, ts_ms: u64) -> Vec<u8> {
    match format {
        Format::Plain => decimal(v).into_bytes(),
        Format::Json => {
            let value = match v {
                // The shortest decimal that reads back to the same f32, not the f64 widening
                // (0.1, not 0.10000000149011612); NaN and infinities have no JSON number.
                PointValue::Float(f) if !f.is_finite() => "null".to_string(),
                v => decimal(v),
            };
            format!("{{\"value\":{value},\"ts\":{ts_ms}}}").into_bytes()
        }
    }
}

/// A number read from a payload.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Number {
    Int(i64),
    Float(f64),
    /// Digits beyond `f64` (`1e400`, a 400-digit integer): finite, too large for any point.
    Beyond,
}

/// Why a received payload cannot become a point's value. Displayed after `payload "..."`,
/// it reads as a sentence: `payload "NaN" is not a finite number`.
#[derive(Clone, Debug, PartialEq)]
pub enum Refusal {
    NotUtf8,
    NotJson(String),
    /// A JSON object without a number or boolean `value` member.
    NoValue,
    NotANumber,
    /// NaN or an infinity: a point only takes finite numbers (one NaN reaching an IEC program
    /// would spread through every computation that reads it).
    NotFinite,
    /// A number the point cannot hold.
    OutOfRange {
        min: String,
        max: String,
    },
    /// A fraction for an integer point.
    NotWhole,
    /// Larger than the module's `max_payload` (bytes).
    TooLarge {
        size: usize,
        max: usize,
    },
}

impl std::fmt::Display for Refusal {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Refusal::NotUtf8 => write!(f, "is not UTF-8 text"),
            Refusal::NotJson(e) => write!(f, "is not JSON ({e})"),
            Refusal::NoValue => write!(f, "has no number or boolean `value` member"),
            Refusal::NotANumber => write!(
                f,
                "is not a number (expected decimal text such as 1, -12, 3.5, true, or JSON \
                 {{\"value\": 3.5}})"
            ),
            Refusal::NotFinite => write!(f, "is not a finite number"),
            Refusal::OutOfRange { min, max } => write!(f, "is out of range ({min} to {max})"),
            Refusal::NotWhole => write!(f, "is not a whole number"),
            Refusal::TooLarge { size, max } => write!(
                f,
                "of {size} bytes is larger than `max_payload = {max}` bytes (raise \
                 `max_payload` if the topic is meant to carry such messages)"
            ),
        }
    }
}

/// A payload as a log shows it: its text quoted and escaped, cut after 40 characters, or its
/// size when it is not UTF-8.
pub fn show(bytes: &[u8]) -> String {
    match std::str::from_utf8(bytes) {
        Ok(text) => {
            let mut shown: String = text.chars().take(40).collect();
            if shown.len() < text.len() {
                shown.push_str("...");
            }
            format!("\"{}\"", shown.escape_debug())
        }
        Err(_) => format!("of {} bytes", bytes.len()),
    }
}

/// How a point's type is written in a configuration: `u8`, `i16`, `f32`.
pub fn type_name(kind: PointKind, bits: u8) -> String {
    match kind {
        PointKind::Unsigned => format!("u{bits}"),
        PointKind::Signed => format!("i{bits}"),
        PointKind::Float => "f32".to_string(),
    }
}

/// Reads a payload, whatever the module's own format: plain decimal text, `true`/`false`,
/// or a JSON object with a `value` member (a number or a boolean). NaN and infinities, in
/// every spelling Rust's float parser knows (`NaN`, `inf`, `-Infinity`), are refused here;
/// a finite number too large for a point is refused by [`to_point`].
pub fn decode(bytes: &[u8]) -> Result<Number, Refusal> {
    let text = std::str::from_utf8(bytes)
        .map_err(|_| Refusal::NotUtf8)?
        .trim();
    if text.starts_with('{') {
        let json: serde_json::Value =
            serde_json::from_str(text).map_err(|e| Refusal::NotJson(e.to_string()))?;
        return match json.get("value") {
            Some(serde_json::Value::Bool(b)) => Ok(Number::Int(i64::from(*b))),
            // serde_json refuses numbers beyond f64 and has no NaN: every number is finite.
            Some(serde_json::Value::Number(n)) => match (n.as_i64(), n.as_f64()) {
                (Some(i), _) => Ok(Number::Int(i)),
                (None, Some(f)) if f.is_finite() => Ok(Number::Float(f)),
                _ => Err(Refusal::NotFinite),
            },
            _ => Err(Refusal::NoValue),
        };
    }
    match text {
        "true" | "TRUE" | "True" | "on" | "ON" => return Ok(Number::Int(1)),
        "false" | "FALSE" | "False" | "off" | "OFF" => return Ok(Number::Int(0)),
        _ => {}
    }
    if let Ok(i) = text.parse::<i64>() {
        return Ok(Number::Int(i));
    }
    match text.parse::<f64>() {
        Ok(f) if f.is_finite() => Ok(Number::Float(f)),
        // Digits beyond f64's range (`1e400`) parse as an infinity: a number, too large.
        Ok(f) if f.is_infinite() && text.bytes().any(|b| b.is_ascii_digit()) => Ok(Number::Beyond),
        Ok(_) => Err(Refusal::NotFinite),
        Err(_) => Err(Refusal::NotANumber),
    }
}

/// The value a point of `kind` and `bits` takes for `n`: always finite and within the
/// point's range, or refused.
pub fn to_point(n: Number, kind: PointKind, bits: u8) -> Result<PointValue, Refusal> {
    let bits = u32::from(bits);
    let (min, max) = match kind {
        PointKind::Float => {
            let out_of_range = || Refusal::OutOfRange {
                min: format!("{:e}", f32::MIN),
                max: format!("{:e}", f32::MAX),
            };
            return match n {
                Number::Int(i) => Ok(PointValue::Float(i as f32)),
                Number::Float(f) if !f.is_finite() => Err(Refusal::NotFinite),
                Number::Float(f) => {
                    // Rounds to the nearest f32; beyond f32::MAX that is an infinity.
                    let v = f as f32;
                    if v.is_finite() {
                        Ok(PointValue::Float(v))
                    } else {
                        Err(out_of_range())
                    }
                }
                Number::Beyond => Err(out_of_range()),
            };
        }
        PointKind::Unsigned => (0i64, (1i64 << bits) - 1),
        PointKind::Signed => (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1),
    };
    let out_of_range = || Refusal::OutOfRange {
        min: min.to_string(),
        max: max.to_string(),
    };
    // 2^63: exactly a float, unlike i64::MAX.
    let two_63 = -(i64::MIN as f64);
    let i = match n {
        Number::Int(i) => i,
        Number::Float(f) if !f.is_finite() => return Err(Refusal::NotFinite),
        Number::Float(f) if f.fract() != 0.0 => return Err(Refusal::NotWhole),
        Number::Float(f) if (-two_63..two_63).contains(&f) => f as i64,
        Number::Float(_) | Number::Beyond => return Err(out_of_range()),
    };
    if !(min..=max).contains(&i) {
        return Err(out_of_range());
    }
    Ok(match kind {
        PointKind::Unsigned => PointValue::Unsigned(i as u32),
        _ => PointValue::Signed(i as i32),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn check(payload: &str, kind: PointKind, bits: u8, expect: Result<PointValue, &str>) {
        let got = decode(payload.as_bytes()).and_then(|n| to_point(n, kind, bits));
        match (got, expect) {
            (Ok(a), Ok(b)) => assert_eq!(a, b, "{payload}"),
            (Err(a), Err(b)) => assert!(a.to_string().contains(b), "{payload}: {a}"),
            (a, b) => panic!("{payload}: got {a:?}, expected {b:?}"),
        }
    }

    #[test]
    fn plain_and_json_payloads_become_point_values() {
        use PointKind::*;
        use PointValue as V;
        check("1", Unsigned, 1, Ok(V::Unsigned(1)));
        check(" 0\n", Unsigned, 1, Ok(V::Unsigned(0)));
        check("true", Unsigned, 1, Ok(V::Unsigned(1)));
        check("2", Unsigned, 1, Err("out of range (0 to 1)"));
        check("-12", Signed, 16, Ok(V::Signed(-12)));
        check("-32769", Signed, 16, Err("out of range (-32768 to 32767)"));
        check("3.5", Float, 32, Ok(V::Float(3.5)));
        check("7", Float, 32, Ok(V::Float(7.0)));
        check("3.0", Unsigned, 8, Ok(V::Unsigned(3)));
        check("3.5", Unsigned, 8, Err("not a whole number"));
        check(
            "{\"value\": 42, \"ts\": 1}",
            Unsigned,
            8,
            Ok(V::Unsigned(42)),
        );
        check("{\"value\": true}", Unsigned, 1, Ok(V::Unsigned(1)));
        check("{\"value\": -1.25}", Float, 32, Ok(V::Float(-1.25)));
        check("{\"v\": 1}", Unsigned, 1, Err("`value` member"));
        check("{\"value\": 1e39}", Float, 32, Err("out of range"));
        check("{\"value\": 1e400}", Float, 32, Err("not JSON"));
        check("{", Unsigned, 1, Err("not JSON"));
        check("", Unsigned, 1, Err("not a number"));
        check("abc", Unsigned, 1, Err("not a number"));
        check("4294967295", Unsigned, 32, Ok(V::Unsigned(u32::MAX)));
        check(
            "4294967296",
            Unsigned,
            32,
            Err("out of range (0 to 4294967295)"),
        );
        check(&"9".repeat(30), Unsigned, 32, Err("out of range"));
        check(&"9".repeat(30), Float, 32, Ok(V::Float(1e30)));
        check("\u{fe}\u{ff}", Unsigned, 8, Err("not a number"));
    }

    #[test]
    fn non_finite_numbers_are_refused_in_every_spelling() {
        use PointKind::*;
        use PointValue as V;
        for text in [
            "NaN",
            "nan",
            "NAN",
            "-nan",
            "+NaN",
            "inf",
            "-inf",
            "+inf",
            "Infinity",
            "-Infinity",
            "infinity",
            "INF",
            " inf\n",
        ] {
            for (kind, bits) in [(Float, 32), (Unsigned, 8), (Signed, 16), (Unsigned, 1)] {
                check(text, kind, bits, Err("is not a finite number"));
            }
        }
        // Finite text beyond the point's range: 1e39 would become +Inf in an f32.
        check(
            "1e39",
            Float,
            32,
            Err("out of range (-3.4028235e38 to 3.4028235e38)"),
        );
        check("-1e39", Float, 32, Err("out of range"));
        check(
            "1e400",
            Float,
            32,
            Err("out of range (-3.4028235e38 to 3.4028235e38)"),
        );
        check("-1e400", Unsigned, 8, Err("out of range (0 to 255)"));
        check(
            &"9".repeat(400),
            Signed,
            8,
            Err("out of range (-128 to 127)"),
        );
        check("1e39", Unsigned, 32, Err("out of range"));
        check("3.4028235e38", Float, 32, Ok(V::Float(f32::MAX)));
        check("1e-50", Float, 32, Ok(V::Float(0.0)));
        check("-0", Float, 32, Ok(V::Float(0.0)));
        check("-0.0", Unsigned, 8, Ok(V::Unsigned(0)));
        check("-0", Signed, 8, Ok(V::Signed(0)));
        assert_eq!(show(b"NaN"), "\"NaN\"");
        assert_eq!(show(b"a\"\n"), "\"a\\\"\\n\"");
        assert_eq!(show(&[0xff, 0xfe]), "of 2 bytes");
        assert_eq!(
            show("x".repeat(100).as_bytes()),
            format!("\"{}...\"", "x".repeat(40))
        );
    }

    #[test]
    fn values_are_written_as_decimal_text_or_json() {
        assert_eq!(encode(PointValue::Unsigned(1), Format::Plain, 0), b"1");
        assert_eq!(encode(PointValue::Signed(-12), Format::Plain, 0), b"-12");
        assert_eq!(encode(PointValue::Float(3.5), Format::Plain, 0), b"3.5");
        assert_eq!(
            encode(PointValue::Float(1e-7), Format::Plain, 0),
            b"0.0000001"
        );
        assert_eq!(
            encode(PointValue::Float(0.1), Format::Json, 5),
            br#"{"value":0.1,"ts":5}"#
        );
        assert_eq!(
            encode(PointValue::Signed(-3), Format::Json, 7),
            br#"{"value":-3,"ts":7}"#
        );
        // Every plain float reads back to the same f32.
        for f in [0.1f32, 1.0 / 3.0, 1e30, -2.5e-20, f32::MAX] {
            let text = encode(PointValue::Float(f), Format::Plain, 0);
            let back = to_point(decode(&text).unwrap(), PointKind::Float, 32).unwrap();
            assert_eq!(back, PointValue::Float(f));
        }
    }

    /// The point types a subscription can have.
    fn point_types() -> impl Strategy<Value = (PointKind, u8)> {
        prop_oneof![
            Just((PointKind::Float, 32)),
            (1u8..=32).prop_map(|b| (PointKind::Unsigned, b)),
            (2u8..=32).prop_map(|b| (PointKind::Signed, b)),
        ]
    }

    /// Numbers in every spelling: signs, digits far beyond any range, fractions, exponents,
    /// the words Rust's parser takes for NaN and the infinities, JSON, spaces.
    fn spellings() -> impl Strategy<Value = String> {
        prop_oneof![
            "[+-]?[0-9]{0,60}(\\.[0-9]{0,20})?([eE][+-]?[0-9]{1,4})?",
            "[+-]?(nan|NaN|NAN|inf|Inf|INF|infinity|Infinity)",
            "[ \t\n]{0,2}[+-]?[0-9]{1,5}[ \t\n]{0,2}",
            "\\{\"value\": ?[+-]?[0-9]{0,40}(\\.[0-9]{0,9})?([eE][+-]?[0-9]{1,3})?\\}",
            "\\{\"value\": ?(true|false|null|\"1\"|NaN)\\}",
            "(true|false|on|off|TRUE|True|-0|0x10|1_000|\\.5|5\\.)",
            ".{0,20}",
        ]
    }

    fn holds(v: PointValue, kind: PointKind, bits: u8) -> bool {
        let bits = u32::from(bits);
        match (v, kind) {
            (PointValue::Float(f), PointKind::Float) => f.is_finite(),
            (PointValue::Unsigned(u), PointKind::Unsigned) => u64::from(u) < (1u64 << bits),
            (PointValue::Signed(i), PointKind::Signed) => {
                let half = 1i64 << (bits - 1);
                (-half..half).contains(&i64::from(i))
            }
            _ => false,
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]

        /// Whatever arrives, the module either refuses it or has a finite value within the
        /// point's range (never a panic).
        #[test]
        fn any_bytes_become_a_value_the_point_holds_or_are_refused(
            bytes in proptest::collection::vec(any::<u8>(), 0..64),
            (kind, bits) in point_types(),
        ) {
            if let Ok(v) = decode(&bytes).and_then(|n| to_point(n, kind, bits)) {
                prop_assert!(holds(v, kind, bits), "{bytes:?} -> {v:?}");
            }
        }

        #[test]
        fn any_spelling_of_a_number_becomes_a_value_the_point_holds_or_is_refused(
            text in spellings(),
            (kind, bits) in point_types(),
        ) {
            match decode(text.as_bytes()).and_then(|n| to_point(n, kind, bits)) {
                Ok(v) => prop_assert!(holds(v, kind, bits), "{text:?} -> {v:?}"),
                Err(why) => prop_assert!(!why.to_string().is_empty()),
            }
        }

        /// Every finite f32 the module publishes reads back as the same value.
        #[test]
        fn published_floats_read_back(bits in any::<u32>()) {
            let f = f32::from_bits(bits);
            let text = encode(PointValue::Float(f), Format::Plain, 0);
            let back = decode(&text).and_then(|n| to_point(n, PointKind::Float, 32));
            if f.is_finite() {
                prop_assert_eq!(back, Ok(PointValue::Float(f)));
            } else {
                prop_assert_eq!(back, Err(Refusal::NotFinite));
            }
        }
    }
}
