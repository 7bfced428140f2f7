//! `fblock` rows made of the words the blocks know, numbers at their edges and point names,
//! in any order: reading them never panics (a row is accepted or refused with a message),
//! and an accepted chain scans NaN, infinities and huge values without panicking.

use petriplc_dsp::block::NumType;
use petriplc_dsp::chain::{Chain, Context, Points, Slot};
use proptest::prelude::*;

const WORDS: &[&str] = &[
    "typeconv",
    "add",
    "mult",
    "pow",
    "pid",
    "filter",
    "ramp",
    "nonlinear",
    "alarm",
    "multiplexor",
    "hysteresis",
    "delay",
    "source",
    "sp",
    "form",
    "ideal",
    "parallel",
    "max_out",
    "min_out",
    "d_on",
    "measurement",
    "error",
    "d_filter",
    "anti_windup",
    "clamp",
    "backcalc",
    "none",
    "tt",
    "rate",
    "mode",
    "manual",
    "iir",
    "fir",
    "butterworth",
    "chebyshev",
    "chebyshev2",
    "elliptic",
    "bessel",
    "lowpass",
    "highpass",
    "bandpass",
    "bandstop",
    "order",
    "ripple",
    "attenuation",
    "norm",
    "phase",
    "mag",
    "steady",
    "true_val",
    "abs_val",
    "hysteresis",
    "lt",
    "gt",
    "eq",
    "ne",
    "le",
    "ge",
    "time",
    "sine",
    "square",
    "triangle",
    "step",
    "amplitude",
    "frequency",
    "offset",
    "start",
    "dxdt",
    "d2xdt2",
    "pos_d2xdt2",
    "cutoff_top",
    "deadband_bot",
    "gain",
    "kaiser",
    "hann",
    "i32",
    "u32",
    "f32",
    "0",
    "1",
    "-1",
    "0.5",
    "2",
    "3",
    "4",
    "10",
    "20",
    "40",
    "49.9",
    "50",
    "1e30",
    "nan",
    "inf",
    "-0",
    "33",
    "0.001",
    "4096",
    "a",
    "b",
    "c",
    "i1",
    "u1",
    "bool1",
];

/// Any name is a point: `i…` signed 16-bit, `u…` unsigned, `b…` boolean, others f32.
#[derive(Default)]
struct Any {
    names: Vec<String>,
}

impl Points for Any {
    fn slot(&mut self, name: &str, _write: bool) -> Result<Slot, String> {
        let ty = match name.as_bytes().first() {
            Some(b'i') => NumType::Signed(16),
            Some(b'u') => NumType::Unsigned(32),
            Some(b'b') => NumType::Unsigned(1),
            _ => NumType::F32,
        };
        let index = match self.names.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                self.names.push(name.to_string());
                self.names.len() - 1
            }
        };
        Ok(Slot { index, ty })
    }
}

fn row() -> impl Strategy<Value = Vec<String>> {
    prop::collection::vec(prop::sample::select(WORDS), 1..14)
        .prop_map(|w| w.into_iter().map(String::from).collect())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]
    #[test]
    fn rows_never_panic(rows in prop::collection::vec(row(), 1..4)) {
        let mut points = Any::default();
        let ctx = Context { scan_period: Some(0.01) };
        match Chain::parse(&rows, &mut points, &ctx) {
            Err(errors) => {
                prop_assert!(!errors.is_empty());
                prop_assert!(errors.iter().all(|(i, e)| *i < rows.len() && !e.is_empty()));
            }
            Ok(mut chain) => {
                let specials = [0.0, 1.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e30, -3e9];
                let mut values = vec![0.0; points.names.len()];
                for k in 0..6 {
                    for (i, v) in values.iter_mut().enumerate() {
                        *v = specials[(i + k) % specials.len()];
                    }
                    chain.scan(&mut values, k as f64 * 0.01);
                }
                prop_assert_eq!(chain.describe().is_empty(), chain.is_empty());
            }
        }
    }
}
