//! `ModuleMap::update()` against a plain copy of the same number of words: MatPLC's update is
//! the shared bottleneck, so its cost should stay within a small factor of a memcpy.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use petriplc_config::Location;
use petriplc_runtime::image::{GlobalMap, ModuleMap};

#[path = "common/layouts.rs"]
mod layouts;
use layouts::layout;

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("update");
    for (label, n) in [("1k", 1024usize), ("64k", 65536)] {
        group.throughput(Throughput::Bytes(4 * n as u64));
        for (shape, interleaved) in [("interleaved", true), ("blocks", false)] {
            let layout = layout(n, interleaved);
            let id = format!("bench-{}-{label}-{shape}", std::process::id());
            let global = GlobalMap::create(&id, &layout).unwrap();
            let mut map = ModuleMap::new(&layout, "m1", Location::Local).unwrap();
            group.bench_function(BenchmarkId::new(format!("update-{shape}"), label), |b| {
                b.iter(|| map.update(black_box(&global)))
            });
        }
        let src = vec![0x5555_5555u32; n];
        let mut dst = vec![0u32; n + 1024];
        // Two allocations in a row can land 16 bytes apart modulo 4 KiB, where glibc's
        // `rep movsb` memcpy is 15-25x slower on AMD Zen (BZ 30994): place the destination
        // at the source's page offset, as `ModuleMap` places its private copy.
        let skip = ((src.as_ptr() as usize + 4096 - dst.as_ptr() as usize % 4096) % 4096) / 4;
        let dst = &mut dst[skip..skip + n];
        group.bench_function(BenchmarkId::new("memcpy", label), |b| {
            b.iter(|| dst.copy_from_slice(black_box(&src)))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
