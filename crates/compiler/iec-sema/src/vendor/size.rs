//! SIZEOF as CODESYS 3 / TwinCAT 3 compute it: the bytes a variable of a type takes in the
//! vendor's memory image, with its 8-byte alignment (each value at a multiple of its own
//! size up to 8, strings at any byte, a structure padded to a multiple of its largest
//! member), whatever petriplc's own storage (one 64-bit slot per value) is.

use crate::types::{Elem, Type, TypeId, TypeTable};

/// Why a type has no CODESYS size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SizeError {
    /// A function block instance: CODESYS adds hidden members (a pointer to its method
    /// table, implicit variables) whose size depends on the runtime.
    FunctionBlock,
    /// A literal or an expression without a storage type.
    NoStorage,
}

impl std::fmt::Display for SizeError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SizeError::FunctionBlock => "a function block instance has no portable size (CODESYS adds hidden members that depend on the runtime)",
            SizeError::NoStorage => "this has no storage type; give a variable or a type name",
        })
    }
}

impl std::error::Error for SizeError {}

/// The size in bytes of a value of `ty`, as CODESYS's SIZEOF gives it.
pub fn size_of(types: &TypeTable, ty: TypeId) -> Result<u64, SizeError> {
    layout(types, ty, 0).map(|(size, _)| size)
}

fn elem_size(e: Elem) -> u64 {
    match e {
        // CODESYS stores TIME, TOD, DATE and DT in 32 bits (milliseconds, seconds).
        Elem::Time | Elem::Tod | Elem::Date | Elem::Dt => 4,
        Elem::Bool => 1,
        _ => u64::from(e.bits()) / 8,
    }
}

/// (size, alignment); `depth` bounds the recursion (types are already bounded by the
/// checker; this is a second guard).
fn layout(types: &TypeTable, ty: TypeId, depth: u32) -> Result<(u64, u64), SizeError> {
    if depth > 200 {
        return Err(SizeError::NoStorage);
    }
    Ok(match types.get(ty) {
        Type::Elem(e) | Type::Subrange { base: e, .. } => {
            let s = elem_size(*e);
            (s, s.min(8))
        }
        Type::Str { len } => (u64::from(*len) + 1, 1),
        // An enumeration's base type is INT in CODESYS when none is given.
        Type::Enum { .. } => (2, 2),
        Type::Array { dims, elem } => {
            let (s, a) = layout(types, *elem, depth + 1)?;
            let n = dims.iter().fold(1u64, |n, (lo, hi)| {
                n.saturating_mul(
                    u64::try_from(hi.saturating_sub(*lo).saturating_add(1)).unwrap_or(0),
                )
            });
            (s.saturating_mul(n), a)
        }
        Type::Struct { fields, .. } => {
            let (mut at, mut align) = (0u64, 1u64);
            for f in fields {
                let (s, a) = layout(types, f.ty, depth + 1)?;
                at = at.div_ceil(a) * a + s;
                align = align.max(a);
            }
            (at.div_ceil(align) * align, align)
        }
        Type::Fb(_) => return Err(SizeError::FunctionBlock),
        Type::IntLit | Type::RealLit | Type::Void | Type::Error => {
            return Err(SizeError::NoStorage)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{ids, Field};

    fn field(name: &str, ty: TypeId) -> Field {
        Field {
            name: name.into(),
            ty,
            init: None,
        }
    }

    #[test]
    fn elementary_and_strings() {
        let mut t = TypeTable::new();
        assert_eq!(size_of(&t, ids::BOOL), Ok(1));
        assert_eq!(size_of(&t, ids::INT), Ok(2));
        assert_eq!(size_of(&t, TypeTable::elem_id(Elem::Real)), Ok(4));
        assert_eq!(size_of(&t, TypeTable::elem_id(Elem::Lreal)), Ok(8));
        assert_eq!(size_of(&t, TypeTable::elem_id(Elem::Time)), Ok(4));
        assert_eq!(size_of(&t, TypeTable::elem_id(Elem::Ltime)), Ok(8));
        let s = t.string(20);
        assert_eq!(size_of(&t, s), Ok(21));
        assert_eq!(size_of(&t, ids::INT_LIT), Err(SizeError::NoStorage));
    }

    #[test]
    fn arrays_and_structures_are_aligned() {
        let mut t = TypeTable::new();
        // CODESYS's own example: ARRAY[0..4] OF INT is 10 bytes.
        let a = t.add(Type::Array {
            dims: vec![(0, 4)],
            elem: ids::INT,
        });
        assert_eq!(size_of(&t, a), Ok(10));
        // Beckhoff's example: BYTE then LREAL is 16 bytes with 8-byte alignment, and so
        // is LREAL then BYTE (padded at the end).
        let lreal = TypeTable::elem_id(Elem::Lreal);
        let s1 = t.add(Type::Struct {
            name: "ST_TEST1".into(),
            fields: vec![field("ui8", ids::BYTE), field("f64", lreal)],
        });
        let s2 = t.add(Type::Struct {
            name: "ST_TEST2".into(),
            fields: vec![field("f64", lreal), field("ui8", ids::BYTE)],
        });
        assert_eq!(size_of(&t, s1), Ok(16));
        assert_eq!(size_of(&t, s2), Ok(16));
        // BYTE, DINT, BYTE, INT: 1 + 3 padding + 4 + 1 + 1 padding + 2 = 12.
        let s3 = t.add(Type::Struct {
            name: "s3".into(),
            fields: vec![
                field("a", ids::BYTE),
                field("b", ids::DINT),
                field("c", ids::BYTE),
                field("d", ids::INT),
            ],
        });
        assert_eq!(size_of(&t, s3), Ok(12));
        // A string inside a structure is at any byte: BOOL + STRING[3] = 5.
        let str3 = t.string(3);
        let s4 = t.add(Type::Struct {
            name: "s4".into(),
            fields: vec![field("a", ids::BOOL), field("s", str3)],
        });
        assert_eq!(size_of(&t, s4), Ok(5));
        // An array of those structures: 3 × 12.
        let a3 = t.add(Type::Array {
            dims: vec![(1, 3)],
            elem: s3,
        });
        assert_eq!(size_of(&t, a3), Ok(36));
    }
}
