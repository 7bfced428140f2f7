//! The handle a reference or pointer holds (one 64-bit slot): what it designates, packed so
//! that no program can forge one (docs/iec.md, "References and pointers"). `pointer` checks
//! and follows handles, `heap` makes those of `__NEW` objects.
//!
//! A handle packs a base field (28 bits), the designated variable's type id plus one (the
//! tag, 16 bits) and a byte offset (20 bits, signed); NULL is 0. The base field is the
//! variable's first slot, or, with [`HEAP_BIT`], a heap object's table entry and generation.

pub(crate) const BASE_BITS: u32 = 28;
const TAG_BITS: u32 = 16;
const OFF_BITS: u32 = 20;
/// The largest type id a handle can carry.
pub const MAX_TAGGED_TYPE: u32 = (1 << TAG_BITS) - 2;
pub(crate) const OFF_MIN: i64 = -(1 << (OFF_BITS - 1));
pub(crate) const OFF_MAX: i64 = (1 << (OFF_BITS - 1)) - 1;

/// A handle's parts: first slot (or, for a heap object, [`crate::heap`]'s entry), type id,
/// byte offset.
pub(crate) fn decode(h: u64) -> (u64, u32, i64) {
    let base = h & ((1 << BASE_BITS) - 1);
    let tag = ((h >> BASE_BITS) & ((1 << TAG_BITS) - 1)) as u32;
    let off = ((h >> (BASE_BITS + TAG_BITS)) as i64) << (64 - OFF_BITS) >> (64 - OFF_BITS);
    (base, tag.wrapping_sub(1), off)
}

/// The type id a handle carries (an interface's instance's own block type), -1 for NULL.
pub fn type_of(h: u64) -> i64 {
    if h == 0 {
        return -1;
    }
    i64::from(decode(h).1)
}

pub(crate) fn encode(base: u64, ty: u32, off: i64) -> u64 {
    base | u64::from(ty + 1) << BASE_BITS
        | ((off as u64) & ((1 << OFF_BITS) - 1)) << (BASE_BITS + TAG_BITS)
}

/// The base field of a heap object's handle: this bit, then its entry and generation
/// (`crate::heap`).
pub const HEAP_BIT: u64 = 1 << 27;
/// A handle of a part of a heap object (`THIS`, `ADR(p^.field)`): its offset field holds the
/// part's first slot within the object, not a byte offset.
pub const SUB_BIT: u64 = 1 << 26;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn handles_round_trip() {
        for (b, t, o) in [
            (0, 0, 0),
            (5, 3, 0),
            ((1 << 28) - 1, MAX_TAGGED_TYPE, -1),
            (7, 9, OFF_MAX),
            (7, 9, OFF_MIN),
        ] {
            assert_eq!(decode(encode(b, t, o)), (b, t, o));
            assert_ne!(encode(b, t, o), 0, "a handle is never NULL");
        }
    }
}
