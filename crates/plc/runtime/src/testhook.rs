//! A test hook that kills this process (SIGKILL) while it holds the PLC's shared-memory lock,
//! half-way through an `update()` or a synchronisation-net firing, so that tests can prove
//! the other modules survive it: the lock is recovered and the half-done change undone.
//!
//! It is armed only by [`arm`] (the C ABI's `plc_init` arms it from the environment variable
//! [`ENV`], for module programs under test); unarmed, each check is one relaxed atomic load.

use std::sync::atomic::{AtomicU32, Ordering};

/// `update:N` or `firing:N`: die in the N-th update (or firing) from now on, N ≥ 1.
pub const ENV: &str = "PETRIPLC_TEST_DIE_HOLDING_LOCK";

/// Where the process dies.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Point {
    /// After the image's journal is written and half of the owned words are copied out.
    Update,
    /// After a transition's input tokens are taken and before its output tokens are added.
    Firing,
}

/// Per point: how many more passes until death (0: unarmed).
static COUNTDOWN: [AtomicU32; 2] = [AtomicU32::new(0), AtomicU32::new(0)];

/// Makes the `after`-th pass through `point` from now kill the process (0 disarms).
pub fn arm(point: Point, after: u32) {
    COUNTDOWN[point as usize].store(after, Ordering::SeqCst);
}

/// Arms the hook from `spec` (`update:N` or `firing:N`), the value of [`ENV`].
pub fn arm_from(spec: &str) -> Result<(), String> {
    let (point, n) = parse(spec)?;
    arm(point, n);
    Ok(())
}

/// Reads `update:N` or `firing:N`.
pub fn parse(spec: &str) -> Result<(Point, u32), String> {
    let bad = || format!("{ENV}={spec}: write `update:N` or `firing:N` with N ≥ 1");
    let (point, n) = spec.split_once(':').ok_or_else(bad)?;
    let n: u32 = n.trim().parse().map_err(|_| bad())?;
    let point = match point.trim() {
        "update" => Point::Update,
        "firing" => Point::Firing,
        _ => return Err(bad()),
    };
    if n == 0 {
        return Err(bad());
    }
    Ok((point, n))
}

/// Whether this pass through `point` is the one that must die.
#[inline]
pub(crate) fn fires(point: Point) -> bool {
    let c = &COUNTDOWN[point as usize];
    if c.load(Ordering::Relaxed) == 0 {
        return false;
    }
    c.fetch_sub(1, Ordering::SeqCst) == 1
}

/// Dies at once, by the signal nothing can catch: as if `kill -9` came at this instruction.
pub(crate) fn die() -> ! {
    let _ = nix::sys::signal::raise(nix::sys::signal::Signal::SIGKILL);
    std::process::abort()
}

#[cfg(test)]
mod tests {
    use super::*;

    // Only parsing: arming would kill the test process in another test's update.
    fn check(spec: &str, expect: Result<(Point, u32), ()>) {
        assert_eq!(parse(spec).map_err(|_| ()), expect, "{spec}");
    }

    #[test]
    fn specs() {
        check("update:3", Ok((Point::Update, 3)));
        check("firing:1", Ok((Point::Firing, 1)));
        check("update:0", Err(()));
        check("update", Err(()));
        check("scan:2", Err(()));
        check("firing:x", Err(()));
    }
}
