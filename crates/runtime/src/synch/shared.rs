//! The marking of the synchronisation net in POSIX shared memory
//! (`/petriplc-<plc_id>-synch`), on which the modules of every process fire transitions
//! atomically, blocking on a futex until the transition they wait on is enabled.
//!
//! Layout: a [`Header`] (magic, version, sizes, a fingerprint of the net, the lock word,
//! the generation counter and the `stopping` flag), then one `u32` per place. The marking
//! is only read or written with the lock held; the generation counter is bumped, under the
//! lock, by every change a waiter could care about (a firing, `stop`), and waiters sleep on
//! it with the value they read under the lock, so a change between their check and their
//! sleep makes the sleep return at once: no lost wake-ups.

use std::fs::File;
use std::mem::size_of;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use memmap2::{MmapMut, MmapOptions};
use nix::errno::Errno;
use nix::fcntl::OFlag;
use nix::sys::mman::{shm_open, shm_unlink};
use nix::sys::stat::Mode;

use super::{SynchError, SynchNet, TransitionRef};
use crate::futex;

const MAGIC: u32 = u32::from_be_bytes(*b"PPSY");
const VERSION: u32 = 1;
/// How long `open` waits for a creator that has made the object but not yet filled it in.
const OPEN_WAIT: Duration = Duration::from_secs(2);

/// Every field is atomic: other processes may read the header while the creator is still
/// filling it in, and `magic` (stored last, with Release) says when it is complete.
#[repr(C)]
struct Header {
    magic: AtomicU32,
    version: AtomicU32,
    places: AtomicU32,
    transitions: AtomicU32,
    fingerprint: AtomicU64,
    lock: AtomicU32,
    generation: AtomicU32,
    stopping: AtomicU32,
    _reserved: AtomicU32,
}

const HEADER_SIZE: usize = size_of::<Header>();

/// A transition fired for this wait.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Fired {
    /// The generation counter right after the firing (for diagnostics; it wraps).
    pub generation: u32,
}

/// The PLC is shutting down ([`SharedSynch::stop`]): the module should end cleanly.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("the PLC is stopping")]
pub struct Stopped;

/// A handle on the shared marking. It may be shared between threads; each process opens
/// its own.
pub struct SharedSynch {
    net: SynchNet,
    shm: String,
    creator: bool,
    /// Keeps the mapping alive; all access goes through the two pointers below.
    _map: MmapMut,
    header: *const Header,
    marking: *mut u32,
}

// SAFETY: the pointers point into `_map`, which lives as long as `self` and is not moved
// by moving `self` (it is a separate mapping). The header is all atomics, and the marking
// is only touched with the futex lock held, which serialises every thread and process.
unsafe impl Send for SharedSynch {}
// SAFETY: as for `Send`: shared access is through atomics or under the lock.
unsafe impl Sync for SharedSynch {}

/// Unlinks a half-made object if `create` fails part-way.
struct UnlinkOnError<'a> {
    shm: &'a str,
    armed: bool,
}

impl Drop for UnlinkOnError<'_> {
    fn drop(&mut self) {
        if self.armed {
            let _ = shm_unlink(self.shm);
        }
    }
}

fn size_for(net: &SynchNet) -> usize {
    HEADER_SIZE + net.places().len() * size_of::<u32>()
}

fn os_error(what: &'static str, shm: &str, errno: Errno) -> SynchError {
    SynchError::Os {
        what,
        shm: shm.to_string(),
        source: std::io::Error::from(errno),
    }
}

impl SharedSynch {
    /// The shared memory object's name for `plc_id`.
    pub fn shm_name(plc_id: &str) -> Result<String, SynchError> {
        crate::shm_name::object_name(plc_id, "synch").map_err(|reason| SynchError::BadPlcId {
            plc_id: plc_id.to_string(),
            reason: reason.to_string(),
        })
    }

    /// Creates the shared marking for `net` with its initial marking. Fails if it already
    /// exists (another PLC with this id, or a stale one: see [`Self::unlink`]). The object
    /// is unlinked when this handle is dropped.
    pub fn create(plc_id: &str, net: &SynchNet) -> Result<SharedSynch, SynchError> {
        let shm = Self::shm_name(plc_id)?;
        let fd = shm_open(
            shm.as_str(),
            OFlag::O_CREAT | OFlag::O_EXCL | OFlag::O_RDWR,
            Mode::S_IRUSR | Mode::S_IWUSR,
        )
        .map_err(|e| match e {
            Errno::EEXIST => SynchError::Exists { shm: shm.clone() },
            e => os_error("cannot create shared memory", &shm, e),
        })?;
        let mut cleanup = UnlinkOnError {
            shm: &shm,
            armed: true,
        };
        let file = File::from(fd);
        let size = size_for(net);
        file.set_len(size as u64).map_err(|source| SynchError::Os {
            what: "cannot size shared memory",
            shm: shm.clone(),
            source,
        })?;
        // SAFETY: we just created the object with O_EXCL and sized it; the mapping is only
        // accessed through atomics or under the futex lock, never as plain Rust references
        // to its bytes.
        let map = unsafe { MmapOptions::new().len(size).map_mut(&file) }.map_err(|source| {
            SynchError::Os {
                what: "cannot map shared memory",
                shm: shm.clone(),
                source,
            }
        })?;
        let this = Self::from_map(net, shm.clone(), true, map);
        let header = this.header();
        let initial = net.initial_marking();
        // SAFETY: the object is not yet published (magic is 0), so no one else touches the
        // marking; `from_map` made the pointer cover exactly one u32 per place.
        let marking = unsafe { std::slice::from_raw_parts_mut(this.marking, net.places().len()) };
        marking.copy_from_slice(initial.tokens());
        header.version.store(VERSION, Ordering::Relaxed);
        header
            .places
            .store(net.places().len() as u32, Ordering::Relaxed);
        header
            .transitions
            .store(net.transitions().len() as u32, Ordering::Relaxed);
        header
            .fingerprint
            .store(net.fingerprint(), Ordering::Relaxed);
        header.lock.store(0, Ordering::Relaxed);
        header.generation.store(0, Ordering::Relaxed);
        header.stopping.store(0, Ordering::Relaxed);
        header.magic.store(MAGIC, Ordering::Release);
        cleanup.armed = false;
        Ok(this)
    }

    /// Opens the shared marking a PLC created for the same `net` (checked by sizes and
    /// fingerprint).
    pub fn open(plc_id: &str, net: &SynchNet) -> Result<SharedSynch, SynchError> {
        let shm = Self::shm_name(plc_id)?;
        let fd = shm_open(shm.as_str(), OFlag::O_RDWR, Mode::empty()).map_err(|e| match e {
            Errno::ENOENT => SynchError::NotRunning { shm: shm.clone() },
            e => os_error("cannot open shared memory", &shm, e),
        })?;
        let file = File::from(fd);
        let size = size_for(net);
        let mismatch = |reason: String| SynchError::Mismatch {
            shm: shm.clone(),
            reason,
        };
        // The creator sizes the object right after making it: give it a moment.
        let started = Instant::now();
        let len = loop {
            let len = file
                .metadata()
                .map_err(|source| SynchError::Os {
                    what: "cannot stat shared memory",
                    shm: shm.clone(),
                    source,
                })?
                .len();
            if len != 0 || started.elapsed() > OPEN_WAIT {
                break len;
            }
            std::thread::sleep(Duration::from_millis(1));
        };
        if len != size as u64 {
            return Err(mismatch(format!(
                "it is {len} bytes, this net needs {size}"
            )));
        }
        // SAFETY: the object has exactly `size` bytes; as in `create`, the mapping is only
        // accessed through atomics or under the lock.
        let map = unsafe { MmapOptions::new().len(size).map_mut(&file) }.map_err(|source| {
            SynchError::Os {
                what: "cannot map shared memory",
                shm: shm.clone(),
                source,
            }
        })?;
        let this = Self::from_map(net, shm.clone(), false, map);
        let header = this.header();
        while header.magic.load(Ordering::Acquire) != MAGIC {
            if started.elapsed() > OPEN_WAIT {
                return Err(mismatch("it was never initialised (bad magic)".into()));
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        let version = header.version.load(Ordering::Relaxed);
        if version != VERSION {
            return Err(mismatch(format!(
                "layout version {version}, this program uses {VERSION}"
            )));
        }
        let places = header.places.load(Ordering::Relaxed) as usize;
        let transitions = header.transitions.load(Ordering::Relaxed) as usize;
        if places != net.places().len() || transitions != net.transitions().len() {
            return Err(mismatch(format!(
                "{places} places and {transitions} transitions, this configuration has {} and {}",
                net.places().len(),
                net.transitions().len()
            )));
        }
        if header.fingerprint.load(Ordering::Relaxed) != net.fingerprint() {
            return Err(mismatch(
                "its places, transitions or arcs differ from this configuration's".into(),
            ));
        }
        Ok(this)
    }

    /// Removes a stale shared memory object left by a PLC that died; says whether there
    /// was one.
    pub fn unlink(plc_id: &str) -> Result<bool, SynchError> {
        let shm = Self::shm_name(plc_id)?;
        crate::shm_name::unlink(&shm).map_err(|e| os_error("cannot remove shared memory", &shm, e))
    }

    fn from_map(net: &SynchNet, shm: String, creator: bool, mut map: MmapMut) -> SharedSynch {
        let base = map.as_mut_ptr();
        SharedSynch {
            net: net.clone(),
            shm,
            creator,
            header: base.cast::<Header>().cast_const(),
            // SAFETY: the mapping is `HEADER_SIZE` + 4 × places bytes, page aligned, and
            // HEADER_SIZE is a multiple of 4, so the marking is in bounds and aligned.
            marking: unsafe { base.add(HEADER_SIZE) }.cast::<u32>(),
            _map: map,
        }
    }

    fn header(&self) -> &Header {
        // SAFETY: the mapping is page aligned, at least HEADER_SIZE long, lives as long as
        // `self`, and Header is all atomics, so shared references to it are sound even
        // though other processes change it.
        unsafe { &*self.header }
    }

    /// The net this marking belongs to.
    pub fn net(&self) -> &SynchNet {
        &self.net
    }

    /// The shared memory object's name.
    pub fn shm(&self) -> &str {
        &self.shm
    }

    /// Runs `f` on the marking with the lock held.
    fn with_marking<R>(&self, f: impl FnOnce(&mut [u32]) -> R) -> R {
        let _guard = futex::lock(&self.header().lock);
        // SAFETY: the lock serialises every access to the marking across threads and
        // processes, so this is the only reference to it until the guard drops (after `f`,
        // which cannot leak the borrow).
        let marking =
            unsafe { std::slice::from_raw_parts_mut(self.marking, self.net.places().len()) };
        f(marking)
    }

    /// Waits until `t` is enabled, then fires it atomically: the seed's modified
    /// semantics, where a transition fires only when a module waits on it, once per wait.
    /// `NULL` returns at once. Returns `Err(Stopped)` once [`Self::stop`] was called
    /// (also for `NULL`, so unsynchronised modules see the shutdown at their next scan).
    ///
    /// # Panics
    ///
    /// If `t` is not a transition of this net.
    pub fn synch(&self, t: TransitionRef) -> Result<Fired, Stopped> {
        self.synch_until(t, Wait::Forever)
            .map(|fired| fired.expect("an unbounded wait ends in a firing"))
    }

    /// As [`Self::synch`], but gives up after `timeout` and returns `Ok(None)`.
    pub fn synch_timeout(
        &self,
        t: TransitionRef,
        timeout: Duration,
    ) -> Result<Option<Fired>, Stopped> {
        match Instant::now().checked_add(timeout) {
            Some(deadline) => self.synch_until(t, Wait::Until(deadline)),
            None => self.synch_until(t, Wait::Forever),
        }
    }

    /// Fires `t` if it is enabled now, without waiting.
    pub fn try_synch(&self, t: TransitionRef) -> Result<Option<Fired>, Stopped> {
        self.synch_until(t, Wait::No)
    }

    fn synch_until(&self, t: TransitionRef, wait: Wait) -> Result<Option<Fired>, Stopped> {
        let header = self.header();
        let index = match t {
            TransitionRef::Null => {
                return if header.stopping.load(Ordering::SeqCst) != 0 {
                    Err(Stopped)
                } else {
                    Ok(Some(Fired {
                        generation: header.generation.load(Ordering::SeqCst),
                    }))
                };
            }
            TransitionRef::Index(i) => i,
        };
        assert!(
            index < self.net.transitions().len(),
            "transition {index} is not in this synchronisation net"
        );
        loop {
            let attempt = self.with_marking(|marking| {
                // Generation before `stopping`: `stop` sets `stopping` before bumping the
                // generation, so either we see the flag or our futex wait sees the bump.
                let seen = header.generation.load(Ordering::SeqCst);
                if header.stopping.load(Ordering::SeqCst) != 0 {
                    return Err(Stopped);
                }
                if self.net.fire_in(index, marking) {
                    let generation = header.generation.fetch_add(1, Ordering::SeqCst);
                    Ok(Ok(generation.wrapping_add(1)))
                } else {
                    Ok(Err(seen))
                }
            })?;
            let seen = match attempt {
                Ok(generation) => {
                    // The firing may have enabled transitions others wait on.
                    futex::wake(&header.generation, i32::MAX);
                    return Ok(Some(Fired { generation }));
                }
                Err(seen) => seen,
            };
            let timeout = match wait {
                Wait::No => return Ok(None),
                Wait::Forever => None,
                Wait::Until(deadline) => {
                    let now = Instant::now();
                    if now >= deadline {
                        return Ok(None);
                    }
                    Some(deadline - now)
                }
            };
            futex::wait(&header.generation, seen, timeout);
        }
    }

    /// Tells every waiter, in every process, that the PLC is stopping: their `synch` calls
    /// (and all later ones) return `Err(Stopped)`. Lock-free, so it may be called from
    /// anywhere, a signal handler's thread included.
    pub fn stop(&self) {
        let header = self.header();
        header.stopping.store(1, Ordering::SeqCst);
        header.generation.fetch_add(1, Ordering::SeqCst);
        futex::wake(&header.generation, i32::MAX);
    }

    /// Whether [`Self::stop`] was called.
    pub fn is_stopping(&self) -> bool {
        self.header().stopping.load(Ordering::SeqCst) != 0
    }

    /// The current marking, one entry per place of [`Self::net`] (a consistent snapshot).
    pub fn marking(&self) -> Vec<u32> {
        self.with_marking(|m| m.to_vec())
    }

    /// How many firings (and stops) there have been; wraps.
    pub fn generation(&self) -> u32 {
        self.header().generation.load(Ordering::SeqCst)
    }
}

#[derive(Clone, Copy)]
enum Wait {
    No,
    Forever,
    Until(Instant),
}

impl Drop for SharedSynch {
    fn drop(&mut self) {
        if self.creator {
            let _ = shm_unlink(self.shm.as_str());
        }
    }
}

impl std::fmt::Debug for SharedSynch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("SharedSynch")
            .field("shm", &self.shm)
            .field("creator", &self.creator)
            .field("marking", &self.marking())
            .field("stopping", &self.is_stopping())
            .finish()
    }
}
