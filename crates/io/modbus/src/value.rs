//! How a point travels in Modbus: as one bit (coils, discrete inputs) or as one or two 16-bit
//! registers of a register type (`u16`, `i16`, `u32`, `i32`, `f32`) in a word order.
//!
//! | type  | registers | holds |
//! |-------|-----------|-------|
//! | `u16` | 1 | 0 to 65535 |
//! | `i16` | 1 | -32768 to 32767 (two's complement) |
//! | `u32` | 2 | 0 to 4294967295 |
//! | `i32` | 2 | -2147483648 to 2147483647 |
//! | `f32` | 2 | an IEEE 754 single (from the network: finite only, see [`convert`]) |
//!
//! Word order of the two-register types, for the value `0x12345678` at address 10:
//!
//! | order | register 10 | register 11 |
//! |-------|-------------|-------------|
//! | `high_first` (Modbus custom, big-endian) | `0x1234` | `0x5678` |
//! | `low_first` ("word swapped") | `0x5678` | `0x1234` |
//!
//! Bytes inside a register are always big-endian, as the protocol says.

use petriplc_config::{PointKind, PointValue};

/// How a point's value is carried in holding or input registers.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum RegisterType {
    U16,
    I16,
    U32,
    I32,
    F32,
}

impl RegisterType {
    /// How many 16-bit registers a value takes: 1 or 2.
    pub fn registers(self) -> usize {
        match self {
            RegisterType::U16 | RegisterType::I16 => 1,
            RegisterType::U32 | RegisterType::I32 | RegisterType::F32 => 2,
        }
    }

    /// `u16`, `i16`, `u32`, `i32` or `f32` (any case).
    pub fn parse(text: &str) -> Option<Self> {
        Some(match text.to_ascii_lowercase().as_str() {
            "u16" => RegisterType::U16,
            "i16" => RegisterType::I16,
            "u32" => RegisterType::U32,
            "i32" => RegisterType::I32,
            "f32" => RegisterType::F32,
            _ => return None,
        })
    }

    /// The name [`RegisterType::parse`] reads.
    pub fn name(self) -> &'static str {
        match self {
            RegisterType::U16 => "u16",
            RegisterType::I16 => "i16",
            RegisterType::U32 => "u32",
            RegisterType::I32 => "i32",
            RegisterType::F32 => "f32",
        }
    }

    /// Whether every value of a point of `kind` and `bits` has a representation in this type,
    /// so that reads never lose anything (e.g. `u16` holds a `u8` point, not an `i8` one).
    pub fn holds(self, kind: PointKind, bits: u8) -> bool {
        match (self, kind) {
            (RegisterType::F32, k) => k == PointKind::Float,
            (_, PointKind::Float) => false,
            (RegisterType::U16, PointKind::Unsigned) => bits <= 16,
            (RegisterType::I16, PointKind::Unsigned) => bits <= 15,
            (RegisterType::I16, PointKind::Signed) => bits <= 16,
            (RegisterType::U32, PointKind::Unsigned) => bits <= 32,
            (RegisterType::I32, PointKind::Unsigned) => bits <= 31,
            (RegisterType::I32, PointKind::Signed) => bits <= 32,
            (RegisterType::U16 | RegisterType::U32, PointKind::Signed) => false,
        }
    }
}

impl std::fmt::Display for RegisterType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Which 16-bit half of a two-register value comes first (at the lower address).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum WordOrder {
    /// The high 16 bits at the lower address: the Modbus custom (big-endian).
    #[default]
    HighFirst,
    /// The low 16 bits at the lower address ("word swapped", little-endian words).
    LowFirst,
}

impl WordOrder {
    /// `high_first` or `low_first` (any case; `-` for `_` too).
    pub fn parse(text: &str) -> Option<Self> {
        match text.to_ascii_lowercase().replace('-', "_").as_str() {
            "high_first" => Some(WordOrder::HighFirst),
            "low_first" => Some(WordOrder::LowFirst),
            _ => None,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            WordOrder::HighFirst => "high_first",
            WordOrder::LowFirst => "low_first",
        }
    }
}

impl std::fmt::Display for WordOrder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// The register type a point gets when its row names none: up to 16 bits one register
/// (`u16`, or `i16` for a signed point), wider points two (`u32`/`i32`), a float `f32`.
pub fn default_type(kind: PointKind, bits: u8) -> RegisterType {
    match kind {
        PointKind::Float => RegisterType::F32,
        PointKind::Unsigned if bits <= 16 => RegisterType::U16,
        PointKind::Signed if bits <= 16 => RegisterType::I16,
        PointKind::Unsigned => RegisterType::U32,
        PointKind::Signed => RegisterType::I32,
    }
}

/// The registers that carry `v` as `ty`, in `order`; only the first `ty.registers()` words
/// are used (the other is 0).
///
/// A value the type holds is carried exactly (a point narrower than its type always is: see
/// [`RegisterType::holds`]), a float point's NaN or ±Inf too (the value the PLC holds is
/// shown as it is). The modules check at start that every row's type holds its point, so the
/// rest is defined only for completeness: an integer is cut to the type's width (its low 16
/// or 32 bits in two's complement, e.g. 70000 as `u16` is 4464, -1 as `u16` is 65535); an
/// integer as `f32` is the nearest float; a float as an integer type is truncated towards
/// zero and saturated at the type's bounds (NaN is 0).
pub fn encode(v: PointValue, ty: RegisterType, order: WordOrder) -> [u16; 2] {
    let bits: u32 = match (ty, v) {
        (RegisterType::F32, PointValue::Float(f)) => f.to_bits(),
        (RegisterType::F32, PointValue::Unsigned(u)) => (u as f32).to_bits(),
        (RegisterType::F32, PointValue::Signed(i)) => (i as f32).to_bits(),
        (_, PointValue::Unsigned(u)) => u,
        (_, PointValue::Signed(i)) => i as u32,
        (RegisterType::U16, PointValue::Float(f)) => u32::from(f as u16),
        (RegisterType::I16, PointValue::Float(f)) => f as i16 as u16 as u32,
        (RegisterType::U32, PointValue::Float(f)) => f as u32,
        (RegisterType::I32, PointValue::Float(f)) => f as i32 as u32,
    };
    if ty.registers() == 1 {
        return [bits as u16, 0];
    }
    let (high, low) = ((bits >> 16) as u16, bits as u16);
    match order {
        WordOrder::HighFirst => [high, low],
        WordOrder::LowFirst => [low, high],
    }
}

/// The value carried by `words` as `ty` in `order`: `Unsigned` for `u16`/`u32`, `Signed` for
/// `i16`/`i32`, `Float` for `f32`. Missing words read as 0 (callers pass
/// `ty.registers()` words).
pub fn decode(words: &[u16], ty: RegisterType, order: WordOrder) -> PointValue {
    let w = |i: usize| u32::from(words.get(i).copied().unwrap_or(0));
    let bits = if ty.registers() == 1 {
        w(0)
    } else {
        match order {
            WordOrder::HighFirst => (w(0) << 16) | w(1),
            WordOrder::LowFirst => (w(1) << 16) | w(0),
        }
    };
    match ty {
        RegisterType::U16 | RegisterType::U32 => PointValue::Unsigned(bits),
        RegisterType::I16 => PointValue::Signed(i32::from(bits as u16 as i16)),
        RegisterType::I32 => PointValue::Signed(bits as i32),
        RegisterType::F32 => PointValue::Float(f32::from_bits(bits)),
    }
}

/// Why a value received from the network cannot be written to a point (see [`convert`]).
#[derive(Clone, Copy, Debug, PartialEq, thiserror::Error)]
pub enum Unfit {
    /// NaN or ±Inf: no point takes one from the network (docs/modbus.md, Bad values). The
    /// IEC engine's REAL arithmetic follows IEEE 754, but a value from outside that is not a
    /// number is a fault of the sender, refused where it enters.
    #[error("{} is not a finite number; points take only finite values from the network", show_float(*.0))]
    NotFinite(f32),
    /// A float with a fractional part into an integer point.
    #[error("{0} has a fractional part; the point holds whole numbers")]
    Fraction(f32),
    /// An integer outside the point's range (300 into a `u8`, -1 into an unsigned point).
    #[error("{value} is outside the point's range {min} to {max}")]
    OutOfRange { value: f64, min: i64, max: i64 },
}

/// `NaN`, `+Inf`, `-Inf` or the number.
fn show_float(f: f32) -> String {
    if f.is_nan() {
        "NaN".to_string()
    } else if f.is_infinite() {
        if f > 0.0 { "+Inf" } else { "-Inf" }.to_string()
    } else {
        f.to_string()
    }
}

/// Whether a value received from the network can be written to a point of `kind` and
/// `bits` (see [`convert`]).
pub fn fits(v: &PointValue, kind: PointKind, bits: u8) -> bool {
    convert(*v, kind, bits).is_ok()
}

/// `v` as the point of `kind` and `bits` holds it (the form `ModuleMap::set` takes), or why
/// it cannot: NaN or ±Inf into any point, an integer outside the point's range (300 into an
/// 8-bit point, -1 into an unsigned one), a float with a fractional part into an integer
/// point. An integer into a float point is converted to the nearest float (exact up to 2^24;
/// the modules never do it: a float point travels as `f32`).
pub fn convert(v: PointValue, kind: PointKind, bits: u8) -> Result<PointValue, Unfit> {
    let whole: f64 = match v {
        PointValue::Float(f) if !f.is_finite() => return Err(Unfit::NotFinite(f)),
        PointValue::Float(f) if kind == PointKind::Float => return Ok(PointValue::Float(f)),
        PointValue::Unsigned(u) if kind == PointKind::Float => {
            return Ok(PointValue::Float(u as f32))
        }
        PointValue::Signed(i) if kind == PointKind::Float => {
            return Ok(PointValue::Float(i as f32))
        }
        // Every integer a point holds (|v| < 2^32), and every f32, is exact in an f64.
        PointValue::Unsigned(u) => f64::from(u),
        PointValue::Signed(i) => f64::from(i),
        PointValue::Float(f) if f.fract() != 0.0 => return Err(Unfit::Fraction(f)),
        PointValue::Float(f) => f64::from(f),
    };
    let bits = u32::from(bits.clamp(1, 32));
    let signed = kind == PointKind::Signed;
    let (min, max) = if signed {
        (-(1i64 << (bits - 1)), (1i64 << (bits - 1)) - 1)
    } else {
        (0, (1i64 << bits) - 1)
    };
    if !(min as f64..=max as f64).contains(&whole) {
        return Err(Unfit::OutOfRange {
            value: whole,
            min,
            max,
        });
    }
    Ok(if signed {
        PointValue::Signed(whole as i32)
    } else {
        PointValue::Unsigned(whole as u32)
    })
}

/// A point as a coil or discrete input: any non-zero value is on.
pub fn to_bit(v: PointValue) -> bool {
    match v {
        PointValue::Unsigned(u) => u != 0,
        PointValue::Signed(i) => i != 0,
        PointValue::Float(f) => f != 0.0,
    }
}

/// A coil written from the network as a point of `kind`: 0 or 1 (0.0 or 1.0 for a float).
pub fn from_bit(on: bool, kind: PointKind) -> PointValue {
    match kind {
        PointKind::Unsigned => PointValue::Unsigned(u32::from(on)),
        PointKind::Signed => PointValue::Signed(i32::from(on)),
        PointKind::Float => PointValue::Float(if on { 1.0 } else { 0.0 }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use PointKind::{Float, Signed, Unsigned};
    use PointValue as V;
    use RegisterType::*;
    use WordOrder::*;

    #[test]
    fn parse_names_round_trip() {
        for ty in [U16, I16, U32, I32, F32] {
            assert_eq!(RegisterType::parse(ty.name()), Some(ty));
            assert_eq!(RegisterType::parse(&ty.name().to_uppercase()), Some(ty));
        }
        assert_eq!(RegisterType::parse("u8"), None);
        assert_eq!(WordOrder::parse("high_first"), Some(HighFirst));
        assert_eq!(WordOrder::parse("Low-First"), Some(LowFirst));
        assert_eq!(WordOrder::parse("big"), None);
        assert_eq!(
            [U16, I16, U32, I32, F32].map(RegisterType::registers),
            [1, 1, 2, 2, 2]
        );
    }

    #[test]
    fn default_types_follow_kind_and_width() {
        assert_eq!(default_type(Unsigned, 1), U16);
        assert_eq!(default_type(Unsigned, 16), U16);
        assert_eq!(default_type(Signed, 16), I16);
        assert_eq!(default_type(Unsigned, 17), U32);
        assert_eq!(default_type(Signed, 32), I32);
        assert_eq!(default_type(Float, 32), F32);
        for (kind, bits) in [
            (Unsigned, 1),
            (Unsigned, 32),
            (Signed, 8),
            (Signed, 20),
            (Float, 32),
        ] {
            assert!(
                default_type(kind, bits).holds(kind, bits),
                "{kind:?} {bits}"
            );
        }
    }

    #[test]
    fn holds_refuses_lossy_types() {
        assert!(!U16.holds(Signed, 8));
        assert!(!U16.holds(Unsigned, 17));
        assert!(!I16.holds(Unsigned, 16));
        assert!(I16.holds(Unsigned, 15));
        assert!(!F32.holds(Unsigned, 16));
        assert!(!I32.holds(Float, 32));
        assert!(I32.holds(Signed, 12));
    }

    #[test]
    fn word_orders_place_the_high_half() {
        let v = V::Unsigned(0x1234_5678);
        assert_eq!(encode(v, U32, HighFirst), [0x1234, 0x5678]);
        assert_eq!(encode(v, U32, LowFirst), [0x5678, 0x1234]);
        assert_eq!(decode(&[0x1234, 0x5678], U32, HighFirst), v);
        assert_eq!(decode(&[0x5678, 0x1234], U32, LowFirst), v);
        // 1.5f32 = 0x3FC00000
        assert_eq!(encode(V::Float(1.5), F32, HighFirst), [0x3FC0, 0]);
        assert_eq!(encode(V::Float(1.5), F32, LowFirst), [0, 0x3FC0]);
        assert_eq!(decode(&[0, 0x3FC0], F32, LowFirst), V::Float(1.5));
        // One-register types ignore the order.
        assert_eq!(encode(V::Unsigned(7), U16, LowFirst), [7, 0]);
    }

    #[test]
    fn signed_values_are_twos_complement() {
        assert_eq!(encode(V::Signed(-2), I16, HighFirst), [0xFFFE, 0]);
        assert_eq!(decode(&[0xFFFE], I16, HighFirst), V::Signed(-2));
        assert_eq!(encode(V::Signed(-2), I32, HighFirst), [0xFFFF, 0xFFFE]);
        assert_eq!(decode(&[0xFFFF, 0xFFFE], I32, HighFirst), V::Signed(-2));
        assert_eq!(decode(&[0xFFFF], U16, HighFirst), V::Unsigned(65535));
    }

    #[test]
    fn values_a_type_does_not_hold_are_cut_or_saturated() {
        assert_eq!(encode(V::Unsigned(70000), U16, HighFirst), [4464, 0]);
        assert_eq!(encode(V::Signed(-1), U16, HighFirst), [65535, 0]);
        assert_eq!(encode(V::Float(-7.9), I16, HighFirst), [(-7i16) as u16, 0]);
        assert_eq!(encode(V::Float(1e9), U16, HighFirst), [65535, 0]);
        assert_eq!(encode(V::Float(f32::NAN), U32, HighFirst), [0, 0]);
        assert_eq!(encode(V::Unsigned(3), F32, HighFirst), [0x4040, 0]);
    }

    #[test]
    fn decode_pads_missing_words() {
        assert_eq!(decode(&[0x0001], U32, HighFirst), V::Unsigned(0x1_0000));
        assert_eq!(decode(&[], U16, HighFirst), V::Unsigned(0));
    }

    #[test]
    fn fits_checks_the_point_range() {
        assert!(fits(&V::Unsigned(255), Unsigned, 8));
        assert!(!fits(&V::Unsigned(300), Unsigned, 8));
        assert!(!fits(&V::Signed(-1), Unsigned, 8));
        assert!(fits(&V::Signed(-128), Signed, 8));
        assert!(!fits(&V::Signed(-129), Signed, 8));
        assert!(!fits(&V::Unsigned(128), Signed, 8));
        assert!(fits(&V::Unsigned(u32::MAX), Unsigned, 32));
        assert!(fits(&V::Signed(i32::MIN), Signed, 32));
        assert!(fits(&V::Float(3.0), Unsigned, 2));
        assert!(!fits(&V::Float(3.5), Unsigned, 2));
        assert!(!fits(&V::Float(f32::INFINITY), Signed, 32));
        assert!(fits(&V::Float(f32::MAX), Float, 32));
        assert!(fits(&V::Float(f32::MIN_POSITIVE / 2.0), Float, 32));
        assert!(fits(&V::Unsigned(1), Unsigned, 1));
        assert!(!fits(&V::Unsigned(2), Unsigned, 1));
    }

    #[test]
    fn convert_gives_the_points_own_kind() {
        assert_eq!(convert(V::Unsigned(5), Signed, 8), Ok(V::Signed(5)));
        assert_eq!(convert(V::Signed(5), Unsigned, 8), Ok(V::Unsigned(5)));
        assert_eq!(convert(V::Signed(-3), Float, 32), Ok(V::Float(-3.0)));
        assert_eq!(convert(V::Float(-3.0), Signed, 4), Ok(V::Signed(-3)));
        assert_eq!(
            convert(V::Float(-9.0), Signed, 4),
            Err(Unfit::OutOfRange {
                value: -9.0,
                min: -8,
                max: 7
            })
        );
        assert_eq!(
            convert(V::Float(4294967296.0), Unsigned, 32).map_err(|e| e.to_string()),
            Err("4294967296 is outside the point's range 0 to 4294967295".to_string())
        );
        assert_eq!(convert(V::Float(0.5), Signed, 8), Err(Unfit::Fraction(0.5)));
    }

    #[test]
    fn no_point_takes_a_value_that_is_not_a_number() {
        for f in [f32::NAN, -f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            for (kind, bits) in [(Float, 32), (Signed, 32), (Unsigned, 16)] {
                assert!(
                    matches!(convert(V::Float(f), kind, bits), Err(Unfit::NotFinite(_))),
                    "{f} into {kind:?}"
                );
            }
        }
        // What the log says, for the registers 0x7FC0 0x0000 and 0xFF80 0x0000.
        let nan = decode(&[0x7FC0, 0], F32, HighFirst);
        assert_eq!(
            convert(nan, Float, 32).unwrap_err().to_string(),
            "NaN is not a finite number; points take only finite values from the network"
        );
        let minus_inf = decode(&[0xFF80, 0], F32, HighFirst);
        assert!(convert(minus_inf, Float, 32)
            .unwrap_err()
            .to_string()
            .starts_with("-Inf is not"));
    }

    #[test]
    fn bits_are_non_zero_and_zero_one() {
        assert!(to_bit(V::Unsigned(2)));
        assert!(to_bit(V::Signed(-1)));
        assert!(!to_bit(V::Float(0.0)));
        assert_eq!(from_bit(true, Unsigned), V::Unsigned(1));
        assert_eq!(from_bit(false, Signed), V::Signed(0));
        assert_eq!(from_bit(true, Float), V::Float(1.0));
    }

    #[test]
    fn every_held_value_round_trips() {
        let cases = [
            (V::Unsigned(65535), U16),
            (V::Signed(-32768), I16),
            (V::Unsigned(u32::MAX), U32),
            (V::Signed(i32::MIN), I32),
            (V::Float(-0.1), F32),
        ];
        for (v, ty) in cases {
            for order in [HighFirst, LowFirst] {
                assert_eq!(
                    decode(&encode(v, ty, order), ty, order),
                    v,
                    "{v:?} {ty} {order}"
                );
            }
        }
    }

    proptest::proptest! {
        /// Any registers as any type into any point the type may be read into: either the
        /// point takes a finite value that carries the same registers back, or it is refused.
        #[test]
        fn registers_from_the_network_are_taken_exactly_or_refused(
            words in proptest::array::uniform2(proptest::prelude::any::<u16>()),
            ty in proptest::sample::select(vec![U16, I16, U32, I32, F32]),
            order in proptest::sample::select(vec![HighFirst, LowFirst]),
            kind in proptest::sample::select(vec![Unsigned, Signed, Float]),
            bits in 1u8..=32,
        ) {
            let bits = if kind == Float { 32 } else { bits };
            let n = ty.registers();
            let v = decode(&words[..n], ty, order);
            match convert(v, kind, bits) {
                Ok(p) => {
                    if let V::Float(f) = p {
                        proptest::prop_assert!(f.is_finite());
                    }
                    proptest::prop_assert!(fits(&p, kind, bits));
                    if ty.holds(kind, bits) {
                        proptest::prop_assert_eq!(&encode(p, ty, order)[..n], &words[..n]);
                    }
                }
                Err(Unfit::NotFinite(f)) => proptest::prop_assert!(!f.is_finite()),
                Err(Unfit::Fraction(f)) => proptest::prop_assert!(f.fract() != 0.0),
                Err(Unfit::OutOfRange { value, min, max }) => {
                    proptest::prop_assert!(value < min as f64 || value > max as f64)
                }
            }
        }
    }
}
