//! The byte image CODESYS and TwinCAT programs see through pointers: `SIZEOF`, and which
//! bytes of a variable a pointer's byte offset designates (the VM's views, iec-vm's
//! `pointer.rs`). Little-endian; each elementary value aligned to its size (at most 8), a
//! structure to its largest member and padded to it, as CODESYS and TwinCAT lay out data
//! on 64-bit targets (docs/iec.md, "References and pointers").

use crate::ir::{Expr, Step};
use crate::types::{Elem, Field, Type, TypeId, TypeTable};

/// Bytes of an elementary value. Durations, dates and times are petriplc's 64-bit
/// nanosecond counts: 8 bytes (CODESYS's 32-bit TIME, DATE, TOD and DT take 4).
pub fn elem_bytes(e: Elem) -> u64 {
    match e {
        Elem::Bool | Elem::Sint | Elem::Usint | Elem::Byte | Elem::Char => 1,
        Elem::Int | Elem::Uint | Elem::Word | Elem::Wchar => 2,
        Elem::Dint | Elem::Udint | Elem::Dword | Elem::Real => 4,
        _ => 8,
    }
}

/// Bytes and alignment of a value of `ty` (`None`: it has no byte image, e.g. a function
/// block instance).
pub fn size_align(types: &TypeTable, ty: TypeId) -> Option<(u64, u64)> {
    Some(match types.get(ty) {
        Type::Elem(e) | Type::Subrange { base: e, .. } => (elem_bytes(*e), elem_bytes(*e)),
        // Enumerations are 16-bit in CODESYS; petriplc's hold DINT values.
        Type::Enum { .. } => (4, 4),
        Type::Ref { .. } | Type::Null => (8, 8),
        // A WSTRING's characters are UTF-16 code units, its terminator a zero unit.
        Type::Str { len, wide: true } => (2 * (u64::from(*len) + 1), 2),
        Type::Str { len, wide: false } => (u64::from(*len) + 1, 1),
        Type::Array { elem, .. } => {
            let (s, a) = size_align(types, *elem)?;
            (s.checked_mul(types.element_count(ty))?, a)
        }
        Type::Struct { .. } if types.union_members(ty).is_some() => {
            return union_size_align(types, types.union_members(ty).unwrap_or(&[]));
        }
        Type::Struct { fields, .. } => {
            let mut off = 0u64;
            let mut align = 1u64;
            for f in fields {
                let (s, a) = size_align(types, f.ty)?;
                off = off.div_ceil(a) * a + s;
                align = align.max(a);
            }
            (off.div_ceil(align) * align, align)
        }
        // An ARRAY[*] has the size of the array passed: none of its own.
        Type::Fb(_)
        | Type::VarArray { .. }
        | Type::IntLit
        | Type::RealLit
        | Type::Void
        | Type::Error => return None,
    })
}

/// Bytes and alignment of a UNION of `members`: the largest member's size, rounded up to
/// the strictest member's alignment, as CODESYS and TwinCAT (and C) lay a union out.
pub fn union_size_align(types: &TypeTable, members: &[Field]) -> Option<(u64, u64)> {
    let mut size = 0u64;
    let mut align = 1u64;
    for m in members {
        let (s, a) = size_align(types, m.ty)?;
        size = size.max(s);
        align = align.max(a);
    }
    Some((size.div_ceil(align) * align, align))
}

/// Where `rest` leads inside a union's member of type `ty` (fields of structures, constant
/// subscripts, and last at most one variable subscript of a one-dimension array): the constant
/// byte offset, the variable subscript with its array's bounds, and the type reached (`None`:
/// a path the byte views do not take, e.g. through another union).
pub type OverlayPath<'p> = (u64, Option<(&'p Expr, (i64, i64))>, TypeId);

/// See [`OverlayPath`].
pub fn overlay_path<'p>(
    types: &TypeTable,
    mut ty: TypeId,
    rest: &'p [Step],
) -> Option<OverlayPath<'p>> {
    let mut off = 0u64;
    let mut var = None;
    for (n, s) in rest.iter().enumerate() {
        match (s, types.get(ty)) {
            (Step::Field(i), Type::Struct { fields, .. }) if types.union_members(ty).is_none() => {
                off += *field_offsets(types, ty).get(*i as usize)?;
                ty = fields.get(*i as usize)?.ty;
            }
            (Step::Index(ix), Type::Array { dims, elem }) => {
                let es = size_align(types, *elem)?.0;
                let consts: Option<Vec<i128>> = ix.iter().map(Expr::const_int).collect();
                match consts {
                    Some(c) if c.len() == dims.len() => {
                        // Row-major, as the array's bytes lie; the checker held constant
                        // subscripts to the bounds.
                        let mut lin = 0i128;
                        for (k, (lo, hi)) in dims.iter().enumerate() {
                            lin = lin * i128::from(hi - lo + 1) + (c[k] - i128::from(*lo));
                        }
                        off += u64::try_from(lin).ok()? * es;
                    }
                    None if dims.len() == 1 && ix.len() == 1 && n + 1 == rest.len() => {
                        var = Some((&ix[0], dims[0]));
                    }
                    _ => return None,
                }
                ty = *elem;
            }
            _ => return None,
        }
    }
    Some((off, var, ty))
}

/// Byte offset of each field of a structure.
pub fn field_offsets(types: &TypeTable, ty: TypeId) -> Vec<u64> {
    let mut out = Vec::new();
    if let Type::Struct { fields, .. } = types.get(ty) {
        let mut off = 0u64;
        for f in fields {
            let (s, a) = size_align(types, f.ty).unwrap_or((0, 1));
            off = off.div_ceil(a) * a;
            out.push(off);
            off += s;
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::types::{ids, Field};

    #[test]
    fn sizes_as_codesys_lays_them_out() {
        let mut t = TypeTable::new();
        assert_eq!(size_align(&t, ids::INT), Some((2, 2)));
        assert_eq!(size_align(&t, ids::REAL), Some((4, 4)));
        assert_eq!(size_align(&t, ids::STRING), Some((255, 1)));
        assert_eq!(size_align(&t, ids::WSTRING), Some((510, 2)));
        let w = t.wstring(80);
        assert_eq!(size_align(&t, w), Some((162, 2)));
        let a = t.array(vec![(1, 10)], ids::DINT);
        assert_eq!(size_align(&t, a), Some((40, 4)));
        // BYTE, then DINT aligned to 4, then BOOL; padded to 12.
        let s = t.add(Type::Struct {
            name: "S".into(),
            fields: [ids::BYTE, ids::DINT, ids::BOOL]
                .iter()
                .enumerate()
                .map(|(i, &ty)| Field {
                    name: format!("f{i}"),
                    ty,
                    init: None,
                })
                .collect(),
        });
        assert_eq!(size_align(&t, s), Some((12, 4)));
        assert_eq!(field_offsets(&t, s), vec![0, 4, 8]);
    }
}
