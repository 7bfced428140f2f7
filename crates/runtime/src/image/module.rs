//! A module's view of the image: a private copy of the words and the mask of the bits it
//! owns, synchronised with the global map by `update()`, and typed access through handles.

use petriplc_config::{Location, PointKind, PointValue};

use super::layout::{decode, encode, show_value, sign_extend, width_mask, Layout, PointId};
use super::shm::{GlobalMap, ImageGuard, Journal, WORDS_PAGE_OFFSET};
use super::{kind_name, ImageError};
use crate::testhook;

mod isolate;

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

/// How `update()` writes the owned bits out; chosen once from the mask's shape.
#[derive(Debug)]
enum Plan {
    /// Owned words scattered thinly: one masked pass over the span that holds them beats a
    /// loop over many tiny runs.
    Span { start: usize, end: usize },
    /// Owned words in runs: whole words are copied, words shared with other owners merged.
    Runs(Vec<Run>),
}

#[derive(Debug)]
struct Run {
    start: usize,
    end: usize,
    /// Every bit of every word in the run is owned.
    full: bool,
}

/// One module's map of the image (MatPLC's private map and map mask).
#[derive(Debug)]
pub struct ModuleMap {
    layout: Layout,
    module: String,
    location: Location,
    mask: Vec<u32>,
    plan: Plan,
    /// The word ranges `update()` writes, for its journal.
    ranges: Vec<(u32, u32)>,
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
            let (mask, plan, ranges) = (&map.mask, &map.plan, &map.ranges);
            let proxy = isolate::Proxy::spawn(
                layout,
                plc_id,
                layout.init_words(),
                private_page_word(),
                |g, p| exchange(plan, ranges, mask, g, p),
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
        let ranges = match &plan {
            Plan::Span { start, end } => vec![(*start as u32, *end as u32)],
            Plan::Runs(runs) => runs
                .iter()
                .map(|r| (r.start as u32, r.end as u32))
                .collect(),
        };
        let shape = Shape { mask, plan, ranges };
        let words = words(&shape)?;
        Ok(ModuleMap {
            layout: layout.clone(),
            module: module.to_string(),
            location,
            mask: shape.mask,
            plan: shape.plan,
            ranges: shape.ranges,
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
        exchange(&self.plan, &self.ranges, &self.mask, &mut guard, private);
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
    ranges: Vec<(u32, u32)>,
}

/// The update under the lock: [`merge`] inside the journal (so that a death half-way is
/// undone by the next locker), then the forced bits laid over the private copy's bits the
/// module does not own. The global words keep what the owners wrote (an owner reads its own
/// value), so releasing a force brings the owner's value back at once.
fn exchange(
    plan: &Plan,
    ranges: &[(u32, u32)],
    m: &[u32],
    guard: &mut ImageGuard<'_>,
    p: &mut [u32],
) {
    let forced = guard.any_forced();
    let mut parts = guard.parts_mut();
    parts.journal.open(ranges);
    if testhook::fires(testhook::Point::Update) {
        die_half_way(ranges, m, parts.words, p, &mut parts.journal);
    }
    merge(plan, m, parts.words, p, &mut parts.journal);
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

/// The test hook's death in the middle of an update: the owned words written out chunk by
/// chunk as [`merge`] writes them, journal saves included, until half of them are out; then
/// SIGKILL with the lock held.
#[cold]
fn die_half_way(
    ranges: &[(u32, u32)],
    m: &[u32],
    g: &mut [u32],
    p: &[u32],
    journal: &mut Journal<'_>,
) -> ! {
    let owned: usize = ranges
        .iter()
        .flat_map(|&(s, e)| s as usize..e as usize)
        .filter(|&w| m[w] != 0)
        .count();
    let mut left = owned.div_ceil(2);
    for &(s, e) in ranges {
        let mut c = s as usize;
        while c < e as usize {
            let d = (c + CHUNK).min(e as usize);
            journal.save(g, c, d);
            for w in c..d {
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

/// Words written out between two journal saves: small enough that the chunk is still in
/// the cache when it is written, large enough that the save's bookkeeping does not count.
const CHUNK: usize = 256;

/// The update itself: the owned bits of `p` out to `g`, every other bit of `g` in, each
/// chunk of `g` saved in the journal (opened with the plan's ranges) before it is written.
/// `g` must be locked.
fn merge(plan: &Plan, m: &[u32], g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    match plan {
        Plan::Span { start, end } => {
            let (s, e) = (*start, *end);
            let mut c = s;
            while c < e {
                let d = (c + CHUNK).min(e);
                journal.save(g, c, d);
                for ((g, p), m) in g[c..d].iter_mut().zip(&mut p[c..d]).zip(&m[c..d]) {
                    let v = (*g & !*m) | (*p & *m);
                    *g = v;
                    *p = v;
                }
                c = d;
            }
            p[..s].copy_from_slice(&g[..s]);
            p[e..].copy_from_slice(&g[e..]);
        }
        Plan::Runs(runs) => {
            for r in runs {
                let mut c = r.start;
                while c < r.end {
                    let d = (c + CHUNK).min(r.end);
                    journal.save(g, c, d);
                    let (g, p) = (&mut g[c..d], &p[c..d]);
                    if r.full {
                        g.copy_from_slice(p);
                    } else {
                        for ((g, p), m) in g.iter_mut().zip(p).zip(&m[c..d]) {
                            *g = (*g & !*m) | (*p & *m);
                        }
                    }
                    c = d;
                }
            }
            p.copy_from_slice(g);
        }
    }
}

/// Picks how `update()` writes out the owned words described by `mask`.
fn plan(mask: &[u32]) -> Plan {
    let mut runs: Vec<Run> = Vec::new();
    for (i, &m) in mask.iter().enumerate() {
        if m == 0 {
            continue;
        }
        let full = m == u32::MAX;
        match runs.last_mut() {
            Some(r) if r.end == i && r.full == full => r.end = i + 1,
            _ => runs.push(Run {
                start: i,
                end: i + 1,
                full,
            }),
        }
    }
    let owned: usize = runs.iter().map(|r| r.end - r.start).sum();
    // Below a few words per run the per-run overhead dominates; the span pass streams the
    // mask instead, at about the cost of a copy.
    if runs.len() > 1 && owned < 8 * runs.len() {
        Plan::Span {
            start: runs[0].start,
            end: runs[runs.len() - 1].end,
        }
    } else {
        Plan::Runs(runs)
    }
}
