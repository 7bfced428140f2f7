//! The global map: a header, the image's words, the force table and the update journal in
//! POSIX shared memory named after the plc id, guarded by a robust mutex in the header that
//! works across processes and threads (`crate::futex`).
//!
//! The force table is two more arrays of as many words: a mask of the forced bits and their
//! forced values. The words keep what the owners write; every read but the owner's (a
//! module's `update()`, [`GlobalMap::read_point`]) lays the forced bits over them.
//!
//! The journal makes a module's `update()` all or nothing even if the module dies half-way
//! (`kill -9` in the middle of the copy): the updater opens it with the [`Span`]s of words it
//! will write, then writes them chunk by chunk, saving each chunk's words (only the words it
//! changes, one after the other) and counting them as saved just before overwriting them
//! (the chunk is still in the cache when it is written, so the journal costs a pass over
//! cache lines, not over memory). The next process to take the lock after the holder's
//! death finds the journal open and puts the saved words back, so the image holds that
//! module's previous values, never a mix of two scans. Each force request is a single word's mask and value, written value first, so it is
//! applied or not.

use std::fs::File;
use std::os::unix::fs::MetadataExt;
use std::sync::atomic::{compiler_fence, AtomicU32, AtomicU64, Ordering};
use std::sync::Arc;

use memmap2::{MmapOptions, MmapRaw};
use nix::errno::Errno;
use nix::fcntl::OFlag;
use nix::sys::mman::{shm_open, shm_unlink};
use nix::sys::stat::Mode;

use super::layout::{Layout, PointId};
use super::{ImageError, PointValue};
use crate::futex::{self, RobustMutex};

const MAGIC: u64 = u64::from_le_bytes(*b"PPLCIMG\0");
/// Bumped whenever the header or the word encoding changes, so that an old module is refused
/// rather than misreading a newer PLC's image.
const VERSION: u32 = 4;
/// The header: its fields, then the lock on a cache line of its own. The words start right
/// after it, away from the contended lock.
const HEADER: usize = 128;
/// Where the words start within a page, for module maps that align their private copy alike.
pub(crate) const WORDS_PAGE_OFFSET: usize = HEADER % 4096;

// Everything but the lock is atomic: other processes read the header while we write it.
#[repr(C)]
struct Header {
    magic: AtomicU64,
    version: AtomicU32,
    words: AtomicU32,
    fingerprint: AtomicU64,
    /// The creating process, for messages.
    creator: AtomicU32,
    /// How many words have forced bits: 0 lets `update()` skip the force table.
    forced_words: AtomicU32,
    /// Bumped by every change of the force table, so maps refresh their copy of the mask.
    force_generation: AtomicU32,
    /// How many spans the journal holds: non-zero while an update writes words out (see
    /// [`Journal`]).
    journal: AtomicU32,
    /// 1 when the lock has priority inheritance.
    inherit: AtomicU32,
    /// How often a lock held by a process that died was recovered.
    recoveries: AtomicU32,
    /// How many words of the open journal's spans, in order, are saved (and may have been
    /// overwritten since).
    journal_saved: AtomicU32,
    _reserved: [AtomicU32; 3],
    lock: RobustMutex,
}

const _: () = assert!(std::mem::size_of::<Header>() == HEADER);

/// The arrays after the header, in units of the image's word count: the words, the force
/// mask, the forced values and the journal's saved words; the journal's spans follow them
/// ([`span_area`] u32s).
const ARRAYS: usize = 4;

/// The journal records which words of a span it saved by their index modulo `LANES`.
pub(crate) const LANES: usize = 16;

/// Every lane of a [`Span`]: every word of it.
pub(crate) const ALL_LANES: u32 = (1 << LANES) - 1;

/// The u32s of the journal's spans: three per span, at most one span per block of [`LANES`]
/// words (an update's spans are whole blocks, the last perhaps cut by the image's end).
fn span_area(words: usize) -> usize {
    3 * words.div_ceil(LANES)
}

/// The size of the mapping of an image of `words` words.
fn map_len(words: usize) -> usize {
    HEADER + 4 * (ARRAYS * words + span_area(words))
}

/// Words an update writes, as its journal lists them: of the words `start..end`, those whose
/// index modulo [`LANES`] is a set bit of `lanes` ([`ALL_LANES`]: all of them). An update
/// may list words it leaves unchanged; it must list every word it changes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Span {
    pub start: u32,
    pub end: u32,
    pub lanes: u32,
}

/// The journal's undo: puts the first `count` saved words back, in the order of the first
/// `open` spans of `spans` (three u32s each). Bounds are checked, as the arrays come from
/// a process that died.
fn undo(words: &mut [u32], saved: &[u32], spans: &[u32], open: usize, count: usize) {
    let mut k = 0;
    let count = count.min(saved.len());
    for s in spans.chunks_exact(3).take(open) {
        let (start, end, lanes) = (s[0] as usize, (s[1] as usize).min(words.len()), s[2]);
        for (i, w) in words.iter_mut().enumerate().take(end).skip(start) {
            if k == count {
                return;
            }
            if lanes >> (i % LANES) & 1 != 0 {
                *w = saved[k];
                k += 1;
            }
        }
    }
}

/// The shared process image of one PLC. Cheap to clone (threads of one process share the
/// mapping); the creator's last clone removes the shared memory name when dropped.
#[derive(Clone)]
pub struct GlobalMap {
    inner: Arc<Inner>,
}

struct Inner {
    map: MmapRaw,
    shm: String,
    plc_id: String,
    words: usize,
    fingerprint: u64,
    /// The inode of the object we created, if we did: only that one is ours to unlink.
    created: Option<u64>,
}

impl std::fmt::Debug for GlobalMap {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GlobalMap")
            .field("shm", &self.inner.shm)
            .field("words", &self.inner.words)
            .field("creator", &self.inner.created.is_some())
            .finish()
    }
}

impl Drop for Inner {
    fn drop(&mut self) {
        let Some(ino) = self.created else { return };
        // If the name was removed and reused by another PLC meanwhile, leave that one alone.
        if let Ok(fd) = shm_open(self.shm.as_str(), OFlag::O_RDONLY, Mode::empty()) {
            let same = File::from(fd).metadata().is_ok_and(|m| m.ino() == ino);
            if same {
                let _ = shm_unlink(self.shm.as_str());
            }
        }
    }
}

/// The shared memory name of a PLC's image.
pub fn shm_name(plc_id: &str) -> Result<String, ImageError> {
    crate::shm_name::object_name(plc_id, "image").map_err(|reason| ImageError::BadPlcId {
        plc_id: plc_id.to_string(),
        reason: reason.to_string(),
    })
}

fn os(what: &'static str, shm: &str, e: impl Into<std::io::Error>) -> ImageError {
    ImageError::Os {
        what,
        shm: shm.to_string(),
        source: e.into(),
    }
}

impl GlobalMap {
    /// Creates the image of PLC `plc_id` with every point at its init value. Refused if a PLC
    /// with that id already has one.
    pub fn create(plc_id: &str, layout: &Layout) -> Result<GlobalMap, ImageError> {
        let shm = shm_name(plc_id)?;
        let flags = OFlag::O_CREAT | OFlag::O_EXCL | OFlag::O_RDWR;
        let fd = match shm_open(shm.as_str(), flags, Mode::from_bits_truncate(0o660)) {
            Ok(fd) => fd,
            Err(Errno::EEXIST) => {
                return Err(ImageError::AlreadyRunning {
                    plc_id: plc_id.to_string(),
                    shm,
                })
            }
            Err(e) => return Err(os("cannot create shared memory", &shm, e)),
        };
        let file = File::from(fd);
        let (map, ino) = match Self::init(&file, &shm, layout) {
            Ok(done) => done,
            Err(e) => {
                // The name is ours and useless: leave nothing behind for the next attempt.
                let _ = shm_unlink(shm.as_str());
                return Err(e);
            }
        };
        Ok(GlobalMap {
            inner: Arc::new(Inner {
                map,
                shm,
                plc_id: plc_id.to_string(),
                words: layout.words(),
                fingerprint: layout.fingerprint(),
                created: Some(ino),
            }),
        })
    }

    fn init(file: &File, shm: &str, layout: &Layout) -> Result<(MmapRaw, u64), ImageError> {
        let ino = file
            .metadata()
            .map_err(|e| os("cannot stat shared memory", shm, e))?
            .ino();
        let len = map_len(layout.words());
        file.set_len(len as u64)
            .map_err(|e| os("cannot size shared memory", shm, e))?;
        let map = MmapOptions::new()
            .len(len)
            .map_raw(file)
            .map_err(|e| os("cannot map shared memory", shm, e))?;
        let init = layout.init_words();
        // SAFETY: the mapping is `len` = map_len(init.len()) bytes and page-aligned, so
        // the words start 4-aligned at HEADER; nobody else can use the words before the magic
        // below is published (`open` refuses an image without it).
        unsafe {
            let words = map.as_mut_ptr().add(HEADER).cast::<u32>();
            std::ptr::copy_nonoverlapping(init.as_ptr(), words, init.len());
        }
        let h = header(&map);
        // SAFETY: the image is not published yet (no magic), so nobody else uses the lock.
        let protocol = unsafe { h.lock.init() }
            .map_err(|e| os("cannot create the lock of shared memory", shm, e))?;
        h.inherit.store(
            u32::from(protocol == futex::Protocol::Inherit),
            Ordering::Relaxed,
        );
        h.version.store(VERSION, Ordering::Relaxed);
        h.words.store(layout.words() as u32, Ordering::Relaxed);
        h.fingerprint.store(layout.fingerprint(), Ordering::Relaxed);
        h.creator.store(std::process::id(), Ordering::Relaxed);
        // Release: whoever sees the magic sees the header and the initial words too.
        h.magic.store(MAGIC, Ordering::Release);
        Ok((map, ino))
    }

    /// Opens the image of the running PLC `plc_id`.
    pub fn open(plc_id: &str) -> Result<GlobalMap, ImageError> {
        let shm = shm_name(plc_id)?;
        let fd = match shm_open(shm.as_str(), OFlag::O_RDWR, Mode::empty()) {
            Ok(fd) => fd,
            Err(Errno::ENOENT) => {
                return Err(ImageError::NotRunning {
                    plc_id: plc_id.to_string(),
                    shm,
                })
            }
            Err(e) => return Err(os("cannot open shared memory", &shm, e)),
        };
        let file = File::from(fd);
        let bad = |reason: String| ImageError::BadImage {
            shm: shm.clone(),
            reason,
        };
        let len = file
            .metadata()
            .map_err(|e| os("cannot stat shared memory", &shm, e))?
            .len() as usize;
        if len < HEADER {
            return Err(bad(format!(
                "{len} bytes, smaller than its header (is the PLC still starting?)"
            )));
        }
        let map = MmapOptions::new()
            .len(len)
            .map_raw(&file)
            .map_err(|e| os("cannot map shared memory", &shm, e))?;
        let h = header(&map);
        if h.magic.load(Ordering::Acquire) != MAGIC {
            return Err(bad(
                "no petriplc header (is the PLC still starting?)".to_string()
            ));
        }
        let version = h.version.load(Ordering::Relaxed);
        if version != VERSION {
            return Err(bad(format!(
                "format version {version}, this program reads version {VERSION}"
            )));
        }
        let words = h.words.load(Ordering::Relaxed) as usize;
        if map_len(words) != len {
            return Err(bad(format!("{len} bytes do not hold {words} words")));
        }
        let fingerprint = h.fingerprint.load(Ordering::Relaxed);
        Ok(GlobalMap {
            inner: Arc::new(Inner {
                map,
                shm,
                plc_id: plc_id.to_string(),
                words,
                fingerprint,
                created: None,
            }),
        })
    }

    /// Removes the shared memory name of PLC `plc_id` (after a crash left it behind).
    /// Processes that have it mapped keep their mapping. Returns whether there was one.
    pub fn unlink(plc_id: &str) -> Result<bool, ImageError> {
        let shm = shm_name(plc_id)?;
        crate::shm_name::unlink(&shm).map_err(|e| os("cannot remove shared memory", &shm, e))
    }

    /// Refuses a layout other than the one the PLC was created with.
    pub fn check_layout(&self, layout: &Layout) -> Result<(), ImageError> {
        if layout.fingerprint() == self.inner.fingerprint && layout.words() == self.inner.words {
            Ok(())
        } else {
            Err(ImageError::LayoutMismatch {
                plc_id: self.inner.plc_id.clone(),
            })
        }
    }

    pub fn words(&self) -> usize {
        self.inner.words
    }

    pub fn plc_id(&self) -> &str {
        &self.inner.plc_id
    }

    /// The shared memory name (`/petriplc-<plc id>-image`).
    pub fn shm(&self) -> &str {
        &self.inner.shm
    }

    pub fn fingerprint(&self) -> u64 {
        self.inner.fingerprint
    }

    /// Takes the image's lock: the words can be accessed through the guard until it drops.
    /// Holders must not block while holding it (every other module would wait). If the
    /// previous holder died holding it, its half-done update is undone first.
    pub fn lock(&self) -> ImageGuard<'_> {
        let h = header(&self.inner.map);
        let lock = h.lock.lock(|| self.repair());
        ImageGuard {
            _lock: lock,
            map: self,
        }
    }

    /// Puts the image back as it was before the update of a process that died holding the
    /// lock (the lock is held).
    fn repair(&self) {
        let h = header(&self.inner.map);
        let n = self.inner.words;
        // SAFETY: we hold the lock (handed over by EOWNERDEAD), so nobody else touches the
        // arrays; the mapping holds map_len(n) - HEADER bytes of u32s at HEADER.
        let all = unsafe {
            std::slice::from_raw_parts_mut(
                self.inner.map.as_mut_ptr().add(HEADER).cast::<u32>(),
                ARRAYS * n + span_area(n),
            )
        };
        let (words, rest) = all.split_at_mut(n);
        let (force_mask, rest) = rest.split_at_mut(n);
        let (_, rest) = rest.split_at_mut(n);
        let (saved, spans) = rest.split_at_mut(n);
        let open = h.journal.load(Ordering::Acquire) as usize;
        let count = h.journal_saved.load(Ordering::Acquire) as usize;
        undo(words, saved, spans, open, count);
        h.journal.store(0, Ordering::Release);
        // A force request is applied whole or not at all, but the count of forced words
        // may lag behind the mask: count again, and make every map refresh its copy.
        let forced = force_mask.iter().filter(|&&m| m != 0).count();
        h.forced_words.store(forced as u32, Ordering::Relaxed);
        h.force_generation.fetch_add(1, Ordering::Relaxed);
        h.recoveries.fetch_add(1, Ordering::Relaxed);
    }

    /// How often the lock was recovered from a process that died holding it.
    pub fn recoveries(&self) -> u32 {
        header(&self.inner.map).recoveries.load(Ordering::Relaxed)
    }

    /// Whether the lock has priority inheritance (bounded priority inversion for
    /// SCHED_FIFO modules); `false` where the kernel has no PI futexes.
    pub fn priority_inheritance(&self) -> bool {
        header(&self.inner.map).inherit.load(Ordering::Relaxed) != 0
    }

    /// The value of one point, read under the lock (for displays and loggers that own
    /// nothing). `layout` must be the one [`GlobalMap::check_layout`] accepted.
    /// Forced points read as forced.
    pub fn read_point(&self, layout: &Layout, id: PointId) -> PointValue {
        let s = layout.slot(id);
        let word = self.lock().parts_mut().forced_word(s.word as usize);
        s.decode(word)
    }

    /// A consistent copy of every word, to decode many points with [`Layout::decode`];
    /// forced points read as forced.
    pub fn snapshot(&self, out: &mut Vec<u32>) {
        let mut g = self.lock();
        let forced = g.any_forced();
        out.clear();
        out.extend_from_slice(g.words());
        if forced {
            let parts = g.parts_mut();
            for (w, word) in out.iter_mut().enumerate() {
                *word = parts.forced_word(w);
            }
        }
    }
}

fn header(map: &MmapRaw) -> &Header {
    debug_assert!(map.len() >= HEADER);
    // SAFETY: every mapping is at least HEADER bytes (checked by `open`, made so by
    // `create`) and page-aligned; Header is all atomics, for which any bit pattern is valid
    // and concurrent access from other processes is fine; the reference lives no longer than
    // the mapping it borrows.
    unsafe { &*map.as_mut_ptr().cast::<Header>() }
}

/// Exclusive access to the image's words; dropping it releases the lock.
pub struct ImageGuard<'a> {
    map: &'a GlobalMap,
    /// Released when the guard drops.
    _lock: futex::Guard<'a>,
}

/// The journal of an update in progress (see the module documentation).
pub struct Journal<'g> {
    /// The saved words, one after the other in the order of the spans.
    saved: &'g mut [u32],
    /// The spans, three u32s each.
    spans: &'g mut [u32],
    open: &'g AtomicU32,
    saved_count: &'g AtomicU32,
    /// Words saved so far (what `saved_count` holds).
    count: u32,
}

impl Journal<'_> {
    /// Opens the journal for an update that will write the words of `spans` (at most one
    /// span per block of [`LANES`] words), in this order, each chunk saved by
    /// [`Journal::save`] just before it is written. From here until [`Journal::close`], a
    /// death of this process makes the next locker put the saved words back.
    pub(crate) fn open(&mut self, spans: &[Span]) {
        assert!(
            3 * spans.len() <= self.spans.len(),
            "{} journal spans for {} words",
            spans.len(),
            self.saved.len()
        );
        for (d, s) in self.spans.chunks_exact_mut(3).zip(spans) {
            d.copy_from_slice(&[s.start, s.end, s.lanes]);
        }
        self.count = 0;
        self.saved_count.store(0, Ordering::Relaxed);
        self.open.store(spans.len() as u32, Ordering::Release);
        // A death is precise (every instruction before the kill ran, none after), so program
        // order is enough: keep the compiler from moving stores across these points.
        compiler_fence(Ordering::SeqCst);
    }

    /// Saves the next `n` words of the spans (in order, the words the spans list) before they
    /// are written: `fill` writes their present values into the slice it is given.
    #[inline(always)]
    pub(crate) fn save(&mut self, n: usize, fill: impl FnOnce(&mut [u32])) {
        let at = self.count as usize;
        fill(&mut self.saved[at..at + n]);
        compiler_fence(Ordering::SeqCst);
        self.count += n as u32;
        self.saved_count.store(self.count, Ordering::Relaxed);
        compiler_fence(Ordering::SeqCst);
    }

    /// Saves and writes `pieces` pieces of `n` words each (`n` > 0), one piece after the
    /// other: `save(i, slot)` writes the present values of piece `i`'s words into `slot`,
    /// then, the journal counting them, `write(i)` may overwrite them. As [`Journal::save`]
    /// once per piece, but the count stays in a register between pieces.
    #[inline(always)]
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))] // used by the vector merges
    pub(crate) fn save_each(
        &mut self,
        pieces: usize,
        n: usize,
        mut save: impl FnMut(usize, &mut [u32]),
        mut write: impl FnMut(usize),
    ) {
        let at = self.count as usize;
        let saved_count = self.saved_count;
        for (i, slot) in self.saved[at..at + pieces * n]
            .chunks_exact_mut(n)
            .enumerate()
        {
            save(i, slot);
            compiler_fence(Ordering::SeqCst);
            saved_count.store((at + (i + 1) * n) as u32, Ordering::Relaxed);
            compiler_fence(Ordering::SeqCst);
            write(i);
        }
        self.count = (at + pieces * n) as u32;
    }

    /// Closes the journal: the update is complete.
    pub fn close(&mut self) {
        compiler_fence(Ordering::SeqCst);
        self.open.store(0, Ordering::Release);
    }
}

/// A journal in private memory, for unit tests of what an update saves.
#[cfg(test)]
pub(crate) struct TestJournal {
    saved: Vec<u32>,
    spans: Vec<u32>,
    open: AtomicU32,
    count: AtomicU32,
}

#[cfg(test)]
impl TestJournal {
    pub(crate) fn new(words: usize) -> TestJournal {
        TestJournal {
            saved: vec![0; words],
            spans: vec![0; span_area(words)],
            open: AtomicU32::new(0),
            count: AtomicU32::new(0),
        }
    }

    pub(crate) fn journal(&mut self) -> Journal<'_> {
        Journal {
            saved: &mut self.saved,
            spans: &mut self.spans,
            open: &self.open,
            saved_count: &self.count,
            count: 0,
        }
    }

    /// What a process taking the lock after a death would do, as if the update had died
    /// after saving its first `count` words (all of them: `None`); the spans as last opened.
    pub(crate) fn undo(&self, words: &mut [u32], count: Option<usize>) {
        let saved = self.count.load(Ordering::Relaxed) as usize;
        let spans = self.spans.len() / 3;
        undo(
            words,
            &self.saved,
            &self.spans,
            spans,
            count.unwrap_or(saved).min(saved),
        );
    }

    /// How many words the last update saved.
    pub(crate) fn saved(&self) -> usize {
        self.count.load(Ordering::Relaxed) as usize
    }
}

/// The words, the force table and the journal, borrowed together from a held lock.
pub struct Parts<'g> {
    pub words: &'g mut [u32],
    /// The forced bits of each word.
    pub force_mask: &'g mut [u32],
    /// Their values (only the bits in `force_mask` mean anything).
    pub force_value: &'g mut [u32],
    /// Makes a copy-out of several words all or nothing.
    pub journal: Journal<'g>,
}

impl Parts<'_> {
    /// Forces the bits `mask` of word `w` to those of `value` (`None`: releases them).
    /// Returns whether the table changed.
    pub fn set_force(&mut self, w: usize, mask: u32, value: Option<u32>) -> bool {
        let (old_mask, old_value) = (self.force_mask[w], self.force_value[w]);
        // Value before mask: a process dying in between leaves the force not yet applied,
        // never applied with a stale value.
        match value {
            Some(v) => {
                self.force_value[w] = (old_value & !mask) | (v & mask);
                compiler_fence(Ordering::SeqCst);
                self.force_mask[w] |= mask;
            }
            None => self.force_mask[w] &= !mask,
        }
        self.force_mask[w] != old_mask || self.force_value[w] & mask != old_value & mask
    }

    /// Word `w` as every module but its owners reads it: with its forced bits.
    pub fn forced_word(&self, w: usize) -> u32 {
        let fm = self.force_mask[w];
        (self.words[w] & !fm) | (self.force_value[w] & fm)
    }
}

impl ImageGuard<'_> {
    /// Whether any bit is forced (cheap: a counter in the header).
    pub fn any_forced(&self) -> bool {
        header(&self.map.inner.map)
            .forced_words
            .load(Ordering::Relaxed)
            != 0
    }

    /// Changes with every change of the force table.
    pub fn force_generation(&self) -> u32 {
        header(&self.map.inner.map)
            .force_generation
            .load(Ordering::Relaxed)
    }

    /// The words, the force table and the journal at once.
    pub fn parts_mut(&mut self) -> Parts<'_> {
        let inner = &self.map.inner;
        let n = inner.words;
        // SAFETY: the mapping holds ARRAYS * `words` + span_area(`words`) u32s at HEADER
        // (4-aligned, checked at open and create); the slices are disjoint; holding the lock
        // makes this the only access among well-behaved users, and the slices borrow the
        // guard mutably.
        let all = unsafe {
            std::slice::from_raw_parts_mut(
                inner.map.as_mut_ptr().add(HEADER).cast::<u32>(),
                ARRAYS * n + span_area(n),
            )
        };
        let (words, rest) = all.split_at_mut(n);
        let (force_mask, rest) = rest.split_at_mut(n);
        let (force_value, rest) = rest.split_at_mut(n);
        let (saved, spans) = rest.split_at_mut(n);
        Parts {
            words,
            force_mask,
            force_value,
            journal: Journal {
                saved,
                spans,
                open: &header(&inner.map).journal,
                saved_count: &header(&inner.map).journal_saved,
                count: 0,
            },
        }
    }

    /// Records that the force table changed (after [`Parts::set_force`] said so).
    pub fn force_changed(&mut self) {
        let forced = self
            .parts_mut()
            .force_mask
            .iter()
            .filter(|&&m| m != 0)
            .count();
        let h = header(&self.map.inner.map);
        h.forced_words.store(forced as u32, Ordering::Relaxed);
        h.force_generation.fetch_add(1, Ordering::Relaxed);
    }

    pub fn words(&self) -> &[u32] {
        let inner = &self.map.inner;
        // SAFETY: the mapping holds `words` u32s at HEADER (4-aligned, checked at open and
        // create); holding the lock makes this the only access to them among well-behaved
        // users, and the slice borrows the guard, so it ends before the lock is released.
        unsafe {
            std::slice::from_raw_parts(
                inner.map.as_mut_ptr().add(HEADER).cast::<u32>(),
                inner.words,
            )
        }
    }

    pub fn words_mut(&mut self) -> &mut [u32] {
        let inner = &self.map.inner;
        // SAFETY: as in `words`; the guard is borrowed mutably, so no other slice from it
        // exists while this one does.
        unsafe {
            std::slice::from_raw_parts_mut(
                inner.map.as_mut_ptr().add(HEADER).cast::<u32>(),
                inner.words,
            )
        }
    }
}
