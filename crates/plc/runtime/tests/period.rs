//! `Period` on the real clock, checked for logic only: deadline indices, the t0 + k·T grid and
//! statistics bookkeeping. No assertion depends on how punctual the machine is, so the test
//! passes on a loaded CI runner too.

use std::time::Duration;

use petriplc_runtime::period::{now, Period, ScanStats};

#[test]
fn twenty_short_periods_stay_on_the_grid() {
    let mut period = Period::new(Duration::from_millis(2));
    let schedule = *period.schedule();
    let mut stats = ScanStats::new();
    let mut last_k = 0;
    for _ in 0..20 {
        let wake = period.wait();
        // A scan that overran (a slow runner) skips deadlines; either way k moves forward by
        // exactly one plus the deadlines it missed.
        assert_eq!(wake.k, last_k + 1 + wake.missed);
        assert_eq!(wake.deadline, schedule.deadline(wake.k));
        assert!(wake.woke() >= wake.deadline);
        last_k = wake.k;
        stats.record(now().saturating_sub(wake.woke()), wake.late, wake.missed);
    }
    assert_eq!(stats.scans(), 20);
    assert_eq!(stats.overruns(), last_k - 20);
    let late = stats.lateness().expect("twenty scans recorded");
    assert!(late.p50 <= late.p99 && late.p99 <= late.max);
    assert!(stats.cycle_min() <= stats.cycle_mean() && stats.cycle_mean() <= stats.cycle_max());
    assert!(stats.to_string().starts_with("scans 20 "));
}

#[test]
fn an_overrun_is_counted_and_skipped_not_caught_up() {
    let mut period = Period::new(Duration::from_millis(1));
    // Sleep well past several deadlines: at least three are missed whatever the scheduling delay.
    std::thread::sleep(Duration::from_millis(4));
    let wake = period.wait();
    assert!(wake.missed >= 3, "{wake:?}");
    assert_eq!(wake.k, 1 + wake.missed);
    // Deadlines skipped are not owed: the next wait is for the following deadline.
    let next = period.wait();
    assert_eq!(next.k, wake.k + 1 + next.missed);
}

#[test]
fn a_shared_time_frame_in_the_future_waits_for_t0_plus_t() {
    let t0 = now() + Duration::from_millis(3);
    let mut period = Period::starting_at(t0, Duration::from_millis(1));
    let wake = period.wait();
    // The first deadline is t0 + T: never earlier. (A thread preempted for more than 4 ms
    // before it waits finds that deadline and maybe more passed: they count as missed.)
    assert!(wake.woke() >= t0 + Duration::from_millis(1), "{wake:?}");
    assert_eq!(wake.k, 1 + wake.missed, "{wake:?}");
    assert_eq!(
        wake.deadline,
        t0 + Duration::from_millis(1) * (wake.k as u32)
    );
}
