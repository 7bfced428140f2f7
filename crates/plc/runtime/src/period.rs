//! Scan periods on absolute deadlines (MatPLC's period library, rebuilt), per-module scan
//! statistics, and the real-time set-up of a module process.
//!
//! A module's scans are enabled at t0, t0+T, t0+2T, … where t0 is the instant the first scan
//! started (`scan_period` in the MatPLC configuration). Each deadline is computed as
//! `t0 + k·T` in integer nanoseconds, never by adding T to the previous deadline, so no error
//! accumulates however long the PLC runs. A module finishing its scan first waits for its
//! period ([`Period::wait`]) and then synchronises with the others.
//!
//! [`Schedule`] is the pure arithmetic (time passed in, no clock) and is what the unit tests
//! exercise; [`Period`] puts it on `CLOCK_MONOTONIC` with `clock_nanosleep(TIMER_ABSTIME)`.
//!
//! Overruns: when a scan runs past one or more deadlines, MatPLC's alarm counter would hold
//! one pending alarm per missed deadline and the module would run the missed scans back to
//! back. Here the missed deadlines are counted as overruns and the module waits for the next
//! deadline still in the future: a burst of catch-up scans only samples the same inputs again
//! and delays the rest of the PLC, while staying on the t0 + k·T grid keeps the phase that the
//! other modules and the I/O expect.

// nix wraps clock_nanosleep and mlockall but not sched_setscheduler / sched_get_priority_*;
// those three libc calls are the only unsafe code here.
#![allow(unsafe_code)]

use std::fmt;
use std::time::Duration;

use nix::errno::Errno;
use nix::sys::mman::{mlockall, MlockAllFlags};
use nix::sys::resource::{getrlimit, Resource};
use nix::sys::time::TimeSpec;
use nix::time::{clock_gettime, clock_nanosleep, ClockId, ClockNanosleepFlags};

const NANOS_PER_SEC: u128 = 1_000_000_000;

/// A `u128` count of nanoseconds as a `Duration`, saturating: only reachable for deadlines
/// hundreds of years out, where saturating is as good as exact.
fn duration_from_nanos(nanos: u128) -> Duration {
    match u64::try_from(nanos / NANOS_PER_SEC) {
        Ok(secs) => Duration::new(secs, (nanos % NANOS_PER_SEC) as u32),
        Err(_) => Duration::MAX,
    }
}

/// The deadlines t0 + k·T of one module, with times as `Duration`s since the clock's epoch
/// (for [`Period`], the boot-relative `CLOCK_MONOTONIC`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    t0: Duration,
    period: Duration,
}

/// Where a module stands after a scan: which deadline it waits for next and how many it
/// let pass.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Step {
    /// Index of the deadline to wait for.
    pub k: u64,
    /// `t0 + k·T`, strictly after the `now` the step was computed at.
    pub deadline: Duration,
    /// Deadlines from the one that was due up to `now` (inclusive) that the scan overran.
    pub missed: u64,
}

impl Schedule {
    /// # Panics
    /// If `period` is zero: a free-running module (no `scan_period`) has no schedule.
    pub fn new(t0: Duration, period: Duration) -> Self {
        assert!(!period.is_zero(), "a scan period must be longer than zero");
        Self { t0, period }
    }

    pub fn t0(&self) -> Duration {
        self.t0
    }

    pub fn period(&self) -> Duration {
        self.period
    }

    /// `t0 + k·T`, exact to the nanosecond.
    pub fn deadline(&self, k: u64) -> Duration {
        // One multiplication from t0, so the k-th deadline inherits no rounding from earlier ones.
        self.period
            .as_nanos()
            .checked_mul(u128::from(k))
            .and_then(|n| n.checked_add(self.t0.as_nanos()))
            .map_or(Duration::MAX, duration_from_nanos)
    }

    /// The first deadline strictly after `now`, as `(k, t0 + k·T)`; before t0 that is t0 itself.
    ///
    /// A deadline equal to `now` counts as passed: a module that reaches it with no time left
    /// has used its whole period, and the deadline it waits for next is always in the future,
    /// so lateness is only ever measured against a deadline the module actually slept to.
    pub fn next_after(&self, now: Duration) -> (u64, Duration) {
        let k = match now.checked_sub(self.t0) {
            None => 0,
            Some(since) => {
                let k = since.as_nanos() / self.period.as_nanos() + 1;
                u64::try_from(k).unwrap_or(u64::MAX)
            }
        };
        (k, self.deadline(k))
    }

    /// The module was due to wait for deadline `due` and its scan ended at `now`: the deadline to
    /// wait for and the number of deadlines (from `due` on) that `now` is at or past.
    pub fn step(&self, due: u64, now: Duration) -> Step {
        let (k, deadline) = self.next_after(now);
        if k <= due {
            Step {
                k: due,
                deadline: self.deadline(due),
                missed: 0,
            }
        } else {
            Step {
                k,
                deadline,
                missed: k - due,
            }
        }
    }
}

/// `CLOCK_MONOTONIC` now, the clock [`Period`] sleeps on.
pub fn now() -> Duration {
    // CLOCK_MONOTONIC exists on every Linux the runtime supports; only a bad clock id fails.
    clock_gettime(ClockId::CLOCK_MONOTONIC)
        .expect("CLOCK_MONOTONIC is always readable")
        .into()
}

/// Sleeps until `deadline` on `CLOCK_MONOTONIC`.
fn sleep_until(deadline: Duration) {
    let request = TimeSpec::from(deadline);
    loop {
        match clock_nanosleep(
            ClockId::CLOCK_MONOTONIC,
            ClockNanosleepFlags::TIMER_ABSTIME,
            &request,
        ) {
            // An absolute sleep can simply be restarted after a signal: the deadline has not moved.
            Err(Errno::EINTR) => continue,
            // EINVAL is only possible for a deadline past the end of time_t; returning at once
            // shows up as lateness rather than hanging the module.
            _ => return,
        }
    }
}

/// What [`Period::wait`] returns at the start of each scan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wake {
    /// Index of the deadline this scan started on (t0 + k·T).
    pub k: u64,
    pub deadline: Duration,
    /// Wake-up time minus deadline: the scheduling latency this scan started with.
    pub late: Duration,
    /// Deadlines the previous scan overran (skipped, not caught up).
    pub missed: u64,
}

impl Wake {
    /// The `CLOCK_MONOTONIC` time the module woke up, the start of its scan.
    pub fn woke(&self) -> Duration {
        self.deadline.saturating_add(self.late)
    }
}

/// A module's scan period on `CLOCK_MONOTONIC`.
///
/// ```no_run
/// use petriplc_runtime::period::{now, Period, ScanStats};
/// use std::time::Duration;
///
/// let mut period = Period::new(Duration::from_millis(10));
/// let mut stats = ScanStats::new();
/// loop {
///     let wake = period.wait();
///     // ... synchronise, update(), scan ...
///     stats.record(now().saturating_sub(wake.woke()), wake.late, wake.missed);
/// }
/// ```
#[derive(Clone, Debug)]
pub struct Period {
    schedule: Schedule,
    due: u64,
}

impl Period {
    /// A period whose t0 is now: the scan about to run is scan 0, the first wait is for t0 + T.
    ///
    /// # Panics
    /// If `period` is zero (see [`Schedule::new`]).
    pub fn new(period: Duration) -> Self {
        Self::starting_at(now(), period)
    }

    /// A period on a given time frame, e.g. one t0 shared by modules that must keep in phase, or
    /// the t0 of a previous instance of the module that is being replaced on-line.
    pub fn starting_at(t0: Duration, period: Duration) -> Self {
        Self {
            schedule: Schedule::new(t0, period),
            due: 1,
        }
    }

    pub fn schedule(&self) -> &Schedule {
        &self.schedule
    }

    /// Sleeps until the next deadline still in the future; deadlines already passed are counted
    /// in [`Wake::missed`] and skipped (see the module documentation for why no burst).
    pub fn wait(&mut self) -> Wake {
        let step = self.schedule.step(self.due, now());
        sleep_until(step.deadline);
        let woke = now();
        self.due = step.k.saturating_add(1);
        Wake {
            k: step.k,
            deadline: step.deadline,
            late: woke.saturating_sub(step.deadline),
            missed: step.missed,
        }
    }
}

/// A log-linear histogram of nanosecond values in a fixed 15 KiB: values below 64 ns are exact,
/// above that each power of two is split into 32 buckets, so a percentile is reported as the top
/// of its bucket, never below the exact value and at most 1/32 (3.1 %) above it.
#[derive(Clone, Debug)]
struct Histogram {
    counts: Box<[u64]>,
    total: u64,
    max: u64,
}

const SUB_BITS: u32 = 5;
const SUB: u64 = 1 << SUB_BITS;
const BUCKETS: usize = ((64 - SUB_BITS + 1) as usize) << SUB_BITS;

fn bucket(v: u64) -> usize {
    if v < SUB {
        return v as usize;
    }
    let shift = (63 - v.leading_zeros()) - SUB_BITS;
    (((shift + 1) as usize) << SUB_BITS) + ((v >> shift) - SUB) as usize
}

/// The smallest and the largest value that fall in bucket `i`.
fn bucket_range(i: usize) -> (u64, u64) {
    let group = (i >> SUB_BITS) as u32;
    let m = i as u64 & (SUB - 1);
    if group == 0 {
        return (m, m);
    }
    let shift = group - 1;
    let low = (SUB + m) << shift;
    (low, low + ((1u64 << shift) - 1))
}

impl Histogram {
    fn new() -> Self {
        Self {
            counts: vec![0; BUCKETS].into_boxed_slice(),
            total: 0,
            max: 0,
        }
    }

    fn add(&mut self, v: u64) {
        self.counts[bucket(v)] += 1;
        self.total += 1;
        self.max = self.max.max(v);
    }

    /// The value of rank ⌊n·q⌋ in sorted order (how cyclic.c picks its percentiles), as the top
    /// of its bucket capped at the exact maximum.
    fn quantile(&self, q: f64) -> Option<u64> {
        if self.total == 0 {
            return None;
        }
        let rank = ((self.total as f64 * q) as u64).min(self.total - 1);
        let mut seen = 0;
        for (i, &c) in self.counts.iter().enumerate() {
            seen += c;
            if seen > rank {
                return Some(bucket_range(i).1.min(self.max));
            }
        }
        Some(self.max)
    }
}

/// Wake-up lateness percentiles: the jitter of a module's scan starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Lateness {
    pub p50: Duration,
    pub p99: Duration,
    pub max: Duration,
}

/// Per-module scan statistics in constant memory (a PLC runs for months): scans, cycle time
/// (the caller's measure of one scan, typically wake-up to end of scan), lateness percentiles
/// and overruns.
#[derive(Clone, Debug)]
pub struct ScanStats {
    scans: u64,
    overruns: u64,
    cycle_min: Duration,
    cycle_max: Duration,
    cycle_sum: u128,
    late: Histogram,
}

impl Default for ScanStats {
    fn default() -> Self {
        Self::new()
    }
}

fn saturating_nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

impl ScanStats {
    pub fn new() -> Self {
        Self {
            scans: 0,
            overruns: 0,
            cycle_min: Duration::MAX,
            cycle_max: Duration::ZERO,
            cycle_sum: 0,
            late: Histogram::new(),
        }
    }

    /// One scan: its cycle time, the lateness it started with and the deadlines missed before it.
    pub fn record(&mut self, cycle: Duration, late: Duration, missed: u64) {
        self.scans += 1;
        self.overruns = self.overruns.saturating_add(missed);
        self.cycle_min = self.cycle_min.min(cycle);
        self.cycle_max = self.cycle_max.max(cycle);
        self.cycle_sum += cycle.as_nanos();
        self.late.add(saturating_nanos(late));
    }

    pub fn scans(&self) -> u64 {
        self.scans
    }

    pub fn overruns(&self) -> u64 {
        self.overruns
    }

    pub fn cycle_min(&self) -> Option<Duration> {
        (self.scans > 0).then_some(self.cycle_min)
    }

    pub fn cycle_max(&self) -> Option<Duration> {
        (self.scans > 0).then_some(self.cycle_max)
    }

    pub fn cycle_mean(&self) -> Option<Duration> {
        (self.scans > 0).then(|| duration_from_nanos(self.cycle_sum / u128::from(self.scans)))
    }

    /// Lateness at quantile `q` in 0..=1 (rank ⌊n·q⌋, like cyclic.c), at most 3.1 % above the
    /// exact value and never below it; exact below 64 ns.
    pub fn late_quantile(&self, q: f64) -> Option<Duration> {
        self.late.quantile(q).map(Duration::from_nanos)
    }

    pub fn lateness(&self) -> Option<Lateness> {
        Some(Lateness {
            p50: self.late_quantile(0.5)?,
            p99: self.late_quantile(0.99)?,
            max: Duration::from_nanos(self.late.max),
        })
    }
}

fn micros(d: Duration) -> f64 {
    d.as_nanos() as f64 / 1e3
}

impl fmt::Display for ScanStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "scans {}", self.scans)?;
        if let (Some(min), Some(mean), Some(max), Some(late)) = (
            self.cycle_min(),
            self.cycle_mean(),
            self.cycle_max(),
            self.lateness(),
        ) {
            write!(
                f,
                " cycle_us min/mean/max {:.1}/{:.1}/{:.1} late_us p50/p99/max {:.1}/{:.1}/{:.1}",
                micros(min),
                micros(mean),
                micros(max),
                micros(late.p50),
                micros(late.p99),
                micros(late.max)
            )?;
        }
        write!(f, " overruns {}", self.overruns)
    }
}

/// Puts the calling process on `SCHED_FIFO` at `priority` and locks its memory
/// (`mlockall(MCL_CURRENT | MCL_FUTURE)`), so scans are neither preempted by ordinary processes
/// nor stalled by page faults. `None` changes nothing.
///
/// Never fails: what could not be applied (no privilege, a container without the capability, a
/// priority out of range) comes back as one warning per item, saying how to allow it, and the
/// module runs on without it. The policy applies to the calling thread and to threads it
/// creates afterwards, so call it before spawning.
pub fn realtime(priority: Option<u8>) -> Vec<String> {
    let Some(priority) = priority else {
        return Vec::new();
    };
    let mut warnings = Vec::new();
    // SAFETY: plain syscalls on an integer argument; no memory is passed.
    let (lo, hi) = unsafe {
        (
            libc::sched_get_priority_min(libc::SCHED_FIFO),
            libc::sched_get_priority_max(libc::SCHED_FIFO),
        )
    };
    let prio = i32::from(priority);
    if prio < lo || prio > hi {
        warnings.push(format!(
            "real-time priority {priority} not applied: SCHED_FIFO priorities are {lo}..={hi}; \
             memory not locked either"
        ));
        return warnings;
    }
    let param = libc::sched_param {
        sched_priority: prio,
    };
    // SAFETY: `param` is a valid, initialised sched_param that outlives the call, which only
    // reads it; pid 0 is the calling thread.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
    if rc != 0 {
        let errno = Errno::last();
        let limit = match getrlimit(Resource::RLIMIT_RTPRIO) {
            Ok((soft, _)) => format!(" (RLIMIT_RTPRIO is {soft})"),
            Err(_) => String::new(),
        };
        warnings.push(format!(
            "real-time priority not applied: SCHED_FIFO priority {priority} refused ({errno}){limit}; \
             scans run at normal priority and may be delayed by other processes. To allow it, run \
             as root, grant CAP_SYS_NICE (setcap cap_sys_nice+ep on the binary; in a container \
             --cap-add SYS_NICE), or raise the limit with `ulimit -r {priority}` (rtprio in \
             /etc/security/limits.conf)"
        ));
    }
    if let Err(errno) = mlockall(MlockAllFlags::MCL_CURRENT | MlockAllFlags::MCL_FUTURE) {
        let limit = match getrlimit(Resource::RLIMIT_MEMLOCK) {
            Ok((soft, _)) if soft == libc::RLIM_INFINITY => " (RLIMIT_MEMLOCK is unlimited)".into(),
            Ok((soft, _)) => format!(" (RLIMIT_MEMLOCK is {} KiB)", soft / 1024),
            Err(_) => String::new(),
        };
        warnings.push(format!(
            "memory not locked: mlockall(MCL_CURRENT | MCL_FUTURE) refused ({errno}){limit}; \
             page faults may delay scans. To allow it, run as root, grant CAP_IPC_LOCK (in a \
             container --cap-add IPC_LOCK), or raise the limit with `ulimit -l unlimited` \
             (memlock in /etc/security/limits.conf)"
        ));
    }
    warnings
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ns(n: u64) -> Duration {
        Duration::from_nanos(n)
    }

    /// `Schedule { t0, period }` in nanoseconds, asked for the first deadline after `now`.
    fn check_next_after(t0: u64, period: u64, now: u64, expect: (u64, u64)) {
        let got = Schedule::new(ns(t0), ns(period)).next_after(ns(now));
        assert_eq!(
            got,
            (expect.0, ns(expect.1)),
            "t0 {t0} T {period} now {now}"
        );
    }

    /// Due to wait for deadline `due`, at `now`: expect `(k, deadline, missed)`.
    fn check_step(t0: u64, period: u64, due: u64, now: u64, expect: (u64, u64, u64)) {
        let got = Schedule::new(ns(t0), ns(period)).step(due, ns(now));
        let want = Step {
            k: expect.0,
            deadline: ns(expect.1),
            missed: expect.2,
        };
        assert_eq!(got, want, "t0 {t0} T {period} due {due} now {now}");
    }

    #[test]
    fn next_after_is_strictly_after() {
        check_next_after(1000, 100, 0, (0, 1000));
        check_next_after(1000, 100, 999, (0, 1000));
        check_next_after(1000, 100, 1000, (1, 1100));
        check_next_after(1000, 100, 1001, (1, 1100));
        check_next_after(1000, 100, 1099, (1, 1100));
        check_next_after(1000, 100, 1100, (2, 1200));
        check_next_after(0, 1, 0, (1, 1));
        check_next_after(0, 1, 41, (42, 42));
    }

    #[test]
    fn step_counts_missed_deadlines() {
        // Finished early: wait for the due deadline, nothing missed.
        check_step(1000, 100, 1, 1050, (1, 1100, 0));
        check_step(1000, 100, 1, 1099, (1, 1100, 0));
        // Exactly on the deadline: it counts as passed.
        check_step(1000, 100, 1, 1100, (2, 1200, 1));
        // Overran three deadlines (1100, 1200, 1300): skip to 1400.
        check_step(1000, 100, 1, 1301, (4, 1400, 3));
        check_step(1000, 100, 1, 1399, (4, 1400, 3));
        check_step(1000, 100, 1, 1400, (5, 1500, 4));
        // A clock reading before the due deadline's predecessor (e.g. a shared t0 in the future).
        check_step(1000, 100, 3, 900, (3, 1300, 0));
    }

    #[test]
    fn no_drift_after_a_million_periods() {
        // Periods that are not round in seconds, and a t0 far into the uptime, where floating
        // point seconds would have lost nanoseconds long ago.
        for (t0, period) in [
            (0u64, 1_000_000u64),
            (86_400_000_000_123, 333_333_333),
            (7, 999_983),
        ] {
            let s = Schedule::new(ns(t0), ns(period));
            let mut due = 1;
            for i in 1..=1_000_000u64 {
                // Each scan takes a little under one period, so none are missed.
                let now = s.deadline(due - 1) + ns(period - 1);
                let step = s.step(due, now);
                assert_eq!(step.missed, 0);
                assert_eq!(step.k, i);
                due = step.k + 1;
            }
            let last = s.deadline(1_000_000);
            assert_eq!(
                last.as_nanos(),
                u128::from(t0) + 1_000_000 * u128::from(period),
                "t0 {t0} T {period}"
            );
            assert_eq!(s.deadline(999_999) + ns(period), last);
        }
    }

    #[test]
    fn deadline_saturates_instead_of_overflowing() {
        let s = Schedule::new(Duration::from_secs(1), Duration::from_secs(u64::MAX / 2));
        assert_eq!(s.deadline(u64::MAX), Duration::MAX);
        assert_eq!(s.deadline(0), Duration::from_secs(1));
    }

    #[test]
    #[should_panic(expected = "longer than zero")]
    fn zero_period_is_rejected() {
        Schedule::new(Duration::ZERO, Duration::ZERO);
    }

    #[test]
    fn wake_time_is_deadline_plus_lateness() {
        let w = Wake {
            k: 3,
            deadline: ns(3000),
            late: ns(42),
            missed: 0,
        };
        assert_eq!(w.woke(), ns(3042));
    }

    #[test]
    fn histogram_buckets_cover_every_value_once() {
        let mut next = 0u64;
        for i in 0..BUCKETS {
            let (lo, hi) = bucket_range(i);
            assert_eq!(lo, next, "bucket {i}");
            assert!(hi >= lo);
            assert_eq!(bucket(lo), i);
            assert_eq!(bucket(hi), i);
            // The promised precision: a bucket is at most 1/32 of its lower bound wide.
            assert!(
                (hi - lo) as u128 * 32 <= lo as u128,
                "bucket {i}: {lo}..={hi}"
            );
            next = hi.wrapping_add(1);
        }
        assert_eq!(next, 0, "the last bucket ends at u64::MAX");
    }

    /// Lateness values in nanoseconds: expect `(p50, p99, max)` in nanoseconds.
    fn check_lateness(late: &[u64], expect: (u64, u64, u64)) {
        let mut s = ScanStats::new();
        for &l in late {
            s.record(Duration::ZERO, ns(l), 0);
        }
        let got = s.lateness().unwrap();
        assert_eq!(
            (got.p50, got.p99, got.max),
            (ns(expect.0), ns(expect.1), ns(expect.2))
        );
    }

    #[test]
    fn lateness_percentiles() {
        check_lateness(&[7], (7, 7, 7));
        // Small values are exact and ranks follow cyclic.c: sorted[n/2], sorted[⌊0.99·n⌋].
        check_lateness(&[5, 1, 3, 2, 4], (3, 5, 5));
        check_lateness(&(0..100).collect::<Vec<_>>(), (50, 99, 99));
        // Larger values: the top of the bucket, capped at the exact maximum.
        check_lateness(&[1_000, 1_000, 1_000], (1_000, 1_000, 1_000));
        check_lateness(&[1_000, 1_000, 50_000], (1_007, 50_000, 50_000));
    }

    #[test]
    fn lateness_percentiles_are_within_a_thirty_second_of_exact() {
        // A spread of lateness like a real run: 1 µs to 2 ms, not uniform.
        let mut late: Vec<u64> = (0..100_000u64)
            .map(|i| 1_000 + (i * i * 7919) % 2_000_000)
            .collect();
        let mut s = ScanStats::new();
        for &l in &late {
            s.record(Duration::ZERO, ns(l), 0);
        }
        late.sort_unstable();
        for q in [0.0, 0.1, 0.5, 0.9, 0.99, 0.999, 1.0] {
            let exact = late[((late.len() as f64 * q) as usize).min(late.len() - 1)];
            let got = saturating_nanos(s.late_quantile(q).unwrap());
            assert!(
                got >= exact && (got - exact) * 32 <= exact,
                "q {q}: {got} vs {exact}"
            );
        }
        assert_eq!(s.lateness().unwrap().max, ns(*late.last().unwrap()));
    }

    #[test]
    fn empty_stats() {
        let s = ScanStats::new();
        assert_eq!(s.scans(), 0);
        assert_eq!(s.cycle_min(), None);
        assert_eq!(s.cycle_mean(), None);
        assert_eq!(s.cycle_max(), None);
        assert_eq!(s.lateness(), None);
        assert_eq!(s.to_string(), "scans 0 overruns 0");
    }

    #[test]
    fn cycle_times_and_overruns() {
        let mut s = ScanStats::default();
        s.record(Duration::from_micros(100), Duration::from_micros(20), 0);
        s.record(Duration::from_micros(300), Duration::from_micros(10), 2);
        s.record(Duration::from_micros(200), Duration::from_micros(30), 1);
        assert_eq!(s.scans(), 3);
        assert_eq!(s.overruns(), 3);
        assert_eq!(s.cycle_min(), Some(Duration::from_micros(100)));
        assert_eq!(s.cycle_mean(), Some(Duration::from_micros(200)));
        assert_eq!(s.cycle_max(), Some(Duration::from_micros(300)));
        // p50 is 20 µs reported as the top of its bucket (19.968..=20.479 µs); p99 is capped at
        // the exact maximum.
        assert_eq!(
            s.to_string(),
            "scans 3 cycle_us min/mean/max 100.0/200.0/300.0 \
             late_us p50/p99/max 20.5/30.0/30.0 overruns 3"
        );
    }

    #[test]
    fn realtime_without_priority_changes_nothing() {
        assert!(realtime(None).is_empty());
    }

    #[test]
    fn realtime_rejects_out_of_range_priority_with_a_warning() {
        let w = realtime(Some(0));
        assert_eq!(w.len(), 1);
        assert!(w[0].contains("priority 0 not applied"), "{}", w[0]);
    }
}
