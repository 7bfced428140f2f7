//! A module's view of the image: a private copy of the words and the mask of the bits it
//! owns, synchronised with the global map by `update()`, and typed access through handles.

use petriplc_config::{Location, PointKind, PointValue};

use super::layout::{decode, encode, show_value, sign_extend, width_mask, Layout, PointId};
use super::shm::{GlobalMap, WORDS_PAGE_OFFSET};
use super::{kind_name, ImageError};

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
    /// The private words are `buf[base..base + words]` (see `aligned_private`); `buf` is
    /// empty once a `Shared` module works on the global map directly.
    buf: Vec<u32>,
    base: usize,
    plan: Plan,
    direct: Option<GlobalMap>,
}

impl ModuleMap {
    /// The map of module `module`, with every point at its init value until the first
    /// `update()`. A `Shared` module keeps this private copy only until its first `update()`,
    /// which attaches it to the global map for good.
    pub fn new(layout: &Layout, module: &str, location: Location) -> Result<ModuleMap, ImageError> {
        if location == Location::Isolate {
            return Err(ImageError::Unsupported {
                what: format!("location isolate (module `{module}`)"),
            });
        }
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
        let (buf, base) = aligned_private(layout.init_words());
        Ok(ModuleMap {
            layout: layout.clone(),
            module: module.to_string(),
            location,
            buf,
            base,
            mask,
            plan,
            direct: None,
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
    /// to every other module's update.
    ///
    /// # Panics
    /// If `global` was created from another layout (check with [`GlobalMap::check_layout`]
    /// after opening it).
    pub fn update(&mut self, global: &GlobalMap) {
        if self.direct.is_some() {
            return;
        }
        assert!(
            global.fingerprint() == self.layout.fingerprint() && global.words() == self.mask.len(),
            "module `{}`: the global map of PLC `{}` has another layout (GlobalMap::check_layout)",
            self.module,
            global.plc_id()
        );
        let mut guard = global.lock();
        let g = guard.words_mut();
        let words = self.mask.len();
        let (p, m) = (&mut self.buf[self.base..self.base + words], &self.mask[..]);
        match &self.plan {
            Plan::Span { start, end } => {
                let (s, e) = (*start, *end);
                for ((g, p), m) in g[s..e].iter_mut().zip(&mut p[s..e]).zip(&m[s..e]) {
                    let v = (*g & !*m) | (*p & *m);
                    *g = v;
                    *p = v;
                }
                p[..s].copy_from_slice(&g[..s]);
                p[e..].copy_from_slice(&g[e..]);
            }
            Plan::Runs(runs) => {
                for r in runs {
                    let (g, p) = (&mut g[r.start..r.end], &p[r.start..r.end]);
                    if r.full {
                        g.copy_from_slice(p);
                    } else {
                        for ((g, p), m) in g.iter_mut().zip(p).zip(&m[r.start..r.end]) {
                            *g = (*g & !*m) | (*p & *m);
                        }
                    }
                }
                p.copy_from_slice(g);
            }
        }
        drop(guard);
        if self.location == Location::Shared {
            self.buf = Vec::new();
            self.direct = Some(global.clone());
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
        let w = match &self.direct {
            Some(g) => g.lock().words()[h.word as usize],
            None => self.buf[self.base + h.word as usize],
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
        match &self.direct {
            Some(g) => {
                // Other points may share the word: the read-modify-write must not interleave
                // with another module's update.
                let mut guard = g.lock();
                let word = &mut guard.words_mut()[w];
                *word = (*word & !h.mask) | bits;
            }
            None => {
                let word = &mut self.buf[self.base + w];
                *word = (*word & !h.mask) | bits;
            }
        }
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
        let raw = encode(h.kind, h.bits, v).map_err(|_| self.out_of_range(h, show_value(v)))?;
        self.put(h, raw)
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
    const PAGE_WORDS: usize = 1024;
    let mut buf = vec![0u32; init.len() + PAGE_WORDS];
    let have = (buf.as_ptr() as usize / 4) % PAGE_WORDS;
    // Half a page away rather than level: the merge loop stores to one array while loading
    // the other, and equal page offsets would make those loads wait on the stores (4K
    // aliasing).
    let want = (WORDS_PAGE_OFFSET / 4 + PAGE_WORDS / 2) % PAGE_WORDS;
    let base = (want + PAGE_WORDS - have) % PAGE_WORDS;
    buf[base..base + init.len()].copy_from_slice(init);
    (buf, base)
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
