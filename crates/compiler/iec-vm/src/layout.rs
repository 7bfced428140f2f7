//! Sizes and offsets: how many slots a value of each type takes, and where each variable of
//! a POU sits in its frame. A function block instance is stored inline, its frame (variables,
//! then the temporaries and constants of its code) at the instance's place.

use petriplc_iec_sema::ir::{Project, VarClass};
use petriplc_iec_sema::types::{FbRef, Type, TypeId};

/// Slots of a string of `len` bytes (a WSTRING's: twice its characters): one for the
/// length, then 8 bytes per slot.
pub fn string_slots(len: u32) -> u32 {
    1 + len.div_ceil(8)
}

/// Frame sizes of function block types, filled in as they are compiled.
#[derive(Clone, Debug, Default)]
pub struct Sizes {
    /// Per POU: the whole frame of a function block (variables, temporaries, constants).
    pub fb: Vec<Option<u32>>,
}

impl Sizes {
    /// Slots a value of `ty` takes (`None` while a function block's size is unknown).
    pub fn of(&self, project: &Project, ty: TypeId) -> Option<u32> {
        Some(match project.types.get(ty) {
            Type::Elem(_)
            | Type::Enum { .. }
            | Type::Subrange { .. }
            | Type::Ref { .. }
            | Type::Null => 1,
            Type::Str { len, wide } => string_slots(len.saturating_mul(1 + u32::from(*wide))),
            Type::Array { elem, .. } => {
                let n = project.types.element_count(ty);
                let e = self.of(project, *elem)? as u64;
                u32::try_from(n.checked_mul(e)?).ok()?
            }
            Type::Struct { fields, .. } => {
                let mut total: u32 = 0;
                for f in fields {
                    total = total.checked_add(self.of(project, f.ty)?)?;
                }
                total
            }
            // Never a value: only an in-out has the type, laid out by `in_out_slots`.
            Type::VarArray { .. } => 1,
            Type::Fb(FbRef::User(p)) => self.fb.get(*p as usize).copied().flatten()?,
            Type::Fb(FbRef::Native(k)) => project.natives[*k as usize].vars.len() as u32,
            Type::IntLit | Type::RealLit | Type::Void | Type::Error => 1,
        })
    }

    /// Slots a value of `ty` takes, without overflow (a function block not compiled counts as
    /// one slot, as its frame does in [`frame_layout`]).
    pub fn of_wide(&self, project: &Project, ty: TypeId) -> u64 {
        match project.types.get(ty) {
            Type::Array { elem, .. } => project
                .types
                .element_count(ty)
                .saturating_mul(self.of_wide(project, *elem)),
            Type::Struct { fields, .. } => fields
                .iter()
                .fold(0u64, |t, f| t.saturating_add(self.of_wide(project, f.ty))),
            _ => self.of(project, ty).map_or(1, u64::from),
        }
    }

    /// Offset of each field of a structure.
    pub fn field_offsets(&self, project: &Project, ty: TypeId) -> Vec<u32> {
        let mut out = Vec::new();
        if let Type::Struct { fields, .. } = project.types.get(ty) {
            let mut off = 0;
            for f in fields {
                out.push(off);
                off += self.of(project, f.ty).unwrap_or(1);
            }
        }
        out
    }
}

/// Where each variable of a POU sits in its frame (`None`: no storage, e.g. VAR_EXTERNAL).
#[derive(Clone, Debug, Default)]
pub struct FrameLayout {
    pub offsets: Vec<Option<u32>>,
    /// Slots of the variables.
    pub vars: u32,
}

/// Slots of a POU's variables, without overflow (what [`frame_layout`] would lay out).
pub fn frame_slots(project: &Project, sizes: &Sizes, pou: u32) -> u64 {
    project
        .pou(pou)
        .vars
        .iter()
        .map(|v| match v.class {
            VarClass::External(_) => 0,
            VarClass::InOut => u64::from(in_out_slots(project, v.ty)),
            _ => sizes.of_wide(project, v.ty),
        })
        .fold(0u64, u64::saturating_add)
}

/// Slots of an in-out of type `ty`: the caller's address, and for an ARRAY[*] its
/// descriptor after it, (lower bound, upper bound, stride in slots) per dimension, which the
/// caller writes with the address and the callee's subscripts are checked against.
pub fn in_out_slots(project: &Project, ty: TypeId) -> u32 {
    match project.types.get(ty) {
        Type::VarArray { dims, .. } => 1 + 3 * dims,
        _ => 1,
    }
}

/// Lays out a POU's variables; in-outs take one slot (a pointer), an ARRAY[*] one its
/// descriptor too ([`in_out_slots`]).
pub fn frame_layout(project: &Project, sizes: &Sizes, pou: u32) -> FrameLayout {
    let p = project.pou(pou);
    let mut offsets = Vec::with_capacity(p.vars.len());
    let mut off: u32 = 0;
    for v in &p.vars {
        let n = match v.class {
            VarClass::External(_) => {
                offsets.push(None);
                continue;
            }
            VarClass::InOut => in_out_slots(project, v.ty),
            _ => sizes.of(project, v.ty).unwrap_or(1),
        };
        offsets.push(Some(off));
        off = off.saturating_add(n);
    }
    FrameLayout { offsets, vars: off }
}
