//! Places: what can be read or written (variables, fields, elements, bits, instance members).

use petriplc_iec_syntax::ast::{self, ExprKind as A};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Place, Root, Step, VarClass, VarId};
use crate::types::{ids, FbRef, Type, TypeId, TypeTable};
use crate::value::Value;

impl<'a> Checker<'a> {
    /// Resolves something that can be read (or written, with `write`): a variable, a field,
    /// an array element, a bit, an instance's input or output. A CODESYS `REFERENCE TO` is
    /// an alias: what it designates is the place (dereferenced implicitly, checked when the
    /// program runs as `^` is).
    /// A union's member is refused here (it has no address of its own): [`Self::value_place`]
    /// is for reading and assigning.
    pub fn place(&mut self, e: &ast::Expr, cx: &mut Cx, write: bool) -> Option<Place> {
        let p = self.place_inner(e, cx, write)?;
        self.union_place_ok(&p, false).then_some(p)
    }

    /// Like [`Self::place`], for a place that is only read or assigned, which may be a
    /// union's member.
    pub fn value_place(&mut self, e: &ast::Expr, cx: &mut Cx, write: bool) -> Option<Place> {
        let p = self.place_inner(e, cx, write)?;
        self.union_place_ok(&p, true).then_some(p)
    }

    /// [`Self::place`] that lets a union's member through, for the callers that know it.
    pub(crate) fn place_inner(&mut self, e: &ast::Expr, cx: &mut Cx, write: bool) -> Option<Place> {
        let p = self.reference_place(e, cx, write)?;
        Some(self.through_reference(p))
    }

    /// A place that is a `REFERENCE TO`: the variable designated, one dereference further.
    pub(crate) fn through_reference(&self, mut p: Place) -> Place {
        if let Type::Ref {
            kind: ast::RefKind::ReferenceTo,
            target,
        } = self.types.get(p.ty)
        {
            p.ty = *target;
            p.path.push(Step::Deref);
        }
        p
    }

    /// Like [`Self::place`], but a `REFERENCE TO` there is the reference itself, not what it
    /// designates (`REF=` binds it, `__ISVALIDREF` tests it).
    pub(crate) fn reference_place(
        &mut self,
        e: &ast::Expr,
        cx: &mut Cx,
        write: bool,
    ) -> Option<Place> {
        match &e.kind {
            A::Paren(inner) if !write => self.place_inner(inner, cx, write),
            A::Name(id) => self.name_place(id, cx),
            A::Field(base, f) if self.is_global_list(base, cx) => match self.list_member(base, f) {
                true => self.name_place(f, cx),
                false => None,
            },
            A::Field(base, f) => self.field_place(e, base, f, cx, write),
            A::Index(base, idx) => self.index_place(e, base, idx, cx, write),
            A::Bit(base, n) => self.bit_place(e, base, n, cx, write),
            A::Part(base, size, n) => self.part_place(e, base, *size, *n, cx, write),
            // A call giving a REFERENCE TO (`obj.Get().x`); any other call has no place.
            A::Call(call) => {
                let x = self.call_expr(call, cx, None);
                match self.types.get(x.ty) {
                    Type::Ref {
                        kind: ast::RefKind::ReferenceTo,
                        ..
                    } => Some(Place {
                        root: Root::Value,
                        ty: x.ty,
                        span: e.span,
                        path: vec![Step::Value(Box::new(x))],
                    }),
                    _ => {
                        if x.ty != ids::ERROR {
                            self.error(diag::NOT_ASSIGNABLE, e.span, "this is not a variable");
                        }
                        None
                    }
                }
            }
            A::Deref(base) => match self.this_deref(base, cx, e.span) {
                Some(this) => Some(this),
                None => self.deref_place(e, base, cx),
            },
            A::Direct(text) => {
                let id = ast::Ident::new(format!("%{text}"), e.span);
                let p = self.var_place(&id, cx);
                if p.is_none() {
                    self.error(
                        diag::UNSUPPORTED,
                        e.span,
                        format!("direct variable %{text} in code: declare a variable located on it (`name AT %{text} : TYPE;`, or without a name: `AT %{text} : TYPE;`)"),
                    );
                }
                p
            }
            _ => {
                self.error(
                    diag::NOT_ASSIGNABLE,
                    e.span,
                    if write {
                        "only a variable, an array element, a field or a bit can be assigned"
                    } else {
                        "this is not a variable"
                    },
                );
                None
            }
        }
    }

    /// A variable by name; an enumeration value or an unknown name is told.
    fn name_place(&mut self, id: &ast::Ident, cx: &mut Cx) -> Option<Place> {
        let p = self.var_place(id, cx);
        if p.is_none() {
            if self.enum_values.contains_key(&id.key()) {
                self.error(
                    diag::NOT_ASSIGNABLE,
                    id.span,
                    format!("`{}` is an enumeration value, not a variable", id.name),
                );
            } else {
                self.undeclared(id, cx);
            }
        }
        p
    }

    /// `base.f`: a structure's field or a function block instance's input or output.
    fn field_place(
        &mut self,
        e: &ast::Expr,
        base: &ast::Expr,
        f: &ast::Ident,
        cx: &mut Cx,
        write: bool,
    ) -> Option<Place> {
        // An ANY input's fields are inputs of their own (check/interface.rs, `any_input`).
        if let A::Name(n) = &base.kind {
            let key = format!("{}.{}", n.key(), f.key());
            if let Some(&v) = cx.names.get(&key) {
                return Some(Place {
                    root: Root::Var(v),
                    path: Vec::new(),
                    ty: cx.vars[v as usize].ty,
                    span: e.span,
                });
            }
        }
        let mut p = self.place_inner(base, cx, write)?;
        let span = e.span;
        if self.types.union_members(p.ty).is_some() {
            return self.union_member(p, f, span);
        }
        match self.types.get(p.ty).clone() {
            Type::Struct { fields, name } => {
                let Some(i) = fields
                    .iter()
                    .position(|x| x.name.eq_ignore_ascii_case(&f.name))
                else {
                    self.error(
                        diag::NO_FIELD,
                        f.span,
                        format!(
                            "structure {name} has no field `{}`; its fields are {}",
                            f.name,
                            fields
                                .iter()
                                .map(|x| x.name.as_str())
                                .collect::<Vec<_>>()
                                .join(", ")
                        ),
                    );
                    return None;
                };
                p.path.push(Step::Field(i as u32));
                p.ty = fields[i].ty;
                p.span = span;
                Some(p)
            }
            Type::Fb(fb) => {
                let (i, ty, class, fb_name) = self.fb_member(fb, f)?;
                let own = self.is_this(&p, cx);
                match class {
                    _ if own => {}
                    VarClass::Input | VarClass::Output | VarClass::InOut => {}
                    VarClass::Local => {
                        let constant = match fb {
                            FbRef::User(u) => self.pous[u as usize].vars[i as usize].constant,
                            FbRef::Native(_) => false,
                        };
                        if write && constant {
                            self.error(
                                diag::ASSIGN_CONSTANT,
                                span,
                                format!(
                                    "`{}` is a CONSTANT of {fb_name} and cannot be assigned",
                                    f.name
                                ),
                            );
                            return None;
                        }
                        // matiec (so OpenPLC and Beremiz), CODESYS and TwinCAT let a
                        // program read and set an instance's VAR; the standard does not.
                        self.diags.warning(
                            diag::INSTANCE_INTERNAL,
                            f.span,
                            format!("`{}` is internal to {fb_name} (its VAR): the standard lets only inputs and outputs be used from outside; matiec, CODESYS and TwinCAT allow it, and so does petriplc", f.name),
                        );
                    }
                    _ => {
                        self.error(
                            diag::NO_FIELD,
                            f.span,
                            format!("`{}` is internal to {fb_name}; only its inputs and outputs can be used from outside", f.name),
                        );
                        return None;
                    }
                }
                if write && class == VarClass::Output && !own {
                    self.error(
                        diag::NOT_ASSIGNABLE,
                        span,
                        format!(
                            "`{}` is an output of {fb_name}: only the function block writes it",
                            f.name
                        ),
                    );
                    return None;
                }
                if write && class == VarClass::InOut && !own {
                    self.error(
                        diag::NOT_ASSIGNABLE,
                        span,
                        format!(
                            "`{}` is an in-out of {fb_name}: connect it in the call",
                            f.name
                        ),
                    );
                    return None;
                }
                p.path.push(Step::Member(i));
                p.ty = ty;
                p.span = span;
                Some(p)
            }
            Type::Error => None,
            _ => {
                let t = self.types.name(p.ty);
                self.error(
                    diag::NO_FIELD,
                    f.span,
                    format!("`{}` of type {t} has no fields", self.src_text(base)),
                );
                None
            }
        }
    }

    /// `base[i, …]`: an array element; constant subscripts are checked against the bounds.
    fn index_place(
        &mut self,
        e: &ast::Expr,
        base: &ast::Expr,
        idx: &[ast::Expr],
        cx: &mut Cx,
        write: bool,
    ) -> Option<Place> {
        let mut p = self.place_inner(base, cx, write)?;
        if let Type::Ref {
            kind: ast::RefKind::PointerTo,
            target,
        } = *self.types.get(p.ty)
        {
            return self.pointer_index(e, p, target, idx, cx);
        }
        let (dims, elem) = match self.types.get(p.ty).clone() {
            Type::Array { dims, elem } => (dims, elem),
            // An ARRAY[*] in-out's subscripts are checked when the program runs, against
            // the bounds of the array the caller passed.
            Type::VarArray { dims, elem } => (vec![(i64::MIN, i64::MAX); dims as usize], elem),
            _ => {
                if p.ty != ids::ERROR {
                    let t = self.types.name(p.ty);
                    self.error(
                        diag::BAD_INDEX,
                        e.span,
                        format!("only arrays are indexed; this is {t}"),
                    );
                }
                return None;
            }
        };
        if idx.len() != dims.len() {
            self.error(
                diag::BAD_INDEX,
                e.span,
                format!(
                    "this array has {} dimension(s); give {} subscript(s)",
                    dims.len(),
                    dims.len()
                ),
            );
            return None;
        }
        let mut subs = Vec::new();
        for (i, (ie, (lo, hi))) in idx.iter().zip(&dims).enumerate() {
            let x = self.expr(ie, cx, Some(ids::DINT));
            if x.ty == ids::ERROR {
                return None;
            }
            if !self.is_integral(x.ty) {
                let t = self.types.name(x.ty);
                self.error(
                    diag::BAD_INDEX,
                    ie.span,
                    format!("a subscript is an integer, not {t}"),
                );
                return None;
            }
            if let Some(Value::Int(v)) = self.eval_const(&x) {
                if v < *lo as i128 || v > *hi as i128 {
                    self.error(
                        diag::BAD_INDEX,
                        ie.span,
                        format!("subscript {v} is outside dimension {} ({lo}..{hi})", i + 1),
                    );
                    return None;
                }
            }
            let x = self.widen_to_lint(x);
            subs.push(x);
        }
        p.path.push(Step::Index(subs));
        p.ty = elem;
        p.span = e.span;
        Some(p)
    }

    /// `base.n`: a bit of a bit string or an integer.
    fn bit_place(
        &mut self,
        e: &ast::Expr,
        base: &ast::Expr,
        n: &u32,
        cx: &mut Cx,
        write: bool,
    ) -> Option<Place> {
        let mut p = self.place_inner(base, cx, write)?;
        let Some(el) = self
            .types
            .elem(p.ty)
            .filter(|e| e.is_bitstring() || e.is_int())
        else {
            if p.ty != ids::ERROR {
                let t = self.types.name(p.ty);
                self.error(
                    diag::BAD_INDEX,
                    e.span,
                    format!("bit access (.{n}) applies to bit strings and integers, not {t}"),
                );
            }
            return None;
        };
        if *n >= el.bits() {
            self.error(
                diag::BAD_INDEX,
                e.span,
                format!(
                    "{} has bits 0 to {}; .{n} does not exist",
                    el.name(),
                    el.bits() - 1
                ),
            );
            return None;
        }
        p.path.push(Step::Bit(*n));
        p.ty = ids::BOOL;
        p.span = e.span;
        Some(p)
    }

    /// `base.%B1`, `.%W0`, `.%D1`: a byte, word or double word of a longer bit string
    /// (part `n` counts from the least significant end, as `.%X` counts bits).
    fn part_place(
        &mut self,
        e: &ast::Expr,
        base: &ast::Expr,
        size: u32,
        n: u32,
        cx: &mut Cx,
        write: bool,
    ) -> Option<Place> {
        let mut p = self.place(base, cx, write)?;
        let (letter, ty) = match size {
            8 => ('B', ids::BYTE),
            16 => ('W', ids::WORD),
            _ => ('D', ids::DWORD),
        };
        let Some(el) = self.types.elem(p.ty).filter(|e| e.is_bitstring()) else {
            if p.ty != ids::ERROR {
                let t = self.types.name(p.ty);
                self.error(
                    diag::BAD_INDEX,
                    e.span,
                    format!("partial access (.%{letter}{n}) applies to bit strings (BYTE, WORD, DWORD, LWORD), not {t}"),
                );
            }
            return None;
        };
        let parts = el.bits() / size;
        if n >= parts {
            let what = if parts == 0 {
                format!("{} has no part of {size} bits", el.name())
            } else {
                format!(
                    "{} has parts .%{letter}0 to .%{letter}{} of {size} bits; .%{letter}{n} does not exist",
                    el.name(),
                    parts - 1
                )
            };
            self.error(diag::BAD_INDEX, e.span, what);
            return None;
        }
        p.path.push(Step::Bits(n * size, size));
        p.ty = ty;
        p.span = e.span;
        Some(p)
    }

    pub(crate) fn src_text(&self, e: &ast::Expr) -> String {
        match &e.kind {
            A::Name(i) => i.name.clone(),
            _ => "this".into(),
        }
    }

    /// A member of a function block type: index, type, class, the FB's name.
    pub fn fb_member(
        &mut self,
        fb: FbRef,
        f: &ast::Ident,
    ) -> Option<(VarId, TypeId, VarClass, String)> {
        match fb {
            FbRef::User(p) => {
                self.interface(p);
                let pou = &self.pous[p as usize];
                let name = pou.name.clone();
                match pou.var_by_name(&f.name) {
                    Some(i) if pou.vars[i as usize].class != VarClass::Hidden => {
                        let v = &pou.vars[i as usize];
                        Some((i, v.ty, v.class, name))
                    }
                    _ => {
                        self.error(
                            diag::NO_FIELD,
                            f.span,
                            format!("function block {name} has no input or output `{}`", f.name),
                        );
                        None
                    }
                }
            }
            FbRef::Native(k) => {
                let sig = &self.natives[k as usize];
                let name = sig.name.clone();
                match sig.var_by_name(&f.name) {
                    Some(i) => {
                        let v = &sig.vars[i as usize];
                        let class = match v.kind {
                            crate::ir::NativeVarKind::Input => VarClass::Input,
                            crate::ir::NativeVarKind::Output => VarClass::Output,
                            crate::ir::NativeVarKind::State => VarClass::Local,
                        };
                        Some((i, TypeTable::elem_id(v.ty), class, name))
                    }
                    None => {
                        let list: Vec<&str> = sig
                            .vars
                            .iter()
                            .filter(|v| v.kind != crate::ir::NativeVarKind::State)
                            .map(|v| v.name.as_str())
                            .collect();
                        self.error(
                            diag::NO_FIELD,
                            f.span,
                            format!(
                                "{name} has no input or output `{}`; it has {}",
                                f.name,
                                list.join(", ")
                            ),
                        );
                        None
                    }
                }
            }
        }
    }

    /// A place that may be written here: reports why not otherwise.
    pub fn writable(&mut self, p: &Place, cx: &Cx, span: Span) -> bool {
        let var = self.var_of(p, cx).clone();
        // CODESYS and TwinCAT copy an instance assigned to another of its block.
        if matches!(self.types.get(p.ty), Type::Fb(_)) && !self.dialect.is_codesys_family() {
            self.error(
                diag::NOT_ASSIGNABLE,
                span,
                "a function block instance cannot be assigned; call it or set its inputs",
            );
            return false;
        }
        if p.path.iter().any(|s| matches!(s, Step::Deref)) {
            // Written through a reference: the variable holding it is only read, and what it
            // designates was writable when the reference was taken (E201).
            return true;
        }
        if var.constant {
            self.error(
                diag::ASSIGN_CONSTANT,
                span,
                format!("`{}` is a CONSTANT and cannot be assigned; declare it in VAR (without CONSTANT) to change it", var.name),
            );
            return false;
        }
        if let Root::Var(v) = p.root {
            if var.class == VarClass::Input && cx.pou.is_some() {
                let member_of_instance = p.path.iter().any(|s| matches!(s, Step::Member(_)));
                if !member_of_instance {
                    // matiec, CODESYS, TwinCAT and PCWorx accept it: it sets the POU's own
                    // copy (in a function block, until a call passes the input again).
                    self.diags.warning(
                        diag::ASSIGN_INPUT,
                        span,
                        format!("`{}` is an input of this POU: assigning it changes this POU's copy, which the next call that passes it overwrites; a local variable (VAR) says that better", var.name),
                    );
                }
            }
            if p.path.is_empty() && cx.for_vars.contains(&v) {
                // CODESYS, TwinCAT and matiec accept it: the loop goes on from the value
                // assigned (the end test reads the variable), as petriplc's FOR does.
                self.diags.warning(
                    diag::ASSIGN_LOOP_VAR,
                    span,
                    format!("`{}` controls the FOR loop around this statement: assigning it in the body changes where the loop goes on from; another variable says that better", var.name),
                );
            }
        }
        true
    }
}
