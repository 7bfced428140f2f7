//! Constant values: literals, initial values and what the checker folds at compile time
//! (array bounds, CASE labels, CONSTANT variables).

#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// BOOL (0/1), integers, bit strings, enumeration values, and durations, dates and times
    /// of day in nanoseconds.
    Int(i128),
    Real(f64),
    Str(Vec<u8>),
    /// A WSTRING's UTF-16 code units.
    WStr(Vec<u16>),
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

/// REAL values are single precision: rounds an f64 to the nearest f32.
pub fn to_real(v: f64) -> f64 {
    v as f32 as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_are_single_precision() {
        assert_eq!(to_real(0.1), 0.10000000149011612);
    }
}
