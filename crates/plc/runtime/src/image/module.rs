//! A module's view of the image: a private copy of the words and the mask of the bits it
//! owns, synchronised with the global map by `update()`, and typed access through handles.

use petriplc_config::{Location, PointKind, PointValue};

use super::layout::{decode, encode, show_value, sign_extend, width_mask, Layout, PointId};
use super::shm::{GlobalMap, ImageGuard, Journal, Span, ALL_LANES, LANES, WORDS_PAGE_OFFSET};
use super::{kind_name, ImageError};
use crate::testhook;

#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(avx512_intrinsics)]
mod avx512;
mod isolate;
#[cfg(target_arch = "x86_64")]
mod one_pass;

pub use isolate::process_threads;

/// A point resolved once by name, so that each access is a shift and a mask.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Handle {
    id: PointId,
    word: u32,
    shift: u8,
    bits: u8,
    kind: PointKind,
    mask: u32,
}

impl Handle {
    fn new(layout: &Layout, id: PointId) -> Handle {
        let s = layout.slot(id);
        Handle {
            id,
            word: s.word,
            shift: s.bit,
            bits: s.bits,
            kind: s.kind,
            mask: s.field_mask(),
        }
    }

    pub fn id(&self) -> PointId {
        self.id
    }

    pub fn bits(&self) -> u8 {
        self.bits
    }

    pub fn kind(&self) -> PointKind {
        self.kind
    }
}

/// How `update()` exchanges the words, precomputed from the mask once. The image is cut into
/// blocks of [`BLOCK`] words (a cache line: the words start line-aligned in both maps), and
/// runs of consecutive blocks alike become one step: owned by others (copied in), owned by
/// the module (copied out), or owned in the same pattern (merged under that pattern, held in
/// registers, so no mask is streamed from memory). Interleaved ownership, the worst case for
/// runs of words, is then one merge over the whole image.
#[derive(Debug, Default)]
struct Plan {
    steps: Vec<Step>,
    /// The patterns of [`Step::Merge`].
    patterns: Vec<Pattern>,
    /// The words the steps write, for the journal: one span per run of `Out` and `Merge`
    /// steps alike, in the order of the steps.
    spans: Vec<Span>,
    /// The widest merge loops this CPU runs (see [`merge`]).
    simd: Simd,
}

/// The instruction sets [`merge`] has loops for, narrowest first.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Simd {
    /// The target's baseline (SSE2 on x86-64).
    #[default]
    Portable,
    /// x86-64 with AVX2.
    Avx2,
    /// x86-64 with AVX-512F.
    Avx512,
}

impl Simd {
    /// The widest this CPU has.
    fn detect() -> Simd {
        [Simd::Avx512, Simd::Avx2]
            .into_iter()
            .find(|s| s.available())
            .unwrap_or(Simd::Portable)
    }

    /// Whether this CPU has it, and this build loops for it.
    fn available(self) -> bool {
        match self {
            Simd::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Simd::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(avx512_intrinsics)]
            Simd::Avx512 => std::arch::is_x86_feature_detected!("avx512f"),
            #[allow(unreachable_patterns)]
            _ => false,
        }
    }
}

/// Words per block of the plan: the journal's lanes, so that a pattern's owned words are
/// the same lanes in every block.
const BLOCK: usize = LANES;

/// A pattern with at most this many owned words per block has only those saved in the
/// journal, one after the other; a denser one has its blocks saved whole (a block copy costs
/// less than picking out most of its words).
const SPARSE: usize = BLOCK / 2;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Step {
    /// `words` words from `start` owned by other modules: global to private.
    In { start: u32, words: u32 },
    /// Owned by this module: private to global.
    Out { start: u32, words: u32 },
    /// Owned in part, every block as `patterns[pattern]` says.
    Merge {
        start: u32,
        words: u32,
        pattern: u32,
    },
}

/// The mask of a block of a [`Step::Merge`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pattern {
    mask: [u32; BLOCK],
    /// The offsets of the owned words, ascending; `sparse` of them.
    owned: [u8; BLOCK],
    /// How many words of a block are owned, if at most [`SPARSE`]; else 0 (a dense pattern).
    sparse: u8,
}

impl Pattern {
    fn new(mask: [u32; BLOCK]) -> Pattern {
        let mut owned = [0u8; BLOCK];
        let mut n = 0;
        for (o, &m) in mask.iter().enumerate() {
            if m != 0 {
                owned[n] = o as u8;
                n += 1;
            }
        }
        Pattern {
            mask,
            owned,
            sparse: if n <= SPARSE { n as u8 } else { 0 },
        }
    }

    /// The journal's lanes: the owned words of a sparse pattern, which alone it writes; every
    /// word of a dense one, which is written whole.
    fn lanes(&self) -> u32 {
        if self.sparse == 0 {
            ALL_LANES
        } else {
            self.owned[..self.sparse as usize]
                .iter()
                .fold(0, |l, &o| l | 1 << o)
        }
    }
}

/// One module's map of the image (MatPLC's private map and map mask).
#[derive(Debug)]
pub struct ModuleMap {
    layout: Layout,
    module: String,
    location: Location,
    mask: Vec<u32>,
    plan: Plan,
    words: Words,
    /// Force requests waiting for the next `update()`: word, bits, value (`None` releases).
    forces: Vec<(u32, u32, Option<u32>)>,
    /// The force mask as of the last `update()`, and the generation it was copied at.
    forced: Vec<u32>,
    forced_generation: u32,
}

/// Where the module's words are.
#[derive(Debug)]
enum Words {
    /// `buf[base..base + words]` (see `aligned_private`): `Local`, and `Shared` until its
    /// first `update()`.
    Private { buf: Vec<u32>, base: usize },
    /// The global map itself (`Shared` after its first `update()`).
    Direct(GlobalMap),
    /// A private map shared with the proxy process that updates it (`Isolate`).
    Isolated(isolate::Proxy),
}

impl ModuleMap {
    /// The map of module `module`, with every point at its init value until the first
    /// `update()`. A `Shared` module keeps this private copy only until its first `update()`,
    /// which attaches it to the global map for good.
    ///
    /// `Isolate` is refused: its proxy must open the PLC's global map, so it is built by
    /// [`ModuleMap::isolated`], which takes the plc id.
    pub fn new(layout: &Layout, module: &str, location: Location) -> Result<ModuleMap, ImageError> {
        if location == Location::Isolate {
            return Err(ImageError::Unsupported {
                what: format!(
                    "location isolate in ModuleMap::new (module `{module}`; build isolated \
                     maps with ModuleMap::isolated, which takes the plc id)"
                ),
            });
        }
        let (buf, base) = aligned_private(layout.init_words());
        Self::build(layout, module, location, |_| {
            Ok(Words::Private { buf, base })
        })
    }

    /// The map of module `module` with `location = isolate` (MatPLC's `--PLCisolate`): forks
    /// a proxy process that opens PLC `plc_id`'s global map, checks the layout, and performs
    /// every `update()` of this map on request over a socket. This process never maps the
    /// global map; `get`/`set` work on the private map, which the two processes share.
    /// Dropping the map closes the socket, which ends the proxy, and reaps it.
    ///
    /// # Fork
    /// Call it from a single-threaded process (a module at start-up, before it starts
    /// threads; see [`process_threads`]), and from the thread that lives as long as the
    /// module: the proxy gets SIGTERM when that thread ends (`PR_SET_PDEATHSIG`), so a killed
    /// module takes its proxy along.
    pub fn isolated(layout: &Layout, module: &str, plc_id: &str) -> Result<ModuleMap, ImageError> {
        Self::build(layout, module, Location::Isolate, |map| {
            let (mask, plan) = (&map.mask, &map.plan);
            let proxy = isolate::Proxy::spawn(
                layout,
                plc_id,
                layout.init_words(),
                private_page_word(),
                |g, p| exchange(plan, mask, g, p),
            )?;
            Ok(Words::Isolated(proxy))
        })
    }

    fn build(
        layout: &Layout,
        module: &str,
        location: Location,
        words: impl FnOnce(&Shape) -> Result<Words, ImageError>,
    ) -> Result<ModuleMap, ImageError> {
        if !layout.modules().iter().any(|m| m == module) {
            return Err(ImageError::UnknownModule {
                module: module.to_string(),
                modules: layout.modules().to_vec(),
            });
        }
        let mut mask = vec![0u32; layout.words()];
        for (_, s) in layout.points().filter(|(_, s)| s.owner == module) {
            mask[s.word as usize] |= s.field_mask();
        }
        let plan = plan(&mask);
        let shape = Shape { mask, plan };
        let words = words(&shape)?;
        Ok(ModuleMap {
            layout: layout.clone(),
            module: module.to_string(),
            location,
            mask: shape.mask,
            plan: shape.plan,
            words,
            forces: Vec::new(),
            forced: Vec::new(),
            forced_generation: 0,
        })
    }

    pub fn module(&self) -> &str {
        &self.module
    }

    pub fn location(&self) -> Location {
        self.location
    }

    pub fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The bits this module may write, word by word.
    pub fn mask(&self) -> &[u32] {
        &self.mask
    }

    /// Copies the owned bits out to `global` and every other bit in, atomically with respect
    /// to every other module's update. An isolated map ignores `global` and has its proxy do
    /// it (see [`ModuleMap::update_isolated`]).
    ///
    /// # Panics
    /// If `global` was created from another layout (check with [`GlobalMap::check_layout`]
    /// after opening it), or if an isolated map's proxy is gone.
    pub fn update(&mut self, global: &GlobalMap) {
        let private = match &mut self.words {
            Words::Direct(_) => return,
            Words::Isolated(_) => {
                if let Err(e) = self.update_isolated() {
                    panic!("{e}");
                }
                return;
            }
            Words::Private { buf, base } => &mut buf[*base..*base + self.mask.len()],
        };
        assert!(
            global.fingerprint() == self.layout.fingerprint() && global.words() == self.mask.len(),
            "module `{}`: the global map of PLC `{}` has another layout (GlobalMap::check_layout)",
            self.module,
            global.plc_id()
        );
        let mut guard = global.lock();
        if !self.forces.is_empty() {
            let mut parts = guard.parts_mut();
            let mut changed = false;
            for (w, bits, value) in self.forces.drain(..) {
                changed |= parts.set_force(w as usize, bits, value);
            }
            if changed {
                guard.force_changed();
            }
        }
        exchange(&self.plan, &self.mask, &mut guard, private);
        let generation = guard.force_generation();
        if generation != self.forced_generation || self.forced.len() != self.mask.len() {
            self.forced_generation = generation;
            self.forced.clear();
            self.forced.extend_from_slice(guard.parts_mut().force_mask);
        }
        drop(guard);
        if self.location == Location::Shared {
            self.words = Words::Direct(global.clone());
        }
    }

    /// Forces point `h` to `v` for every module but its owner, from this map's next
    /// `update()` until [`ModuleMap::unforce`] (an operator's force from a display or HMI):
    /// each module reads the forced value from its next update on, whatever the owner
    /// writes; the owner reads its own. `v` must suit the point as for [`ModuleMap::set`].
    /// Isolated maps cannot force.
    pub fn force(&mut self, h: &Handle, v: PointValue) -> Result<(), ImageError> {
        let raw = self.raw_of(h, v)?;
        self.request_force(h, Some(raw << h.shift))
    }

    /// Releases a force of point `h` (made by any module) at this map's next `update()`.
    pub fn unforce(&mut self, h: &Handle) -> Result<(), ImageError> {
        self.request_force(h, None)
    }

    fn request_force(&mut self, h: &Handle, value: Option<u32>) -> Result<(), ImageError> {
        match &self.words {
            Words::Isolated(_) => Err(ImageError::Unsupported {
                what: format!("forcing points from isolated module `{}`", self.module),
            }),
            Words::Direct(g) => {
                // A shared map has no update of its own to wait for: force at once.
                let mut guard = g.lock();
                if guard.parts_mut().set_force(h.word as usize, h.mask, value) {
                    guard.force_changed();
                }
                Ok(())
            }
            Words::Private { .. } => {
                self.forces.push((h.word, h.mask, value));
                Ok(())
            }
        }
    }

    /// Whether point `h` is forced: as of the last `update()` (a shared map: now).
    pub fn is_forced(&self, h: &Handle) -> bool {
        let w = h.word as usize;
        match &self.words {
            Words::Direct(g) => g.lock().parts_mut().force_mask[w] & h.mask != 0,
            _ => self.forced.get(w).is_some_and(|m| m & h.mask != 0),
        }
    }

    /// The `update()` of an isolated map, which has no global map to pass: the proxy
    /// performs it while this process waits. Fails (now and on every later call) if the
    /// proxy is gone.
    ///
    /// # Panics
    /// If the map is not isolated (use [`ModuleMap::update`]).
    pub fn update_isolated(&mut self) -> Result<(), ImageError> {
        let Words::Isolated(proxy) = &mut self.words else {
            panic!(
                "module `{}`: update_isolated on a map that is not isolated (use update)",
                self.module
            );
        };
        proxy.update().map_err(|why| ImageError::Os {
            what: "cannot update the isolated map of module",
            shm: self.module.clone(),
            source: std::io::Error::other(why),
        })
    }

    /// Whether the map was built by [`ModuleMap::isolated`].
    pub fn is_isolated(&self) -> bool {
        matches!(self.words, Words::Isolated(_))
    }

    /// The pid of an isolated map's proxy process.
    pub fn proxy_pid(&self) -> Option<u32> {
        match &self.words {
            Words::Isolated(p) => Some(p.pid()),
            _ => None,
        }
    }

    /// A handle to point `name`; an unknown name is an error listing close matches.
    pub fn handle(&self, name: &str) -> Result<Handle, ImageError> {
        Ok(Handle::new(&self.layout, self.layout.lookup(name)?))
    }

    /// Whether this module may write the point.
    pub fn owns(&self, h: &Handle) -> bool {
        self.mask
            .get(h.word as usize)
            .is_some_and(|&m| m & h.mask == h.mask)
    }

    fn raw(&self, h: &Handle) -> u32 {
        let w = match &self.words {
            Words::Private { buf, base } => buf[base + h.word as usize],
            Words::Direct(g) => {
                let w = h.word as usize;
                let mut guard = g.lock();
                let forced = guard.any_forced();
                let parts = guard.parts_mut();
                if forced {
                    let others = parts.force_mask[w] & !self.mask[w];
                    (parts.words[w] & !others) | (parts.force_value[w] & others)
                } else {
                    parts.words[w]
                }
            }
            Words::Isolated(p) => p.words()[h.word as usize],
        };
        (w & h.mask) >> h.shift
    }

    fn put(&mut self, h: &Handle, raw: u32) -> Result<(), ImageError> {
        if !self.owns(h) {
            let s = self.layout.slot(h.id);
            return Err(ImageError::NotOwner {
                point: s.name.clone(),
                owner: s.owner.clone(),
                module: self.module.clone(),
            });
        }
        let bits = raw << h.shift;
        let w = h.word as usize;
        let word = match &mut self.words {
            Words::Direct(g) => {
                // Other points may share the word: the read-modify-write must not interleave
                // with another module's update.
                let mut guard = g.lock();
                let word = &mut guard.words_mut()[w];
                *word = (*word & !h.mask) | bits;
                return Ok(());
            }
            Words::Private { buf, base } => &mut buf[*base + w],
            Words::Isolated(p) => &mut p.words_mut()[w],
        };
        *word = (*word & !h.mask) | bits;
        Ok(())
    }

    /// The point's value, typed by its kind.
    pub fn get(&self, h: &Handle) -> PointValue {
        decode(h.kind, h.bits, self.raw(h))
    }

    /// Whether the point is non-zero.
    pub fn get_bool(&self, h: &Handle) -> bool {
        match h.kind {
            PointKind::Float => f32::from_bits(self.raw(h)) != 0.0,
            _ => self.raw(h) != 0,
        }
    }

    /// The point's bits, zero-extended (a float point's IEEE 754 bits).
    pub fn get_u32(&self, h: &Handle) -> u32 {
        self.raw(h)
    }

    /// A signed point's value, sign-extended from its width; an unsigned point's bits as
    /// `i32`; a float point's value truncated towards zero.
    pub fn get_i32(&self, h: &Handle) -> i32 {
        let raw = self.raw(h);
        match h.kind {
            PointKind::Signed => sign_extend(raw, h.bits),
            PointKind::Unsigned => raw as i32,
            PointKind::Float => f32::from_bits(raw) as i32,
        }
    }

    /// A float point's value; an integer point's value converted (so a dsp block can read
    /// any point as a number).
    pub fn get_f32(&self, h: &Handle) -> f32 {
        let raw = self.raw(h);
        match h.kind {
            PointKind::Float => f32::from_bits(raw),
            PointKind::Unsigned => raw as f32,
            PointKind::Signed => sign_extend(raw, h.bits) as f32,
        }
    }

    /// Writes `v`, which must suit the point's kind and fit its bits.
    pub fn set(&mut self, h: &Handle, v: PointValue) -> Result<(), ImageError> {
        let raw = self.raw_of(h, v)?;
        self.put(h, raw)
    }

    /// `v` as the point's bits, if it suits the point's kind and fits its width.
    fn raw_of(&self, h: &Handle, v: PointValue) -> Result<u32, ImageError> {
        let requested = match v {
            PointValue::Unsigned(_) => "unsigned",
            PointValue::Signed(_) => "signed",
            PointValue::Float(_) => "float",
        };
        // Integers convert to floats only in `init`: a program writing 1 to a float point
        // more likely has the wrong handle.
        if (h.kind == PointKind::Float) != matches!(v, PointValue::Float(_)) {
            return Err(self.wrong_kind(h, requested));
        }
        encode(h.kind, h.bits, v).map_err(|_| self.out_of_range(h, show_value(v)))
    }

    pub fn set_bool(&mut self, h: &Handle, v: bool) -> Result<(), ImageError> {
        if h.kind == PointKind::Float {
            return Err(self.wrong_kind(h, "bool"));
        }
        self.put(h, u32::from(v))
    }

    /// Writes an unsigned value; it must fit the point (for a signed point, its positive
    /// range).
    pub fn set_u32(&mut self, h: &Handle, v: u32) -> Result<(), ImageError> {
        if h.kind == PointKind::Unsigned {
            // The common case, without the generic checks.
            if v & !width_mask(h.bits) != 0 {
                return Err(self.out_of_range(h, v.to_string()));
            }
            return self.put(h, v);
        }
        self.set(h, PointValue::Unsigned(v))
    }

    pub fn set_i32(&mut self, h: &Handle, v: i32) -> Result<(), ImageError> {
        self.set(h, PointValue::Signed(v))
    }

    pub fn set_f32(&mut self, h: &Handle, v: f32) -> Result<(), ImageError> {
        self.set(h, PointValue::Float(v))
    }

    fn wrong_kind(&self, h: &Handle, requested: &'static str) -> ImageError {
        ImageError::WrongKind {
            point: self.layout.slot(h.id).name.clone(),
            kind: kind_name(h.kind),
            requested,
        }
    }

    fn out_of_range(&self, h: &Handle, value: String) -> ImageError {
        ImageError::OutOfRange {
            point: self.layout.slot(h.id).name.clone(),
            kind: kind_name(h.kind),
            bits: h.bits,
            value,
        }
    }
}

/// A copy of `init` placed half a page from the global map's words, modulo the page size.
///
/// glibc's memcpy uses `rep movsb` for large copies, and on some CPUs (AMD Zen, glibc
/// before 2.39, BZ 30994) that runs 15-25 times slower when the destination sits a few dozen
/// bytes past the source modulo 4 KiB; fixing the distance keeps both copy directions of
/// `update()` off that cliff whatever address the allocator returns.
fn aligned_private(init: &[u32]) -> (Vec<u32>, usize) {
    let mut buf = vec![0u32; init.len() + PAGE_WORDS];
    let have = (buf.as_ptr() as usize / 4) % PAGE_WORDS;
    let base = (private_page_word() + PAGE_WORDS - have) % PAGE_WORDS;
    buf[base..base + init.len()].copy_from_slice(init);
    (buf, base)
}

const PAGE_WORDS: usize = 1024;

/// Where within a page the private words start (see `aligned_private`).
fn private_page_word() -> usize {
    // Half a page away rather than level: the merge loop stores to one array while loading
    // the other, and equal page offsets would make those loads wait on the stores (4K
    // aliasing).
    (WORDS_PAGE_OFFSET / 4 + PAGE_WORDS / 2) % PAGE_WORDS
}

/// The mask and plan a map's `update()` needs, available before the map itself (an
/// isolated map's proxy is forked with them).
struct Shape {
    mask: Vec<u32>,
    plan: Plan,
}

/// The update under the lock: [`merge`] inside the journal (so that a death half-way is
/// undone by the next locker), then the forced bits laid over the private copy's bits the
/// module does not own. The global words keep what the owners wrote (an owner reads its own
/// value), so releasing a force brings the owner's value back at once.
fn exchange(plan: &Plan, m: &[u32], guard: &mut ImageGuard<'_>, p: &mut [u32]) {
    let forced = guard.any_forced();
    let mut parts = guard.parts_mut();
    parts.journal.open(&plan.spans);
    if testhook::fires(testhook::Point::Update) {
        die_half_way(plan, m, parts.words, p, &mut parts.journal);
    }
    merge(plan, parts.words, p, &mut parts.journal);
    parts.journal.close();
    if forced {
        for (w, &fm) in parts.force_mask.iter().enumerate() {
            let others = fm & !m[w];
            if others != 0 {
                p[w] = (p[w] & !others) | (parts.force_value[w] & others);
            }
        }
    }
}

/// The test hook's death in the middle of an update: the journal's words saved and written
/// out chunk by chunk, in the order every [`merge`] saves them (the vector merges save the
/// same words in smaller pieces), until half of the owned words are out; then SIGKILL with
/// the lock held.
#[cold]
fn die_half_way(plan: &Plan, m: &[u32], g: &mut [u32], p: &[u32], journal: &mut Journal<'_>) -> ! {
    let owned = m.iter().filter(|&&m| m != 0).count();
    let mut left = owned.div_ceil(2);
    for s in &plan.spans {
        let mut c = s.start as usize;
        while c < s.end as usize {
            let d = (c + CHUNK).min(s.end as usize);
            let listed: Vec<usize> = (c..d).filter(|i| s.lanes >> (i % LANES) & 1 != 0).collect();
            journal.save(listed.len(), |saved| {
                for (saved, &i) in saved.iter_mut().zip(&listed) {
                    *saved = g[i];
                }
            });
            for w in listed {
                if left == 0 {
                    testhook::die();
                }
                if m[w] != 0 {
                    g[w] = (g[w] & !m[w]) | (p[w] & m[w]);
                    left -= 1;
                }
            }
            c = d;
        }
    }
    testhook::die()
}

/// Words written out between two journal saves by the portable merge and by copied-out steps
/// (the vector merges save every two blocks, `one_pass.rs`), a whole number of blocks: small
/// enough that the chunk's global and private words (16 KiB) stay in the L1 cache between
/// the save and the write, large enough that the save's bookkeeping does not count and the
/// hardware prefetchers see long streams. On the bench machine (AMD EPYC, 32 KiB L1d) interleaved
/// ownership took 3.3x memcpy with chunks of 64 words, 2.2x with 256, 1.85x with 2048.
const CHUNK: usize = 128 * BLOCK;

/// The update itself: the owned bits of `p` out to `g`, every other bit of `g` in, the words
/// the plan's spans list saved in the journal (opened with those spans), in order, before
/// they are written; a word the merge leaves as it is may be written or not. `g` must be
/// locked.
fn merge(plan: &Plan, g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    merge_with(plan.simd, plan, g, p, journal);
}

/// [`merge`] with the loops for `simd`.
///
/// # Panics
/// If `simd` is not [available](Simd::available).
fn merge_with(simd: Simd, plan: &Plan, g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    assert!(
        simd.available(),
        "{simd:?} merge on a CPU or build without it"
    );
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: the CPU has AVX2 (asserted above).
        Simd::Avx2 => unsafe { avx2::merge(plan, g, p, journal) },
        #[cfg(avx512_intrinsics)]
        // SAFETY: the CPU has AVX-512F (asserted above).
        Simd::Avx512 => unsafe { avx512::merge(plan, g, p, journal) },
        _ => merge_portable(plan, g, p, journal),
    }
}

/// The merge in the target's baseline instructions (SSE2 on x86-64), two passes per chunk:
/// the chunk's journal words saved, then the chunk merged.
#[inline(always)]
fn merge_portable(plan: &Plan, g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    each_step(plan, g, p, journal, |pattern, g, p, journal| {
        let mut c = 0;
        while c < g.len() {
            let d = (c + CHUNK).min(g.len());
            merge_chunk(pattern, &mut g[c..d], &mut p[c..d], journal);
            c = d;
        }
    });
}

/// Runs the plan's steps in order: the copies by [`copy_step`], each [`Step::Merge`] by
/// `merge` with its pattern and its words of `g` and `p`.
#[inline(always)]
fn each_step(
    plan: &Plan,
    g: &mut [u32],
    p: &mut [u32],
    journal: &mut Journal<'_>,
    mut merge: impl FnMut(&Pattern, &mut [u32], &mut [u32], &mut Journal<'_>),
) {
    for &step in &plan.steps {
        match step {
            Step::Merge {
                start,
                words,
                pattern,
            } => {
                let r = start as usize..(start + words) as usize;
                let pattern = &plan.patterns[pattern as usize];
                merge(pattern, &mut g[r.clone()], &mut p[r], journal);
            }
            step => copy_step(step, g, p, journal),
        }
    }
}

/// A [`Step::In`] or [`Step::Out`]: whole words one way, an `Out` saved chunk by chunk.
#[inline(always)]
fn copy_step(step: Step, g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    match step {
        Step::In { start, words } => {
            let r = start as usize..(start + words) as usize;
            p[r.clone()].copy_from_slice(&g[r]);
        }
        Step::Out { start, words } => {
            let (start, end) = (start as usize, (start + words) as usize);
            let mut c = start;
            while c < end {
                let d = (c + CHUNK).min(end);
                journal.save(d - c, |saved| saved.copy_from_slice(&g[c..d]));
                g[c..d].copy_from_slice(&p[c..d]);
                c = d;
            }
        }
        Step::Merge { .. } => unreachable!("a merge step is not a copy"),
    }
}

/// Up to a [`CHUNK`] of a [`Step::Merge`]'s words: saved, then merged.
#[inline(always)]
fn merge_chunk(pattern: &Pattern, g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    if pattern.sparse == 0 {
        journal.save(g.len(), |saved| saved.copy_from_slice(g));
        merge_dense(&pattern.mask, g, p);
    } else {
        merge_sparse(pattern, g, p, journal);
    }
}

/// Merges blocks owned as `m` says, whole blocks at a time: the merged words to both sides.
#[inline(always)]
fn merge_dense(m: &[u32; BLOCK], g: &mut [u32], p: &mut [u32]) {
    let mut gc = g.chunks_exact_mut(BLOCK);
    let mut pc = p.chunks_exact_mut(BLOCK);
    for (g, p) in (&mut gc).zip(&mut pc) {
        let g: &mut [u32; BLOCK] = g.try_into().expect("a whole block");
        let p: &mut [u32; BLOCK] = p.try_into().expect("a whole block");
        for i in 0..BLOCK {
            let v = (g[i] & !m[i]) | (p[i] & m[i]);
            g[i] = v;
            p[i] = v;
        }
    }
    for ((g, p), m) in gc
        .into_remainder()
        .iter_mut()
        .zip(pc.into_remainder())
        .zip(m)
    {
        let v = (*g & !*m) | (*p & *m);
        *g = v;
        *p = v;
    }
}

/// Merges blocks with a few owned words: saves only those in the journal, then merges the
/// blocks whole (the other words are written unchanged, so they need no saving; writing
/// the owned words one by one instead would make the next block-wide load wait for them).
#[inline(always)]
fn merge_sparse(pattern: &Pattern, g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    let owned = &pattern.owned[..pattern.sparse as usize];
    let blocks = g.len().div_ceil(BLOCK);
    journal.save(blocks * owned.len(), |saved| match owned.len() {
        1 => gather::<1>(owned, g, saved),
        2 => gather::<2>(owned, g, saved),
        3 => gather::<3>(owned, g, saved),
        4 => gather::<4>(owned, g, saved),
        5 => gather::<5>(owned, g, saved),
        6 => gather::<6>(owned, g, saved),
        7 => gather::<7>(owned, g, saved),
        _ => gather::<SPARSE>(owned, g, saved),
    });
    merge_dense(&pattern.mask, g, p);
}

/// Copies the `N` words at offsets `owned` of each block of `g` to `saved`, one after the
/// other (`N` a constant, so that the loop over a block is unrolled).
#[inline(always)]
fn gather<const N: usize>(owned: &[u8], g: &[u32], saved: &mut [u32]) {
    let owned: [u8; N] = owned.try_into().expect("N owned words");
    // The blocks first in each zip: the saved words run out with them.
    let mut saved = saved.chunks_exact_mut(N);
    let mut gc = g.chunks_exact(BLOCK);
    for (g, s) in (&mut gc).zip(&mut saved) {
        let g: &[u32; BLOCK] = g.try_into().expect("a whole block");
        let s: &mut [u32; N] = s.try_into().expect("N words");
        for i in 0..N {
            s[i] = g[owned[i] as usize % BLOCK];
        }
    }
    if let Some(s) = saved.next() {
        // The image's last block, cut short: its owned words are within it (the pattern is
        // zero past its end).
        let g = gc.remainder();
        for (s, &o) in s.iter_mut().zip(&owned) {
            *s = g[o as usize];
        }
    }
}

/// Precomputes how `update()` exchanges the words of a module owning the bits of `mask`.
fn plan(mask: &[u32]) -> Plan {
    let mut plan = Plan {
        simd: Simd::detect(),
        ..Plan::default()
    };
    for (b, block) in mask.chunks(BLOCK).enumerate() {
        let start = (b * BLOCK) as u32;
        let words = block.len() as u32;
        let step = if block.iter().all(|&m| m == 0) {
            Step::In { start, words }
        } else if block.iter().all(|&m| m == u32::MAX) {
            Step::Out { start, words }
        } else {
            let mut pattern = [0u32; BLOCK];
            pattern[..block.len()].copy_from_slice(block);
            let same = matches!(plan.steps.last(), Some(Step::Merge { pattern: k, .. })
                if plan.patterns[*k as usize].mask == pattern);
            if !same {
                plan.patterns.push(Pattern::new(pattern));
            }
            Step::Merge {
                start,
                words,
                pattern: (plan.patterns.len() - 1) as u32,
            }
        };
        // Extend the previous step when this block continues it.
        match (plan.steps.last_mut(), step) {
            (Some(Step::In { words: w, .. }), Step::In { words, .. })
            | (Some(Step::Out { words: w, .. }), Step::Out { words, .. }) => *w += words,
            (
                Some(Step::Merge {
                    words: w,
                    pattern: a,
                    ..
                }),
                Step::Merge {
                    words, pattern: b, ..
                },
            ) if *a == b => *w += words,
            _ => plan.steps.push(step),
        }
    }
    for &step in &plan.steps {
        let (start, words, lanes) = match step {
            Step::In { .. } => continue,
            Step::Out { start, words } => (start, words, ALL_LANES),
            Step::Merge {
                start,
                words,
                pattern,
            } => (start, words, plan.patterns[pattern as usize].lanes()),
        };
        match plan.spans.last_mut() {
            Some(s) if s.end == start && s.lanes == lanes => s.end += words,
            _ => plan.spans.push(Span {
                start,
                end: start + words,
                lanes,
            }),
        }
    }
    plan
}

#[cfg(test)]
mod tests;
