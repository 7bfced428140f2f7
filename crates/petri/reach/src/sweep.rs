//! Parallel sweeps over a range of state numbers, in chunks taken from a shared counter: used
//! by the state space (rebuilding its index) and the strongly connected components.

use std::sync::atomic::{AtomicU64, Ordering};

/// States per unit of work in a parallel sweep.
const SWEEP_CHUNK: u64 = 2048;

/// Runs `f(lo, hi)` over `a..b` in chunks on `threads` threads.
pub(crate) fn parallel(threads: usize, a: u64, b: u64, f: impl Fn(u64, u64) + Sync) {
    if b <= a {
        return;
    }
    if threads <= 1 || b - a <= SWEEP_CHUNK {
        f(a, b);
        return;
    }
    let next = AtomicU64::new(a);
    std::thread::scope(|sc| {
        for _ in 0..threads {
            sc.spawn(|| loop {
                let lo = next.fetch_add(SWEEP_CHUNK, Ordering::Relaxed);
                if lo >= b {
                    return;
                }
                f(lo, (lo + SWEEP_CHUNK).min(b));
            });
        }
    });
}
