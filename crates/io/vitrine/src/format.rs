//! How values are written on the screen: point values by kind, and MatPLC's `show` fields
//! by data type.

use petriplc_config::PointValue;

use crate::setup::DataType;

/// A point's value for the points table and graphs: a bool (1-bit unsigned) point as
/// `ON`/`off` (with its truth), integers in decimal, floats by [`float`].
pub fn point(bits: u8, v: PointValue) -> (String, Option<bool>) {
    match v {
        PointValue::Unsigned(n) if bits == 1 => {
            let on = n != 0;
            (if on { "ON" } else { "off" }.to_string(), Some(on))
        }
        PointValue::Unsigned(n) => (n.to_string(), None),
        PointValue::Signed(n) => (n.to_string(), None),
        PointValue::Float(x) => (float(x), None),
    }
}

/// An f32 with three decimals, or in scientific notation where that would lose it (very
/// large or very small magnitudes).
pub fn float(x: f32) -> String {
    if x.is_nan() {
        return "NaN".into();
    }
    if x.is_infinite() {
        return if x > 0.0 { "inf" } else { "-inf" }.into();
    }
    let a = x.abs();
    if x == 0.0 || (1e-3..1e7).contains(&a) {
        format!("{x:.3}")
    } else {
        format!("{x:.3e}")
    }
}

/// A point's value as a number, for graphs.
pub fn number(v: PointValue) -> f64 {
    match v {
        PointValue::Unsigned(n) => f64::from(n),
        PointValue::Signed(n) => f64::from(n),
        PointValue::Float(x) => f64::from(x),
    }
}

/// A `show` field: the point's value read as MatPLC's data type (integer types wrap the
/// point's integer value the way a C cast would; `f32` shows a float point's value, or an
/// integer point's value as a float), a bool as the ON / OFF strings.
pub fn show(ty: DataType, v: PointValue, on: &str, off: &str) -> (String, Option<bool>) {
    let int = match v {
        PointValue::Unsigned(n) => i64::from(n),
        PointValue::Signed(n) => i64::from(n),
        PointValue::Float(x) => x as i64,
    };
    let text = match ty {
        DataType::Bool => {
            let truth = match v {
                PointValue::Float(x) => x != 0.0,
                _ => int != 0,
            };
            return (if truth { on } else { off }.to_string(), Some(truth));
        }
        DataType::I8 => (int as i8).to_string(),
        DataType::U8 => (int as u8).to_string(),
        DataType::I16 => (int as i16).to_string(),
        DataType::U16 => (int as u16).to_string(),
        DataType::I32 => (int as i32).to_string(),
        DataType::U32 => (int as u32).to_string(),
        DataType::F32 => float(match v {
            PointValue::Float(x) => x,
            _ => int as f32,
        }),
    };
    (text, None)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_values_by_kind() {
        let p = |bits, v| point(bits, v).0;
        assert_eq!(p(1, PointValue::Unsigned(1)), "ON");
        assert_eq!(p(1, PointValue::Unsigned(0)), "off");
        assert_eq!(point(1, PointValue::Unsigned(1)).1, Some(true));
        assert_eq!(p(16, PointValue::Unsigned(65535)), "65535");
        assert_eq!(point(16, PointValue::Unsigned(3)).1, None);
        assert_eq!(p(8, PointValue::Signed(-128)), "-128");
        assert_eq!(p(32, PointValue::Float(2.5)), "2.500");
        assert_eq!(p(32, PointValue::Float(-0.1)), "-0.100");
        assert_eq!(p(32, PointValue::Float(0.0)), "0.000");
        assert_eq!(p(32, PointValue::Float(1.5e9)), "1.500e9");
        assert_eq!(p(32, PointValue::Float(2.5e-5)), "2.500e-5");
        assert_eq!(p(32, PointValue::Float(f32::NAN)), "NaN");
        assert_eq!(p(32, PointValue::Float(f32::NEG_INFINITY)), "-inf");
    }

    #[test]
    fn show_fields_by_data_type() {
        let s = |ty, v| show(ty, v, "(*)", " -").0;
        assert_eq!(s(DataType::Bool, PointValue::Unsigned(1)), "(*)");
        assert_eq!(s(DataType::Bool, PointValue::Unsigned(0)), " -");
        assert_eq!(s(DataType::Bool, PointValue::Float(0.5)), "(*)");
        assert_eq!(s(DataType::I8, PointValue::Unsigned(200)), "-56");
        assert_eq!(s(DataType::U8, PointValue::Signed(-1)), "255");
        assert_eq!(s(DataType::I16, PointValue::Signed(-300)), "-300");
        assert_eq!(s(DataType::U16, PointValue::Unsigned(70000)), "4464");
        assert_eq!(s(DataType::I32, PointValue::Unsigned(u32::MAX)), "-1");
        assert_eq!(s(DataType::U32, PointValue::Signed(-1)), "4294967295");
        assert_eq!(s(DataType::F32, PointValue::Float(21.25)), "21.250");
        assert_eq!(s(DataType::F32, PointValue::Signed(-3)), "-3.000");
    }
}
