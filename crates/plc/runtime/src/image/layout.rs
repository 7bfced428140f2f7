//! Where each plc point lives in the process image: a word index, a first bit and a width,
//! fixed by `at` or allocated first-fit, deterministically, from the configuration.

use std::collections::HashMap;
use std::sync::Arc;

use petriplc_config::{Origin, PlcConfig, PointKind, PointValue};

use super::{kind_name, ImageError};

/// The largest image allowed (64 MiB of words): a stray `at 4000000000.0` should be an error,
/// not an attempt to map 16 GiB.
pub const MAX_WORDS: usize = 1 << 24;

/// A point's index in declaration order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PointId(pub u32);

impl PointId {
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// One point's place in the image, with what is needed to read, write and initialise it.
#[derive(Clone, Debug, PartialEq)]
pub struct Slot {
    pub name: String,
    pub word: u32,
    /// The lowest bit of the field (0 = least significant).
    pub bit: u8,
    /// 1 to 32.
    pub bits: u8,
    pub kind: PointKind,
    pub init: PointValue,
    pub owner: String,
    /// Whether `at` fixed the place (otherwise the layout allocated it).
    pub fixed: bool,
    /// Whether the point is retentive (`retain`): restored at start, kept in the retain file.
    pub retain: bool,
    pub origin: Origin,
}

impl Slot {
    /// The point's bits within its word.
    pub fn field_mask(&self) -> u32 {
        width_mask(self.bits) << self.bit
    }

    /// The point's value in `word` (the whole word it lives in).
    pub fn decode(&self, word: u32) -> PointValue {
        decode(self.kind, self.bits, (word & self.field_mask()) >> self.bit)
    }
}

/// The layout of a configuration's points. Cheap to clone: every module map keeps one.
#[derive(Clone, Debug)]
pub struct Layout {
    inner: Arc<Inner>,
}

#[derive(Debug)]
struct Inner {
    slots: Vec<Slot>,
    by_name: HashMap<String, PointId>,
    modules: Vec<String>,
    init: Vec<u32>,
    fingerprint: u64,
}

impl Layout {
    /// Places every point: those with `at` where they say, then the others first-fit into
    /// the free bits, in declaration order, never straddling a word.
    pub fn new(cfg: &PlcConfig) -> Result<Layout, ImageError> {
        let modules: Vec<String> = cfg.modules.iter().map(|m| m.name.clone()).collect();
        let mut by_name: HashMap<String, PointId> = HashMap::with_capacity(cfg.points.len());
        let mut slots = Vec::with_capacity(cfg.points.len());
        let mut init_raw = Vec::with_capacity(cfg.points.len());
        for (i, p) in cfg.points.iter().enumerate() {
            let place = place(&p.origin);
            let invalid = |reason: String| ImageError::InvalidPoint {
                point: p.name.clone(),
                place: place.clone(),
                reason,
            };
            if p.name.is_empty() {
                return Err(invalid("a point needs a name".into()));
            }
            if let Some(&first) = by_name.get(&p.name) {
                let first: &Slot = &slots[first.index()];
                return Err(ImageError::DuplicatePoint {
                    point: p.name.clone(),
                    place,
                    first: first.origin.to_string(),
                });
            }
            if !(1..=32).contains(&p.bits) {
                return Err(invalid(format!("{} bits (1 to 32 are allowed)", p.bits)));
            }
            if p.kind == PointKind::Float && p.bits != 32 {
                return Err(invalid(format!(
                    "a float point has 32 bits, not {}",
                    p.bits
                )));
            }
            if let Some((word, bit)) = p.at {
                if u32::from(bit) + u32::from(p.bits) > 32 {
                    return Err(invalid(format!(
                        "at {word}.{bit} with {} bits would straddle two words",
                        p.bits
                    )));
                }
                if word as usize >= MAX_WORDS {
                    return Err(ImageError::TooLarge {
                        words: u64::from(word) + 1,
                        max: MAX_WORDS as u64,
                    });
                }
            }
            if !modules.contains(&p.owner) {
                return Err(ImageError::UnknownOwner {
                    point: p.name.clone(),
                    owner: p.owner.clone(),
                    place,
                    modules: modules.clone(),
                });
            }
            let raw = encode(p.kind, p.bits, p.init)
                .map_err(|why| invalid(format!("init {}: {why}", show_value(p.init))))?;
            init_raw.push(raw);
            by_name.insert(p.name.clone(), PointId(i as u32));
            let (word, bit) = p.at.unwrap_or((0, 0));
            slots.push(Slot {
                name: p.name.clone(),
                word,
                bit,
                bits: p.bits,
                kind: p.kind,
                init: p.init,
                owner: p.owner.clone(),
                fixed: p.at.is_some(),
                retain: p.retain,
                origin: p.origin.clone(),
            });
        }

        let mut used = place_fixed(&slots)?;
        allocate(&mut slots, &mut used)?;

        let mut init = vec![0u32; used.len()];
        for (s, raw) in slots.iter().zip(&init_raw) {
            init[s.word as usize] |= raw << s.bit;
        }
        let fingerprint = fingerprint(&slots, used.len());
        Ok(Layout {
            inner: Arc::new(Inner {
                slots,
                by_name,
                modules,
                init,
                fingerprint,
            }),
        })
    }

    /// The number of 32-bit words in the image.
    pub fn words(&self) -> usize {
        self.inner.init.len()
    }

    pub fn len(&self) -> usize {
        self.inner.slots.len()
    }

    pub fn is_empty(&self) -> bool {
        self.inner.slots.is_empty()
    }

    pub fn point(&self, name: &str) -> Option<PointId> {
        self.inner.by_name.get(name).copied()
    }

    /// Like [`Layout::point`], but an unknown name is an error that lists close matches.
    pub fn lookup(&self, name: &str) -> Result<PointId, ImageError> {
        self.point(name).ok_or_else(|| ImageError::UnknownPoint {
            name: name.to_string(),
            close: close_matches(name, self.inner.slots.iter().map(|s| s.name.as_str())),
        })
    }

    /// # Panics
    /// If `id` is not a point of this layout.
    pub fn slot(&self, id: PointId) -> &Slot {
        &self.inner.slots[id.index()]
    }

    /// Every point, in declaration order.
    pub fn points(&self) -> impl ExactSizeIterator<Item = (PointId, &Slot)> + '_ {
        self.inner
            .slots
            .iter()
            .enumerate()
            .map(|(i, s)| (PointId(i as u32), s))
    }

    /// The declared modules, in declaration order.
    pub fn modules(&self) -> &[String] {
        &self.inner.modules
    }

    /// Every word with every point at its `init` value.
    pub fn init_words(&self) -> &[u32] {
        &self.inner.init
    }

    /// A hash of where every point lives, stored in the shared header so that a module whose
    /// configuration no longer matches the running PLC is refused instead of reading garbage.
    pub fn fingerprint(&self) -> u64 {
        self.inner.fingerprint
    }

    /// The value of point `id` in a copy of the image's words.
    pub fn decode(&self, id: PointId, words: &[u32]) -> PointValue {
        let s = self.slot(id);
        s.decode(words[s.word as usize])
    }
}

/// Marks the `at` points' bits, refusing overlaps; returns the used bits of every word up to
/// the last fixed one.
fn place_fixed(slots: &[Slot]) -> Result<Vec<u32>, ImageError> {
    let mut fixed: Vec<usize> = (0..slots.len()).filter(|&i| slots[i].fixed).collect();
    fixed.sort_by_key(|&i| (slots[i].word, slots[i].bit));
    let words = fixed.last().map_or(0, |&i| slots[i].word as usize + 1);
    let mut used = vec![0u32; words];
    for pair in fixed.windows(2) {
        // Until the first overlap the sorted fields are disjoint, so only neighbours can
        // collide.
        let (a, b) = (&slots[pair[0]], &slots[pair[1]]);
        if a.word == b.word && u32::from(a.bit) + u32::from(a.bits) > u32::from(b.bit) {
            // Name the earlier declaration first.
            let (a, b) = if pair[0] < pair[1] { (a, b) } else { (b, a) };
            let declared = if a.origin.file.is_empty() {
                String::new()
            } else {
                format!(", declared at {}", a.origin)
            };
            return Err(ImageError::Overlap {
                first: a.name.clone(),
                second: b.name.clone(),
                place: place(&b.origin),
                detail: format!(
                    "word {}: bits {} against bits {}{declared}",
                    b.word,
                    bit_range(b),
                    bit_range(a)
                ),
            });
        }
    }
    for &i in &fixed {
        used[slots[i].word as usize] |= slots[i].field_mask();
    }
    Ok(used)
}

/// First-fit, in declaration order, for the points without `at`.
fn allocate(slots: &mut [Slot], used: &mut Vec<u32>) -> Result<(), ImageError> {
    // Free space only shrinks, so the first word that can still take an n-bit field never
    // moves back: one cursor per width keeps the search linear overall.
    let mut cursor = [0usize; 33];
    for s in slots.iter_mut().filter(|s| !s.fixed) {
        let n = s.bits;
        let mut w = cursor[n as usize];
        let bit = loop {
            if w == used.len() {
                if used.len() >= MAX_WORDS {
                    return Err(ImageError::TooLarge {
                        words: used.len() as u64 + 1,
                        max: MAX_WORDS as u64,
                    });
                }
                used.push(0);
            }
            if let Some(bit) = first_fit(used[w], n) {
                break bit;
            }
            w += 1;
        };
        cursor[n as usize] = w;
        s.word = w as u32;
        s.bit = bit;
        used[w] |= s.field_mask();
    }
    Ok(())
}

/// The lowest bit at which `n` free bits start in a word with `used` bits taken.
fn first_fit(used: u32, n: u8) -> Option<u8> {
    let m = width_mask(n);
    (0..=32 - n).find(|&b| (used >> b) & m == 0)
}

fn fingerprint(slots: &[Slot], words: usize) -> u64 {
    // FNV-1a: stable across builds and processes, unlike the std hasher.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(&(words as u64).to_le_bytes());
    for s in slots {
        eat(s.name.as_bytes());
        eat(&[0]);
        eat(&s.word.to_le_bytes());
        eat(&[s.bit, s.bits, s.kind as u8]);
        eat(s.owner.as_bytes());
        eat(&[0]);
    }
    h
}

pub(crate) fn width_mask(bits: u8) -> u32 {
    if bits >= 32 {
        u32::MAX
    } else {
        (1u32 << bits) - 1
    }
}

/// The raw field bits for `value` in a point of `kind` and `bits`, or why it does not fit.
pub(crate) fn encode(kind: PointKind, bits: u8, value: PointValue) -> Result<u32, String> {
    let wm = width_mask(bits);
    match (kind, value) {
        (PointKind::Float, PointValue::Float(f)) => Ok(f.to_bits()),
        // A bare `init 0` reads as an integer; a float point takes its value.
        (PointKind::Float, PointValue::Unsigned(v)) => Ok((v as f32).to_bits()),
        (PointKind::Float, PointValue::Signed(v)) => Ok((v as f32).to_bits()),
        (_, PointValue::Float(_)) => {
            Err(format!("a {} point does not hold floats", kind_name(kind)))
        }
        (PointKind::Unsigned, PointValue::Unsigned(v)) => {
            if v & !wm == 0 {
                Ok(v)
            } else {
                Err(format!("does not fit in {bits} unsigned bits"))
            }
        }
        (PointKind::Unsigned, PointValue::Signed(v)) => {
            if v >= 0 && (v as u32) & !wm == 0 {
                Ok(v as u32)
            } else {
                Err(format!("does not fit in {bits} unsigned bits"))
            }
        }
        (PointKind::Signed, PointValue::Unsigned(v)) => encode_signed(i64::from(v), bits),
        (PointKind::Signed, PointValue::Signed(v)) => encode_signed(i64::from(v), bits),
    }
}

fn encode_signed(v: i64, bits: u8) -> Result<u32, String> {
    let min = -(1i64 << (bits - 1));
    let max = (1i64 << (bits - 1)) - 1;
    if (min..=max).contains(&v) {
        Ok((v as u32) & width_mask(bits))
    } else {
        Err(format!(
            "does not fit in {bits} signed bits ({min} to {max})"
        ))
    }
}

/// The value of a field's raw bits (already shifted down).
pub(crate) fn decode(kind: PointKind, bits: u8, raw: u32) -> PointValue {
    match kind {
        PointKind::Unsigned => PointValue::Unsigned(raw),
        PointKind::Signed => PointValue::Signed(sign_extend(raw, bits)),
        PointKind::Float => PointValue::Float(f32::from_bits(raw)),
    }
}

pub(crate) fn sign_extend(raw: u32, bits: u8) -> i32 {
    let shift = 32 - u32::from(bits);
    ((raw << shift) as i32) >> shift
}

pub(crate) fn show_value(v: PointValue) -> String {
    match v {
        PointValue::Unsigned(v) => v.to_string(),
        PointValue::Signed(v) => v.to_string(),
        PointValue::Float(v) => format!("{v:?}"),
    }
}

fn bit_range(s: &Slot) -> String {
    if s.bits == 1 {
        s.bit.to_string()
    } else {
        format!("{}-{}", s.bit, s.bit + s.bits - 1)
    }
}

fn place(origin: &Origin) -> String {
    if origin.file.is_empty() {
        String::new()
    } else {
        format!("{origin}: ")
    }
}

/// Names a typo is likely to have meant, best first.
pub(crate) fn close_matches<'a>(name: &str, names: impl Iterator<Item = &'a str>) -> Vec<String> {
    let lower = name.to_lowercase();
    let limit = (name.chars().count() / 3).max(2);
    let mut scored: Vec<(usize, &str)> = names
        .filter_map(|n| {
            let ln = n.to_lowercase();
            let d = edit_distance(&lower, &ln);
            let contains = lower.len() >= 3 && (ln.contains(&lower) || lower.contains(&ln));
            (d <= limit || contains).then_some((if contains { d.min(limit) } else { d }, n))
        })
        .collect();
    scored.sort();
    scored
        .into_iter()
        .take(5)
        .map(|(_, n)| n.to_string())
        .collect()
}

fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diag = row[0];
        row[0] = i + 1;
        for (j, &cb) in b.iter().enumerate() {
            let next = (diag + usize::from(ca != cb))
                .min(row[j] + 1)
                .min(row[j + 1] + 1);
            diag = row[j + 1];
            row[j + 1] = next;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use petriplc_config::{ModuleDecl, PointDecl};

    pub(crate) fn module(name: &str) -> ModuleDecl {
        ModuleDecl::new(name, "test")
    }

    fn point(name: &str, owner: &str, at: Option<(u32, u8)>, bits: u8) -> PointDecl {
        PointDecl {
            name: name.into(),
            description: String::new(),
            owner: owner.into(),
            at,
            kind: PointKind::Unsigned,
            bits,
            init: PointValue::Unsigned(0),
            retain: false,
            origin: Origin {
                file: "t.conf".into(),
                line: 1,
            },
        }
    }

    fn cfg(points: Vec<PointDecl>) -> PlcConfig {
        PlcConfig {
            modules: vec![module("a"), module("b")],
            points,
            ..Default::default()
        }
    }

    fn places(l: &Layout) -> Vec<(u32, u8)> {
        l.points().map(|(_, s)| (s.word, s.bit)).collect()
    }

    #[test]
    fn booleans_pack_and_words_do_not_straddle() {
        let l = Layout::new(&cfg(vec![
            point("x0", "a", None, 1),
            point("w", "a", None, 32),
            point("x1", "b", None, 1),
            point("n", "a", None, 31),
            point("m", "a", None, 2),
        ]))
        .unwrap();
        assert_eq!(places(&l), vec![(0, 0), (1, 0), (0, 1), (2, 0), (0, 2)]);
        assert_eq!(l.words(), 3);
    }

    #[test]
    fn free_points_fill_around_fixed_ones() {
        let l = Layout::new(&cfg(vec![
            point("f", "a", None, 4),
            point("fixed", "a", Some((0, 2)), 4),
            point("g", "a", None, 2),
            point("far", "b", Some((3, 0)), 32),
            point("h", "a", None, 32),
        ]))
        .unwrap();
        assert_eq!(places(&l), vec![(0, 6), (0, 2), (0, 0), (3, 0), (1, 0)]);
        assert_eq!(l.words(), 4);
    }

    #[test]
    fn overlap_names_both_points() {
        let e = Layout::new(&cfg(vec![
            point("first", "a", Some((2, 0)), 8),
            point("other", "a", Some((2, 10)), 1),
            point("second", "b", Some((2, 7)), 2),
        ]))
        .unwrap_err();
        let msg = e.to_string();
        assert!(matches!(e, ImageError::Overlap { .. }), "{msg}");
        assert!(msg.contains("`first`") && msg.contains("`second`"), "{msg}");
    }

    #[test]
    fn adjacent_fixed_fields_do_not_overlap() {
        let l = Layout::new(&cfg(vec![
            point("hi", "a", Some((0, 16)), 16),
            point("lo", "b", Some((0, 0)), 16),
        ]))
        .unwrap();
        assert_eq!(l.words(), 1);
    }

    #[test]
    fn owner_must_be_a_module() {
        let e = Layout::new(&cfg(vec![point("p", "nobody", None, 1)])).unwrap_err();
        assert!(e.to_string().contains("`nobody`"), "{e}");
        assert!(e.to_string().contains("declared: a, b"), "{e}");
    }

    #[test]
    fn bad_widths_and_inits_are_refused() {
        assert!(Layout::new(&cfg(vec![point("p", "a", None, 0)])).is_err());
        assert!(Layout::new(&cfg(vec![point("p", "a", None, 33)])).is_err());
        assert!(Layout::new(&cfg(vec![point("p", "a", Some((0, 31)), 2)])).is_err());
        let mut p = point("p", "a", None, 4);
        p.init = PointValue::Unsigned(16);
        assert!(Layout::new(&cfg(vec![p.clone()])).is_err());
        p.kind = PointKind::Signed;
        p.init = PointValue::Signed(-8);
        assert!(Layout::new(&cfg(vec![p.clone()])).is_ok());
        p.init = PointValue::Signed(8);
        assert!(Layout::new(&cfg(vec![p.clone()])).is_err());
        p.kind = PointKind::Float;
        assert!(Layout::new(&cfg(vec![p])).is_err());
        let dup = Layout::new(&cfg(vec![
            point("p", "a", None, 1),
            point("p", "b", None, 1),
        ]));
        assert!(matches!(dup, Err(ImageError::DuplicatePoint { .. })));
        let far = Layout::new(&cfg(vec![point("p", "a", Some((u32::MAX, 0)), 1)]));
        assert!(matches!(far, Err(ImageError::TooLarge { .. })));
    }

    #[test]
    fn init_values_land_in_their_bits() {
        let mut s = point("s", "a", Some((0, 4)), 4);
        s.kind = PointKind::Signed;
        s.init = PointValue::Signed(-2);
        let mut f = point("f", "a", None, 32);
        f.kind = PointKind::Float;
        f.init = PointValue::Float(1.5);
        let l = Layout::new(&cfg(vec![s, f])).unwrap();
        assert_eq!(l.init_words(), &[0xE0, 1.5f32.to_bits()]);
        let id = l.point("s").unwrap();
        assert_eq!(l.decode(id, l.init_words()), PointValue::Signed(-2));
    }

    #[test]
    fn unknown_names_suggest_close_ones() {
        let l = Layout::new(&cfg(vec![
            point("motor_on", "a", None, 1),
            point("motor_off", "a", None, 1),
            point("valve", "a", None, 1),
        ]))
        .unwrap();
        let e = l.lookup("moter_on").unwrap_err().to_string();
        assert!(e.contains("did you mean `motor_on`"), "{e}");
        assert!(!e.contains("valve"), "{e}");
    }

    #[test]
    fn allocation_is_linear_enough_for_large_images() {
        let points = (0..65536)
            .map(|i| point(&format!("p{i}"), "a", None, 32))
            .collect();
        let l = Layout::new(&cfg(points)).unwrap();
        assert_eq!(l.words(), 65536);
    }
}
