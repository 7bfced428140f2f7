//! CODESYS's and TwinCAT's `UNION … END_UNION` (docs/iec.md, "Unions"): every member starts
//! at byte 0 of the same bytes, little-endian; the union is as large as its largest member,
//! rounded up to its strictest alignment. A union is kept as a structure of one field, its
//! byte image (`ARRAY[0..n-1] OF BYTE`), so a whole union is copied, passed and pointed at
//! like any structure, and `u.m` reads and writes member `m` through that image (a
//! `Step::Overlay`, which the VM runs as a pointer view of `u`).

use petriplc_iec_syntax::ast::{Ident, Init, VarDecl};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::ir::{Place, Step};
use crate::memory;
use crate::types::{ids, Elem, Field, Type, TypeId};
use crate::value::Value;

use super::{Checker, Cx};

impl<'a> Checker<'a> {
    /// The type `TYPE name : UNION members END_UNION`.
    pub(super) fn union_type(
        &mut self,
        name: &Ident,
        members: &[VarDecl],
        span: Span,
        cx: &mut Cx,
    ) -> TypeId {
        let uname = name.name.clone();
        let id = self.types.add(Type::Struct {
            name: uname.clone(),
            fields: Vec::new(),
        });
        let mut out: Vec<Field> = Vec::new();
        let mut ok = true;
        for m in members {
            let (mty, _) = self.resolve_spec(&m.ty, cx);
            if mty == ids::ERROR {
                ok = false;
                continue;
            }
            if m.location.is_some() || m.init.is_some() {
                let what = if m.location.is_some() {
                    "located (AT)"
                } else {
                    "given an initial value"
                };
                self.error(
                    diag::UNION_MEMBER,
                    m.span,
                    format!("a member of UNION {uname} cannot be {what}; give the union variable its initial value instead: `u : {uname} := (member := value);`"),
                );
                ok = false;
            }
            let why = match self.types.get(mty) {
                Type::Fb(_) => Some("a function block instance"),
                _ if self.types.holds_reference(mty) => {
                    Some("a reference or pointer, or holds one")
                }
                _ if memory::size_align(&self.types, mty).is_none() => Some("without a byte image"),
                _ => None,
            };
            for n in &m.names {
                if let Some(why) = why {
                    let tn = self.types.name(mty);
                    self.error(
                        diag::UNION_MEMBER,
                        n.span,
                        format!("member `{}` of UNION {uname} is {tn}, {why}: a union's members are data whose bytes can be shared (elementary values, strings, arrays, structures)", n.name),
                    );
                    ok = false;
                    continue;
                }
                if out.iter().any(|o| o.name.eq_ignore_ascii_case(&n.name)) {
                    self.error(
                        diag::DUPLICATE,
                        n.span,
                        format!("member `{}` is declared twice in UNION {uname}", n.name),
                    );
                    ok = false;
                    continue;
                }
                out.push(Field {
                    name: n.name.clone(),
                    ty: mty,
                    init: None,
                });
            }
        }
        if out.is_empty() && ok {
            self.error(
                diag::UNION_MEMBER,
                span,
                format!("UNION {uname} has no members; declare at least one"),
            );
            ok = false;
        }
        let size = memory::union_size_align(&self.types, &out).map_or(1, |x| x.0.max(1));
        let Ok(hi) = i64::try_from(size - 1) else {
            return ids::ERROR;
        };
        let bytes = self.types.array(vec![(0, hi)], ids::BYTE);
        self.types.set(
            id,
            Type::Struct {
                name: uname.clone(),
                fields: vec![Field {
                    name: "(bytes)".into(),
                    ty: bytes,
                    init: None,
                }],
            },
        );
        self.types.set_union(id, out);
        let what = format!("type {uname}");
        if ok && self.record_shape(id, &[bytes], 1, &what, name.span) {
            id
        } else {
            ids::ERROR
        }
    }

    /// Reports that union `uname` has no member named `name`, listing its members.
    fn no_member(&mut self, uname: &str, members: &[Field], name: &Ident) {
        let list = members
            .iter()
            .map(|x| x.name.as_str())
            .collect::<Vec<_>>()
            .join(", ");
        self.error(
            diag::NO_FIELD,
            name.span,
            format!(
                "UNION {uname} has no member `{}`; its members are {list}",
                name.name
            ),
        );
    }

    /// `u.m`: member `m` of the union `p` (`None`, reported: there is no such member).
    pub(crate) fn union_member(&mut self, mut p: Place, f: &Ident, span: Span) -> Option<Place> {
        let members = self.types.union_members(p.ty)?.to_vec();
        let Some(i) = members
            .iter()
            .position(|m| m.name.eq_ignore_ascii_case(&f.name))
        else {
            let uname = self.types.name(p.ty);
            self.no_member(&uname, &members, f);
            return None;
        };
        p.path.push(Step::Overlay {
            union: p.ty,
            member: i as u32,
            ty: members[i].ty,
        });
        p.ty = members[i].ty;
        p.span = span;
        Some(p)
    }

    /// Whether a place reached through a union member is one the engine reads and writes
    /// through the union's bytes: an elementary member, or an element of a member that is a
    /// one-dimension array of elementary values (`value`: it is read or assigned; other uses,
    /// an in-out, an output's target, `ADR`, need an address of the member's own). Reported
    /// when not.
    pub(crate) fn union_place_ok(&mut self, p: &Place, value: bool) -> bool {
        let Some(k) = p
            .path
            .iter()
            .rposition(|s| matches!(s, Step::Overlay { .. }))
        else {
            return true;
        };
        let Step::Overlay {
            union,
            member,
            ty: mty,
        } = p.path[k]
        else {
            return true;
        };
        // A whole STRING or WSTRING is read and written through the bytes too.
        let elementary = |t: TypeId, me: &Self| {
            (me.types.elem(t).is_some() && !matches!(me.types.get(t), Type::Subrange { .. }))
                || matches!(me.types.get(t), Type::Str { .. })
        };
        let overlays = p
            .path
            .iter()
            .filter(|s| matches!(s, Step::Overlay { .. }))
            .count();
        let fits = overlays == 1
            && memory::overlay_path(&self.types, mty, &p.path[k + 1..])
                .is_some_and(|(_, _, t)| elementary(t, self));
        if fits && value {
            return true;
        }
        let tn = self.types.name(mty);
        let un = self.types.name(union);
        let mn = self
            .types
            .union_members(union)
            .and_then(|m| m.get(member as usize))
            .map_or(String::new(), |m| m.name.clone());
        let msg = if overlays > 1 {
            format!("member `{mn}` of UNION {un} lies inside another union: a union within a union is not read through yet; copy the inner union's bytes to a variable with MEMCPY(ADR(x), ADR(u), SIZEOF(x)) and use x.{mn}")
        } else if fits {
            format!("member `{mn}` of UNION {un} is read and assigned through the union's bytes and has no address of its own: it cannot be an in-out, an output's target, REF's argument, nor (a part of it) ADR's; copy it to a variable first, or take ADR of the member itself")
        } else {
            format!("member `{mn}` of UNION {un} is {tn}: only its elementary values and strings are read and written (an elementary or string member, an element of an array member, a structure member's elementary field), not a whole array or structure, nor a union inside it, yet; copy the member's bytes with MEMCPY(ADR(x), ADR(u), SIZEOF(x))")
        };
        self.error(diag::UNION_ACCESS, p.span, msg);
        false
    }

    /// Whether `ADR` takes the place: a union's member itself is at the union's address
    /// (and the pointer designates the union's bytes); a part of a member is not (reported).
    pub(crate) fn union_address_ok(&mut self, p: &Place) -> bool {
        match p
            .path
            .iter()
            .rposition(|s| matches!(s, Step::Overlay { .. }))
        {
            None => true,
            Some(k)
                if k + 1 == p.path.len()
                    && !p.path[..k]
                        .iter()
                        .any(|s| matches!(s, Step::Overlay { .. })) =>
            {
                true
            }
            Some(_) => self.union_place_ok(p, false),
        }
    }

    /// The initial value of a union: `(m := v)` for a named member, or a value for the first.
    pub(super) fn union_initial(&mut self, init: &Init, ty: TypeId, cx: &mut Cx) -> Option<Value> {
        let members = self.types.union_members(ty)?.to_vec();
        let uname = self.types.name(ty);
        let (m, v) = match init {
            Init::Struct { fields, span } => {
                let [(n, v)] = fields.as_slice() else {
                    self.error(
                        diag::UNION_INITIAL,
                        *span,
                        format!("a UNION holds one member's value at a time: initialise one member of {uname}, `(member := value)`"),
                    );
                    return None;
                };
                let Some(m) = members
                    .iter()
                    .find(|m| m.name.eq_ignore_ascii_case(&n.name))
                else {
                    self.no_member(&uname, &members, n);
                    return None;
                };
                (m.clone(), v)
            }
            other => (members.first()?.clone(), other),
        };
        let value = self.initial_inner(v, m.ty, cx)?;
        let size = memory::size_align(&self.types, ty).map_or(0, |x| x.0) as usize;
        let mut bytes = vec![0u8; size];
        if !self.value_bytes(m.ty, &value, &mut bytes) {
            let tn = self.types.name(m.ty);
            self.error(
                diag::UNION_INITIAL,
                v.span(),
                format!("member `{}` of UNION {uname} is {tn}: only an elementary or STRING member takes an initial value yet", m.name),
            );
            return None;
        }
        Some(Value::Fields(vec![(
            0,
            Value::Array(bytes.into_iter().map(|b| Value::Int(b.into())).collect()),
        )]))
    }

    /// Writes `v`, a value of `ty`, into `out` as CODESYS lays it in memory (little-endian);
    /// false when the type has no such form here.
    fn value_bytes(&self, ty: TypeId, v: &Value, out: &mut [u8]) -> bool {
        let raw: [u8; 8] = match (self.types.get(ty), v) {
            (Type::Str { .. }, Value::Str(s)) => {
                let n = s.len().min(out.len().saturating_sub(1));
                out[..n].copy_from_slice(&s[..n]);
                return true;
            }
            (Type::Enum { .. }, Value::Int(i)) => (*i as i64).to_le_bytes(),
            _ => match (self.types.elem(ty), v) {
                (Some(Elem::Real), v) => {
                    (u64::from((v.as_real().unwrap_or(0.0) as f32).to_bits())).to_le_bytes()
                }
                (Some(Elem::Lreal), v) => v.as_real().unwrap_or(0.0).to_bits().to_le_bytes(),
                (Some(_), Value::Int(i)) => (*i as i64).to_le_bytes(),
                _ => return false,
            },
        };
        let n = memory::size_align(&self.types, ty).map_or(0, |x| x.0) as usize;
        let n = n.min(8).min(out.len());
        out[..n].copy_from_slice(&raw[..n]);
        true
    }
}
