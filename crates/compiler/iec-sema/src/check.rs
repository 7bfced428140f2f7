//! The checker's driver and declarations: type declarations, POU interfaces, global
//! variables and configurations are collected and resolved here; bodies are checked in
//! `stmt.rs` and `expr.rs`.

use std::collections::HashMap;

use petriplc_iec_syntax::ast::{self, Element, Ident, Init, Library, PouKind, TypeSpec, VarKind};
use petriplc_iec_syntax::depth::{Depth, MAX_TYPE_DEPTH};
use petriplc_iec_syntax::diag::{self, Diagnostics};
use petriplc_iec_syntax::source::Span;

use crate::ir::{self, GlobalId, NativeSig, PouId, Var, VarClass, VarId};
use crate::limits::Shape;
use crate::stdlib;
use crate::types::{ids, Elem, FbRef, Field, Type, TypeId, TypeTable, MAX_STRING_LEN};
use crate::value::Value;
use crate::Options;

/// Where an expression is checked.
pub(crate) struct Cx {
    pub pou: Option<PouId>,
    pub kind: Option<PouKind>,
    pub vars: Vec<Var>,
    pub names: HashMap<String, VarId>,
    /// Loops around the statement being checked.
    pub loops: u32,
    /// FOR control variables of the loops around, which the body must not assign.
    pub for_vars: Vec<VarId>,
    /// In a declaration: only constants may be read.
    pub const_only: bool,
}

impl Cx {
    pub fn global() -> Self {
        Cx {
            pou: None,
            kind: None,
            vars: Vec::new(),
            names: HashMap::new(),
            loops: 0,
            for_vars: Vec::new(),
            const_only: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum State {
    Todo,
    Busy,
    Done,
}

pub(crate) struct Checker<'a> {
    pub lib: &'a Library,
    pub types: TypeTable,
    pub diags: Diagnostics,
    type_decls: HashMap<String, &'a ast::TypeDecl>,
    type_done: HashMap<String, (TypeId, Option<Value>)>,
    type_busy: Vec<String>,
    pub pou_asts: Vec<&'a ast::Pou>,
    pub pou_names: HashMap<String, PouId>,
    pub pous: Vec<ir::Pou>,
    pou_state: Vec<State>,
    pub natives: Vec<NativeSig>,
    pub native_names: HashMap<String, u32>,
    pub globals: Vec<Var>,
    pub global_names: HashMap<String, GlobalId>,
    /// Globals of a top-level VAR_GLOBAL list: visible without VAR_EXTERNAL.
    pub global_direct: Vec<bool>,
    /// Enumeration value names → (type, value) of every enumeration declaring them.
    pub enum_values: HashMap<String, Vec<(TypeId, i64)>>,
    /// R_EDGE / F_EDGE inputs per POU.
    edges: HashMap<PouId, Vec<(VarId, ast::Edge)>>,
    /// Calls between POUs (caller, callee, where), for recursion.
    pub calls: Vec<(Option<PouId>, PouId, Span)>,
    /// Named types and function block interfaces being resolved inside each other, and
    /// their names (`limits.rs`).
    pub(crate) nesting: Depth,
    pub(crate) nest_path: Vec<String>,
    /// E116 is reported once: one cause, not a report per level.
    pub(crate) too_deep_reported: bool,
    /// Depth and size of every array and structure type.
    pub(crate) shapes: HashMap<TypeId, Shape>,
    /// Per POU: depth and size of its variables (a function block's instance).
    pub(crate) fb_shapes: Vec<Shape>,
}

impl<'a> Checker<'a> {
    pub fn new(lib: &'a Library, options: &Options) -> Self {
        let mut natives = stdlib::standard_fbs();
        natives.extend(options.natives.iter().cloned());
        let native_names = natives
            .iter()
            .enumerate()
            .map(|(i, n)| (n.name.to_ascii_uppercase(), i as u32))
            .collect();
        Checker {
            lib,
            types: TypeTable::new(),
            diags: Diagnostics::new(),
            type_decls: HashMap::new(),
            type_done: HashMap::new(),
            type_busy: Vec::new(),
            pou_asts: Vec::new(),
            pou_names: HashMap::new(),
            pous: Vec::new(),
            pou_state: Vec::new(),
            natives,
            native_names,
            globals: Vec::new(),
            global_names: HashMap::new(),
            global_direct: Vec::new(),
            enum_values: HashMap::new(),
            edges: HashMap::new(),
            calls: Vec::new(),
            nesting: Depth::new(MAX_TYPE_DEPTH),
            nest_path: Vec::new(),
            too_deep_reported: false,
            shapes: HashMap::new(),
            fb_shapes: Vec::new(),
        }
    }

    pub fn error(&mut self, code: diag::Code, span: Span, msg: impl Into<String>) {
        self.diags.error(code, span, msg);
    }

    pub fn run(mut self) -> (Option<ir::Project>, Diagnostics) {
        self.collect();
        // Named types, in declaration order (each resolves what it needs first).
        let names: Vec<(String, &'a ast::TypeDecl)> = self
            .lib
            .elements
            .iter()
            .filter_map(|e| match e {
                Element::Types(ds) => Some(ds),
                _ => None,
            })
            .flatten()
            .map(|d| (d.name.key(), d))
            .collect();
        for (key, d) in names {
            if self
                .type_decls
                .get(&key)
                .is_some_and(|x| std::ptr::eq(*x, d))
            {
                self.named_type(&key, d.name.span);
            }
        }
        self.collect_globals();
        for i in 0..self.pou_asts.len() {
            self.interface(i as PouId);
        }
        for i in 0..self.pou_asts.len() {
            self.body(i as PouId);
        }
        let configuration = self.configurations();
        let diags = std::mem::take(&mut self.diags).sorted();
        if diags.has_errors() {
            return (None, diags);
        }
        let project = ir::Project {
            types: self.types,
            pous: self.pous,
            natives: self.natives,
            globals: self.globals,
            configuration,
        };
        (Some(project), diags)
    }

    // ---- collection ----

    fn collect(&mut self) {
        let lib = self.lib;
        let mut seen: HashMap<String, Span> = HashMap::new();
        for el in &lib.elements {
            match el {
                Element::Types(ds) => {
                    for d in ds {
                        let key = d.name.key();
                        if Elem::from_name(&key).is_some() || key == "STRING" || key == "WSTRING" {
                            self.error(
                                diag::DUPLICATE,
                                d.name.span,
                                format!("`{}` is an elementary type and cannot be declared again; choose another name", d.name.name),
                            );
                            continue;
                        }
                        if let Some(prev) = seen.get(&key).copied() {
                            self.duplicate(&d.name, prev);
                            continue;
                        }
                        seen.insert(key.clone(), d.name.span);
                        self.type_decls.insert(key, d);
                    }
                }
                Element::Pou(p) => {
                    let key = p.name.key();
                    if Elem::from_name(&key).is_some() || key == "STRING" {
                        self.error(
                            diag::DUPLICATE,
                            p.name.span,
                            format!(
                                "`{}` is an elementary type and cannot name a POU",
                                p.name.name
                            ),
                        );
                        continue;
                    }
                    if let Some(prev) = seen.get(&key).copied() {
                        self.duplicate(&p.name, prev);
                        continue;
                    }
                    seen.insert(key.clone(), p.name.span);
                    if self.native_names.contains_key(&key) || stdlib::is_standard_function(&key) {
                        self.diags.warning(
                            diag::SHADOWS_STANDARD,
                            p.name.span,
                            format!(
                                "{} {} replaces the standard {} of that name in this project",
                                p.kind.keyword(),
                                p.name.name,
                                if self.native_names.contains_key(&key) {
                                    "function block"
                                } else {
                                    "function"
                                }
                            ),
                        );
                    }
                    let id = self.pou_asts.len() as PouId;
                    self.pou_asts.push(p);
                    self.pou_names.insert(key, id);
                    self.pous.push(ir::Pou {
                        name: p.name.name.clone(),
                        kind: p.kind,
                        vars: Vec::new(),
                        result: None,
                        body: Vec::new(),
                        span: p.name.span,
                        runnable: matches!(p.body, ast::Body::St(_) | ast::Body::Il { .. }),
                    });
                    self.pou_state.push(State::Todo);
                    self.fb_shapes.push(Shape::default());
                }
                Element::Configuration(_) | Element::Globals(_) => {}
            }
        }
    }

    pub fn duplicate(&mut self, name: &Ident, prev: Span) {
        self.error(
            diag::DUPLICATE,
            name.span,
            format!(
                "`{}` is declared twice (first at byte {} of its source); rename one of them",
                name.name, prev.start
            ),
        );
    }

    // ---- types ----

    /// Resolves a declared type by its upper-case name.
    fn named_type(&mut self, key: &str, use_span: Span) -> Option<(TypeId, Option<Value>)> {
        if let Some(r) = self.type_done.get(key) {
            return Some(r.clone());
        }
        let d = *self.type_decls.get(key)?;
        if self.type_busy.iter().any(|k| k == key) {
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
        let mut cx = Cx::global();
        cx.const_only = true;
        let (id, mut default) = match &d.spec {
            TypeSpec::Struct { fields, .. } => {
                let name = d.name.name.clone();
                let id = self.types.add(Type::Struct {
                    name: name.clone(),
                    fields: Vec::new(),
                });
                let mut out: Vec<Field> = Vec::new();
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
                if self.record_shape(id, &parts, 1, &what, d.name.span) {
                    (id, None)
                } else {
                    (ids::ERROR, None)
                }
            }
            TypeSpec::Enum { values, base, .. } => {
                let id = self.enum_type(&d.name.name, values, base.as_ref(), &mut cx);
                (id, None)
            }
            spec => self.resolve_spec(spec, &mut cx),
        };
        if let Some(init) = &d.init {
            default = self.initial_value(init, id, &mut cx);
        }
        self.type_busy.pop();
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

    /// Resolves a type as written; returns its id and the default value it brings (a
    /// declared type's initial value).
    pub fn resolve_spec(&mut self, spec: &TypeSpec, cx: &mut Cx) -> (TypeId, Option<Value>) {
        match spec {
            TypeSpec::Named(id) => self.type_by_name(id),
            TypeSpec::String { wide, len, span } => {
                if *wide {
                    self.error(
                        diag::UNSUPPORTED,
                        *span,
                        "WSTRING is not supported; use STRING",
                    );
                    return (ids::ERROR, None);
                }
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
                (self.types.string(n), None)
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
            TypeSpec::Enum { values, base, .. } => {
                let id = self.enum_type("(anonymous enumeration)", values, base.as_ref(), cx);
                (id, None)
            }
            TypeSpec::Unsupported { what, span } => {
                self.error(
                    diag::UNSUPPORTED,
                    *span,
                    format!("{what} types are not supported"),
                );
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
        let key = id.key();
        if self.type_decls.contains_key(&key) {
            return self.named_type(&key, id.span).unwrap_or((ids::ERROR, None));
        }
        if let Some(&p) = self.pou_names.get(&key) {
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
        if id.is("WSTRING") {
            self.error(
                diag::UNSUPPORTED,
                id.span,
                "WSTRING is not supported; use STRING",
            );
            return (ids::ERROR, None);
        }
        let hint = if ["CHAR", "WCHAR"].iter().any(|w| id.is(w)) {
            " (CHAR is not supported; use STRING[1] or BYTE)"
        } else {
            ""
        };
        self.error(
            diag::UNKNOWN_TYPE,
            id.span,
            format!("unknown type `{}`{hint}; declare it in TYPE … END_TYPE, or use an elementary type (INT, REAL, BOOL, TIME, STRING…)", id.name),
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

    fn initial_inner(&mut self, init: &Init, ty: TypeId, cx: &mut Cx) -> Option<Value> {
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
            Type::Str { .. } => Value::Str(Vec::new()),
            Type::Enum { values, .. } => Value::Int(values.first().map_or(0, |v| v.1) as i128),
            Type::Subrange { lo, .. } => Value::Int(*lo),
            Type::Array { .. } => Value::Array(Vec::new()),
            Type::Struct { .. } | Type::Fb(_) => Value::Fields(Vec::new()),
            _ => Value::Int(0),
        }
    }

    // ---- globals ----

    fn collect_globals(&mut self) {
        let lib = self.lib;
        let mut blocks: Vec<(&ast::VarBlock, bool)> = Vec::new();
        for el in &lib.elements {
            match el {
                Element::Globals(b) => blocks.push((b, true)),
                Element::Configuration(c) => {
                    blocks.extend(c.globals.iter().map(|b| (b, false)));
                    for r in &c.resources {
                        blocks.extend(r.globals.iter().map(|b| (b, false)));
                    }
                }
                _ => {}
            }
        }
        let mut cx = Cx::global();
        for (b, direct) in blocks {
            if b.kind != VarKind::Global {
                self.error(
                    diag::UNSUPPORTED,
                    b.span,
                    format!(
                        "{} blocks are not supported in a configuration; use VAR_GLOBAL",
                        b.kind.keyword()
                    ),
                );
                continue;
            }
            for d in &b.vars {
                let (ty, def) = self.resolve_spec(&d.ty, &mut cx);
                let first = d.names.first().map_or("", |n| n.name.as_str());
                let ty = self.var_type_fits(ty, first, d.span);
                let init = match &d.init {
                    Some(i) => self.initial_value(i, ty, &mut cx),
                    None => def,
                };
                if b.constant && d.init.is_none() {
                    self.error(
                        diag::BAD_DECLARATION,
                        d.span,
                        "a VAR_GLOBAL CONSTANT needs its value: write `name : TYPE := value;`",
                    );
                }
                for n in &d.names {
                    let key = n.key();
                    if let Some(&g) = self.global_names.get(&key) {
                        let prev = self.globals[g as usize].span;
                        self.duplicate(n, prev);
                        continue;
                    }
                    let g = self.globals.len() as GlobalId;
                    self.globals.push(Var {
                        name: n.name.clone(),
                        ty,
                        class: VarClass::Global,
                        init: init.clone(),
                        constant: b.constant,
                        retain: b.retain == ast::Retain::Retain,
                        location: d.location.as_ref().map(|l| l.text.clone()),
                        span: n.span,
                    });
                    self.global_direct.push(direct);
                    self.global_names.insert(key, g);
                }
            }
        }
        if let Some(at) = self.globals.first().map(|g| g.span) {
            let vars = std::mem::take(&mut self.globals);
            self.frame_shape(&vars, "the global variables", at);
            self.globals = vars;
        }
    }

    // ---- POU interfaces ----

    /// Resolves a POU's variables (once; detects function blocks that contain themselves).
    pub fn interface(&mut self, p: PouId) {
        match self.pou_state[p as usize] {
            State::Done => return,
            State::Busy => {
                let name = self.pou_asts[p as usize].name.clone();
                self.error(
                    diag::RECURSION,
                    name.span,
                    format!("function block {} contains an instance of itself (directly or through another function block)", name.name),
                );
                return;
            }
            State::Todo => {}
        }
        let ast = self.pou_asts[p as usize];
        if !self.enter_type(&ast.name.name, ast.name.span) {
            return;
        }
        self.pou_state[p as usize] = State::Busy;
        let mut cx = Cx::global();
        cx.pou = Some(p);
        cx.kind = Some(ast.kind);
        cx.const_only = true;
        let mut result = None;
        let order = [
            VarKind::Input,
            VarKind::InOut,
            VarKind::Output,
            VarKind::Local,
            VarKind::Temp,
            VarKind::External,
            VarKind::Global,
            VarKind::Other,
        ];
        if ast.kind == PouKind::Function {
            let ty = match &ast.return_type {
                Some(t) => self.resolve_spec(t, &mut cx).0,
                None => ids::ERROR,
            };
            if let Type::Fb(_) = self.types.get(ty) {
                self.error(
                    diag::BAD_DECLARATION,
                    ast.name.span,
                    "a function cannot return a function block instance",
                );
            }
            result = Some(0);
            cx.vars.push(Var {
                name: ast.name.name.clone(),
                ty,
                class: VarClass::Result,
                init: None,
                constant: false,
                retain: false,
                location: None,
                span: ast.name.span,
            });
            cx.names.insert(ast.name.key(), 0);
        }
        let mut edges: Vec<(VarId, ast::Edge)> = Vec::new();
        // Parameters in declaration order (positional arguments follow it), then the rest.
        let param = |k: VarKind| matches!(k, VarKind::Input | VarKind::InOut | VarKind::Output);
        for b in ast.var_blocks.iter().filter(|b| param(b.kind)) {
            self.var_block(ast, b, &mut cx, &mut edges);
        }
        for kind in order.into_iter().filter(|k| !param(*k)) {
            for b in ast.var_blocks.iter().filter(|b| b.kind == kind) {
                self.var_block(ast, b, &mut cx, &mut edges);
            }
        }
        let mut vars = std::mem::take(&mut cx.vars);
        // R_EDGE / F_EDGE inputs keep their previous raw value (and a copy of the raw one).
        for (v, _) in &edges {
            for suffix in ["$prev", "$raw"] {
                let name = format!("{}{suffix}", vars[*v as usize].name);
                let span = vars[*v as usize].span;
                vars.push(Var {
                    name,
                    ty: ids::BOOL,
                    class: VarClass::Hidden,
                    init: None,
                    constant: false,
                    retain: false,
                    location: None,
                    span,
                });
            }
        }
        let what = format!("{} {}", ast.kind.keyword(), ast.name.name);
        let (shape, _) = self.frame_shape(&vars, &what, ast.name.span);
        self.fb_shapes[p as usize] = shape;
        let pou = &mut self.pous[p as usize];
        pou.vars = vars;
        pou.result = result;
        self.pou_state[p as usize] = State::Done;
        self.edges.insert(p, edges);
        self.leave_type();
    }

    fn var_block(
        &mut self,
        pou: &ast::Pou,
        b: &ast::VarBlock,
        cx: &mut Cx,
        edges: &mut Vec<(VarId, ast::Edge)>,
    ) {
        let allowed = match pou.kind {
            PouKind::Program => !matches!(b.kind, VarKind::Global | VarKind::Other),
            PouKind::FunctionBlock => !matches!(b.kind, VarKind::Global | VarKind::Other),
            PouKind::Function => matches!(
                b.kind,
                VarKind::Input
                    | VarKind::Output
                    | VarKind::InOut
                    | VarKind::Local
                    | VarKind::Temp
                    | VarKind::External
            ),
        };
        if !allowed {
            self.error(
                diag::BAD_DECLARATION,
                b.span,
                format!(
                    "{} is not allowed in a {}; {}",
                    b.kind.keyword(),
                    pou.kind.keyword(),
                    if b.kind == VarKind::Global {
                        "declare global variables in the CONFIGURATION (or a top-level VAR_GLOBAL list) and use VAR_EXTERNAL here"
                    } else {
                        "use VAR, VAR_INPUT, VAR_OUTPUT, VAR_IN_OUT or VAR_TEMP"
                    }
                ),
            );
            return;
        }
        if b.retain == ast::Retain::Retain
            && (matches!(b.kind, VarKind::Temp | VarKind::InOut | VarKind::External)
                || pou.kind == PouKind::Function)
        {
            self.error(
                diag::BAD_DECLARATION,
                b.span,
                "RETAIN applies to VAR, VAR_INPUT, VAR_OUTPUT and VAR_GLOBAL of programs and function blocks",
            );
        }
        if b.constant && !matches!(b.kind, VarKind::Local | VarKind::External | VarKind::Global) {
            self.error(
                diag::BAD_DECLARATION,
                b.span,
                "CONSTANT applies to VAR, VAR_EXTERNAL and VAR_GLOBAL blocks",
            );
        }
        for d in &b.vars {
            let (ty, def) = self.resolve_spec(&d.ty, cx);
            if let Type::Fb(FbRef::User(q)) = *self.types.get(ty) {
                self.interface(q);
                if pou.kind == PouKind::Function {
                    self.error(
                        diag::BAD_DECLARATION,
                        d.span,
                        "a FUNCTION has no memory between calls and cannot hold a function block instance; make it a FUNCTION_BLOCK",
                    );
                }
            } else if matches!(self.types.get(ty), Type::Fb(_)) && pou.kind == PouKind::Function {
                self.error(
                    diag::BAD_DECLARATION,
                    d.span,
                    "a FUNCTION has no memory between calls and cannot hold a function block instance; make it a FUNCTION_BLOCK",
                );
            }
            // A reference (VAR_EXTERNAL, VAR_IN_OUT) takes no storage of its own.
            let ty = if matches!(b.kind, VarKind::External | VarKind::InOut) {
                ty
            } else {
                let first = d.names.first().map_or("", |n| n.name.as_str());
                self.var_type_fits(ty, first, d.span)
            };
            let init = match &d.init {
                Some(i) => {
                    if matches!(b.kind, VarKind::External | VarKind::InOut) {
                        self.error(
                            diag::BAD_DECLARATION,
                            i.span(),
                            format!("{} variables take no initial value: they refer to another variable", b.kind.keyword()),
                        );
                        None
                    } else {
                        self.initial_value(i, ty, cx)
                    }
                }
                None => def,
            };
            if let Some(edge) = d.edge {
                if ty != ids::BOOL || b.kind != VarKind::Input {
                    self.error(
                        diag::BAD_DECLARATION,
                        d.span,
                        "R_EDGE and F_EDGE apply to BOOL inputs (VAR_INPUT x : BOOL R_EDGE;)",
                    );
                } else if pou.kind == PouKind::Function {
                    self.error(
                        diag::BAD_DECLARATION,
                        d.span,
                        "a FUNCTION has no memory to detect edges; use a FUNCTION_BLOCK",
                    );
                } else {
                    for k in 0..d.names.len() {
                        edges.push(((cx.vars.len() + k) as VarId, edge));
                    }
                }
            }
            if b.constant && d.init.is_none() && b.kind == VarKind::Local {
                self.error(
                    diag::BAD_DECLARATION,
                    d.span,
                    "a CONSTANT needs its value: write `name : TYPE := value;`",
                );
            }
            if d.location.is_some() && !matches!(b.kind, VarKind::Local | VarKind::Global) {
                self.error(
                    diag::BAD_DECLARATION,
                    d.span,
                    "only VAR and VAR_GLOBAL variables can be located with AT",
                );
            }
            if d.location.is_some() && pou.kind != PouKind::Program {
                self.error(
                    diag::BAD_DECLARATION,
                    d.span,
                    "located variables (AT) belong in programs and configurations",
                );
            }
            for (k, n) in d.names.iter().enumerate() {
                let key = n.key();
                if cx.names.contains_key(&key) {
                    let first = cx.vars[cx.names[&key] as usize].span;
                    self.duplicate(n, first);
                    let _ = k;
                    edges.clear();
                    continue;
                }
                let class = match b.kind {
                    VarKind::Input => VarClass::Input,
                    VarKind::Output => VarClass::Output,
                    VarKind::InOut => VarClass::InOut,
                    VarKind::Temp => VarClass::Temp,
                    VarKind::External => match self.global_names.get(&key) {
                        Some(&g) => {
                            let gv = &self.globals[g as usize];
                            if gv.ty != ty && ty != ids::ERROR && gv.ty != ids::ERROR {
                                let (a, bn) = (self.types.name(ty), self.types.name(gv.ty));
                                self.error(
                                    diag::EXTERNAL_MISMATCH,
                                    n.span,
                                    format!("VAR_EXTERNAL {} is {a} but the global variable is {bn}; declare it with the global's type", n.name),
                                );
                            } else if gv.constant && !b.constant {
                                self.error(
                                    diag::EXTERNAL_MISMATCH,
                                    n.span,
                                    format!("global {} is CONSTANT; declare it in VAR_EXTERNAL CONSTANT", n.name),
                                );
                            }
                            VarClass::External(g)
                        }
                        None => {
                            self.error(
                                diag::EXTERNAL_MISMATCH,
                                n.span,
                                format!("VAR_EXTERNAL {} has no VAR_GLOBAL of that name; declare `{} : {}` in the CONFIGURATION's VAR_GLOBAL", n.name, n.name, self.types.name(ty)),
                            );
                            VarClass::Local
                        }
                    },
                    _ => VarClass::Local,
                };
                let constant = b.constant
                    || matches!(class, VarClass::External(g) if self.globals[g as usize].constant);
                let init = if let VarClass::External(g) = class {
                    self.globals[g as usize].init.clone()
                } else {
                    init.clone()
                };
                let id = cx.vars.len() as VarId;
                cx.vars.push(Var {
                    name: n.name.clone(),
                    ty,
                    class,
                    init,
                    constant,
                    retain: b.retain == ast::Retain::Retain,
                    location: d.location.as_ref().map(|l| l.text.clone()),
                    span: n.span,
                });
                cx.names.insert(key, id);
            }
        }
    }

    // ---- bodies ----

    fn body(&mut self, p: PouId) {
        let ast = self.pou_asts[p as usize];
        match &ast.body {
            ast::Body::St(stmts) => {
                let mut cx = Cx::global();
                cx.pou = Some(p);
                cx.kind = Some(ast.kind);
                cx.vars = self.pous[p as usize].vars.clone();
                cx.names = cx
                    .vars
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.class != VarClass::Hidden)
                    .map(|(i, v)| (v.name.to_ascii_uppercase(), i as VarId))
                    .collect();
                let mut body = self.edge_prologue(p, ast.name.span);
                body.extend(self.stmts(stmts, &mut cx));
                self.pous[p as usize].body = body;
            }
            ast::Body::Il { code, .. } => {
                let mut cx = Cx::global();
                cx.pou = Some(p);
                cx.kind = Some(ast.kind);
                cx.vars = self.pous[p as usize].vars.clone();
                cx.names = cx
                    .vars
                    .iter()
                    .enumerate()
                    .filter(|(_, v)| v.class != VarClass::Hidden)
                    .map(|(i, v)| (v.name.to_ascii_uppercase(), i as VarId))
                    .collect();
                let mut body = self.edge_prologue(p, ast.name.span);
                body.extend(self.il_body(code, &mut cx));
                // The accumulator's temporaries are variables of the POU.
                self.pous[p as usize].vars = cx.vars;
                self.pous[p as usize].body = body;
            }
            ast::Body::Graphical { language, span, .. } => {
                self.diags.warning(
                    diag::NOT_CHECKED,
                    *span,
                    format!("{} {} is written in {}, which the engine does not run yet; it cannot be called or instantiated", ast.kind.keyword(), ast.name.name, language.name()),
                );
            }
            ast::Body::Missing(span) => {
                self.error(
                    diag::PLCOPEN_STRUCTURE,
                    *span,
                    format!("{} {} has no body", ast.kind.keyword(), ast.name.name),
                );
            }
        }
    }

    /// For every R_EDGE input: `x$raw := x; x := x AND NOT x$prev; x$prev := x$raw;`
    /// (F_EDGE: `NOT x AND x$prev`).
    fn edge_prologue(&mut self, p: PouId, span: Span) -> Vec<ir::Stmt> {
        let edges = self.edges.get(&p).cloned().unwrap_or_default();
        let mut out = Vec::new();
        let vars = &self.pous[p as usize].vars;
        let find = |n: String| vars.iter().position(|x| x.name == n);
        for (v, edge) in edges {
            let base = &vars[v as usize].name;
            let (Some(prev), Some(raw)) =
                (find(format!("{base}$prev")), find(format!("{base}$raw")))
            else {
                continue;
            };
            let place = |id: usize| ir::Place {
                root: ir::Root::Var(id as VarId),
                path: Vec::new(),
                ty: ids::BOOL,
                span,
            };
            let load = |id: usize| ir::Expr {
                kind: ir::ExprKind::Load(place(id)),
                ty: ids::BOOL,
                span,
            };
            let not = |e: ir::Expr| ir::Expr {
                kind: ir::ExprKind::Unary(ir::UnaryOp::Not, Box::new(e)),
                ty: ids::BOOL,
                span,
            };
            let and = |a: ir::Expr, b: ir::Expr| ir::Expr {
                kind: ir::ExprKind::Binary(ir::BinaryOp::And, Box::new(a), Box::new(b)),
                ty: ids::BOOL,
                span,
            };
            let assign = |target: usize, value: ir::Expr| ir::Stmt {
                kind: ir::StmtKind::Assign {
                    target: place(target),
                    value,
                },
                span,
            };
            let v = v as usize;
            out.push(assign(raw, load(v)));
            let edge_value = match edge {
                ast::Edge::Rising => and(load(v), not(load(prev))),
                ast::Edge::Falling => and(not(load(v)), load(prev)),
            };
            out.push(assign(v, edge_value));
            out.push(assign(prev, load(raw)));
        }
        out
    }
}
