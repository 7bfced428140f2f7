//! The bare-loop measurement of `testdata/anchors/cyclic.c`, taken through [`Period`]:
//! wake up at every deadline of a fixed period and record how late each wake-up was.
//!
//! Usage: `cyclic PERIOD_US SECONDS [--rt PRIORITY]`. Prints on stdout, in cyclic.c's format,
//! `wakeups N p50_us X p99_us Y max_us Z` (sorted exact percentiles over all wake-ups, ranks
//! n/2 and ⌊0.99·n⌋ as cyclic.c), and on stderr the [`ScanStats`] line and any real-time warning.
//! `bench/scan_timing.sh` runs it against cyclic.c.

use std::process::ExitCode;
use std::time::Duration;

use petriplc_runtime::period::{now, realtime, Period, ScanStats};

fn usage() -> ExitCode {
    eprintln!("usage: cyclic PERIOD_US SECONDS [--rt PRIORITY]");
    ExitCode::from(2)
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (period_us, seconds, rt) = match args.as_slice() {
        [p, s] => (p, s, None),
        [p, s, flag, prio] if flag == "--rt" => (p, s, Some(prio)),
        _ => return usage(),
    };
    let (Ok(period_us), Ok(seconds)) = (period_us.parse::<u64>(), seconds.parse::<f64>()) else {
        return usage();
    };
    let rt = match rt.map(|p| p.parse::<u8>()) {
        None => None,
        Some(Ok(p)) => Some(p),
        Some(Err(_)) => return usage(),
    };
    let period_ns = period_us * 1000;
    let n = (seconds * 1e9 / period_ns as f64) as usize;
    if n == 0 {
        eprintln!("cyclic: {seconds} s holds no period of {period_us} µs");
        return ExitCode::from(2);
    }

    for warning in realtime(rt) {
        eprintln!("warning: {warning}");
    }
    // Allocated up front, like cyclic.c's malloc, so the loop itself never allocates.
    let mut late = Vec::with_capacity(n);
    let mut stats = ScanStats::new();
    let mut period = Period::new(Duration::from_nanos(period_ns));
    for _ in 0..n {
        let wake = period.wait();
        late.push(wake.late.as_nanos() as u64);
        stats.record(now().saturating_sub(wake.woke()), wake.late, wake.missed);
    }

    late.sort_unstable();
    let us = |i: usize| late[i] as f64 / 1e3;
    println!(
        "wakeups {n} p50_us {:.1} p99_us {:.1} max_us {:.1}",
        us(n / 2),
        us((n as f64 * 0.99) as usize),
        us(n - 1)
    );
    eprintln!("{stats}");
    ExitCode::SUCCESS
}
