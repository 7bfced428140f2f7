//! A dsp module's scan: a chain of 1000 mixed blocks (every kind, as a large MatPLC
//! configuration would have them) and a chain of filters with 1000 second-order sections
//! in all, run over their point values as `Chain::scan` does every PLC scan.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use petriplc_dsp::block::NumType;
use petriplc_dsp::chain::{Chain, Context, Points, Slot};

/// Points `p0`, `p1`, … (f32, owned) and `i0`, … (i32), each its own slot.
#[derive(Default)]
struct Table {
    names: Vec<String>,
}

impl Points for Table {
    fn slot(&mut self, name: &str, _write: bool) -> Result<Slot, String> {
        let ty = if name.starts_with('i') {
            NumType::Signed(32)
        } else {
            NumType::F32
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

fn cells(row: &str) -> Vec<String> {
    row.split_whitespace().map(String::from).collect()
}

/// 1000 rows cycling through the kinds, each reading the previous block's output.
fn mixed(n: usize) -> Vec<Vec<String>> {
    (0..n)
        .map(|k| {
            let (i, o) = (format!("p{k}"), format!("p{}", k + 1));
            cells(&match k % 12 {
                0 => format!("add {o} {i} 0.5 p0 0.25"),
                1 => format!("mult {o} {i} 1 p0 0.5"),
                2 => format!("pid {i} {o} 2 0.1 0.05 sp p0 min_out -100 max_out 100 d_filter 0.01"),
                3 => format!("filter {i} {o} butterworth lowpass 1 order 4 20"),
                4 => format!("ramp {i} {o} dxdt 10 d2xdt2 100"),
                5 => format!(
                    "nonlinear {i} {o} cutoff_top 50 cutoff_bot -50 deadband_bot -1 deadband_top 1"
                ),
                6 => format!("alarm {i} true_val hysteresis 0.5 a{k} gt 10 b{k} lt -10"),
                7 => format!("multiplexor {o} p0 {i} 0 p1"),
                8 => format!("pow {o} {i} 2"),
                9 => format!("delay {i} {o} 5"),
                10 => format!("typeconv {i} f32 i{k} i32"),
                _ => format!("hysteresis {i} h{k} 5 -5"),
            })
        })
        .collect()
}

/// Filters of ten sections each (`iir` rows), `sections` sections in all.
fn filters(sections: usize) -> Vec<Vec<String>> {
    let section = "-1.6 0.8 -1.5 0.7";
    (0..sections / 10)
        .map(|k| {
            let coeffs = [section; 10].join(" ");
            cells(&format!("filter p{k} p{} iir 0.01 {coeffs}", k + 1))
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let ctx = Context {
        scan_period: Some(0.001),
    };
    let mut group = c.benchmark_group("dsp_scan");
    for (name, rows, per) in [
        ("mixed_1000_blocks", mixed(1000), 1000u64),
        ("sos_1000_sections", filters(1000), 1000u64),
    ] {
        let mut table = Table::default();
        let mut chain = Chain::parse(&rows, &mut table, &ctx).unwrap();
        let mut values: Vec<f64> = (0..table.names.len()).map(|i| (i % 7) as f64).collect();
        let mut t = 0.0f64;
        group.throughput(Throughput::Elements(per));
        group.bench_function(name, |b| {
            b.iter(|| {
                t += 0.001;
                values[0] = (t * 50.0).sin();
                chain.scan(black_box(&mut values), t);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
