//! The `dsp` module's whole scan as the runner frames it (the harness: `update()`, the scan
//! reading and writing its points through the module's map, `update()`), for 1000 mixed
//! blocks on 1000-odd f32 points: what a user's PLC pays per scan.

use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

fn config(n: usize) -> String {
    let mut text = String::from("[PLC]\nmodule dsp dsp\n");
    for k in 0..=n {
        text += &format!("point p{k} \"\" dsp f32\n");
    }
    for k in 0..n {
        text += &format!("point a{k} \"\" dsp\n");
    }
    text += "[dsp]\nscan_period = 0.001\n";
    for k in 0..n {
        let (i, o) = (format!("p{k}"), format!("p{}", k + 1));
        text += &match k % 10 {
            0 => format!("fblock add {o} {i} 0.5 p0 0.25\n"),
            1 => format!("fblock mult {o} {i} 1 p0 0.5\n"),
            2 => format!("fblock pid {i} {o} 2 0.1 0.05 sp p0 min_out -100 max_out 100\n"),
            3 => format!("fblock filter {i} {o} butterworth lowpass 1 order 4 20\n"),
            4 => format!("fblock ramp {i} {o} dxdt 10 d2xdt2 100\n"),
            5 => format!("fblock nonlinear {i} {o} cutoff_top 50 cutoff_bot -50\n"),
            6 => format!(
                "fblock alarm {i} true_val hysteresis 0.5 a{k} gt 10\nfblock add {o} {i} 1\n"
            ),
            7 => format!("fblock multiplexor {o} p0 {i} 0 p1\n"),
            8 => format!("fblock pow {o} {i} 2\n"),
            _ => format!("fblock delay {i} {o} 5\n"),
        };
    }
    text
}

fn bench(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let mut plc =
        petriplc_runtime::harness::start(&config(1000), dir.path(), petriplc_modules::builtin)
            .unwrap_or_else(|e| panic!("{e}"));
    let mut k = 0u64;
    let mut group = c.benchmark_group("dsp_module");
    group.throughput(Throughput::Elements(1000));
    group.bench_function("scan_1000_blocks_with_points", |b| {
        b.iter(|| {
            k += 1;
            plc.tick(Duration::from_millis(k)).unwrap();
        })
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
