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
}

/// Reads a payload, whatever the module's own format: plain decimal text, `true`/`false`,
/// or a JSON object with a `value` member (a number or a boolean).
pub fn decode(bytes: &[u8]) -> Result<Number, String> {
    let text = std::str::from_utf8(bytes)
        .map_err(|_| "the payload is not UTF-8 text".to_string())?
        .trim();
    if text.starts_with('{') {
        let json: serde_json::Value =
            serde_json::from_str(text).map_err(|e| format!("the payload is not JSON: {e}"))?;
        return match json.get("value") {
            Some(serde_json::Value::Bool(b)) => Ok(Number::Int(i64::from(*b))),
            Some(serde_json::Value::Number(n)) => match n.as_i64() {
                Some(i) => Ok(Number::Int(i)),
                None => n
                    .as_f64()
                    .map(Number::Float)
                    .ok_or_else(|| format!("`{n}` is out of range")),
            },
            _ => Err("a JSON payload needs a number or boolean `value` member".to_string()),
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
        Ok(f) if !text.is_empty() => Ok(Number::Float(f)),
        _ => Err(format!(
            "`{}` is not a number (expected decimal text like 1, -12, 3.5, true, or JSON \
             {{\"value\": 3.5}})",
            text.chars().take(40).collect::<String>()
        )),
    }
}

/// The value a point of `kind` and `bits` takes for `n`, or why it cannot.
pub fn to_point(n: Number, kind: PointKind, bits: u8) -> Result<PointValue, String> {
    let int = |n: Number| -> Result<i64, String> {
        match n {
            Number::Int(i) => Ok(i),
            Number::Float(f) if f.fract() == 0.0 && f.abs() < 9.0e15 => Ok(f as i64),
            Number::Float(f) => Err(format!("{f} is not a whole number")),
        }
    };
    let bits = u32::from(bits);
    match kind {
        PointKind::Float => Ok(PointValue::Float(match n {
            Number::Int(i) => i as f32,
            Number::Float(f) => f as f32,
        })),
        PointKind::Unsigned => {
            let i = int(n)?;
            let max = (1i64 << bits) - 1;
            if (0..=max).contains(&i) {
                Ok(PointValue::Unsigned(i as u32))
            } else {
                Err(format!("{i} does not fit a u{bits} point (0 to {max})"))
            }
        }
        PointKind::Signed => {
            let i = int(n)?;
            let half = 1i64 << (bits - 1);
            if (-half..half).contains(&i) {
                Ok(PointValue::Signed(i as i32))
            } else {
                Err(format!(
                    "{i} does not fit an i{bits} point ({} to {})",
                    -half,
                    half - 1
                ))
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(payload: &str, kind: PointKind, bits: u8, expect: Result<PointValue, &str>) {
        let got = decode(payload.as_bytes()).and_then(|n| to_point(n, kind, bits));
        match (got, expect) {
            (Ok(a), Ok(b)) => assert_eq!(a, b, "{payload}"),
            (Err(a), Err(b)) => assert!(a.contains(b), "{payload}: {a}"),
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
        check("2", Unsigned, 1, Err("does not fit a u1 point"));
        check("-12", Signed, 16, Ok(V::Signed(-12)));
        check("-32769", Signed, 16, Err("does not fit an i16"));
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
        check("{", Unsigned, 1, Err("not JSON"));
        check("", Unsigned, 1, Err("not a number"));
        check("abc", Unsigned, 1, Err("not a number"));
        check("4294967295", Unsigned, 32, Ok(V::Unsigned(u32::MAX)));
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
}
