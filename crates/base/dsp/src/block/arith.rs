//! The arithmetic blocks: `typeconv` (conversions between f32 and whole numbers, saturating),
//! `add` (a weighted sum), `mult` (a product of offset inputs) and `pow`.

/// A point's number type as a conversion target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NumType {
    /// A 32-bit float.
    F32,
    /// A signed whole number of `bits` (1 to 32) bits.
    Signed(u8),
    /// An unsigned whole number of `bits` (1 to 32) bits; a 1-bit one is a boolean.
    Unsigned(u8),
}

impl NumType {
    /// The smallest and largest value the type holds.
    pub fn range(self) -> (f64, f64) {
        match self {
            NumType::F32 => (f64::from(f32::MIN), f64::from(f32::MAX)),
            NumType::Signed(bits) => {
                let half = (1u64 << (bits - 1)) as f64;
                (-half, half - 1.0)
            }
            NumType::Unsigned(bits) => (0.0, ((1u64 << bits) - 1) as f64),
        }
    }

    pub fn name(self) -> String {
        match self {
            NumType::F32 => "f32".into(),
            NumType::Signed(b) => format!("i{b}"),
            NumType::Unsigned(1) => "bool".into(),
            NumType::Unsigned(b) => format!("u{b}"),
        }
    }
}

/// Converts a value to what a point of type `to` holds. To a float: the nearest `f32` (values
/// beyond its range become ±∞; NaN stays NaN). To a whole number: rounded to the nearest
/// (halves away from zero), saturated at the type's range (so ±∞ give its ends), and NaN
/// gives 0. Never undefined, whatever the input.
pub fn convert(x: f64, to: NumType) -> f64 {
    match to {
        NumType::F32 => f64::from(x as f32),
        _ if x.is_nan() => 0.0,
        _ => {
            let (lo, hi) = to.range();
            x.round().clamp(lo, hi)
        }
    }
}

/// `add`: `Σ xᵢ·kᵢ`, summed in `f64` in the order of the row.
#[derive(Clone, Debug, PartialEq)]
pub struct Add {
    pub gains: Vec<f64>,
}

impl Add {
    pub fn step(&self, inputs: &[f64]) -> f64 {
        inputs
            .iter()
            .zip(&self.gains)
            .fold(0.0, |sum, (x, k)| sum + x * k)
    }
}

/// `mult`: `Π (xᵢ + oᵢ)`, multiplied in `f64` in the order of the row.
#[derive(Clone, Debug, PartialEq)]
pub struct Mult {
    pub offsets: Vec<f64>,
}

impl Mult {
    pub fn step(&self, inputs: &[f64]) -> f64 {
        inputs
            .iter()
            .zip(&self.offsets)
            .fold(1.0, |prod, (x, o)| prod * (x + o))
    }
}

/// `pow`: `x^p` with IEEE `pow`'s edge values (a negative base to a non-integer power is NaN,
/// 0 to a negative power is +∞, anything to the power 0 is 1).
#[derive(Clone, Debug, PartialEq)]
pub struct Pow {
    pub exponent: f64,
}

impl Pow {
    pub fn step(&self, x: f64) -> f64 {
        x.powf(self.exponent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(x: f64, to: NumType, expect: f64) {
        let got = convert(x, to);
        assert!(
            got == expect || (got.is_nan() && expect.is_nan()),
            "{x} to {}: {got}, expected {expect}",
            to.name()
        );
    }

    #[test]
    fn conversions_round_and_saturate() {
        let i32_ = NumType::Signed(32);
        check(2.5, i32_, 3.0);
        check(-2.5, i32_, -3.0);
        check(2.4999, i32_, 2.0);
        check(f64::NAN, i32_, 0.0);
        check(f64::INFINITY, i32_, 2147483647.0);
        check(f64::NEG_INFINITY, i32_, -2147483648.0);
        check(3e9, i32_, 2147483647.0);
        check(-1.0, NumType::Unsigned(32), 0.0);
        check(5e9, NumType::Unsigned(32), 4294967295.0);
        check(300.0, NumType::Unsigned(8), 255.0);
        check(-200.0, NumType::Signed(8), -128.0);
        check(0.7, NumType::Unsigned(1), 1.0);
        check(16777217.0, NumType::F32, 16777216.0);
        check(1e39, NumType::F32, f64::INFINITY);
        check(f64::NAN, NumType::F32, f64::NAN);
    }

    #[test]
    fn add_mult_pow() {
        let a = Add {
            gains: vec![1.0, -1.0, 0.5],
        };
        assert_eq!(a.step(&[3.0, 1.0, 4.0]), 4.0);
        assert!(a.step(&[f64::INFINITY, f64::INFINITY, 0.0]).is_nan());
        let m = Mult {
            offsets: vec![0.0, 1.0],
        };
        assert_eq!(m.step(&[3.0, 1.0]), 6.0);
        let p = Pow { exponent: -1.0 };
        assert_eq!(p.step(0.0), f64::INFINITY);
        assert!(Pow { exponent: 0.5 }.step(-4.0).is_nan());
        assert_eq!(Pow { exponent: 0.0 }.step(f64::NAN), 1.0);
    }
}
