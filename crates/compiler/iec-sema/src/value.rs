//! Constant values: literals, initial values and what the checker folds at compile time
//! (array bounds, CASE labels, CONSTANT variables).

use crate::types::Elem;

#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// BOOL (0/1), integers, bit strings, enumeration values, and durations, dates and times
    /// of day in nanoseconds.
    Int(i128),
    Real(f64),
    Str(Vec<u8>),
    /// Every element, in row-major order.
    Array(Vec<Value>),
    /// Some fields of a structure, or some variables of a function block instance, by index.
    Fields(Vec<(u32, Value)>),
}

impl Value {
    pub fn as_int(&self) -> Option<i128> {
        match self {
            Value::Int(v) => Some(*v),
            _ => None,
        }
    }

    pub fn as_real(&self) -> Option<f64> {
        match self {
            Value::Real(v) => Some(*v),
            Value::Int(v) => Some(*v as f64),
            _ => None,
        }
    }
}

/// Whether an integer value lies in the range of an integral type.
pub fn fits(v: i128, e: Elem) -> bool {
    let (lo, hi) = e.range();
    (lo..=hi).contains(&v)
}

/// The value kept in `e`'s bits (two's complement wrap-around), as type conversions between
/// integer types keep the low bits.
pub fn wrap(v: i128, e: Elem) -> i128 {
    match e {
        Elem::Bool => (v != 0) as i128,
        Elem::Sint => v as i8 as i128,
        Elem::Int => v as i16 as i128,
        Elem::Dint => v as i32 as i128,
        Elem::Usint | Elem::Byte => v as u8 as i128,
        Elem::Uint | Elem::Word => v as u16 as i128,
        Elem::Udint | Elem::Dword => v as u32 as i128,
        Elem::Ulint | Elem::Lword => v as u64 as i128,
        _ => v as i64 as i128,
    }
}

/// REAL values are single precision: rounds an f64 to the nearest f32.
pub fn to_real(v: f64) -> f64 {
    v as f32 as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping_and_ranges() {
        assert_eq!(wrap(200, Elem::Sint), -56);
        assert_eq!(wrap(-1, Elem::Uint), 65535);
        assert_eq!(wrap(70000, Elem::Int), 4464);
        assert_eq!(wrap(5, Elem::Bool), 1);
        assert!(fits(-128, Elem::Sint));
        assert!(!fits(128, Elem::Sint));
        assert!(fits(u64::MAX as i128, Elem::Ulint));
        assert_eq!(to_real(0.1), 0.10000000149011612);
    }
}
