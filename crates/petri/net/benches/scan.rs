//! The cost of one PLC scan on N independent copies of seed 002's mixer net (8 places of
//! capacity 1, 4 transitions guarded by their input signals), with every input TRUE so that
//! each copy advances every scan. Throughput is counted in transitions, so criterion also
//! reports the time per transition.
//!
//! Run: `cargo bench -p petriplc-net --bench scan -- --quick`

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use petriplc_net::guard::parse;
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, Net, NetBuilder, PlaceSpec, ScanOptions, Scanner, StepRule,
    TransitionSpec,
};

/// Seed 002's mixer, copy by copy: places L1 A1 V1 L2 V2 M1 V3 L3 (capacity 1, L1 marked),
/// transitions B1: L1 → A1 V1 L2; N2: V1 → V2 M1; N3: V2 M1 A1 L2 → V3 L3; N1: V3 L3 → L1,
/// each guarded by the input signal of its name with the copy's suffix.
fn mixers(n: usize) -> Net {
    let mut b = NetBuilder::new("mixers", "mixers");
    for c in 0..n {
        for p in ["L1", "A1", "V1", "L2", "V2", "M1", "V3", "L3"] {
            b.place(PlaceSpec {
                id: format!("{p}_{c}"),
                name: format!("{p}_{c}"),
                initial: u32::from(p == "L1"),
                capacity: Some(1),
                ..Default::default()
            });
        }
        let transitions: [(&str, &[&str], &[&str]); 4] = [
            ("B1", &["L1"], &["A1", "V1", "L2"]),
            ("N2", &["V1"], &["V2", "M1"]),
            ("N3", &["V2", "M1", "A1", "L2"], &["V3", "L3"]),
            ("N1", &["V3", "L3"], &["L1"]),
        ];
        for (t, pre, post) in transitions {
            let id = format!("{t}_{c}");
            b.transition(TransitionSpec {
                id: id.clone(),
                name: id.clone(),
                guard: parse(&id).unwrap(),
            });
            let arcs = pre
                .iter()
                .map(|p| (format!("{p}_{c}"), id.clone()))
                .chain(post.iter().map(|p| (id.clone(), format!("{p}_{c}"))));
            for (i, (source, target)) in arcs.enumerate() {
                b.arc(ArcSpec {
                    id: format!("{id}_a{i}"),
                    source,
                    target,
                    kind: ArcKind::Normal,
                    weight: 1,
                    delay: None,
                });
            }
        }
    }
    b.build().unwrap()
}

fn bench_scan(c: &mut Criterion, group_name: &str, step: StepRule, sizes: &[usize]) {
    let mut group = c.benchmark_group(group_name);
    for &n in sizes {
        let net = mixers(n);
        group.throughput(Throughput::Elements(net.transitions().len() as u64));
        group.bench_with_input(BenchmarkId::from_parameter(n), &net, |b, net| {
            let options = ScanOptions {
                step,
                evolve: Evolution::OnePass,
                ..ScanOptions::of(net)
            };
            let mut scanner = Scanner::new(net, options);
            // Every input TRUE: every copy fires a transition each scan (maximal-step) or its
            // whole cycle (sequential), for as long as the benchmark runs.
            let mut signals = vec![1i64; net.signals().len()];
            let mut now = Duration::ZERO;
            let period = Duration::from_millis(10);
            scanner.scan(now, &mut signals).unwrap();
            assert!(!scanner.fired().is_empty(), "the copies must advance");
            b.iter(|| {
                now += period;
                scanner
                    .scan(black_box(now), black_box(&mut signals))
                    .unwrap();
            });
            assert_eq!(
                scanner.fired().len(),
                if step == StepRule::MaximalStep {
                    n
                } else {
                    4 * n
                }
            );
        });
    }
    group.finish();
}

fn scan(c: &mut Criterion) {
    bench_scan(
        c,
        "scan/maximal-step",
        StepRule::MaximalStep,
        &[1, 10, 100, 1000],
    );
    bench_scan(c, "scan/sequential", StepRule::Sequential, &[1000]);
}

criterion_group!(benches, scan);
criterion_main!(benches);
