//! Types by name and by specification, constant integers, initial and default values.

use petriplc_iec_syntax::ast::{self, Ident, Init, PouKind, TypeSpec};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::types::{ids, Elem, FbRef, Field, Type, TypeId, TypeTable, MAX_STRING_LEN};
use crate::value::Value;

use super::{Checker, Cx};

impl<'a> Checker<'a> {
    /// Resolves a declared type by its upper-case name.
    pub(super) fn named_type(
        &mut self,
        key: &str,
        use_span: Span,
    ) -> Option<(TypeId, Option<Value>)> {
        if let Some(r) = self.type_done.get(key) {
            return Some(r.clone());
        }
        let d = *self.type_decls.get(key)?;
        if self.type_busy.iter().any(|k| k == key) {
            // A linked list's node: a reference to the structure being resolved.
            if self.in_ref_target > 0 {
                if let Some(&id) = self.type_partial.get(key) {
                    return Some((id, None));
                }
            }
            self.error(
                diag::RECURSION,
                use_span,
                format!(
                    "type {} contains itself; a structure or array cannot hold its own type",
                    d.name.name
                ),
            );
            return Some((ids::ERROR, None));
        }
        if !self.enter_type(&d.name.name, use_span) {
            return Some((ids::ERROR, None));
        }
        self.type_busy.push(key.to_string());
        // A reference further in designates this type's own parts, which need their size.
        let in_ref = std::mem::replace(&mut self.in_ref_target, 0);
        let mut cx = Cx::global();
        cx.const_only = true;
        let (id, mut default) = match &d.spec {
            TypeSpec::Struct { base, fields, .. } => {
                let name = d.name.name.clone();
                let id = self.types.add(Type::Struct {
                    name: name.clone(),
                    fields: Vec::new(),
                });
                self.type_partial.insert(key.to_string(), id);
                // EXTENDS: the base's fields first, flattened, with their initial values.
                let (mut out, base_ok): (Vec<Field>, bool) = match base {
                    Some(b) => match self.base_struct_fields(b, &mut cx) {
                        Some(f) => (f, true),
                        None => (Vec::new(), false),
                    },
                    None => (Vec::new(), true),
                };
                for f in fields {
                    let (fty, fdef) = self.resolve_spec(&f.ty, &mut cx);
                    for n in &f.names {
                        if out.iter().any(|o| o.name.eq_ignore_ascii_case(&n.name)) {
                            self.error(
                                diag::DUPLICATE,
                                n.span,
                                format!("field `{}` is declared twice in {name}", n.name),
                            );
                            continue;
                        }
                        let init = match &f.init {
                            Some(i) => self.initial_value(i, fty, &mut cx),
                            None => fdef.clone(),
                        };
                        out.push(Field {
                            name: n.name.clone(),
                            ty: fty,
                            init,
                        });
                    }
                    if f.location.is_some() {
                        self.error(
                            diag::BAD_DECLARATION,
                            f.span,
                            "a structure's field cannot be located (AT); locate the variable of the structure type instead",
                        );
                    }
                }
                let parts: Vec<TypeId> = out.iter().map(|f| f.ty).collect();
                self.types.set(id, Type::Struct { name, fields: out });
                let what = format!("type {}", d.name.name);
                if base_ok && self.record_shape(id, &parts, 1, &what, d.name.span) {
                    (id, None)
                } else {
                    (ids::ERROR, None)
                }
            }
            TypeSpec::Enum { values, base, .. } => {
                let id = self.enum_type(&d.name.name, values, base.as_ref(), &mut cx);
                (id, None)
            }
            TypeSpec::Union { members, span } => {
                (self.union_type(&d.name, members, *span, &mut cx), None)
            }
            spec => self.resolve_spec(spec, &mut cx),
        };
        if let Some(init) = &d.init {
            default = self.initial_value(init, id, &mut cx);
        }
        self.type_busy.pop();
        self.type_partial.remove(key);
        self.in_ref_target = in_ref;
        self.leave_type();
        self.type_done
            .insert(key.to_string(), (id, default.clone()));
        Some((id, default))
    }

    fn enum_type(
        &mut self,
        name: &str,
        values: &[(Ident, Option<ast::Expr>)],
        base: Option<&Ident>,
        cx: &mut Cx,
    ) -> TypeId {
        if let Some(b) = base {
            match Elem::from_name(&b.name) {
                Some(e) if e.is_int() || e.is_bitstring() => {}
                _ => self.error(
                    diag::BAD_DECLARATION,
                    b.span,
                    format!("the values of an enumeration are integers; `{}` cannot be its base type (write INT, DINT, WORD…)", b.name),
                ),
            }
        }
        let mut out: Vec<(String, i64)> = Vec::new();
        let mut next: i64 = 0;
        for (n, v) in values {
            let value = match v {
                Some(e) => match self.const_int(e, cx) {
                    Some(x) => match i64::try_from(x) {
                        Ok(x) => x,
                        Err(_) => {
                            self.error(
                                diag::OUT_OF_RANGE,
                                e.span,
                                "enumeration value out of range",
                            );
                            0
                        }
                    },
                    None => next,
                },
                None => next,
            };
            if out.iter().any(|(o, _)| o.eq_ignore_ascii_case(&n.name)) {
                self.error(
                    diag::DUPLICATE,
                    n.span,
                    format!("`{}` is listed twice in enumeration {name}", n.name),
                );
                continue;
            }
            out.push((n.name.clone(), value));
            next = value.wrapping_add(1);
        }
        let id = self.types.add(Type::Enum {
            name: name.to_string(),
            values: out.clone(),
        });
        for (n, v) in out {
            self.enum_values
                .entry(n.to_ascii_uppercase())
                .or_default()
                .push((id, v));
        }
        id
    }

    /// The fields of the structure `b` a structure EXTENDS (`None`, reported: it is no
    /// structure).
    fn base_struct_fields(&mut self, b: &Ident, cx: &mut Cx) -> Option<Vec<Field>> {
        let (t, _) = self.resolve_spec(&TypeSpec::Named(b.clone()), cx);
        match self.types.get(t) {
            Type::Struct { fields, .. } => Some(fields.clone()),
            _ if t == ids::ERROR => None,
            _ => {
                let tn = self.types.name(t);
                self.error(
                    diag::BAD_DECLARATION,
                    b.span,
                    format!("a structure extends a structure; {tn} is not one"),
                );
                None
            }
        }
    }

    /// The type of a VAR_IN_OUT as written: `ARRAY[*, …] OF T` is allowed here (`in_pou`:
    /// the POU is not a PROGRAM, which no caller passes arrays to), any other type as
    /// [`Self::resolve_spec`] resolves it.
    pub fn resolve_in_out_spec(
        &mut self,
        spec: &TypeSpec,
        cx: &mut Cx,
        in_pou: bool,
    ) -> (TypeId, Option<Value>) {
        match spec {
            TypeSpec::ArrayStar { dims, elem, span } if in_pou => {
                let (et, _) = self.resolve_spec(elem, cx);
                if et == ids::ERROR {
                    return (ids::ERROR, None);
                }
                if *dims > 3 {
                    // The standard's and the vendors' uses go to three; the limit keeps
                    // the in-out's descriptor small.
                    self.error(
                        diag::ARRAY_STAR_PLACE,
                        *span,
                        format!("ARRAY[*] has at most 3 dimensions here, not {dims}"),
                    );
                    return (ids::ERROR, None);
                }
                (self.types.var_array(*dims, et), None)
            }
            _ => self.resolve_spec(spec, cx),
        }
    }

    /// Resolves a type as written; returns its id and the default value it brings (a
    /// declared type's initial value).
    pub fn resolve_spec(&mut self, spec: &TypeSpec, cx: &mut Cx) -> (TypeId, Option<Value>) {
        match spec {
            TypeSpec::Named(id) => self.type_by_name(id),
            TypeSpec::String { wide, len, .. } => {
                let n = match len {
                    None => crate::types::DEFAULT_STRING_LEN,
                    Some(e) => match self.const_int(e, cx) {
                        Some(n) if (1..=MAX_STRING_LEN as i128).contains(&n) => n as u32,
                        Some(n) => {
                            self.error(
                                diag::BAD_DECLARATION,
                                e.span,
                                format!("a string's length is 1 to {MAX_STRING_LEN}, not {n}"),
                            );
                            return (ids::ERROR, None);
                        }
                        None => return (ids::ERROR, None),
                    },
                };
                (self.types.string_of(n, *wide), None)
            }
            TypeSpec::Array { ranges, elem, .. } => {
                let mut dims = Vec::new();
                let mut ok = true;
                for (lo, hi) in ranges {
                    let l = self.const_int(lo, cx);
                    let h = self.const_int(hi, cx);
                    match (l, h) {
                        (Some(l), Some(h)) => {
                            let fits = |v: i128| i64::try_from(v).is_ok();
                            if !fits(l) || !fits(h) || h < l || h - l >= 100_000_000 {
                                self.error(
                                    diag::BAD_DECLARATION,
                                    lo.span.to(hi.span),
                                    format!("array bounds {l}..{h}: the upper bound must be at least the lower one, and an array has at most 100 000 000 elements"),
                                );
                                ok = false;
                            } else {
                                dims.push((l as i64, h as i64));
                            }
                        }
                        _ => ok = false,
                    }
                }
                let (et, edef) = self.resolve_spec(elem, cx);
                if !ok || et == ids::ERROR {
                    return (ids::ERROR, None);
                }
                let count: u64 = dims.iter().map(|(l, h)| (h - l + 1) as u64).product();
                if count > 100_000_000 {
                    self.error(
                        diag::BAD_DECLARATION,
                        spec.span(),
                        "this array has more than 100 000 000 elements",
                    );
                    return (ids::ERROR, None);
                }
                let id = self.types.array(dims, et);
                if !self.record_shape(id, &[et], count, "this array", spec.span()) {
                    return (ids::ERROR, None);
                }
                let default = edef
                    .filter(|_| count <= 1_000_000)
                    .map(|v| Value::Array(vec![v; count as usize]));
                (id, default)
            }
            TypeSpec::ArrayStar { span, .. } => {
                self.error(
                    diag::ARRAY_STAR_PLACE,
                    *span,
                    "ARRAY[*] takes the bounds of the array a caller passes, so it is only the type of a VAR_IN_OUT of a FUNCTION, FUNCTION_BLOCK or METHOD; give the bounds here (ARRAY[1..10] OF …)",
                );
                (ids::ERROR, None)
            }
            TypeSpec::Subrange { base, lo, hi, span } => {
                let Some(b) = Elem::from_name(&base.name).filter(|e| e.is_int()) else {
                    self.error(
                        diag::BAD_DECLARATION,
                        base.span,
                        format!("a subrange is of an integer type, not `{}`", base.name),
                    );
                    return (ids::ERROR, None);
                };
                let (Some(l), Some(h)) = (self.const_int(lo, cx), self.const_int(hi, cx)) else {
                    return (ids::ERROR, None);
                };
                let (tl, th) = b.range();
                if l > h || l < tl || h > th {
                    self.error(
                        diag::BAD_DECLARATION,
                        *span,
                        format!(
                            "subrange {l}..{h} is empty or outside {} ({tl}..{th})",
                            b.name()
                        ),
                    );
                    return (ids::ERROR, None);
                }
                (self.types.subrange(b, l, h), None)
            }
            TypeSpec::Struct { span, .. } => {
                self.error(
                    diag::BAD_DECLARATION,
                    *span,
                    "declare the structure in TYPE … END_TYPE and use its name here",
                );
                (ids::ERROR, None)
            }
            TypeSpec::Union { span, .. } => {
                self.error(
                    diag::BAD_DECLARATION,
                    *span,
                    "declare the UNION in TYPE … END_TYPE and use its name here",
                );
                (ids::ERROR, None)
            }
            TypeSpec::Enum { values, base, .. } => {
                let id = self.enum_type("(anonymous enumeration)", values, base.as_ref(), cx);
                (id, None)
            }
            TypeSpec::Ref { kind, target, span } => {
                self.in_ref_target += 1;
                let (t, _) = self.resolve_spec(target, cx);
                self.in_ref_target -= 1;
                if t == ids::ERROR {
                    return (ids::ERROR, None);
                }
                if *kind == ast::RefKind::ReferenceTo {
                    // A reference is an alias of data or of an instance; CODESYS has no
                    // reference to a reference.
                    let why = match self.types.get(t) {
                        Type::Ref { kind: ast::RefKind::ReferenceTo, .. } => Some("a REFERENCE TO cannot designate another REFERENCE TO; reference the data itself"),
                        _ => None,
                    };
                    if let Some(why) = why {
                        self.error(diag::UNSUPPORTED, *span, why);
                        return (ids::ERROR, None);
                    }
                }
                (self.types.reference(*kind, t), None)
            }
            TypeSpec::Unsupported { what, span } => {
                self.error(diag::UNSUPPORTED, *span, what.clone());
                (ids::ERROR, None)
            }
        }
    }

    /// A type by name: elementary, STRING, declared, or a function block.
    pub fn type_by_name(&mut self, id: &Ident) -> (TypeId, Option<Value>) {
        if let Some(e) = Elem::from_name(&id.name) {
            return (TypeTable::elem_id(e), None);
        }
        if id.is("STRING") {
            return (ids::STRING, None);
        }
        if id.is("WSTRING") {
            return (ids::WSTRING, None);
        }
        let key = id.key();
        if self.type_decls.contains_key(&key) {
            return self.named_type(&key, id.span).unwrap_or((ids::ERROR, None));
        }
        if let Some(&p) = self.pou_names.get(&key) {
            if self.is_interface(p) {
                return (self.itf_type(p), None);
            }
            if self.pou_asts[p as usize].kind == PouKind::FunctionBlock {
                return (self.types.fb(FbRef::User(p)), None);
            }
            self.error(
                diag::UNKNOWN_TYPE,
                id.span,
                format!(
                    "`{}` is a {}, not a type; only function blocks can be instantiated",
                    id.name,
                    self.pou_asts[p as usize].kind.keyword()
                ),
            );
            return (ids::ERROR, None);
        }
        if let Some(&n) = self.native_names.get(&key) {
            return (self.types.fb(FbRef::Native(n)), None);
        }
        if let Some(lib) = crate::vendor::fb_provider(&key) {
            // A vendor library's function block whose library is not loaded.
            self.error(
                diag::VENDOR_NOT_LOADED,
                id.span,
                format!(
                    "{} is a {} function block: add --lib {lib} (`libs = {lib}` on `module NAME iec`), or declare a FUNCTION_BLOCK of that name",
                    id.name,
                    crate::vendor::title(lib)
                ),
            );
            return (ids::ERROR, None);
        }
        self.error(
            diag::UNKNOWN_TYPE,
            id.span,
            format!("unknown type `{}`; declare it in TYPE … END_TYPE, or use an elementary type (INT, REAL, BOOL, TIME, STRING…)", id.name),
        );
        (ids::ERROR, None)
    }

    /// A constant integer (array bounds, string lengths, enumeration values).
    pub fn const_int(&mut self, e: &ast::Expr, cx: &mut Cx) -> Option<i128> {
        let was = cx.const_only;
        cx.const_only = true;
        let x = self.expr(e, cx, None);
        cx.const_only = was;
        if x.ty == ids::ERROR {
            return None;
        }
        match self.eval_const(&x) {
            Some(Value::Int(v)) if self.is_integral(x.ty) => Some(v),
            _ => {
                self.error(
                    diag::CONSTANT_REQUIRED,
                    e.span,
                    "this must be a constant integer (a literal, or an expression of literals and CONSTANT variables)",
                );
                None
            }
        }
    }

    pub fn is_integral(&self, ty: TypeId) -> bool {
        match self.types.get(ty) {
            Type::IntLit => true,
            Type::Elem(e) | Type::Subrange { base: e, .. } => e.is_int() || e.is_bitstring(),
            _ => false,
        }
    }

    /// An initial value for a variable of type `ty`.
    pub fn initial_value(&mut self, init: &Init, ty: TypeId, cx: &mut Cx) -> Option<Value> {
        if ty == ids::ERROR {
            return None;
        }
        let was = cx.const_only;
        cx.const_only = true;
        let v = self.initial_inner(init, ty, cx);
        cx.const_only = was;
        v
    }

    pub(super) fn initial_inner(&mut self, init: &Init, ty: TypeId, cx: &mut Cx) -> Option<Value> {
        if self.types.union_members(ty).is_some() {
            return self.union_initial(init, ty, cx);
        }
        match (init, self.types.get(ty).clone()) {
            (Init::Array { items, span }, Type::Array { dims, elem }) => {
                let count: u64 = dims.iter().map(|(l, h)| (h - l + 1) as u64).product();
                let mut out = Vec::new();
                for item in items {
                    let n = match &item.repeat {
                        Some(r) => match self.const_int(r, cx) {
                            Some(n) if n >= 0 => n as u64,
                            Some(_) => {
                                self.error(
                                    diag::BAD_INITIAL,
                                    r.span,
                                    "a repeat count is not negative",
                                );
                                return None;
                            }
                            None => return None,
                        },
                        None => 1,
                    };
                    if out.len() as u64 + n > count {
                        self.error(
                            diag::BAD_INITIAL,
                            *span,
                            format!("more initial values than the array's {count} elements"),
                        );
                        return None;
                    }
                    let v = match &item.value {
                        Some(v) => self.initial_inner(v, elem, cx)?,
                        None => self.default_value(elem),
                    };
                    for _ in 0..n {
                        out.push(v.clone());
                    }
                }
                // Elements not listed keep their default.
                let d = self.default_value(elem);
                while (out.len() as u64) < count {
                    out.push(d.clone());
                }
                Some(Value::Array(out))
            }
            (Init::Struct { fields, .. }, Type::Struct { fields: decl, name }) => {
                let mut out = Vec::new();
                for (n, v) in fields {
                    let Some(i) = decl
                        .iter()
                        .position(|f| f.name.eq_ignore_ascii_case(&n.name))
                    else {
                        self.error(
                            diag::NO_FIELD,
                            n.span,
                            format!(
                                "structure {name} has no field `{}`; its fields are {}",
                                n.name,
                                decl.iter()
                                    .map(|f| f.name.as_str())
                                    .collect::<Vec<_>>()
                                    .join(", ")
                            ),
                        );
                        continue;
                    };
                    let fv = self.initial_inner(v, decl[i].ty, cx)?;
                    out.push((i as u32, fv));
                }
                Some(Value::Fields(out))
            }
            (Init::Struct { fields, .. }, Type::Fb(fb)) => {
                // `t : TON := (PT := T#1s);`
                let mut out = Vec::new();
                for (n, v) in fields {
                    let found = match fb {
                        FbRef::User(p) => {
                            self.interface(p);
                            self.pous[p as usize]
                                .var_by_name(&n.name)
                                .map(|i| (i, self.pous[p as usize].vars[i as usize].ty))
                        }
                        FbRef::Native(k) => {
                            self.natives[k as usize].var_by_name(&n.name).map(|i| {
                                (
                                    i,
                                    TypeTable::elem_id(
                                        self.natives[k as usize].vars[i as usize].ty,
                                    ),
                                )
                            })
                        }
                    };
                    let Some((i, vty)) = found else {
                        self.error(
                            diag::NO_FIELD,
                            n.span,
                            format!("the function block has no variable `{}`", n.name),
                        );
                        continue;
                    };
                    let fv = self.initial_inner(v, vty, cx)?;
                    out.push((i, fv));
                }
                Some(Value::Fields(out))
            }
            (Init::Expr(e), _) => {
                let x = self.expr(e, cx, Some(ty));
                if x.ty == ids::ERROR {
                    return None;
                }
                let x = self.coerce(x, ty, "the initial value");
                if x.ty == ids::ERROR {
                    return None;
                }
                match self.eval_const(&x) {
                    Some(v) => Some(v),
                    None => {
                        self.error(
                            diag::CONSTANT_REQUIRED,
                            e.span,
                            "an initial value must be a constant expression",
                        );
                        None
                    }
                }
            }
            (i, _) => {
                let name = self.types.name(ty);
                self.error(
                    diag::BAD_INITIAL,
                    i.span(),
                    format!("this initial value does not fit a variable of type {name}"),
                );
                None
            }
        }
    }

    /// The value a variable of type `ty` starts with when nothing is said.
    pub fn default_value(&self, ty: TypeId) -> Value {
        match self.types.get(ty) {
            Type::Elem(e) if e.is_real() => Value::Real(0.0),
            Type::Str { wide: false, .. } => Value::Str(Vec::new()),
            Type::Str { wide: true, .. } => Value::WStr(Vec::new()),
            Type::Enum { values, .. } => Value::Int(values.first().map_or(0, |v| v.1) as i128),
            Type::Subrange { lo, .. } => Value::Int(*lo),
            Type::Array { .. } => Value::Array(Vec::new()),
            Type::Struct { .. } | Type::Fb(_) => Value::Fields(Vec::new()),
            _ => Value::Int(0),
        }
    }
}
