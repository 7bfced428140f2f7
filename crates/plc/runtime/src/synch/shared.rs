//! The marking of the synchronisation net in POSIX shared memory
//! (`/petriplc-<plc_id>-synch`), on which the modules of every process fire transitions
//! atomically, blocking on a futex until the transition they wait on is enabled.
//!
//! Layout: a [`Header`] (magic, version, sizes, a fingerprint of the net, the generation
//! counter, the `stopping` flag, the journal's state, then the robust lock on a cache line of
//! its own), then one `u32` per place (the marking), one per synchronised module (whether it
//! is inside a scan: its `scan_beg` fired, its `scan_end` not yet), and the journal's copy of
//! the marking. The marking and the scan slots are only read or written with the lock held;
//! the generation counter is bumped, under the lock, by every change a waiter could care
//! about (a firing, `stop`), and waiters sleep on it with the value they read under the lock,
//! so a change between their check and their sleep makes the sleep return at once: no lost
//! wake-ups.
//!
//! A firing is all or nothing even if the firing process dies half-way: the marking (and
//! the scan slot the firing changes) is copied to the journal before the firing, and the
//! next process to take the lock after the holder's death puts it back (`crate::futex`).

use std::fs::File;
use std::mem::size_of;
use std::sync::atomic::{compiler_fence, AtomicU32, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use memmap2::{MmapMut, MmapOptions};
use nix::errno::Errno;
use nix::fcntl::OFlag;
use nix::sys::mman::{shm_open, shm_unlink};
use nix::sys::stat::Mode;

use super::{ScanRef, SynchError, SynchNet, TransitionRef};
use crate::futex::{self, RobustMutex};
use crate::testhook;

const MAGIC: u32 = u32::from_be_bytes(*b"PPSY");
const VERSION: u32 = 2;
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
    generation: AtomicU32,
    stopping: AtomicU32,
    /// Non-zero while a firing changes the marking (the journal holds the marking before it).
    journal: AtomicU32,
    /// The scan slot the journalled firing changes (`NO_SLOT`: none) and its value before.
    journal_slot: AtomicU32,
    journal_slot_value: AtomicU32,
    /// How many scan slots follow the marking.
    slots: AtomicU32,
    /// 1 when the lock has priority inheritance.
    inherit: AtomicU32,
    /// How often a lock held by a process that died was recovered.
    recoveries: AtomicU32,
    _reserved: [AtomicU32; 2],
    lock: RobustMutex,
}

const HEADER_SIZE: usize = size_of::<Header>();
const _: () = assert!(HEADER_SIZE == 128);
const NO_SLOT: u32 = u32::MAX;

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
    /// Keeps the mapping alive; all access goes through the pointers below.
    _map: MmapMut,
    header: *const Header,
    /// The marking (one u32 per place), then the scan slots (one per synchronised module),
    /// then the journal's marking.
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
    HEADER_SIZE + (2 * net.places().len() + net.scan_slots()) * size_of::<u32>()
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
        // marking; the mapping holds the marking, the slots and the journal (`size_for`),
        // and a fresh object is all zeros (no module is inside a scan).
        let marking = unsafe { std::slice::from_raw_parts_mut(this.marking, net.places().len()) };
        marking.copy_from_slice(initial.tokens());
        // SAFETY: as above, nobody else can use the lock before the magic is published.
        let protocol = unsafe { header.lock.init() }.map_err(|source| SynchError::Os {
            what: "cannot create the lock of shared memory",
            shm: shm.clone(),
            source,
        })?;
        header.inherit.store(
            u32::from(protocol == futex::Protocol::Inherit),
            Ordering::Relaxed,
        );
        header
            .slots
            .store(net.scan_slots() as u32, Ordering::Relaxed);
        header.journal.store(0, Ordering::Relaxed);
        header.journal_slot.store(NO_SLOT, Ordering::Relaxed);
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
                "it is {len} bytes, this net and its {} synchronised modules need {size}",
                net.scan_slots()
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

    /// Runs `f` on the marking, the scan slots and the journal's marking with the lock held.
    fn with_marking<R>(&self, f: impl FnOnce(Arrays<'_>) -> R) -> R {
        let _guard = self.header().lock.lock(|| self.repair());
        f(self.arrays())
    }

    /// The arrays after the header. Only to be called with the lock held.
    fn arrays(&self) -> Arrays<'_> {
        let places = self.net.places().len();
        let slots = self.net.scan_slots();
        // SAFETY: the caller holds the lock, which serialises every access to the arrays
        // across threads and processes, so this is the only reference to them until the
        // lock is released (the borrow cannot outlive the closure of `with_marking`); the
        // mapping holds 2 × places + slots u32s after the header (`size_for`).
        let all = unsafe { std::slice::from_raw_parts_mut(self.marking, 2 * places + slots) };
        let (marking, rest) = all.split_at_mut(places);
        let (slots, journal) = rest.split_at_mut(slots);
        Arrays {
            marking,
            slots,
            journal,
        }
    }

    /// Undoes the firing of a process that died holding the lock (the lock is held).
    fn repair(&self) {
        let header = self.header();
        let a = self.arrays();
        if header.journal.load(Ordering::Acquire) != 0 {
            a.marking.copy_from_slice(a.journal);
            let slot = header.journal_slot.load(Ordering::Relaxed);
            if let Some(s) = a.slots.get_mut(slot as usize) {
                *s = header.journal_slot_value.load(Ordering::Relaxed);
            }
            header.journal.store(0, Ordering::Release);
        }
        header.recoveries.fetch_add(1, Ordering::Relaxed);
        // Waiters may have seen a generation the undone firing bumped: make them look again.
        header.generation.fetch_add(1, Ordering::SeqCst);
        futex::wake(&header.generation, i32::MAX);
    }

    /// How often the lock was recovered from a process that died holding it.
    pub fn recoveries(&self) -> u32 {
        self.header().recoveries.load(Ordering::Relaxed)
    }

    /// Whether the lock has priority inheritance (see [`crate::image::GlobalMap::priority_inheritance`]).
    pub fn priority_inheritance(&self) -> bool {
        self.header().inherit.load(Ordering::Relaxed) != 0
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
        self.fire_when_enabled(t, None, wait)
    }

    /// Waits until module `scan`'s `scan_beg` is enabled and fires it, marking the module
    /// inside its scan in the same atomic step (see [`Self::abandon_scan`]).
    pub fn begin_scan(&self, scan: &ScanRef) -> Result<Fired, Stopped> {
        self.fire_when_enabled(scan.beg, Some((scan.slot, 1)), Wait::Forever)
            .map(|fired| fired.expect("an unbounded wait ends in a firing"))
    }

    /// Waits until module `scan`'s `scan_end` is enabled and fires it, marking the module
    /// outside its scan in the same atomic step.
    pub fn end_scan(&self, scan: &ScanRef) -> Result<Fired, Stopped> {
        self.fire_when_enabled(scan.end, Some((scan.slot, 0)), Wait::Forever)
            .map(|fired| fired.expect("an unbounded wait ends in a firing"))
    }

    /// Whether module `scan` is inside a scan: its `scan_beg` fired and its `scan_end` not yet.
    pub fn in_scan(&self, scan: &ScanRef) -> bool {
        self.with_marking(|a| a.slots.get(scan.slot).is_some_and(|&v| v != 0))
    }

    /// Ends the scan of a module that failed inside it (its process died, its scan failed),
    /// so that the modules lock-stepped with it are not left waiting for a `scan_end` that
    /// would never come: if the module is inside a scan, its `scan_end` is fired now on its
    /// behalf when enabled, and the module is marked outside its scan either way.
    pub fn abandon_scan(&self, scan: &ScanRef) -> Abandoned {
        let header = self.header();
        let result = self.with_marking(|a| {
            if a.slots.get(scan.slot).is_none_or(|&v| v == 0) {
                return Abandoned::NotInScan;
            }
            let fired = match scan.end {
                TransitionRef::Null => true,
                TransitionRef::Index(i) => {
                    if self.net.enabled_in(i, a.marking) {
                        self.fire_journalled(i, Some((scan.slot, 0)), a);
                        return Abandoned::Ended;
                    }
                    false
                }
            };
            a.slots[scan.slot] = 0;
            if fired {
                Abandoned::Ended
            } else {
                Abandoned::EndNotEnabled
            }
        });
        if result == Abandoned::Ended {
            futex::wake(&header.generation, i32::MAX);
        }
        result
    }

    /// Fires transition `index` (enabled in `a.marking`) and sets `slot`, inside the
    /// journal. The lock is held.
    fn fire_journalled(&self, index: usize, slot: Option<(usize, u32)>, a: Arrays<'_>) -> u32 {
        let header = self.header();
        a.journal.copy_from_slice(a.marking);
        match slot {
            Some((s, _)) => {
                header.journal_slot.store(s as u32, Ordering::Relaxed);
                header
                    .journal_slot_value
                    .store(a.slots[s], Ordering::Relaxed);
            }
            None => header.journal_slot.store(NO_SLOT, Ordering::Relaxed),
        }
        header.journal.store(1, Ordering::Release);
        // A death is precise (everything before the kill ran, nothing after): program order
        // is enough, so keep the compiler from moving the firing above the journal.
        compiler_fence(Ordering::SeqCst);
        let fired = self.net.fire_in_with(index, a.marking, || {
            if testhook::fires(testhook::Point::Firing) {
                testhook::die();
            }
        });
        debug_assert!(fired, "fire_journalled on a disabled transition");
        if let Some((s, v)) = slot {
            a.slots[s] = v;
        }
        let generation = header.generation.fetch_add(1, Ordering::SeqCst);
        compiler_fence(Ordering::SeqCst);
        header.journal.store(0, Ordering::Release);
        generation.wrapping_add(1)
    }

    fn fire_when_enabled(
        &self,
        t: TransitionRef,
        slot: Option<(usize, u32)>,
        wait: Wait,
    ) -> Result<Option<Fired>, Stopped> {
        let header = self.header();
        let index = match t {
            TransitionRef::Null => {
                if header.stopping.load(Ordering::SeqCst) != 0 {
                    return Err(Stopped);
                }
                if let Some((s, v)) = slot {
                    self.with_marking(|a| a.slots[s] = v);
                }
                return Ok(Some(Fired {
                    generation: header.generation.load(Ordering::SeqCst),
                }));
            }
            TransitionRef::Index(i) => i,
        };
        assert!(
            index < self.net.transitions().len(),
            "transition {index} is not in this synchronisation net"
        );
        loop {
            let attempt = self.with_marking(|a| {
                // Generation before `stopping`: `stop` sets `stopping` before bumping the
                // generation, so either we see the flag or our futex wait sees the bump.
                let seen = header.generation.load(Ordering::SeqCst);
                if header.stopping.load(Ordering::SeqCst) != 0 {
                    return Err(Stopped);
                }
                if self.net.enabled_in(index, a.marking) {
                    Ok(Ok(self.fire_journalled(index, slot, a)))
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
        self.with_marking(|a| a.marking.to_vec())
    }

    /// How many firings (and stops) there have been; wraps.
    pub fn generation(&self) -> u32 {
        self.header().generation.load(Ordering::SeqCst)
    }
}

/// What [`SharedSynch::abandon_scan`] did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Abandoned {
    /// The module was not inside a scan: nothing to do.
    NotInScan,
    /// Its `scan_end` fired on its behalf.
    Ended,
    /// Its `scan_end` is not enabled: the module is marked outside its scan, but the
    /// modules waiting for that transition go on waiting.
    EndNotEnabled,
}

/// The arrays after the header, borrowed with the lock held.
struct Arrays<'a> {
    marking: &'a mut [u32],
    slots: &'a mut [u32],
    journal: &'a mut [u32],
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
