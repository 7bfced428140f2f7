//! `update()` of a module map against a plain `memcpy` of the same words, measured in turns
//! in one process: petriplc's side of bench/update.sh. Prints one line per shape with the
//! median time of each and the median of the per-round ratios.
//!
//! `cargo run --release -p petriplc-runtime --example update-ratio -- [WORDS] [ROUNDS]`

use std::hint::black_box;
use std::time::Instant;

use petriplc_config::Location;
use petriplc_runtime::image::{GlobalMap, ModuleMap};

#[path = "../benches/common/layouts.rs"]
mod layouts;
use layouts::layout;

/// The median time of one call over 15 batches of 50 calls, in ns.
fn time(mut f: impl FnMut()) -> f64 {
    let mut v: Vec<f64> = (0..15)
        .map(|_| {
            let t = Instant::now();
            for _ in 0..50 {
                f();
            }
            t.elapsed().as_nanos() as f64 / 50.0
        })
        .collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let mut args = std::env::args().skip(1);
    let n: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(65536);
    let rounds: usize = args.next().and_then(|a| a.parse().ok()).unwrap_or(9);
    let src = vec![0x5555_5555u32; n];
    let mut buf = vec![0u32; n + 1024];
    // The destination at the source's page offset, as ModuleMap places its private copy
    // (glibc's memcpy is much slower at some small distances modulo 4 KiB).
    let skip = ((src.as_ptr() as usize + 4096 - buf.as_ptr() as usize % 4096) % 4096) / 4;
    let dst = &mut buf[skip..skip + n];
    for (shape, interleaved) in [("interleaved", true), ("blocks", false)] {
        let l = layout(n, interleaved);
        let id = format!("update-ratio-{}-{shape}", std::process::id());
        let global = match GlobalMap::create(&id, &l) {
            Ok(g) => g,
            Err(e) => {
                eprintln!("update-ratio: {e}");
                std::process::exit(1);
            }
        };
        let mut map = ModuleMap::new(&l, "m1", Location::Local).expect("map");
        let (mut us, mut ms, mut rs) = (Vec::new(), Vec::new(), Vec::new());
        for _ in 0..rounds {
            let u = time(|| map.update(black_box(&global)));
            let m = time(|| dst.copy_from_slice(black_box(&src)));
            us.push(u);
            ms.push(m);
            rs.push(u / m);
        }
        println!(
            "{shape} words={n} update_ns={:.0} memcpy_ns={:.0} ratio={:.2}",
            median(us),
            median(ms),
            median(rs)
        );
    }
}
