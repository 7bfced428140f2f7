//! Scan clocks for the modules' watchdogs: per module, in a small POSIX shared memory object
//! of the PLC (`/petriplc-ID-watchdog`), when its scan under way began, so that the runner
//! can see a scan that runs too long whether the module is a thread of the runner or a
//! process of its own.
//!
//! A module (the runner's scan loop, or `plc_scan_beg`/`plc_scan_end` in a module program)
//! [`ScanClock::begin`]s its scan once `scan_beg` has fired and the map is updated, and
//! [`ScanClock::end`]s it before the end-of-scan update: the watchdog measures the
//! module's own work, not its waits for the period or the synchronisation net. The runner
//! watches the clock and, past the watchdog, [`ScanClock::expire`]s the scan. Both are one
//! compare-and-swap on the same word, so exactly one of them wins: either the scan ended in
//! time and its outputs are committed, or it is the watchdog's and the module's `end` fails
//! (its outputs are never written to the image).

#![allow(unsafe_code)]

use std::fs::File;
use std::os::unix::fs::MetadataExt;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use memmap2::{MmapOptions, MmapRaw};
use nix::errno::Errno;
use nix::fcntl::OFlag;
use nix::sys::mman::{shm_open, shm_unlink};
use nix::sys::stat::Mode;

const MAGIC: u64 = u64::from_le_bytes(*b"PPLCWDG\0");
const HEADER: usize = 64;
/// A clock's value while its scan belongs to the watchdog.
const EXPIRED: u64 = u64::MAX;

#[repr(C)]
struct Header {
    magic: AtomicU64,
    modules: AtomicU32,
}

/// Why the clocks cannot be made or opened.
#[derive(Debug, thiserror::Error)]
#[error("{what} {shm}: {source}")]
pub struct ClockError {
    what: &'static str,
    shm: String,
    #[source]
    source: std::io::Error,
}

/// The scan clocks of one PLC's modules (by their index in the configuration).
#[derive(Clone)]
pub struct ScanClocks {
    inner: Arc<Inner>,
}

struct Inner {
    map: MmapRaw,
    shm: String,
    modules: usize,
    created: Option<u64>,
}

impl Drop for Inner {
    fn drop(&mut self) {
        let Some(ino) = self.created else { return };
        if let Ok(fd) = shm_open(self.shm.as_str(), OFlag::O_RDONLY, Mode::empty()) {
            if File::from(fd).metadata().is_ok_and(|m| m.ino() == ino) {
                let _ = shm_unlink(self.shm.as_str());
            }
        }
    }
}

/// The shared memory name of PLC `plc_id`'s scan clocks.
pub fn shm_name(plc_id: &str) -> Option<String> {
    crate::shm_name::object_name(plc_id, "watchdog").ok()
}

fn os<'a>(what: &'static str, shm: &'a str) -> impl FnOnce(Errno) -> ClockError + 'a {
    move |e| ClockError {
        what,
        shm: shm.to_string(),
        source: e.into(),
    }
}

impl ScanClocks {
    /// Creates the clocks of PLC `plc_id` for `modules` modules, all idle.
    pub fn create(plc_id: &str, modules: usize) -> Result<ScanClocks, ClockError> {
        let shm = shm_name(plc_id).unwrap_or_default();
        let fd = shm_open(
            shm.as_str(),
            OFlag::O_CREAT | OFlag::O_EXCL | OFlag::O_RDWR,
            Mode::from_bits_truncate(0o660),
        )
        .map_err(os("cannot create shared memory", &shm))?;
        let file = File::from(fd);
        let made = (|| {
            let ino = file.metadata()?.ino();
            let len = HEADER + 8 * modules.max(1);
            file.set_len(len as u64)?;
            let map = MmapOptions::new().len(len).map_raw(&file)?;
            Ok::<_, std::io::Error>((map, ino))
        })();
        let (map, ino) = match made {
            Ok(m) => m,
            Err(e) => {
                let _ = shm_unlink(shm.as_str());
                return Err(ClockError {
                    what: "cannot set up shared memory",
                    shm,
                    source: e,
                });
            }
        };
        let h = header(&map);
        h.modules.store(modules as u32, Ordering::Relaxed);
        h.magic.store(MAGIC, Ordering::Release);
        Ok(ScanClocks {
            inner: Arc::new(Inner {
                map,
                shm,
                modules,
                created: Some(ino),
            }),
        })
    }

    /// Opens the clocks of the running PLC `plc_id` (a module program).
    pub fn open(plc_id: &str) -> Result<ScanClocks, ClockError> {
        let shm = shm_name(plc_id).unwrap_or_default();
        let fd = shm_open(shm.as_str(), OFlag::O_RDWR, Mode::empty())
            .map_err(os("cannot open shared memory", &shm))?;
        let file = File::from(fd);
        let bad = |why: &str| ClockError {
            what: "not the scan clocks of a PLC:",
            shm: shm.clone(),
            source: std::io::Error::other(why.to_string()),
        };
        let len = file.metadata().map_err(|e| bad(&e.to_string()))?.len() as usize;
        if len < HEADER + 8 {
            return Err(bad("too small"));
        }
        let map = MmapOptions::new()
            .len(len)
            .map_raw(&file)
            .map_err(|e| bad(&e.to_string()))?;
        let h = header(&map);
        let modules = h.modules.load(Ordering::Relaxed) as usize;
        if h.magic.load(Ordering::Acquire) != MAGIC || HEADER + 8 * modules.max(1) != len {
            return Err(bad("no header, or the wrong size"));
        }
        Ok(ScanClocks {
            inner: Arc::new(Inner {
                map,
                shm,
                modules,
                created: None,
            }),
        })
    }

    /// Removes the name of PLC `plc_id`'s clocks; says whether there was one.
    pub fn unlink(plc_id: &str) -> bool {
        shm_name(plc_id).is_some_and(|n| crate::shm_name::unlink(&n).unwrap_or(false))
    }

    /// The clock of module `index`.
    pub fn clock(&self, index: usize) -> Option<ScanClock> {
        (index < self.inner.modules).then(|| ScanClock {
            clocks: self.clone(),
            index,
        })
    }

    fn word(&self, index: usize) -> &AtomicU64 {
        assert!(index < self.inner.modules);
        // SAFETY: the mapping holds HEADER + 8 × modules bytes (checked at create and
        // open), page-aligned, so word `index` is in it and 8-aligned; AtomicU64 has the
        // layout of u64, any bit pattern is valid, and atomic access from other processes
        // is fine; the reference lives no longer than `self`, which keeps the mapping.
        unsafe {
            &*self
                .inner
                .map
                .as_mut_ptr()
                .add(HEADER + 8 * index)
                .cast::<AtomicU64>()
        }
    }
}

fn header(map: &MmapRaw) -> &Header {
    // SAFETY: every mapping is at least HEADER bytes and page-aligned; Header is all
    // atomics; the reference borrows the mapping.
    unsafe { &*map.as_mut_ptr().cast::<Header>() }
}

impl std::fmt::Debug for ScanClocks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ScanClocks")
            .field("shm", &self.inner.shm)
            .field("modules", &self.inner.modules)
            .finish()
    }
}

/// One module's scan clock.
#[derive(Clone, Debug)]
pub struct ScanClock {
    clocks: ScanClocks,
    index: usize,
}

/// A started scan, to end it with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Token(u64);

impl Token {
    /// When the scan began (`CLOCK_MONOTONIC`).
    pub fn began(self) -> Duration {
        Duration::from_nanos(self.0)
    }
}

impl ScanClock {
    /// The module's scan begins now.
    pub fn begin(&self) -> Token {
        let ns = (crate::period::now().as_nanos() as u64).clamp(1, EXPIRED - 1);
        self.clocks.word(self.index).store(ns, Ordering::SeqCst);
        Token(ns)
    }

    /// The module's scan ends: `false` if the watchdog took it first (then nothing of the
    /// scan may be written).
    pub fn end(&self, token: Token) -> bool {
        self.clocks
            .word(self.index)
            .compare_exchange(token.0, 0, Ordering::SeqCst, Ordering::SeqCst)
            .is_ok()
    }

    /// The scan under way, if any.
    pub fn running(&self) -> Option<Token> {
        match self.clocks.word(self.index).load(Ordering::SeqCst) {
            0 | EXPIRED => None,
            ns => Some(Token(ns)),
        }
    }

    /// The watchdog takes scan `token`: `false` if it has ended meanwhile.
    pub fn expire(&self, token: Token) -> bool {
        self.clocks
            .word(self.index)
            .compare_exchange(token.0, EXPIRED, Ordering::SeqCst, Ordering::SeqCst)
            .is_ok()
    }

    /// Idle again (a new instance of the module starts).
    pub fn reset(&self) {
        self.clocks.word(self.index).store(0, Ordering::SeqCst);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_scan_or_the_watchdog_wins_never_both() {
        let id = format!("wdg-{}", std::process::id());
        let clocks = ScanClocks::create(&id, 2).unwrap();
        let other = ScanClocks::open(&id).unwrap();
        let (mine, theirs) = (clocks.clock(1).unwrap(), other.clock(1).unwrap());
        assert!(clocks.clock(2).is_none());
        let t = mine.begin();
        assert_eq!(theirs.running(), Some(t));
        assert!(mine.end(t));
        assert!(!theirs.expire(t), "an ended scan cannot expire");
        assert_eq!(theirs.running(), None);
        let t = mine.begin();
        assert!(theirs.expire(t));
        assert!(!mine.end(t), "an expired scan cannot end");
        assert_eq!(theirs.running(), None);
        mine.reset();
        drop((mine, theirs, clocks, other));
        assert!(!ScanClocks::unlink(&id), "the creator removes the name");
    }
}
