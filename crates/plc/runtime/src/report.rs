//! Scan statistics a module process sends the runner that started it, so that `petriplc
//! status` shows C and other program modules' scans like a built-in module's.
//!
//! The runner opens a pipe per program it starts and passes the write end's number in
//! `PETRIPLC_STATS_FD`; the process (the C API's `plc_scan_end`) writes one line of figures
//! at most every 25 ms and once more when it detaches; the runner reads the last line. Writes
//! never block: a full pipe drops a line, the next one carries the same totals. A module
//! started by hand has no such variable and reports nothing.

use std::fs::{File, OpenOptions};
use std::io::{ErrorKind, Read, Write};
use std::os::fd::OwnedFd;
use std::os::unix::fs::OpenOptionsExt;
use std::time::Duration;

use nix::fcntl::{fcntl, FcntlArg, FdFlag, OFlag};

use crate::period::{self, ScanStats};
use crate::status::ModuleStatus;

/// The environment variable naming the pipe's write end in a module process.
pub const STATS_FD: &str = "PETRIPLC_STATS_FD";

/// How often a process reports.
const EVERY: Duration = Duration::from_millis(25);

/// The figures of one report, as `ModuleStatus` shows them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Report {
    pub scans: u64,
    pub overruns: u64,
    /// Cycle time min / mean / max, µs.
    pub cycle_us: [f64; 3],
    /// Lateness p50 / p99 / max, µs.
    pub late_us: [f64; 3],
}

impl Report {
    pub fn of(stats: &ScanStats) -> Report {
        let us = |d: Option<Duration>| d.map_or(0.0, |d| d.as_secs_f64() * 1e6);
        Report {
            scans: stats.scans(),
            overruns: stats.overruns(),
            cycle_us: [
                us(stats.cycle_min()),
                us(stats.cycle_mean()),
                us(stats.cycle_max()),
            ],
            late_us: match stats.lateness() {
                Some(l) => [us(Some(l.p50)), us(Some(l.p99)), us(Some(l.max))],
                None => [0.0; 3],
            },
        }
    }

    /// Puts the figures into a module's status.
    pub fn apply(&self, status: &mut ModuleStatus) {
        status.scans = self.scans;
        status.overruns = self.overruns;
        status.cycle_us = self.cycle_us;
        status.late_us = self.late_us;
    }

    fn line(&self) -> String {
        let [c0, c1, c2] = self.cycle_us;
        let [l0, l1, l2] = self.late_us;
        format!(
            "{} {} {c0:.1} {c1:.1} {c2:.1} {l0:.1} {l1:.1} {l2:.1}\n",
            self.scans, self.overruns
        )
    }

    fn parse(line: &str) -> Option<Report> {
        let w: Vec<&str> = line.split_whitespace().collect();
        let [scans, overruns, rest @ ..] = w.as_slice() else {
            return None;
        };
        let f: Vec<f64> = rest.iter().map(|x| x.parse().ok()).collect::<Option<_>>()?;
        let [c0, c1, c2, l0, l1, l2] = f.as_slice() else {
            return None;
        };
        Some(Report {
            scans: scans.parse().ok()?,
            overruns: overruns.parse().ok()?,
            cycle_us: [*c0, *c1, *c2],
            late_us: [*l0, *l1, *l2],
        })
    }
}

/// The runner's end of a module process's pipe.
pub struct Receiver {
    file: File,
    pending: String,
    latest: Option<Report>,
}

impl Receiver {
    /// A pipe: the receiver, and the write end to hand the process (inherited: the runner
    /// closes its copy once the process is started).
    pub fn pipe() -> std::io::Result<(Receiver, OwnedFd)> {
        let (read, write) = nix::unistd::pipe()?;
        fcntl(&read, FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC))?;
        fcntl(&read, FcntlArg::F_SETFL(OFlag::O_NONBLOCK))?;
        Ok((
            Receiver {
                file: File::from(read),
                pending: String::new(),
                latest: None,
            },
            write,
        ))
    }

    /// The last complete report received so far.
    pub fn latest(&mut self) -> Option<Report> {
        let mut buf = [0u8; 4096];
        loop {
            match self.file.read(&mut buf) {
                Ok(0) => break,
                Ok(n) => self.pending.push_str(&String::from_utf8_lossy(&buf[..n])),
                Err(e) if e.kind() == ErrorKind::Interrupted => continue,
                Err(_) => break,
            }
        }
        if let Some(end) = self.pending.rfind('\n') {
            let complete: String = self.pending.drain(..=end).collect();
            if let Some(r) = complete.lines().rev().find_map(Report::parse) {
                self.latest = Some(r);
            }
        }
        self.latest
    }
}

/// A module process's end: reports its scan statistics if the runner asked for them.
pub struct Sender {
    file: File,
    last: Option<Duration>,
}

impl Sender {
    /// The sender `PETRIPLC_STATS_FD` names, if any (a module started by `petriplc run`).
    pub fn from_env() -> Option<Sender> {
        let fd: i32 = std::env::var(STATS_FD).ok()?.trim().parse().ok()?;
        // A new open file description of the same pipe, non-blocking, opened without unsafe
        // code and without touching the inherited descriptor's flags.
        let file = OpenOptions::new()
            .write(true)
            .custom_flags(libc::O_NONBLOCK | libc::O_CLOEXEC)
            .open(format!("/proc/self/fd/{fd}"))
            .ok()?;
        Some(Sender { file, last: None })
    }

    /// Sends the figures of `stats`: at most every 25 ms unless `now` (the last report).
    pub fn send(&mut self, stats: &ScanStats, now: bool) {
        let t = period::now();
        if !now && self.last.is_some_and(|l| t.saturating_sub(l) < EVERY) {
            return;
        }
        self.last = Some(t);
        // One short line is written whole or not at all (PIPE_BUF); a full pipe drops it.
        let _ = self.file.write(Report::of(stats).line().as_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(line: &str, expect: Option<Report>) {
        assert_eq!(Report::parse(line), expect, "{line}");
    }

    #[test]
    fn lines_round_trip_and_junk_is_ignored() {
        let r = Report {
            scans: 12,
            overruns: 1,
            cycle_us: [3.5, 10.0, 250.2],
            late_us: [40.0, 90.1, 120.0],
        };
        check(&r.line(), Some(r));
        check("12 1 3.5", None);
        check("x 1 1 1 1 1 1 1", None);
        check("", None);
    }

    #[test]
    fn the_receiver_keeps_the_last_complete_line() {
        let (mut rx, tx) = Receiver::pipe().unwrap();
        let mut tx = File::from(tx);
        assert_eq!(rx.latest(), None);
        let mut stats = ScanStats::new();
        stats.record(Duration::from_micros(100), Duration::ZERO, 0);
        tx.write_all(Report::of(&stats).line().as_bytes()).unwrap();
        stats.record(Duration::from_micros(300), Duration::ZERO, 0);
        tx.write_all(Report::of(&stats).line().as_bytes()).unwrap();
        tx.write_all(b"99 0 1").unwrap();
        let r = rx.latest().unwrap();
        assert_eq!(r.scans, 2);
        assert_eq!(r.cycle_us[2], 300.0);
        // The half line completes later.
        tx.write_all(b" 1 1 1 1 1\n").unwrap();
        assert_eq!(rx.latest().unwrap().scans, 99);
    }
}
