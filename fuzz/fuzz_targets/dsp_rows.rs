//! Fuzzes the dsp module's `fblock` rows (petriplc-dsp's `Chain::parse`, which also designs
//! the filters): no input may panic, and a chain it accepts must scan any values, NaN and
//! infinities included, without panicking.

#![no_main]

use libfuzzer_sys::fuzz_target;
use petriplc_dsp::block::NumType;
use petriplc_dsp::chain::{Chain, Context, Points, Slot};

/// Any point name is a point: `i…` signed, `u…` unsigned, `b…` boolean, others f32.
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
        let index = self.names.iter().position(|n| n == name).unwrap_or_else(|| {
            self.names.push(name.to_string());
            self.names.len() - 1
        });
        Ok(Slot { index, ty })
    }
}

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let rows: Vec<Vec<String>> = text
        .lines()
        .map(|l| l.split_whitespace().map(String::from).collect())
        .collect();
    let mut points = Any::default();
    let ctx = Context {
        scan_period: Some(0.01),
    };
    if let Ok(mut chain) = Chain::parse(&rows, &mut points, &ctx) {
        let specials = [0.0, 1.0, -1.0, f64::NAN, f64::INFINITY, f64::NEG_INFINITY, 1e30, -3e9];
        let mut values = vec![0.0; points.names.len()];
        for k in 0..8 {
            for (i, v) in values.iter_mut().enumerate() {
                *v = specials[(i + k) % specials.len()];
            }
            chain.scan(&mut values, k as f64 * 0.01);
        }
        let _ = chain.describe();
    }
});
