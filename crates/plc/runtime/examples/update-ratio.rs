//! `update()` of a module map against a plain `memcpy` of the same words, measured in turns
//! in one process: petriplc's side of bench/update.sh. Prints one line per shape with the
//! median time of each and the median of the per-round ratios.
//!
//! Shapes: the module owns every fourth word (`interleaved`) or a quarter of the image in one
//! block (`blocks`), with nothing changed between updates (a steady scan); and interleaved
//! with every word changed before each update (`interleaved-changed`: the other modules wrote
//! all their words, this module all of its own; the memcpy's source is rewritten likewise),
//! the writes untimed.
//!
//! `cargo run --release -p petriplc-runtime --example update-ratio -- [WORDS] [ROUNDS]`

use std::hint::black_box;
use std::time::{Duration, Instant};

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

/// As [`time`] for a `call` that times only part of itself and returns that time.
fn time_each(mut call: impl FnMut() -> Duration) -> f64 {
    let mut v: Vec<f64> = (0..15)
        .map(|_| (0..50).map(|_| call()).sum::<Duration>().as_nanos() as f64 / 50.0)
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
    // Two sources and destinations: one memcpy is the anchor; two, the traffic of any
    // exchange of interleaved words (every line of both images read and written).
    let mut src = [vec![0x5555_5555u32; n], vec![0x3333_3333u32; n]];
    let mut bufs = [vec![0u32; n + 1024], vec![0u32; n + 1024]];
    // Each destination at its source's page offset, as ModuleMap places its private copy
    // (glibc's memcpy is much slower at some small distances modulo 4 KiB).
    let [d0, d1] = &mut bufs;
    let [dst, dst2] = [(d0, &src[0]), (d1, &src[1])].map(|(buf, src)| {
        let skip = ((src.as_ptr() as usize + 4096 - buf.as_ptr() as usize % 4096) % 4096) / 4;
        &mut buf[skip..skip + n]
    });
    for (shape, interleaved, changed) in [
        ("interleaved", true, false),
        ("interleaved-changed", true, true),
        ("blocks", false, false),
    ] {
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
        let owned: Vec<_> = (0..n)
            .map(|i| map.handle(&format!("p{i}")).expect("point"))
            .filter(|h| map.owns(h))
            .collect();
        let mask = map.mask().to_vec();
        let mut round = 0u32;
        let (mut us, mut ms, mut twos, mut rs) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for _ in 0..rounds {
            let (u, m, two) = if changed {
                let u = time_each(|| {
                    round = round.wrapping_add(1);
                    // The other modules' words, as their updates would leave them.
                    let mut g = global.lock();
                    for (w, m) in g.words_mut().iter_mut().zip(&mask) {
                        *w = (*w & m) | (round & !m);
                    }
                    drop(g);
                    for h in &owned {
                        map.set_u32(h, round.wrapping_mul(3)).expect("set");
                    }
                    let t = Instant::now();
                    map.update(black_box(&global));
                    t.elapsed()
                });
                let m = time_each(|| {
                    src[0].iter_mut().for_each(|w| *w = w.wrapping_add(1));
                    let t = Instant::now();
                    dst.copy_from_slice(black_box(&src[0]));
                    t.elapsed()
                });
                let two = time_each(|| {
                    for s in &mut src {
                        s.iter_mut().for_each(|w| *w = w.wrapping_add(1));
                    }
                    let t = Instant::now();
                    dst.copy_from_slice(black_box(&src[0]));
                    dst2.copy_from_slice(black_box(&src[1]));
                    t.elapsed()
                });
                (u, m, two)
            } else {
                (
                    time(|| map.update(black_box(&global))),
                    time(|| dst.copy_from_slice(black_box(&src[0]))),
                    time(|| {
                        dst.copy_from_slice(black_box(&src[0]));
                        dst2.copy_from_slice(black_box(&src[1]));
                    }),
                )
            };
            us.push(u);
            ms.push(m);
            twos.push(two);
            rs.push(u / m);
        }
        println!(
            "{shape} words={n} update_ns={:.0} memcpy_ns={:.0} two_ns={:.0} ratio={:.2}",
            median(us),
            median(ms),
            median(twos),
            median(rs)
        );
    }
}
