//! References and pointers as the VM keeps them: one slot holding a checked handle, never a
//! raw address a program could forge (docs/iec.md, "References and pointers").
//!
//! A handle packs the designated variable's first slot (28 bits), its type's id plus one
//! (the tag, 16 bits) and a byte offset into the variable's byte image (20 bits, signed,
//! moved by CODESYS pointer arithmetic); `NULL` is 0. Handles are made only by `REF`/`ADR`
//! of a variable that outlives them (the checker's E201), so what a handle designates is
//! always there: a dereference checks NULL, the tag and the offset against the variable's
//! size. A pointer of the variable's own type at offset 0 reaches its slots directly; any
//! other elementary access (a `POINTER TO BYTE` over a STRING, a `POINTER TO DWORD` over a
//! REAL) reads and writes the bytes of the variable's image ([`Shape`],
//! `petriplc_iec_sema::memory`), little-endian as CODESYS.

use std::collections::BTreeMap;

use petriplc_iec_sema::ir::{Builtin, Project};
use petriplc_iec_sema::memory;
use petriplc_iec_sema::ops::OpError;
use petriplc_iec_sema::types::{Elem, Type, TypeId};

use crate::ext::{ExtOp, OpFault};
use crate::layout::Sizes;

use crate::handle::{decode, encode, BASE_BITS, OFF_MAX, OFF_MIN};
pub use crate::handle::{type_of, MAX_TAGGED_TYPE};

fn domain(what: &'static str, detail: String) -> OpFault {
    OpFault::new(OpError::Domain(what), detail)
}

/// Slots a handle of a variable reaches (the base field's upper bits mark heap objects).
const STATIC_SLOTS: u64 = 1 << (BASE_BITS - 2);

/// `mem[base + d]` = the handle of the variable whose slot address is in `mem[base + s]`.
pub fn make(
    mem: &mut [u64],
    base: usize,
    [d, s]: [u32; 2],
    ty: u32,
    shapes: &Shapes,
) -> Result<(), OpFault> {
    let addr = mem[base + s as usize];
    if let Some(h) = shapes.heap.filter(|h| h.holds(addr)) {
        mem[base + d as usize] = h.handle_at(mem, addr, ty)?;
        return Ok(());
    }
    if addr >= STATIC_SLOTS {
        return Err(domain(
            "reference out of range",
            format!("slot {addr} is past the {STATIC_SLOTS} slots references reach"),
        ));
    }
    mem[base + d as usize] = encode(addr, ty, 0);
    Ok(())
}

/// `mem[base + d]` = the pointer in `p` moved by `mem[base + n]` bytes (back when `sub`).
pub fn add(mem: &mut [u64], base: usize, d: u32, p: u32, n: u32, sub: bool) -> Result<(), OpFault> {
    let h = mem[base + p as usize];
    let k = mem[base + n as usize] as i64;
    if h == 0 {
        return Err(domain(
            "NULL dereferenced",
            "pointer arithmetic on a NULL pointer".into(),
        ));
    }
    let (b, ty, off) = decode(h);
    if b & crate::handle::SUB_BIT != 0 {
        return Err(domain(
            "pointer out of range",
            "pointer arithmetic on the address of a part of a __NEW object: take the address of the element you want (ADR(p^.a[i]))".into(),
        ));
    }
    let moved = if sub {
        off.checked_sub(k)
    } else {
        off.checked_add(k)
    };
    match moved {
        Some(o) if (OFF_MIN..=OFF_MAX).contains(&o) => {
            mem[base + d as usize] = encode(b, ty, o);
            Ok(())
        }
        _ => Err(domain(
            "pointer out of range",
            format!(
                "moving a pointer at byte {off} by {}{k} bytes leaves the variable",
                if sub { "-" } else { "" }
            ),
        )),
    }
}

/// What a checked handle designates: the variable's first slot, its type id, the byte
/// offset of the access, and how many values of the type lie from the first slot on (more
/// than one only for a heap array: `__NEW(T, n)`).
struct Live {
    b: u64,
    t: u32,
    off: i64,
    count: u64,
}

/// The checked handle in `mem[base + p]`.
fn live(mem: &[u64], base: usize, p: u32, what: &str, shapes: &Shapes) -> Result<Live, OpFault> {
    let h = mem[base + p as usize];
    if h == 0 {
        return Err(domain(
            "NULL dereferenced",
            if what.starts_with("REFERENCE TO") {
                format!("this {what} is not bound; bind it with `r REF= x` or test __ISVALIDREF(r) first")
            } else {
                format!("this {what} is NULL; set it with REF(x)/ADR(x) or test `<> NULL` first")
            },
        ));
    }
    let (b, t, off) = decode(h);
    if b & crate::handle::HEAP_BIT == 0 {
        return Ok(Live {
            b,
            t,
            off,
            count: 1,
        });
    }
    let Some(heap) = shapes.heap else {
        return Err(domain(
            "invalid reference",
            format!("this {what} designates nothing the program referenced"),
        ));
    };
    let d = heap.designated(mem, b, off, what)?;
    Ok(Live {
        b: d.first,
        t,
        off: d.off,
        count: d.count,
    })
}

/// `mem[base + d]` = the first slot of the variable the handle in `p` designates, which
/// must be of type `ty` (`n` slots) at offset 0: a whole structure, array or string.
#[allow(clippy::too_many_arguments)]
pub fn deref(
    mem: &mut [u64],
    base: usize,
    d: u32,
    p: u32,
    ty: u32,
    n: u32,
    what: &str,
    shapes: &Shapes,
) -> Result<(), OpFault> {
    let Live { b, t, off, count } = live(mem, base, p, what, shapes)?;
    // An element of a heap array (`p[i]` over `__NEW(T, n)`): a whole multiple of its size.
    let (b, off) = match shapes.get(&t) {
        Some(img) if count > 1 && off > 0 && img.bytes > 0 && off as u64 % img.bytes == 0 => {
            let k = off as u64 / img.bytes;
            if k >= count {
                return Err(domain(
                    "pointer out of range",
                    format!(
                        "this {what} designates element {k} of {count} {}s (counted from 0)",
                        img.name
                    ),
                ));
            }
            (b + k * img.slots, 0)
        }
        _ => (b, off),
    };
    if t != ty || off != 0 || b + u64::from(n) > mem.len() as u64 {
        return Err(domain(
            "invalid reference",
            format!(
                "this {what} designates byte {off} of a {}; only an elementary value is read through a pointer of another type",
                name_of(shapes, t)
            ),
        ));
    }
    mem[base + d as usize] = b;
    Ok(())
}

/// The byte image of a referenced type: where each byte lives in the slots.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Elem(Elem),
    /// A length slot, then the bytes eight to a slot; `cap + 1` bytes (the terminator), or
    /// for a WSTRING (`wide`) `cap` bytes of UTF-16LE units and a zero unit.
    Str {
        cap: u32,
        wide: bool,
    },
    Array {
        count: u64,
        elem: Box<Shape>,
        /// Bytes and slots of one element.
        bytes: u64,
        slots: u32,
    },
    /// Fields: byte offset, slot offset, bytes, shape (padding between them reads 0).
    Struct {
        fields: Vec<(u64, u32, u64, Shape)>,
    },
    /// Bytes no program may see or forge (a reference, a function block).
    Sealed,
}

/// A referenced type's byte image: its shape, its size in bytes, its name for messages.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub shape: Shape,
    pub bytes: u64,
    /// Slots of the variable, checked against the memory before any access.
    pub slots: u64,
    pub name: String,
}

/// The image of every type the program references (by type id), and where its dynamic
/// memory lies, if it has any: what a handle is checked against.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Shapes {
    pub images: BTreeMap<u32, Image>,
    pub heap: Option<crate::heap::Layout>,
}

impl Shapes {
    pub fn get(&self, t: &u32) -> Option<&Image> {
        self.images.get(t)
    }
}

fn name_of(shapes: &Shapes, t: u32) -> &str {
    shapes
        .get(&t)
        .map_or("variable of another type", |i| i.name.as_str())
}

/// The image of `ty`.
pub fn image_of(p: &Project, sizes: &Sizes, ty: TypeId) -> Image {
    let (shape, bytes) = shape_of(p, sizes, ty);
    Image {
        shape,
        bytes,
        slots: u64::from(sizes.of(p, ty).unwrap_or(1)),
        name: p.types.name(ty),
    }
}

/// The shape of `ty` and its size in bytes.
pub fn shape_of(p: &Project, sizes: &Sizes, ty: TypeId) -> (Shape, u64) {
    let bytes = memory::size_align(&p.types, ty).map_or(0, |x| x.0);
    let shape = match p.types.get(ty) {
        Type::Elem(e) | Type::Subrange { base: e, .. } => Shape::Elem(*e),
        Type::Enum { .. } => Shape::Elem(Elem::Dint),
        Type::Str { len, wide } => Shape::Str {
            cap: len.saturating_mul(1 + u32::from(*wide)),
            wide: *wide,
        },
        Type::Array { elem, .. } => {
            let (e, eb) = shape_of(p, sizes, *elem);
            Shape::Array {
                count: p.types.element_count(ty),
                elem: Box::new(e),
                bytes: eb,
                slots: sizes.of(p, *elem).unwrap_or(1),
            }
        }
        Type::Struct { fields, .. } => {
            let bo = memory::field_offsets(&p.types, ty);
            let so = sizes.field_offsets(p, ty);
            Shape::Struct {
                fields: fields
                    .iter()
                    .enumerate()
                    .map(|(i, f)| {
                        let (s, b) = shape_of(p, sizes, f.ty);
                        (bo[i], so[i], b, s)
                    })
                    .collect(),
            }
        }
        _ => Shape::Sealed,
    };
    (shape, bytes)
}

/// Where byte `o` of a value of `shape` at slot `at` lives: the leaf's slot, the leaf, the
/// byte within it (`None`: padding).
fn locate(shape: &Shape, at: u64, o: u64) -> Result<Option<(u64, &Shape, u64)>, OpFault> {
    match shape {
        Shape::Elem(_) | Shape::Str { .. } => Ok(Some((at, shape, o))),
        Shape::Array {
            elem, bytes, slots, ..
        } => {
            let k = o / bytes.max(&1);
            locate(elem, at + k * u64::from(*slots), o - k * bytes)
        }
        Shape::Struct { fields } => {
            for (bo, so, b, s) in fields {
                if o >= *bo && o < bo + b {
                    return locate(s, at + u64::from(*so), o - bo);
                }
            }
            Ok(None)
        }
        Shape::Sealed => Err(domain(
            "invalid reference",
            "the bytes of a reference or a function block are not readable through a pointer"
                .into(),
        )),
    }
}

/// A slot's value as `e`'s little-endian bytes.
fn elem_bytes(e: Elem, raw: u64) -> [u8; 8] {
    match e {
        Elem::Real => ((f64::from_bits(raw) as f32).to_bits() as u64).to_le_bytes(),
        _ => raw.to_le_bytes(),
    }
}

/// `e`'s bytes as a slot's value (sign-extended for signed integers).
fn elem_value(e: Elem, b: [u8; 8]) -> u64 {
    let n = memory::elem_bytes(e) as u32;
    let v = u64::from_le_bytes(b);
    let v = if n < 8 { v & ((1 << (8 * n)) - 1) } else { v };
    match e {
        Elem::Bool => u64::from(v != 0),
        Elem::Real => f64::from(f32::from_bits(v as u32)).to_bits(),
        e if e.is_signed() && n < 8 => (((v << (64 - 8 * n)) as i64) >> (64 - 8 * n)) as u64,
        _ => v,
    }
}

fn read_byte(mem: &[u64], leaf: Option<(u64, &Shape, u64)>) -> u8 {
    match leaf {
        Some((at, Shape::Elem(e), k)) => elem_bytes(*e, mem[at as usize])[k as usize],
        Some((at, Shape::Str { .. }, k)) => {
            let len = mem[at as usize];
            if k < len {
                let w = mem[at as usize + 1 + (k / 8) as usize];
                w.to_le_bytes()[(k % 8) as usize]
            } else {
                0
            }
        }
        _ => 0,
    }
}

fn write_byte(mem: &mut [u64], leaf: Option<(u64, &Shape, u64)>, v: u8) {
    match leaf {
        Some((at, Shape::Elem(e), k)) => {
            let mut b = elem_bytes(*e, mem[at as usize]);
            b[k as usize] = v;
            mem[at as usize] = elem_value(*e, b);
        }
        Some((at, Shape::Str { cap, wide: true }, k)) => {
            write_wide_byte(mem, at as usize, *cap, k, v)
        }
        Some((at, Shape::Str { cap, wide: false }, k)) => {
            let at = at as usize;
            let len = mem[at];
            // The string ends at its first zero byte, as a CODESYS STRING does; bytes past
            // it read as 0, and the terminator's place (byte `cap`) stays 0.
            if k >= u64::from(*cap) || (v == 0 && k >= len) {
                return;
            }
            if v == 0 {
                mem[at] = k;
                return;
            }
            let w = &mut mem[at + 1 + (k / 8) as usize];
            let mut b = w.to_le_bytes();
            b[(k % 8) as usize] = v;
            *w = u64::from_le_bytes(b);
            if k == len {
                mem[at] = k + 1;
            }
        }
        _ => {}
    }
}

/// Byte `k` of a WSTRING written through a pointer: the string ends at its first zero unit,
/// as a CODESYS WSTRING does; a unit written past the end extends it when it is not zero.
fn write_wide_byte(mem: &mut [u64], at: usize, cap: u32, k: u64, v: u8) {
    if k >= u64::from(cap) {
        return;
    }
    let len = mem[at];
    let unit = k & !1;
    if unit > len {
        // A unit after the terminator: it stays outside the string.
        return;
    }
    let w = &mut mem[at + 1 + (k / 8) as usize];
    let mut b = w.to_le_bytes();
    if unit == len {
        // The unit after the end holds nothing yet, whatever an older value left there.
        b[(unit % 8) as usize] = 0;
        b[(unit % 8) as usize + 1] = 0;
    }
    b[(k % 8) as usize] = v;
    *w = u64::from_le_bytes(b);
    let pair = [b[(unit % 8) as usize], b[(unit % 8) as usize + 1]];
    if pair == [0, 0] {
        if unit < len {
            mem[at] = unit;
        }
    } else if unit == len {
        mem[at] = unit + 2;
    }
}

/// An elementary access through a pointer: the handle in `p`, moved by `(i - lo)` elements
/// of `e` when `idx` is `Some((i, lo))`.
pub struct View<'a> {
    pub p: u32,
    pub idx: Option<(u32, i64)>,
    pub e: Elem,
    pub what: &'a str,
}

impl View<'_> {
    /// The variable's first slot, its image and the byte offset of the access, checked.
    fn target<'s>(
        &self,
        mem: &[u64],
        base: usize,
        shapes: &'s Shapes,
    ) -> Result<(u64, &'s Image, u64), OpFault> {
        let n = memory::elem_bytes(self.e) as i64;
        let mut extra = 0i128;
        if let Some((i, lo)) = self.idx {
            let i = mem[base + i as usize] as i64;
            extra = (i128::from(i) - i128::from(lo)) * i128::from(n);
        }
        within(
            mem,
            base,
            self.p,
            extra,
            n as u64,
            shapes,
            (self.what, false),
        )
    }

    pub fn load(
        &self,
        mem: &mut [u64],
        base: usize,
        d: u32,
        shapes: &Shapes,
    ) -> Result<(), OpFault> {
        let (b, img, o) = self.target(mem, base, shapes)?;
        let n = memory::elem_bytes(self.e);
        let v = match leaf_at(img, b, o)? {
            Some((at, Shape::Elem(le), 0)) if *le == self.e => mem[at as usize],
            _ => {
                let mut bytes = [0u8; 8];
                for (k, byte) in bytes.iter_mut().enumerate().take(n as usize) {
                    *byte = read_byte(mem, leaf_at(img, b, o + k as u64)?);
                }
                elem_value(self.e, bytes)
            }
        };
        mem[base + d as usize] = v;
        Ok(())
    }

    pub fn store(
        &self,
        mem: &mut [u64],
        base: usize,
        s: u32,
        shapes: &Shapes,
    ) -> Result<(), OpFault> {
        let (b, img, o) = self.target(mem, base, shapes)?;
        let v = mem[base + s as usize];
        match leaf_at(img, b, o)? {
            Some((at, Shape::Elem(le), 0)) if *le == self.e => mem[at as usize] = v,
            _ => {
                let bytes = elem_bytes(self.e, v);
                for (k, byte) in bytes
                    .iter()
                    .enumerate()
                    .take(memory::elem_bytes(self.e) as usize)
                {
                    let leaf = leaf_at(img, b, o + k as u64)?;
                    write_byte(mem, leaf, *byte);
                }
            }
        }
        Ok(())
    }
}

/// Runs a pointer instruction (`None`: `x` is another kind, for [`crate::ext::exec`]).
pub fn exec(
    x: &ExtOp,
    shapes: &Shapes,
    mem: &mut [u64],
    base: usize,
) -> Option<Result<(), OpFault>> {
    Some(match x {
        ExtOp::MakeRef { d, s, ty } => make(mem, base, [*d, *s], *ty, shapes),
        ExtOp::Deref { d, p, ty, n, what } => deref(mem, base, *d, *p, *ty, *n, what, shapes),
        ExtOp::PtrAdd { d, p, n, sub } => add(mem, base, *d, *p, *n, *sub),
        ExtOp::ViewLoad { d, p, idx, e, what } => View {
            p: *p,
            idx: *idx,
            e: *e,
            what,
        }
        .load(mem, base, *d, shapes),
        ExtOp::ViewStore { s, p, idx, e, what } => View {
            p: *p,
            idx: *idx,
            e: *e,
            what,
        }
        .store(mem, base, *s, shapes),
        ExtOp::Mem { f, d, a, b, n } => mem_fn(*f, mem, base, [*d, *a, *b, *n], shapes),
        ExtOp::ViewStr {
            s,
            p,
            cap,
            wide,
            load,
            what,
        } => view_str(mem, base, [*s, *p], *cap, *wide, *load, what, shapes),
        ExtOp::ItfType { d, s } => {
            mem[base + *d as usize] = type_of(mem[base + *s as usize]) as u64;
            Ok(())
        }
        ExtOp::New {
            d,
            n,
            ty,
            slots,
            proto,
        } => {
            let count = n.map_or(1, |n| mem[base + n as usize]);
            mem[base + *d as usize] = match shapes.heap {
                Some(h) => h.new_object(mem, *ty, u64::from(*slots), count, u64::from(*proto)),
                None => 0,
            };
            Ok(())
        }
        ExtOp::Free { p, by_addr } => {
            let at = if *by_addr {
                mem[base + *p as usize] as usize
            } else {
                base + *p as usize
            };
            let r = match shapes.heap {
                Some(h) => h.delete(mem, mem[at], "pointer"),
                None => crate::heap::delete_static(mem[at]),
            };
            if r.is_ok() && *by_addr {
                mem[at] = 0;
            }
            r
        }
        ExtOp::Area { d, p } => {
            let h = mem[base + *p as usize];
            mem[base + *d as usize] = match shapes.heap {
                Some(heap) => heap.area(mem, h),
                None => crate::heap::area_static(h),
            };
            Ok(())
        }
        _ => return None,
    })
}

/// The variable a pointer designates and the `n` bytes from it, checked to lie inside it.
fn bytes_at<'s>(
    mem: &[u64],
    base: usize,
    p: u32,
    n: u64,
    shapes: &'s Shapes,
    f: &str,
) -> Result<(u64, &'s Image, u64), OpFault> {
    within(mem, base, p, 0, n, shapes, (f, true))
}

/// The variable the handle in `p` designates, and the byte offset of the `n` bytes at its
/// offset moved by `extra`, checked to lie inside it (all of a heap array's elements).
/// `what` names the pointer, and the fault starts with it when `named` (a function's).
fn within<'s>(
    mem: &[u64],
    base: usize,
    p: u32,
    extra: i128,
    n: u64,
    shapes: &'s Shapes,
    (what, named): (&str, bool),
) -> Result<(u64, &'s Image, u64), OpFault> {
    let Live { b, t, off, count } = live(mem, base, p, what, shapes)?;
    let Some(img) = shapes
        .get(&t)
        .filter(|i| b + i.slots.saturating_mul(count) <= mem.len() as u64)
    else {
        return Err(domain(
            "invalid reference",
            if named {
                format!("{what}: the pointer designates nothing the program referenced")
            } else {
                format!("this {what} designates nothing the program referenced")
            },
        ));
    };
    let size = img.bytes.saturating_mul(count);
    let o = i128::from(off) + extra;
    if o < 0 || o + i128::from(n) > i128::from(size) {
        let of = if count > 1 {
            format!("{count} {}s", img.name)
        } else {
            format!("a {}", img.name)
        };
        return Err(domain(
            "pointer out of range",
            format!(
                "{}{n} bytes at byte {o} of {of} of {size} bytes",
                if named {
                    format!("{what}: ")
                } else {
                    String::new()
                }
            ),
        ));
    }
    Ok((b, img, o as u64))
}

/// Where byte `o` of the values of `img` from slot `at` on lives (see [`locate`]).
fn leaf_at(img: &Image, b: u64, o: u64) -> Result<Option<(u64, &Shape, u64)>, OpFault> {
    let k = o / img.bytes.max(1);
    locate(&img.shape, b + k * img.slots, o - k * img.bytes)
}

/// A string read from or written to a byte image ([`ExtOp::ViewStr`]): the characters up to
/// the first zero one (at most `cap`), then, when written, a zero one.
#[allow(clippy::too_many_arguments)]
fn view_str(
    mem: &mut [u64],
    base: usize,
    [s, p]: [u32; 2],
    cap: u32,
    wide: bool,
    load: bool,
    what: &str,
    shapes: &Shapes,
) -> Result<(), OpFault> {
    let unit: u64 = if wide { 2 } else { 1 };
    let n = (u64::from(cap) + 1) * unit;
    let (b, img, o) = bytes_at(mem, base, p, n, shapes, what)?;
    let at = mem[base + s as usize] as usize;
    if load {
        let mut units: Vec<u16> = Vec::new();
        for k in 0..u64::from(cap) {
            let mut u = u16::from(read_byte(mem, leaf_at(img, b, o + k * unit)?));
            if wide {
                u |= u16::from(read_byte(mem, leaf_at(img, b, o + k * unit + 1)?)) << 8;
            }
            if u == 0 {
                break;
            }
            units.push(u);
        }
        if wide {
            crate::ext::write_units(mem, at, &units, cap.saturating_mul(2));
        } else {
            let bytes: Vec<u8> = units.iter().map(|&u| u as u8).collect();
            crate::ext::write_str(mem, at, &bytes, cap);
        }
        return Ok(());
    }
    let units: Vec<u16> = if wide {
        crate::ext::read_units(mem, at)
    } else {
        crate::ext::read_str(mem, at)
            .into_iter()
            .map(u16::from)
            .collect()
    };
    let len = units.len().min(cap as usize);
    for (k, u) in units[..len].iter().copied().chain([0]).enumerate() {
        let k = k as u64 * unit;
        write_byte(mem, leaf_at(img, b, o + k)?, u as u8);
        if wide {
            write_byte(mem, leaf_at(img, b, o + k + 1)?, (u >> 8) as u8);
        }
    }
    Ok(())
}

/// MEMCPY (result 1), MEMSET (result 1), MEMCMP (-1, 0, 1) as TwinCAT's Tc2_System and
/// CODESYS's MemoryUtils define them, over checked pointers.
fn mem_fn(
    f: Builtin,
    mem: &mut [u64],
    base: usize,
    [d, a, b, n]: [u32; 4],
    shapes: &Shapes,
) -> Result<(), OpFault> {
    let name = f.name();
    let count = mem[base + n as usize] as i64;
    if count < 0 {
        return Err(domain(
            "pointer out of range",
            format!("{name}: a negative byte count ({count})"),
        ));
    }
    let count = count as u64;
    let (ab, aimg, aoff) = bytes_at(mem, base, a, count, shapes, name)?;
    let result = match f {
        Builtin::MemSet => {
            let fill = mem[base + b as usize] as u8;
            for k in 0..count {
                write_byte(mem, leaf_at(aimg, ab, aoff + k)?, fill);
            }
            1
        }
        Builtin::MemCpy => {
            let (bb, bimg, boff) = bytes_at(mem, base, b, count, shapes, name)?;
            // Read all, then write: overlapping copies give the source's bytes (memmove).
            let mut buf = Vec::with_capacity(count as usize);
            for k in 0..count {
                buf.push(read_byte(mem, leaf_at(bimg, bb, boff + k)?));
            }
            for (k, v) in buf.into_iter().enumerate() {
                write_byte(mem, leaf_at(aimg, ab, aoff + k as u64)?, v);
            }
            1
        }
        _ => {
            let (bb, bimg, boff) = bytes_at(mem, base, b, count, shapes, name)?;
            let mut r = 0i64;
            for k in 0..count {
                let x = read_byte(mem, leaf_at(aimg, ab, aoff + k)?);
                let y = read_byte(mem, leaf_at(bimg, bb, boff + k)?);
                if x != y {
                    r = if x < y { -1 } else { 1 };
                    break;
                }
            }
            r
        }
    };
    mem[base + d as usize] = result as u64;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_of_elementary_values_are_little_endian() {
        let raw = (-2i64) as u64; // INT -2
        assert_eq!(&elem_bytes(Elem::Int, raw)[..2], &[0xfe, 0xff]);
        assert_eq!(elem_value(Elem::Int, elem_bytes(Elem::Int, raw)), raw);
        let one = 1.0f64.to_bits();
        assert_eq!(
            &elem_bytes(Elem::Real, one)[..4],
            &1.0f32.to_bits().to_le_bytes()
        );
        assert_eq!(
            elem_value(Elem::Dword, elem_bytes(Elem::Real, one)),
            0x3f80_0000
        );
    }

    #[test]
    fn string_bytes_end_at_the_terminator() {
        // STRING[4] holding "ab": length slot, one data slot.
        let mut mem = vec![2u64, u64::from_le_bytes(*b"ab\0\0\0\0\0\0")];
        let s = Shape::Str {
            cap: 4,
            wide: false,
        };
        let at = |k| Some((0u64, &s, k));
        assert_eq!(read_byte(&mem, at(1)), b'b');
        assert_eq!(read_byte(&mem, at(2)), 0);
        write_byte(&mut mem, at(2), b'c');
        assert_eq!(mem[0], 3);
        write_byte(&mut mem, at(1), 0);
        assert_eq!(mem[0], 1, "a zero byte ends the string");
        write_byte(&mut mem, at(4), b'x');
        assert_eq!(mem[0], 1, "the terminator's place stays 0");
    }

    #[test]
    fn wide_string_bytes_are_utf16le_units() {
        // WSTRING[4] holding "A€": 41 00 AC 20.
        let mut mem = vec![4u64, u64::from_le_bytes([0x41, 0, 0xac, 0x20, 0, 0, 0, 0])];
        let s = Shape::Str { cap: 8, wide: true };
        let at = |k| Some((0u64, &s, k));
        assert_eq!(read_byte(&mem, at(3)), 0x20);
        assert_eq!(read_byte(&mem, at(4)), 0);
        write_byte(&mut mem, at(4), b'z');
        assert_eq!(mem[0], 6, "a unit written at the end extends the string");
        write_byte(&mut mem, at(1), 0);
        assert_eq!(mem[0], 6, "a zero high byte of 'A' is no terminator");
        write_byte(&mut mem, at(0), 0);
        assert_eq!(mem[0], 0, "a zero unit ends the string");
        write_byte(&mut mem, at(8), b'x');
        assert_eq!(mem[0], 0, "the terminator's place stays 0");
    }
}
