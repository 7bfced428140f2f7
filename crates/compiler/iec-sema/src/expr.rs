//! Expressions: names, literals typed by their context, operators with the standard's type
//! rules, places (what can be written), and calls of functions (user and standard).

use petriplc_iec_syntax::ast::{self, BinaryOp, ExprKind as A, Literal, UnaryOp};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::lexer::TimeKind;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Builtin, Expr, ExprKind, FnCall, Place, Root, Step, VarClass, VarId};
use crate::stdlib;
use crate::types::{ids, Elem, FbRef, Type, TypeId, TypeTable, MAX_STRING_LEN};
use crate::value::{self, Value};

pub(crate) fn err(span: Span) -> Expr {
    Expr {
        kind: ExprKind::Const(Value::Int(0)),
        ty: ids::ERROR,
        span,
    }
}

fn konst(v: Value, ty: TypeId, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Const(v),
        ty,
        span,
    }
}

/// An argument of a standard function, bound to its position.
struct StdArg<'e> {
    expr: &'e ast::Expr,
    span: Span,
}

impl<'a> Checker<'a> {
    /// Checks an expression; `expected` is the type the context wants, when known (it
    /// resolves bare enumeration values and generic results, and types literals).
    pub fn expr(&mut self, e: &ast::Expr, cx: &mut Cx, expected: Option<TypeId>) -> Expr {
        let span = e.span;
        match &e.kind {
            A::Error => err(span),
            A::Literal(l) => self.literal(l, span),
            A::Paren(inner) => {
                let mut x = self.expr(inner, cx, expected);
                x.span = span;
                x
            }
            A::Name(id) => self.name(id, cx, expected),
            A::Field(..) | A::Index(..) | A::Bit(..) => match self.place(e, cx, false) {
                Some(p) => Expr {
                    ty: p.ty,
                    kind: ExprKind::Load(p),
                    span,
                },
                None => err(span),
            },
            A::Direct(text) => {
                self.error(
                    diag::UNSUPPORTED,
                    span,
                    format!("direct variable %{text} in code: declare a variable located on it (name AT %{text} : TYPE;) and use the name"),
                );
                err(span)
            }
            A::Unary(op, inner) => self.unary(*op, inner, cx, expected, span),
            A::Binary(op, a, b) => self.binary(*op, a, b, cx, expected, span),
            A::Call(call) => self.call_expr(call, cx, expected),
        }
    }

    /// A BOOL condition.
    pub fn cond(&mut self, e: &ast::Expr, cx: &mut Cx) -> Expr {
        let x = self.expr(e, cx, Some(ids::BOOL));
        if x.ty == ids::ERROR {
            return x;
        }
        if x.ty != ids::BOOL {
            let t = self.types.name(x.ty);
            self.error(
                diag::NOT_BOOL,
                e.span,
                format!("a condition must be BOOL, not {t}; compare it (e.g. `x <> 0`)"),
            );
            return err(e.span);
        }
        x
    }

    fn literal(&mut self, l: &Literal, span: Span) -> Expr {
        match l {
            Literal::Int { value, ty: None } => konst(Value::Int(*value), ids::INT_LIT, span),
            Literal::Real { value, ty: None } => konst(Value::Real(*value), ids::REAL_LIT, span),
            Literal::Bool { value, ty: None } => konst(Value::Int(*value as i128), ids::BOOL, span),
            Literal::Int { value, ty: Some(t) } => {
                let Some(e) = Elem::from_name(&t.name) else {
                    return self.bad_prefix(t);
                };
                if e.is_real() {
                    let v = *value as f64;
                    let v = if e == Elem::Real {
                        value::to_real(v)
                    } else {
                        v
                    };
                    return konst(Value::Real(v), TypeTable::elem_id(e), span);
                }
                if !e.is_integral() || e.is_duration() || e.is_date() {
                    return self.bad_prefix(t);
                }
                if !value::fits(*value, e) {
                    self.error(
                        diag::OUT_OF_RANGE,
                        span,
                        format!(
                            "{value} does not fit {} ({}..{})",
                            e.name(),
                            e.range().0,
                            e.range().1
                        ),
                    );
                    return err(span);
                }
                konst(Value::Int(*value), TypeTable::elem_id(e), span)
            }
            Literal::Real { value, ty: Some(t) } => match Elem::from_name(&t.name) {
                Some(Elem::Real) => konst(Value::Real(value::to_real(*value)), ids::REAL, span),
                Some(Elem::Lreal) => konst(Value::Real(*value), ids::LREAL, span),
                _ => {
                    self.error(
                        diag::TYPE_MISMATCH,
                        span,
                        format!(
                            "{}# takes an integer; a real literal is typed REAL# or LREAL#",
                            t.name
                        ),
                    );
                    err(span)
                }
            },
            Literal::Bool { value, ty: Some(t) } => match Elem::from_name(&t.name) {
                Some(Elem::Bool) => konst(Value::Int(*value as i128), ids::BOOL, span),
                _ => self.bad_prefix(t),
            },
            Literal::String { bytes, wide } => {
                if *wide {
                    self.error(
                        diag::UNSUPPORTED,
                        span,
                        "WSTRING literals (\"…\") are not supported; write STRING literals in single quotes",
                    );
                    return err(span);
                }
                let len = (bytes.len() as u32).clamp(1, MAX_STRING_LEN);
                let ty = self.types.string(len);
                konst(Value::Str(bytes.clone()), ty, span)
            }
            Literal::Time { kind, nanos } => {
                let ty = match kind {
                    TimeKind::Time => ids::TIME,
                    TimeKind::LTime => ids::LTIME,
                    TimeKind::Date => ids::DATE,
                    TimeKind::Tod => ids::TOD,
                    TimeKind::Dt => ids::DT,
                };
                konst(Value::Int(*nanos), ty, span)
            }
            Literal::Enum { ty, value } => {
                let (t, _) = self.type_by_name(ty);
                match self.types.get(t).clone() {
                    Type::Enum { values, name } => {
                        match values
                            .iter()
                            .find(|(n, _)| n.eq_ignore_ascii_case(&value.name))
                        {
                            Some((_, v)) => konst(Value::Int(*v as i128), t, span),
                            None => {
                                self.error(
                                    diag::UNDECLARED,
                                    value.span,
                                    format!(
                                        "enumeration {name} has no value `{}`; its values are {}",
                                        value.name,
                                        values
                                            .iter()
                                            .map(|v| v.0.as_str())
                                            .collect::<Vec<_>>()
                                            .join(", ")
                                    ),
                                );
                                err(span)
                            }
                        }
                    }
                    Type::Error => err(span),
                    _ => {
                        self.error(
                            diag::TYPE_MISMATCH,
                            ty.span,
                            format!(
                                "`{}#{}`: {} is not an enumeration",
                                ty.name, value.name, ty.name
                            ),
                        );
                        err(span)
                    }
                }
            }
        }
    }

    fn bad_prefix(&mut self, t: &ast::Ident) -> Expr {
        self.error(
            diag::TYPE_MISMATCH,
            t.span,
            format!(
                "`{}#` cannot type this literal; write e.g. INT#5, REAL#1.5, BOOL#TRUE, WORD#16#FF",
                t.name
            ),
        );
        err(t.span)
    }

    /// A name in an expression: a variable, a constant of an enumeration, or an error.
    fn name(&mut self, id: &ast::Ident, cx: &mut Cx, expected: Option<TypeId>) -> Expr {
        if let Some(place) = self.var_place(id, cx) {
            let var = self.var_of(&place, cx).clone();
            if cx.const_only {
                if !var.constant {
                    self.error(
                        diag::CONSTANT_REQUIRED,
                        id.span,
                        format!("`{}` is a variable; only constants (VAR CONSTANT, literals) can be used here", id.name),
                    );
                    return err(id.span);
                }
                let v = var
                    .init
                    .clone()
                    .unwrap_or_else(|| self.default_value(var.ty));
                return konst(v, var.ty, id.span);
            }
            if matches!(self.types.get(place.ty), Type::Fb(_)) {
                // Loading an instance is only meaningful as a place (member access).
            }
            return Expr {
                ty: place.ty,
                kind: ExprKind::Load(place),
                span: id.span,
            };
        }
        // An enumeration value, resolved by the expected type when several enums have it.
        if let Some(cands) = self.enum_values.get(&id.key()).cloned() {
            let pick = match expected.and_then(|t| cands.iter().find(|(ct, _)| *ct == t)) {
                Some(c) => Some(*c),
                None if cands.len() == 1 => Some(cands[0]),
                None => None,
            };
            return match pick {
                Some((t, v)) => konst(Value::Int(v as i128), t, id.span),
                None => {
                    let names: Vec<String> =
                        cands.iter().map(|(t, _)| self.types.name(*t)).collect();
                    self.error(
                        diag::UNDECLARED,
                        id.span,
                        format!(
                            "`{}` is a value of several enumerations ({}); write TYPE#{}",
                            id.name,
                            names.join(", "),
                            id.name
                        ),
                    );
                    err(id.span)
                }
            };
        }
        self.undeclared(id, cx);
        err(id.span)
    }

    fn undeclared(&mut self, id: &ast::Ident, cx: &Cx) {
        let key = id.key();
        let hint = if self.global_names.contains_key(&key) && cx.pou.is_some() {
            format!(
                "; it is a global variable: declare it in the POU's VAR_EXTERNAL (`{} : {};`)",
                id.name,
                self.types
                    .name(self.globals[self.global_names[&key] as usize].ty)
            )
        } else if self.pou_names.contains_key(&key) || stdlib::is_standard_function(&key) {
            "; it is a POU: call it with (…)".to_string()
        } else {
            "; declare it in VAR … END_VAR".to_string()
        };
        self.error(
            diag::UNDECLARED,
            id.span,
            format!("`{}` is not declared{hint}", id.name),
        );
    }

    /// The place a plain name denotes, if it is a variable.
    fn var_place(&mut self, id: &ast::Ident, cx: &Cx) -> Option<Place> {
        let key = id.key();
        if let Some(&v) = cx.names.get(&key) {
            let var = &cx.vars[v as usize];
            let root = match var.class {
                VarClass::External(g) => Root::Global(g),
                _ => Root::Var(v),
            };
            return Some(Place {
                root,
                path: Vec::new(),
                ty: var.ty,
                span: id.span,
            });
        }
        if let Some(&g) = self.global_names.get(&key) {
            // Inside a POU only globals of a top-level VAR_GLOBAL list are visible without
            // VAR_EXTERNAL; configurations see every global.
            if cx.pou.is_none() || self.global_direct[g as usize] {
                return Some(Place {
                    root: Root::Global(g),
                    path: Vec::new(),
                    ty: self.globals[g as usize].ty,
                    span: id.span,
                });
            }
        }
        None
    }

    /// The declaration a place's root refers to (the POU's own, for an external its
    /// VAR_EXTERNAL with its constness).
    pub fn var_of<'c>(&'c self, p: &Place, cx: &'c Cx) -> &'c crate::ir::Var {
        match p.root {
            Root::Var(v) => &cx.vars[v as usize],
            Root::Global(g) => {
                if let Some(v) = cx.vars.iter().find(|v| v.class == VarClass::External(g)) {
                    return v;
                }
                &self.globals[g as usize]
            }
        }
    }

    /// Resolves something that can be read (or written, with `write`): a variable, a field,
    /// an array element, a bit, an instance's input or output.
    pub fn place(&mut self, e: &ast::Expr, cx: &mut Cx, write: bool) -> Option<Place> {
        match &e.kind {
            A::Paren(inner) if !write => self.place(inner, cx, write),
            A::Name(id) => {
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
            A::Field(base, f) => {
                let mut p = self.place(base, cx, write)?;
                let span = e.span;
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
                        match class {
                            VarClass::Input | VarClass::Output | VarClass::InOut => {}
                            _ => {
                                self.error(
                                    diag::NO_FIELD,
                                    f.span,
                                    format!("`{}` is internal to {fb_name}; only its inputs and outputs can be used from outside", f.name),
                                );
                                return None;
                            }
                        }
                        if write && class == VarClass::Output {
                            self.error(
                                diag::NOT_ASSIGNABLE,
                                span,
                                format!("`{}` is an output of {fb_name}: only the function block writes it", f.name),
                            );
                            return None;
                        }
                        if write && class == VarClass::InOut {
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
            A::Index(base, idx) => {
                let mut p = self.place(base, cx, write)?;
                let Type::Array { dims, elem } = self.types.get(p.ty).clone() else {
                    if p.ty != ids::ERROR {
                        let t = self.types.name(p.ty);
                        self.error(
                            diag::BAD_INDEX,
                            e.span,
                            format!("only arrays are indexed; this is {t}"),
                        );
                    }
                    return None;
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
                                format!(
                                    "subscript {v} is outside dimension {} ({lo}..{hi})",
                                    i + 1
                                ),
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
            A::Bit(base, n) => {
                let mut p = self.place(base, cx, write)?;
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
                            format!(
                                "bit access (.{n}) applies to bit strings and integers, not {t}"
                            ),
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

    fn src_text(&self, e: &ast::Expr) -> String {
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
        if matches!(self.types.get(p.ty), Type::Fb(_)) {
            self.error(
                diag::NOT_ASSIGNABLE,
                span,
                "a function block instance cannot be assigned; call it or set its inputs",
            );
            return false;
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
                    self.error(
                        diag::ASSIGN_INPUT,
                        span,
                        format!("`{}` is an input of this POU and cannot be assigned here; copy it into a local variable (VAR) and change that", var.name),
                    );
                    return false;
                }
            }
            if p.path.is_empty() && cx.for_vars.contains(&v) {
                self.error(
                    diag::ASSIGN_LOOP_VAR,
                    span,
                    format!("`{}` controls the FOR loop around this statement and must not be assigned in its body; use another variable", var.name),
                );
                return false;
            }
        }
        true
    }

    // ---- operators ----

    fn unary(
        &mut self,
        op: UnaryOp,
        inner: &ast::Expr,
        cx: &mut Cx,
        expected: Option<TypeId>,
        span: Span,
    ) -> Expr {
        let x = self.expr(inner, cx, expected);
        if x.ty == ids::ERROR {
            return x;
        }
        match op {
            UnaryOp::Plus => {
                if self.numeric_or_lit(x.ty) || self.duration(x.ty) {
                    Expr { span, ..x }
                } else {
                    self.op_error("+", x.ty, None, span);
                    err(span)
                }
            }
            UnaryOp::Neg => {
                match (&x.kind, self.types.get(x.ty)) {
                    (ExprKind::Const(Value::Int(v)), Type::IntLit) => {
                        return konst(Value::Int(-v), ids::INT_LIT, span)
                    }
                    (ExprKind::Const(Value::Real(v)), Type::RealLit) => {
                        return konst(Value::Real(-v), ids::REAL_LIT, span)
                    }
                    _ => {}
                }
                let ok = match self.types.elem(x.ty) {
                    Some(e) => e.is_signed() || e.is_real() || e.is_duration(),
                    None => false,
                };
                if !ok {
                    let t = self.types.name(x.ty);
                    self.error(
                        diag::OPERAND_TYPE,
                        span,
                        format!("`-` negates signed integers, reals and durations, not {t}"),
                    );
                    return err(span);
                }
                let ty = self.base_type(x.ty);
                self.fold(Expr {
                    kind: ExprKind::Unary(op, Box::new(x)),
                    ty,
                    span,
                })
            }
            UnaryOp::Not => {
                let x = if self.types.get(x.ty) == &Type::IntLit {
                    match expected.filter(|t| self.types.elem(*t).is_some_and(|e| e.is_bitstring()))
                    {
                        Some(t) => self.coerce(x, t, "the operand of NOT"),
                        None => x,
                    }
                } else {
                    x
                };
                let ok = self.types.elem(x.ty).is_some_and(|e| e.is_bit());
                if !ok {
                    let t = self.types.name(x.ty);
                    self.error(
                        diag::OPERAND_TYPE,
                        span,
                        format!("NOT applies to BOOL and bit strings (BYTE, WORD, DWORD, LWORD), not {t}"),
                    );
                    return err(span);
                }
                let ty = self.base_type(x.ty);
                self.fold(Expr {
                    kind: ExprKind::Unary(op, Box::new(x)),
                    ty,
                    span,
                })
            }
        }
    }

    /// A subrange's base type (operations compute in the base type).
    pub fn base_type(&self, ty: TypeId) -> TypeId {
        match self.types.get(ty) {
            Type::Subrange { base, .. } => TypeTable::elem_id(*base),
            _ => ty,
        }
    }

    fn numeric_or_lit(&self, ty: TypeId) -> bool {
        matches!(self.types.get(ty), Type::IntLit | Type::RealLit)
            || self.types.elem(ty).is_some_and(|e| e.is_num())
    }

    fn duration(&self, ty: TypeId) -> bool {
        self.types.elem(ty).is_some_and(|e| e.is_duration())
    }

    fn op_error(&mut self, op: &str, a: TypeId, b: Option<TypeId>, span: Span) {
        let an = self.types.name(a);
        let msg = match b {
            Some(b) => {
                let bn = self.types.name(b);
                let hint = conversion_hint(&self.types, a, b);
                format!("`{op}` cannot combine {an} and {bn}{hint}")
            }
            None => format!("`{op}` does not apply to {an}"),
        };
        self.error(diag::OPERAND_TYPE, span, msg);
    }

    pub fn binary(
        &mut self,
        op: BinaryOp,
        a: &ast::Expr,
        b: &ast::Expr,
        cx: &mut Cx,
        expected: Option<TypeId>,
        span: Span,
    ) -> Expr {
        let hint = if op.is_comparison() { None } else { expected };
        let mut x = self.expr(a, cx, hint);
        let mut y = self.expr(
            b,
            cx,
            hint.or(Some(x.ty))
                .filter(|t| *t != ids::INT_LIT && *t != ids::REAL_LIT),
        );
        if x.ty == ids::INT_LIT
            && self.types.get(y.ty) != &Type::IntLit
            && matches!(self.types.get(y.ty), Type::Enum { .. })
        {
            // keep
        }
        if matches!(self.types.get(x.ty), Type::Enum { .. })
            || matches!(self.types.get(y.ty), Type::Enum { .. })
        {
            // Re-resolve a bare enumeration value against the other side's type.
            if matches!(a.kind, A::Name(_)) && !matches!(self.types.get(x.ty), Type::Enum { .. }) {
                x = self.expr(a, cx, Some(y.ty));
            }
            if matches!(b.kind, A::Name(_)) && !matches!(self.types.get(y.ty), Type::Enum { .. }) {
                y = self.expr(b, cx, Some(x.ty));
            }
        }
        self.binary_checked(op, x, y, span)
    }

    /// Types an operator over checked operands.
    pub fn binary_checked(&mut self, op: BinaryOp, x: Expr, y: Expr, span: Span) -> Expr {
        if x.ty == ids::ERROR || y.ty == ids::ERROR {
            return err(span);
        }
        let (xe, ye) = (self.types.elem(x.ty), self.types.elem(y.ty));
        // Time arithmetic with mixed types.
        use BinaryOp::*;
        use Elem::*;
        let mixed = match (op, xe, ye) {
            (Add, Some(Tod), Some(Time | Ltime)) => Some(ids::TOD),
            (Add, Some(Dt), Some(Time | Ltime)) => Some(ids::DT),
            (Sub, Some(Tod), Some(Time | Ltime)) => Some(ids::TOD),
            (Sub, Some(Dt), Some(Time | Ltime)) => Some(ids::DT),
            (Sub, Some(Date), Some(Date)) => Some(ids::TIME),
            (Sub, Some(Tod), Some(Tod)) => Some(ids::TIME),
            (Sub, Some(Dt), Some(Dt)) => Some(ids::TIME),
            _ => None,
        };
        if let Some(ty) = mixed {
            return self.fold(Expr {
                kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
                ty,
                span,
            });
        }
        if matches!(op, Mul | Div) && xe.is_some_and(|e| e.is_duration()) {
            // TIME * ANY_NUM, TIME / ANY_NUM.
            let y = match self.types.get(y.ty) {
                Type::IntLit => self.coerce(y, ids::LINT, "the factor"),
                Type::RealLit => self.coerce(y, ids::LREAL, "the factor"),
                _ => y,
            };
            if !self.types.elem(y.ty).is_some_and(|e| e.is_num()) {
                self.op_error(op.text(), x.ty, Some(y.ty), span);
                return err(span);
            }
            let ty = x.ty;
            return self.fold(Expr {
                kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
                ty,
                span,
            });
        }
        if op == Power {
            let x = match self.types.get(x.ty) {
                Type::IntLit | Type::RealLit => self.coerce(x, ids::LREAL, "the base"),
                _ => x,
            };
            let y = match self.types.get(y.ty) {
                Type::IntLit => self.coerce(y, ids::DINT, "the exponent"),
                Type::RealLit => self.coerce(y, ids::LREAL, "the exponent"),
                _ => y,
            };
            let (xe, ye) = (self.types.elem(x.ty), self.types.elem(y.ty));
            if !xe.is_some_and(|e| e.is_real()) || !ye.is_some_and(|e| e.is_num()) {
                let an = self.types.name(x.ty);
                self.error(
                    diag::OPERAND_TYPE,
                    span,
                    format!("`**` (EXPT) raises REAL or LREAL to a number; this base is {an} (convert it, e.g. INT_TO_REAL(x) ** 2)"),
                );
                return err(span);
            }
            let ty = x.ty;
            return self.fold(Expr {
                kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
                ty,
                span,
            });
        }
        let Some((x, y, t)) = self.unify(x, y, op.text(), span) else {
            return err(span);
        };
        let tt = self.types.get(t).clone();
        let elem = self.types.elem(t);
        let ok = match op {
            Or | Xor | And => matches!(tt, Type::IntLit) || elem.is_some_and(|e| e.is_bit()),
            Eq | Ne => true,
            Lt | Le | Gt | Ge => !matches!(
                tt,
                Type::Enum { .. } | Type::Struct { .. } | Type::Array { .. } | Type::Fb(_)
            ),
            Add | Sub => {
                matches!(tt, Type::IntLit | Type::RealLit)
                    || elem.is_some_and(|e| e.is_num() || e.is_duration())
            }
            Mul | Div => {
                matches!(tt, Type::IntLit | Type::RealLit) || elem.is_some_and(|e| e.is_num())
            }
            Mod => matches!(tt, Type::IntLit) || elem.is_some_and(|e| e.is_int()),
            Power => true,
        };
        let ok = ok
            && !matches!(
                tt,
                Type::Struct { .. } | Type::Array { .. } | Type::Fb(_) | Type::Void
            );
        if !ok {
            let tn = self.types.name(t);
            let what = match op {
                Or | Xor | And => "BOOL and bit strings",
                Add | Sub => "numbers and durations",
                Mul | Div => "numbers",
                Mod => "integers",
                _ => "elementary values and strings",
            };
            self.error(
                diag::OPERAND_TYPE,
                span,
                format!("`{}` applies to {what}, not {tn}", op.text()),
            );
            return err(span);
        }
        let ty = if op.is_comparison() { ids::BOOL } else { t };
        self.fold(Expr {
            kind: ExprKind::Binary(op, Box::new(x), Box::new(y)),
            ty,
            span,
        })
    }

    /// Brings two operands to one type (literals take the other side's type, elementary
    /// types widen); `None` after reporting a mismatch.
    pub fn unify(
        &mut self,
        x: Expr,
        y: Expr,
        op: &str,
        span: Span,
    ) -> Option<(Expr, Expr, TypeId)> {
        let (tx, ty) = (self.base_type(x.ty), self.base_type(y.ty));
        let lit = |t: TypeId| t == ids::INT_LIT || t == ids::REAL_LIT;
        if tx == ty {
            return Some((x, y, tx));
        }
        if lit(tx) && lit(ty) {
            let x = self.coerce(x, ids::REAL_LIT, op);
            let y = self.coerce(y, ids::REAL_LIT, op);
            return Some((x, y, ids::REAL_LIT));
        }
        if lit(tx) {
            let x = self.coerce_quiet(x, ty)?;
            return Some((x, y, ty));
        }
        if lit(ty) {
            let y = self.coerce_quiet(y, tx)?;
            return Some((x, y, tx));
        }
        // Strings of any lengths compare and combine.
        if let (Type::Str { len: a }, Type::Str { len: b }) =
            (self.types.get(tx), self.types.get(ty))
        {
            let t = self.types.string((*a).max(*b));
            return Some((x, y, t));
        }
        match (self.types.elem(tx), self.types.elem(ty)) {
            (Some(a), Some(b)) if a.widens_to(b) => {
                let x = self.convert(x, ty);
                Some((x, y, ty))
            }
            (Some(a), Some(b)) if b.widens_to(a) => {
                let y = self.convert(y, tx);
                Some((x, y, tx))
            }
            _ => {
                self.op_error(op, x.ty, Some(y.ty), span);
                None
            }
        }
    }

    /// `coerce` that reports a literal out of range but not other mismatches.
    fn coerce_quiet(&mut self, x: Expr, to: TypeId) -> Option<Expr> {
        let span = x.span;
        let r = self.coerce(x, to, "this operand");
        (r.ty != ids::ERROR).then_some(r).or_else(|| {
            let _ = span;
            None
        })
    }

    fn convert(&self, x: Expr, to: TypeId) -> Expr {
        let span = x.span;
        if let ExprKind::Const(v) = &x.kind {
            if let Some(v) = self.convert_const(v, x.ty, to) {
                return konst(v, to, span);
            }
        }
        Expr {
            kind: ExprKind::Convert(Box::new(x)),
            ty: to,
            span,
        }
    }

    fn widen_to_lint(&mut self, x: Expr) -> Expr {
        if x.ty == ids::LINT {
            return x;
        }
        if x.ty == ids::INT_LIT {
            return self.coerce(x, ids::LINT, "the subscript");
        }
        self.convert(x, ids::LINT)
    }

    /// Converts an expression to `to` where the standard converts implicitly; otherwise
    /// reports a mismatch naming the conversion to write.
    pub fn coerce(&mut self, x: Expr, to: TypeId, what: &str) -> Expr {
        let span = x.span;
        if x.ty == ids::ERROR || to == ids::ERROR {
            return err(span);
        }
        if x.ty == to {
            return x;
        }
        let from_t = self.types.get(x.ty).clone();
        let to_t = self.types.get(to).clone();
        match (&from_t, &to_t) {
            (Type::IntLit, Type::IntLit) | (Type::RealLit, Type::RealLit) => return x,
            (Type::IntLit, Type::RealLit) => {
                let v = x.const_int().unwrap_or(0);
                return konst(Value::Real(v as f64), ids::REAL_LIT, span);
            }
            (Type::IntLit, _) => {
                let v = x.const_int().unwrap_or(0);
                let target = match &to_t {
                    Type::Elem(e) => Some((*e, None)),
                    Type::Subrange { base, lo, hi } => Some((*base, Some((*lo, *hi)))),
                    _ => None,
                };
                match target {
                    Some((e, sub)) if e.is_int() || e.is_bitstring() || e == Elem::Bool => {
                        let (lo, hi) = sub.unwrap_or(e.range());
                        if v < lo || v > hi {
                            self.error(
                                diag::OUT_OF_RANGE,
                                span,
                                format!(
                                    "{v} does not fit {} ({lo}..{hi}){}",
                                    self.types.name(to),
                                    if e == Elem::Bool {
                                        "; write TRUE or FALSE"
                                    } else {
                                        ""
                                    }
                                ),
                            );
                            return err(span);
                        }
                        return konst(Value::Int(v), to, span);
                    }
                    Some((e, _)) if e.is_real() => {
                        let f = v as f64;
                        let f = if e == Elem::Real {
                            value::to_real(f)
                        } else {
                            f
                        };
                        return konst(Value::Real(f), to, span);
                    }
                    _ => {}
                }
            }
            (Type::RealLit, Type::Elem(e)) if e.is_real() => {
                let f = x.const_real().unwrap_or(0.0);
                let f = if *e == Elem::Real {
                    value::to_real(f)
                } else {
                    f
                };
                if !f.is_finite() {
                    self.error(
                        diag::OUT_OF_RANGE,
                        span,
                        format!("this value does not fit {}", e.name()),
                    );
                    return err(span);
                }
                return konst(Value::Real(f), to, span);
            }
            (Type::Str { .. }, Type::Str { len }) => {
                if let ExprKind::Const(Value::Str(s)) = &x.kind {
                    if s.len() > *len as usize {
                        self.error(
                            diag::OUT_OF_RANGE,
                            span,
                            format!(
                                "this string has {} characters; {} holds {len}",
                                s.len(),
                                self.types.name(to)
                            ),
                        );
                        return err(span);
                    }
                    return konst(Value::Str(s.clone()), to, span);
                }
                return Expr {
                    kind: ExprKind::Convert(Box::new(x)),
                    ty: to,
                    span,
                };
            }
            (Type::Elem(a), Type::Elem(b)) if a.widens_to(*b) => return self.convert(x, to),
            (Type::Subrange { base, .. }, Type::Elem(b)) if base.widens_to(*b) => {
                return self.convert(x, to)
            }
            (Type::Elem(a), Type::Subrange { base, lo, hi })
            | (Type::Subrange { base: a, .. }, Type::Subrange { base, lo, hi })
                if a.widens_to(*base) =>
            {
                if let Some(v) = x.const_int() {
                    if v < *lo || v > *hi {
                        self.error(
                            diag::OUT_OF_RANGE,
                            span,
                            format!("{v} is outside {}", self.types.name(to)),
                        );
                        return err(span);
                    }
                    return konst(Value::Int(v), to, span);
                }
                // Checked when the program runs.
                return Expr {
                    kind: ExprKind::Convert(Box::new(x)),
                    ty: to,
                    span,
                };
            }
            _ => {}
        }
        let (a, b) = (self.types.name(x.ty), self.types.name(to));
        let hint = conversion_hint(&self.types, x.ty, to);
        self.error(
            diag::TYPE_MISMATCH,
            span,
            format!("{what} is {a} but {b} is needed{hint}"),
        );
        err(span)
    }

    // ---- calls in expressions ----

    fn call_expr(&mut self, call: &ast::Call, cx: &mut Cx, expected: Option<TypeId>) -> Expr {
        let span = call.span;
        let A::Name(name) = &call.callee.kind else {
            self.error(
                diag::NOT_CALLABLE,
                call.callee.span,
                "only functions can be called in an expression; a function block instance is called as a statement (inst(…);) and its outputs read as inst.Q",
            );
            return err(span);
        };
        if cx.const_only {
            // Conversions and a few functions of constants fold; anything else is not constant.
        }
        let key = name.key();
        if let Some(&p) = self.pou_names.get(&key) {
            let kind = self.pou_asts[p as usize].kind;
            if kind != crate::ir::PouKind::Function {
                self.error(
                    diag::NOT_CALLABLE,
                    name.span,
                    format!("{} is a {}; declare an instance (VAR x : {}; END_VAR) and call it as a statement", name.name, kind.keyword(), name.name),
                );
                return err(span);
            }
            return self.fn_call(p, call, cx);
        }
        if let Some(place) = self.var_place(name, cx) {
            let what = if matches!(self.types.get(place.ty), Type::Fb(_)) {
                "a function block instance is called as a statement (inst(…);), not in an expression; read its outputs as inst.Q"
            } else {
                "this is a variable, not a function"
            };
            self.error(
                diag::NOT_CALLABLE,
                name.span,
                format!("`{}`: {what}", name.name),
            );
            return err(span);
        }
        if let Some(x) = self.std_call(name, call, cx, expected) {
            return x;
        }
        let hint = if self.native_names.contains_key(&key) {
            format!("; {} is a function block: declare an instance (VAR t : {}; END_VAR) and call it as a statement", name.name, name.name)
        } else {
            "; declare it as a FUNCTION".into()
        };
        self.error(
            diag::UNKNOWN_POU,
            name.span,
            format!("unknown function `{}`{hint}", name.name),
        );
        err(span)
    }

    /// A call of a user FUNCTION.
    fn fn_call(&mut self, p: crate::ir::PouId, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        self.interface(p);
        if Some(p) == cx.pou {
            self.error(
                diag::RECURSION,
                span,
                format!(
                    "{} calls itself; IEC 61131-3 does not allow recursion",
                    self.pous[p as usize].name
                ),
            );
            return err(span);
        }
        if !self.pous[p as usize].runnable {
            let n = self.pous[p as usize].name.clone();
            self.error(
                diag::UNSUPPORTED,
                span,
                format!("{n} is not written in Structured Text or Instruction List and cannot be called yet"),
            );
            return err(span);
        }
        let pou = self.pous[p as usize].clone();
        let Some(bound) = self.bind_args(&pou.name, &pou.vars, call, cx, false) else {
            return err(span);
        };
        let mut inputs = Vec::new();
        for (i, v) in pou.vars.iter().enumerate() {
            if v.class == VarClass::Input {
                let given = bound.inputs.iter().find(|(k, _)| *k == i as VarId);
                let e = match given {
                    Some((_, e)) => e.clone(),
                    None => konst(
                        v.init.clone().unwrap_or_else(|| self.default_value(v.ty)),
                        v.ty,
                        span,
                    ),
                };
                inputs.push((i as VarId, e));
            }
        }
        let ty = pou.result.map_or(ids::VOID, |r| pou.vars[r as usize].ty);
        self.calls.push((cx.pou, p, span));
        Expr {
            kind: ExprKind::Call(FnCall {
                pou: p,
                inputs,
                in_outs: bound.in_outs,
                outputs: bound
                    .outputs
                    .into_iter()
                    .map(|(v, pl, _)| (v, pl))
                    .collect(),
            }),
            ty,
            span,
        }
    }

    /// Binds a call's arguments to parameters (`vars`): formal (by name) or positional (in
    /// declaration order), never mixed. `fb`: a function block call (inputs not given keep
    /// their values; in-outs must be given).
    pub fn bind_args(
        &mut self,
        callee: &str,
        vars: &[crate::ir::Var],
        call: &ast::Call,
        cx: &mut Cx,
        fb: bool,
    ) -> Option<Bound> {
        let mut out = Bound::default();
        let formal = call.args.iter().any(|a| a.name.is_some());
        let positional = call.args.iter().any(|a| a.name.is_none());
        if formal && positional {
            self.error(
                diag::BAD_ARGUMENTS,
                call.span,
                format!("the call of {callee} mixes named (x := …) and positional arguments; name them all"),
            );
            return None;
        }
        let params: Vec<(VarId, &crate::ir::Var)> = vars
            .iter()
            .enumerate()
            .filter(|(_, v)| {
                matches!(
                    v.class,
                    VarClass::Input | VarClass::InOut | VarClass::Output
                )
            })
            .map(|(i, v)| (i as VarId, v))
            .collect();
        let list = |ps: &[(VarId, &crate::ir::Var)]| {
            ps.iter()
                .map(|(_, v)| v.name.clone())
                .collect::<Vec<_>>()
                .join(", ")
        };
        let mut ok = true;
        let mut given: Vec<VarId> = Vec::new();
        for (k, a) in call.args.iter().enumerate() {
            let param = match &a.name {
                Some(n) => {
                    if n.is("EN") || n.is("ENO") {
                        self.error(
                            diag::UNSUPPORTED,
                            n.span,
                            "EN/ENO are not supported; call the function under an IF instead",
                        );
                        ok = false;
                        continue;
                    }
                    match params
                        .iter()
                        .find(|(_, v)| v.name.eq_ignore_ascii_case(&n.name))
                    {
                        Some(p) => *p,
                        None => {
                            self.error(
                                diag::BAD_ARGUMENTS,
                                n.span,
                                format!(
                                    "{callee} has no parameter `{}`; its parameters are {}",
                                    n.name,
                                    list(&params)
                                ),
                            );
                            ok = false;
                            continue;
                        }
                    }
                }
                None => match params.get(k) {
                    Some(p) => *p,
                    None => {
                        self.error(
                            diag::BAD_ARGUMENTS,
                            a.span,
                            format!(
                                "{callee} takes {} argument(s) ({}), this is argument {}",
                                params.len(),
                                list(&params),
                                k + 1
                            ),
                        );
                        ok = false;
                        continue;
                    }
                },
            };
            let (id, var) = param;
            if given.contains(&id) {
                self.error(
                    diag::BAD_ARGUMENTS,
                    a.span,
                    format!("parameter `{}` is given twice", var.name),
                );
                ok = false;
                continue;
            }
            given.push(id);
            match var.class {
                VarClass::Input => {
                    if a.output {
                        self.error(
                            diag::BAD_ARGUMENTS,
                            a.span,
                            format!("`{}` is an input of {callee}: give it with `:=`", var.name),
                        );
                        ok = false;
                        continue;
                    }
                    let Some(v) = &a.value else { continue };
                    let x = self.expr(v, cx, Some(var.ty));
                    let x = self.assign_coerce(x, var.ty, &format!("argument `{}`", var.name));
                    if x.ty == ids::ERROR {
                        ok = false;
                        continue;
                    }
                    out.inputs.push((id, x));
                }
                VarClass::InOut => {
                    if a.output {
                        self.error(
                            diag::BAD_ARGUMENTS,
                            a.span,
                            format!(
                                "`{}` is an in-out of {callee}: give a variable with `:=`",
                                var.name
                            ),
                        );
                        ok = false;
                        continue;
                    }
                    let Some(v) = &a.value else { continue };
                    let Some(pl) = self.place(v, cx, true) else {
                        ok = false;
                        continue;
                    };
                    if !self.writable(&pl, cx, v.span) {
                        ok = false;
                        continue;
                    }
                    if pl.ty != var.ty && pl.ty != ids::ERROR {
                        let (a1, b1) = (self.types.name(pl.ty), self.types.name(var.ty));
                        self.error(
                            diag::TYPE_MISMATCH,
                            v.span,
                            format!("in-out `{}` is {b1}; this variable is {a1} (an in-out is passed by reference, so the types must be the same)", var.name),
                        );
                        ok = false;
                        continue;
                    }
                    out.in_outs.push((id, pl));
                }
                VarClass::Output => {
                    if !a.output && a.name.is_some() {
                        self.error(
                            diag::BAD_ARGUMENTS,
                            a.span,
                            format!("`{}` is an output of {callee}: connect it with `=>` ({} => variable)", var.name, var.name),
                        );
                        ok = false;
                        continue;
                    }
                    let Some(v) = &a.value else { continue };
                    let Some(pl) = self.place(v, cx, true) else {
                        ok = false;
                        continue;
                    };
                    if !self.writable(&pl, cx, v.span) {
                        ok = false;
                        continue;
                    }
                    if a.negated && var.ty != ids::BOOL {
                        self.error(
                            diag::BAD_ARGUMENTS,
                            a.span,
                            "NOT … => applies to BOOL outputs",
                        );
                        ok = false;
                        continue;
                    }
                    let assignable = self.assignable(var.ty, pl.ty);
                    if !assignable {
                        let (a1, b1) = (self.types.name(var.ty), self.types.name(pl.ty));
                        self.error(
                            diag::TYPE_MISMATCH,
                            v.span,
                            format!("output `{}` is {a1} and cannot be stored in {b1}", var.name),
                        );
                        ok = false;
                        continue;
                    }
                    out.outputs.push((id, pl, a.negated));
                }
                _ => {}
            }
        }
        for (id, var) in &params {
            if var.class == VarClass::InOut && !given.contains(id) {
                self.error(
                    diag::BAD_ARGUMENTS,
                    call.span,
                    format!(
                        "in-out `{}` of {callee} must be given in every call ({} := variable)",
                        var.name, var.name
                    ),
                );
                ok = false;
            }
        }
        let _ = fb;
        ok.then_some(out)
    }

    /// Whether a value of type `from` may be stored in `to` (same type, widening, any
    /// string into any string).
    pub fn assignable(&self, from: TypeId, to: TypeId) -> bool {
        if from == to {
            return true;
        }
        match (self.types.get(from), self.types.get(to)) {
            (Type::Str { .. }, Type::Str { .. }) => true,
            (Type::Elem(a), Type::Elem(b)) => a.widens_to(*b),
            (Type::Subrange { base, .. }, Type::Elem(b)) => base.widens_to(*b),
            (Type::Elem(a), Type::Subrange { base, .. }) => a.widens_to(*base),
            (Type::Subrange { base: a, .. }, Type::Subrange { base, .. }) => a.widens_to(*base),
            _ => false,
        }
    }

    /// `coerce` for a value stored into a place of type `to` (literals typed, widening).
    pub fn assign_coerce(&mut self, x: Expr, to: TypeId, what: &str) -> Expr {
        self.coerce(x, to, what)
    }

    // ---- standard functions ----

    /// Binds a standard function's arguments to its parameter names; `extensible`: the
    /// last name repeats with increasing numbers.
    fn std_args<'e>(
        &mut self,
        fname: &str,
        call: &'e ast::Call,
        params: &[&str],
        min: usize,
        extensible: bool,
    ) -> Option<Vec<StdArg<'e>>> {
        let formal = call.args.iter().any(|a| a.name.is_some());
        let mut out: Vec<Option<StdArg<'e>>> = Vec::new();
        for (k, a) in call.args.iter().enumerate() {
            if a.output {
                self.error(
                    diag::BAD_ARGUMENTS,
                    a.span,
                    format!("{fname} has no outputs to connect"),
                );
                return None;
            }
            let idx = match &a.name {
                None if formal => {
                    self.error(
                        diag::BAD_ARGUMENTS,
                        call.span,
                        format!("the call of {fname} mixes named and positional arguments"),
                    );
                    return None;
                }
                None => k,
                Some(n) => {
                    let key = n.key();
                    match params.iter().position(|p| *p == key) {
                        Some(i) => i,
                        None if extensible => {
                            // IN1, IN2, … beyond the listed names.
                            let last = params.last().copied().unwrap_or("IN");
                            let stem = last.trim_end_matches(|c: char| c.is_ascii_digit());
                            let first_num: usize = last[stem.len()..].parse().unwrap_or(0);
                            match key.strip_prefix(stem).and_then(|d| d.parse::<usize>().ok()) {
                                Some(d) if d >= first_num => params.len() - 1 + (d - first_num),
                                _ => {
                                    self.error(
                                        diag::BAD_ARGUMENTS,
                                        n.span,
                                        format!("{fname} has no parameter `{}`; its parameters are {}, …", n.name, params.join(", ")),
                                    );
                                    return None;
                                }
                            }
                        }
                        None => {
                            self.error(
                                diag::BAD_ARGUMENTS,
                                n.span,
                                format!(
                                    "{fname} has no parameter `{}`; its parameters are {}",
                                    n.name,
                                    params.join(", ")
                                ),
                            );
                            return None;
                        }
                    }
                }
            };
            if !extensible && idx >= params.len() {
                self.error(
                    diag::BAD_ARGUMENTS,
                    a.span,
                    format!(
                        "{fname} takes {} argument(s) ({})",
                        params.len(),
                        params.join(", ")
                    ),
                );
                return None;
            }
            if out.len() <= idx {
                out.resize_with(idx + 1, || None);
            }
            if out[idx].is_some() {
                self.error(diag::BAD_ARGUMENTS, a.span, "this parameter is given twice");
                return None;
            }
            let Some(v) = a.value.as_ref() else {
                self.error(diag::BAD_ARGUMENTS, a.span, "give this parameter a value");
                return None;
            };
            out[idx] = Some(StdArg {
                expr: v,
                span: a.span,
            });
        }
        let n = out.len();
        if n < min || out.iter().any(|a| a.is_none()) {
            self.error(
                diag::BAD_ARGUMENTS,
                call.span,
                format!(
                    "{fname} takes {}{} argument(s) ({}{})",
                    if extensible { "at least " } else { "" },
                    min,
                    params.join(", "),
                    if extensible { ", …" } else { "" }
                ),
            );
            return None;
        }
        Some(out.into_iter().flatten().collect())
    }

    /// A standard function call, or `None` when `name` is not one.
    fn std_call(
        &mut self,
        name: &ast::Ident,
        call: &ast::Call,
        cx: &mut Cx,
        expected: Option<TypeId>,
    ) -> Option<Expr> {
        let key = name.key();
        let span = call.span;
        let f = key.as_str();
        use BinaryOp::*;
        // Operators as functions.
        let op = match f {
            "ADD" | "ADD_TIME" | "ADD_LTIME" | "ADD_TOD_TIME" | "ADD_DT_TIME" => Some((Add, true)),
            "MUL" | "MUL_TIME" | "MUL_LTIME" => Some((Mul, true)),
            "SUB" | "SUB_TIME" | "SUB_LTIME" | "SUB_TOD_TIME" | "SUB_DT_TIME" | "SUB_DATE_DATE"
            | "SUB_TOD_TOD" | "SUB_DT_DT" => Some((Sub, false)),
            "DIV" | "DIV_TIME" | "DIV_LTIME" => Some((Div, false)),
            "MOD" => Some((Mod, false)),
            "AND" => Some((And, true)),
            "OR" => Some((Or, true)),
            "XOR" => Some((Xor, true)),
            "EXPT" => Some((Power, false)),
            _ => None,
        };
        if let Some((op, ext)) = op {
            let args = self.std_args(f, call, &["IN1", "IN2"], 2, ext)?;
            let mut acc = self.expr(args[0].expr, cx, expected);
            for a in &args[1..] {
                let y = self.expr(a.expr, cx, expected);
                acc = self.binary_checked(op, acc, y, span);
            }
            acc.span = span;
            return Some(acc);
        }
        let cmp = match f {
            "GT" => Some(Gt),
            "GE" => Some(Ge),
            "EQ" => Some(Eq),
            "LE" => Some(Le),
            "LT" => Some(Lt),
            "NE" => Some(Ne),
            _ => None,
        };
        if let Some(op) = cmp {
            let ext = op != Ne;
            let args = self.std_args(f, call, &["IN1", "IN2"], 2, ext)?;
            let xs: Vec<Expr> = args.iter().map(|a| self.expr(a.expr, cx, None)).collect();
            let mut acc: Option<Expr> = None;
            for w in xs.windows(2) {
                let c = self.binary_checked(op, w[0].clone(), w[1].clone(), span);
                acc = Some(match acc {
                    None => c,
                    Some(a) => self.binary_checked(And, a, c, span),
                });
            }
            return acc;
        }
        match f {
            "NOT" => {
                let args = self.std_args(f, call, &["IN"], 1, false)?;
                return Some(self.unary(UnaryOp::Not, args[0].expr, cx, expected, span));
            }
            "MOVE" => {
                let args = self.std_args(f, call, &["IN"], 1, false)?;
                return Some(self.expr(args[0].expr, cx, expected));
            }
            _ => {}
        }
        if let Some((from, to, trunc)) = stdlib::conversion_of(f) {
            if f == "TRUNC" {
                // handled below
            } else {
                return Some(self.conversion(name, call, cx, from, &to, trunc));
            }
        }
        let b = match f {
            "ABS" => Builtin::Abs,
            "SQRT" => Builtin::Sqrt,
            "LN" => Builtin::Ln,
            "LOG" => Builtin::Log,
            "EXP" => Builtin::Exp,
            "SIN" => Builtin::Sin,
            "COS" => Builtin::Cos,
            "TAN" => Builtin::Tan,
            "ASIN" => Builtin::Asin,
            "ACOS" => Builtin::Acos,
            "ATAN" => Builtin::Atan,
            "ATAN2" => Builtin::Atan2,
            "SEL" => Builtin::Sel,
            "MAX" => Builtin::Max,
            "MIN" => Builtin::Min,
            "LIMIT" => Builtin::Limit,
            "MUX" => Builtin::Mux,
            "SHL" => Builtin::Shl,
            "SHR" => Builtin::Shr,
            "ROL" => Builtin::Rol,
            "ROR" => Builtin::Ror,
            "LEN" => Builtin::Len,
            "LEFT" => Builtin::Left,
            "RIGHT" => Builtin::Right,
            "MID" => Builtin::Mid,
            "CONCAT" => Builtin::Concat,
            "INSERT" => Builtin::Insert,
            "DELETE" => Builtin::Delete,
            "REPLACE" => Builtin::Replace,
            "FIND" => Builtin::Find,
            "CONCAT_DATE_TOD" => Builtin::ConcatDateTod,
            "TRUNC" => {
                let args = self.std_args(f, call, &["IN"], 1, false)?;
                let x = self.expr(args[0].expr, cx, None);
                let to = expected
                    .filter(|t| self.types.elem(*t).is_some_and(|e| e.is_int()))
                    .unwrap_or(ids::DINT);
                return Some(self.trunc(x, to, span));
            }
            _ => return None,
        };
        Some(self.builtin(b, f, call, cx, expected))
    }

    fn trunc(&mut self, x: Expr, to: TypeId, span: Span) -> Expr {
        if x.ty == ids::ERROR {
            return x;
        }
        let x = if x.ty == ids::REAL_LIT || x.ty == ids::INT_LIT {
            self.coerce(x, ids::LREAL, "TRUNC's input")
        } else {
            x
        };
        if !self.types.elem(x.ty).is_some_and(|e| e.is_real()) {
            let t = self.types.name(x.ty);
            self.error(
                diag::TYPE_MISMATCH,
                span,
                format!("TRUNC takes REAL or LREAL, not {t}"),
            );
            return err(span);
        }
        self.fold(Expr {
            kind: ExprKind::Trunc(Box::new(x)),
            ty: to,
            span,
        })
    }

    fn conversion(
        &mut self,
        name: &ast::Ident,
        call: &ast::Call,
        cx: &mut Cx,
        from: Option<String>,
        to: &str,
        trunc: bool,
    ) -> Expr {
        let span = call.span;
        let f = name.key();
        let Some(args) = self.std_args(&f, call, &["IN"], 1, false) else {
            return err(span);
        };
        let to_ty = match self.conv_type(to) {
            Some(t) => t,
            None => {
                self.error(
                    diag::UNKNOWN_POU,
                    name.span,
                    format!(
                        "unknown function `{}`: {to} is not an elementary type",
                        name.name
                    ),
                );
                return err(span);
            }
        };
        let from_ty = match &from {
            Some(fr) => match self.conv_type(fr) {
                Some(t) => Some(t),
                None => {
                    self.error(
                        diag::UNKNOWN_POU,
                        name.span,
                        format!(
                            "unknown function `{}`: {fr} is not an elementary type",
                            name.name
                        ),
                    );
                    return err(span);
                }
            },
            None => None,
        };
        let x = self.expr(args[0].expr, cx, from_ty);
        if x.ty == ids::ERROR {
            return x;
        }
        let x = match from_ty {
            Some(ft) => {
                // The argument must be of the named type (or widen to it).
                let from_elem = self.types.elem(ft);
                let ok_same = self.base_type(x.ty) == ft
                    || matches!(
                        (self.types.get(x.ty), self.types.get(ft)),
                        (Type::Str { .. }, Type::Str { .. })
                    );
                if ok_same
                    || matches!(self.types.get(x.ty), Type::IntLit | Type::RealLit)
                    || self.assignable(x.ty, ft)
                {
                    self.coerce(x, ft, &format!("the argument of {}", name.name))
                } else {
                    let (a, b) = (self.types.name(x.ty), self.types.name(ft));
                    let _ = from_elem;
                    self.error(
                        diag::TYPE_MISMATCH,
                        args[0].span,
                        format!("{} converts {b}, and this argument is {a}; use {a}_TO_{to} (or TO_{to})", name.name),
                    );
                    return err(span);
                }
            }
            None => match self.types.get(x.ty) {
                Type::IntLit => self.coerce(x, ids::LINT, "the argument"),
                Type::RealLit => self.coerce(x, ids::LREAL, "the argument"),
                _ => x,
            },
        };
        if x.ty == ids::ERROR {
            return x;
        }
        if trunc {
            return self.trunc(x, to_ty, span);
        }
        if !self.convertible(x.ty, to_ty) {
            let (a, b) = (self.types.name(x.ty), self.types.name(to_ty));
            self.error(
                diag::TYPE_MISMATCH,
                span,
                format!("{a} cannot be converted to {b}"),
            );
            return err(span);
        }
        let x = if let Type::Enum { .. } = self.types.get(x.ty) {
            x
        } else {
            x
        };
        self.fold(Expr {
            kind: ExprKind::Convert(Box::new(x)),
            ty: to_ty,
            span,
        })
    }

    fn conv_type(&mut self, name: &str) -> Option<TypeId> {
        if let Some(e) = Elem::from_name(name) {
            return Some(TypeTable::elem_id(e));
        }
        (name == "STRING").then_some(ids::STRING)
    }

    /// Whether the explicit conversion functions convert `from` to `to`.
    fn convertible(&self, from: TypeId, to: TypeId) -> bool {
        let s = |t: TypeId| matches!(self.types.get(t), Type::Str { .. });
        if s(from) && s(to) {
            return true;
        }
        let fe = self.types.elem(from).or(match self.types.get(from) {
            Type::Enum { .. } => Some(Elem::Dint),
            _ => None,
        });
        let te = self.types.elem(to);
        match (fe, te) {
            (Some(a), Some(b)) => {
                let date = |e: Elem| e.is_date();
                // Dates convert among themselves (DT → DATE, DT → TOD) and to/from integers.
                if date(a) && date(b) {
                    return a == b || a == Elem::Dt;
                }
                if (a.is_duration() || date(a)) && b.is_real()
                    || (b.is_duration() || date(b)) && a.is_real()
                {
                    return a.is_duration() || b.is_duration();
                }
                if a.is_duration() && date(b) || date(a) && b.is_duration() {
                    return false;
                }
                true
            }
            (Some(_), None) if s(to) => true,
            (None, Some(_)) if s(from) => true,
            _ => false,
        }
    }

    fn builtin(
        &mut self,
        b: Builtin,
        f: &str,
        call: &ast::Call,
        cx: &mut Cx,
        expected: Option<TypeId>,
    ) -> Expr {
        let span = call.span;
        use Builtin::*;
        let (params, min, ext): (&[&str], usize, bool) = match b {
            Abs | Sqrt | Ln | Log | Exp | Sin | Cos | Tan | Asin | Acos | Atan | Len => {
                (&["IN"], 1, false)
            }
            Atan2 => (&["Y", "X"], 2, false),
            Sel => (&["G", "IN0", "IN1"], 3, false),
            Max | Min => (&["IN1", "IN2"], 2, true),
            Limit => (&["MN", "IN", "MX"], 3, false),
            Mux => (&["K", "IN0"], 2, true),
            Shl | Shr | Rol | Ror => (&["IN", "N"], 2, false),
            Left | Right => (&["IN", "L"], 2, false),
            Mid => (&["IN", "L", "P"], 3, false),
            Concat => (&["IN1", "IN2"], 2, true),
            Insert => (&["IN1", "IN2", "P"], 3, false),
            Delete => (&["IN", "L", "P"], 3, false),
            Replace => (&["IN1", "IN2", "L", "P"], 4, false),
            Find => (&["IN1", "IN2"], 2, false),
            ConcatDateTod => (&["IN1", "IN2"], 2, false),
            DtToTod | DtToDate | Expt => (&["IN"], 1, false),
        };
        let Some(args) = self.std_args(f, call, params, min, ext) else {
            return err(span);
        };
        let mk = |args: Vec<Expr>, ty: TypeId| Expr {
            kind: ExprKind::Builtin(b, args),
            ty,
            span,
        };
        match b {
            Abs => {
                let x = self.expr(args[0].expr, cx, expected);
                if x.ty == ids::ERROR {
                    return x;
                }
                if !self.numeric_or_lit(x.ty) {
                    self.arg_error(f, "a number", x.ty, args[0].span);
                    return err(span);
                }
                let ty = self.base_type(x.ty);
                self.fold(mk(vec![x], ty))
            }
            Sqrt | Ln | Log | Exp | Sin | Cos | Tan | Asin | Acos | Atan => {
                let x = self.real_arg(f, &args[0], cx, expected);
                if x.ty == ids::ERROR {
                    return x;
                }
                let ty = x.ty;
                self.fold(mk(vec![x], ty))
            }
            Atan2 => {
                let y = self.real_arg(f, &args[0], cx, expected);
                let x = self.real_arg(f, &args[1], cx, expected);
                let Some((y, x, t)) = self.unify(y, x, f, span) else {
                    return err(span);
                };
                self.fold(mk(vec![y, x], t))
            }
            Sel => {
                let g = self.expr(args[0].expr, cx, Some(ids::BOOL));
                let g = self.coerce(g, ids::BOOL, "SEL's G");
                let a = self.expr(args[1].expr, cx, expected);
                let c = self.expr(args[2].expr, cx, expected);
                if g.ty == ids::ERROR {
                    return err(span);
                }
                let Some((a, c, t)) = self.unify(a, c, f, span) else {
                    return err(span);
                };
                let (a, c, t) = self.settle(a, c, t, expected);
                self.fold(mk(vec![g, a, c], t))
            }
            Max | Min | Limit => {
                let mut xs: Vec<Expr> = args
                    .iter()
                    .map(|a| self.expr(a.expr, cx, expected))
                    .collect();
                if xs.iter().any(|x| x.ty == ids::ERROR) {
                    return err(span);
                }
                let mut t = xs[0].ty;
                for x in &xs[1..] {
                    let acc = konst(Value::Int(0), t, span);
                    let Some((_, _, nt)) = self.unify_types(acc, x.clone(), f, span) else {
                        return err(span);
                    };
                    t = nt;
                }
                let t = self.settle_type(t, expected);
                for x in xs.iter_mut() {
                    *x = self.coerce(x.clone(), t, f);
                }
                if xs.iter().any(|x| x.ty == ids::ERROR) {
                    return err(span);
                }
                let tt = self.types.get(t).clone();
                if matches!(tt, Type::Struct { .. } | Type::Array { .. } | Type::Fb(_)) {
                    self.arg_error(f, "elementary values", t, span);
                    return err(span);
                }
                self.fold(mk(xs, t))
            }
            Mux => {
                let k = self.expr(args[0].expr, cx, Some(ids::DINT));
                if k.ty == ids::ERROR {
                    return err(span);
                }
                if !self.is_integral(k.ty) {
                    self.arg_error(f, "an integer selector K", k.ty, args[0].span);
                    return err(span);
                }
                let k = self.widen_to_lint(k);
                let mut xs: Vec<Expr> = args[1..]
                    .iter()
                    .map(|a| self.expr(a.expr, cx, expected))
                    .collect();
                if xs.iter().any(|x| x.ty == ids::ERROR) {
                    return err(span);
                }
                let mut t = xs[0].ty;
                for x in &xs[1..] {
                    let acc = konst(Value::Int(0), t, span);
                    let Some((_, _, nt)) = self.unify_types(acc, x.clone(), f, span) else {
                        return err(span);
                    };
                    t = nt;
                }
                let t = self.settle_type(t, expected);
                for x in xs.iter_mut() {
                    *x = self.coerce(x.clone(), t, f);
                }
                let mut all = vec![k];
                all.extend(xs);
                self.fold(mk(all, t))
            }
            Shl | Shr | Rol | Ror => {
                let hint =
                    expected.filter(|t| self.types.elem(*t).is_some_and(|e| e.is_bitstring()));
                let x = self.expr(args[0].expr, cx, hint);
                let x = match (self.types.get(x.ty), hint) {
                    (Type::IntLit, Some(h)) => self.coerce(x, h, f),
                    (Type::IntLit, None) => self.coerce(x, ids::DWORD, f),
                    _ => x,
                };
                let n = self.expr(args[1].expr, cx, Some(ids::DINT));
                if x.ty == ids::ERROR || n.ty == ids::ERROR {
                    return err(span);
                }
                if !self
                    .types
                    .elem(x.ty)
                    .is_some_and(|e| e.is_bitstring() || e.is_int())
                {
                    self.arg_error(
                        f,
                        "a bit string (BYTE, WORD, DWORD, LWORD)",
                        x.ty,
                        args[0].span,
                    );
                    return err(span);
                }
                if !self.is_integral(n.ty) {
                    self.arg_error(f, "an integer N", n.ty, args[1].span);
                    return err(span);
                }
                let n = self.widen_to_lint(n);
                let ty = self.base_type(x.ty);
                self.fold(mk(vec![x, n], ty))
            }
            Len => {
                let Some(s) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                self.fold(mk(vec![s], ids::INT))
            }
            Left | Right => {
                let Some(s) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let Some(l) = self.int_arg(f, &args[1], cx) else {
                    return err(span);
                };
                let ty = s.ty;
                self.fold(mk(vec![s, l], ty))
            }
            Mid => {
                let Some(s) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let (Some(l), Some(p)) =
                    (self.int_arg(f, &args[1], cx), self.int_arg(f, &args[2], cx))
                else {
                    return err(span);
                };
                let ty = s.ty;
                self.fold(mk(vec![s, l, p], ty))
            }
            Concat => {
                let mut xs = Vec::new();
                let mut len: u32 = 0;
                for a in &args {
                    let Some(s) = self.string_arg(f, a, cx) else {
                        return err(span);
                    };
                    len = len.saturating_add(self.str_len(s.ty));
                    xs.push(s);
                }
                let ty = self.types.string(len.clamp(1, MAX_STRING_LEN));
                self.fold(mk(xs, ty))
            }
            Insert | Replace => {
                let Some(a) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let Some(c) = self.string_arg(f, &args[1], cx) else {
                    return err(span);
                };
                let mut xs = vec![a.clone(), c.clone()];
                for arg in &args[2..] {
                    let Some(n) = self.int_arg(f, arg, cx) else {
                        return err(span);
                    };
                    xs.push(n);
                }
                let len = self.str_len(a.ty).saturating_add(self.str_len(c.ty));
                let ty = self.types.string(len.clamp(1, MAX_STRING_LEN));
                self.fold(mk(xs, ty))
            }
            Delete => {
                let Some(s) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let (Some(l), Some(p)) =
                    (self.int_arg(f, &args[1], cx), self.int_arg(f, &args[2], cx))
                else {
                    return err(span);
                };
                let ty = s.ty;
                self.fold(mk(vec![s, l, p], ty))
            }
            Find => {
                let Some(a) = self.string_arg(f, &args[0], cx) else {
                    return err(span);
                };
                let Some(c) = self.string_arg(f, &args[1], cx) else {
                    return err(span);
                };
                self.fold(mk(vec![a, c], ids::INT))
            }
            ConcatDateTod => {
                let d = self.expr(args[0].expr, cx, Some(ids::DATE));
                let t = self.expr(args[1].expr, cx, Some(ids::TOD));
                let d = self.coerce(d, ids::DATE, "CONCAT_DATE_TOD's first argument");
                let t = self.coerce(t, ids::TOD, "CONCAT_DATE_TOD's second argument");
                if d.ty == ids::ERROR || t.ty == ids::ERROR {
                    return err(span);
                }
                self.fold(mk(vec![d, t], ids::DT))
            }
            DtToTod | DtToDate | Expt => err(span),
        }
    }

    fn arg_error(&mut self, f: &str, want: &str, got: TypeId, span: Span) {
        let g = self.types.name(got);
        self.error(
            diag::TYPE_MISMATCH,
            span,
            format!("{f} takes {want}, not {g}"),
        );
    }

    fn real_arg(&mut self, f: &str, a: &StdArg<'_>, cx: &mut Cx, expected: Option<TypeId>) -> Expr {
        let real_hint = expected.filter(|t| self.types.elem(*t).is_some_and(|e| e.is_real()));
        let x = self.expr(a.expr, cx, real_hint);
        if x.ty == ids::ERROR {
            return x;
        }
        match self.types.get(x.ty) {
            Type::IntLit | Type::RealLit => self.coerce(x, real_hint.unwrap_or(ids::LREAL), f),
            _ if self.types.elem(x.ty).is_some_and(|e| e.is_real()) => x,
            _ => {
                let t = self.types.name(x.ty);
                self.error(
                    diag::TYPE_MISMATCH,
                    a.span,
                    format!("{f} takes REAL or LREAL, not {t}; convert it (e.g. {t}_TO_REAL(x))"),
                );
                err(a.span)
            }
        }
    }

    fn string_arg(&mut self, f: &str, a: &StdArg<'_>, cx: &mut Cx) -> Option<Expr> {
        let x = self.expr(a.expr, cx, Some(ids::STRING));
        if x.ty == ids::ERROR {
            return None;
        }
        if !self.types.is_string(x.ty) {
            self.arg_error(f, "a STRING", x.ty, a.span);
            return None;
        }
        Some(x)
    }

    fn int_arg(&mut self, f: &str, a: &StdArg<'_>, cx: &mut Cx) -> Option<Expr> {
        let x = self.expr(a.expr, cx, Some(ids::INT));
        if x.ty == ids::ERROR {
            return None;
        }
        if !self.is_integral(x.ty) {
            self.arg_error(f, "an integer", x.ty, a.span);
            return None;
        }
        Some(self.widen_to_lint(x))
    }

    pub fn str_len(&self, ty: TypeId) -> u32 {
        match self.types.get(ty) {
            Type::Str { len } => *len,
            _ => 0,
        }
    }

    /// Like `unify`, for finding a common type only.
    fn unify_types(
        &mut self,
        x: Expr,
        y: Expr,
        op: &str,
        span: Span,
    ) -> Option<(Expr, Expr, TypeId)> {
        self.unify(x, y, op, span)
    }

    /// A literal-typed generic result gets the expected type when it fits, else DINT/LREAL.
    pub(crate) fn settle_type(&self, t: TypeId, expected: Option<TypeId>) -> TypeId {
        match self.types.get(t) {
            Type::IntLit => expected
                .filter(|e| {
                    self.types
                        .elem(*e)
                        .is_some_and(|x| x.is_num() || x.is_bitstring())
                })
                .unwrap_or(ids::DINT),
            Type::RealLit => expected
                .filter(|e| self.types.elem(*e).is_some_and(|x| x.is_real()))
                .unwrap_or(ids::LREAL),
            _ => t,
        }
    }

    fn settle(
        &mut self,
        a: Expr,
        c: Expr,
        t: TypeId,
        expected: Option<TypeId>,
    ) -> (Expr, Expr, TypeId) {
        let t2 = self.settle_type(t, expected);
        if t2 == t {
            return (a, c, t);
        }
        let a = self.coerce(a, t2, "SEL's input");
        let c = self.coerce(c, t2, "SEL's input");
        (a, c, t2)
    }
}

/// `; write REAL_TO_INT(…)`-style advice for a mismatch between two types.
pub fn conversion_hint(types: &TypeTable, from: TypeId, to: TypeId) -> String {
    match (types.elem(from), types.elem(to)) {
        (Some(a), Some(b)) if a != b => {
            if a.is_real() && b.is_int() {
                format!(
                    "; convert explicitly: {}_TO_{}(…) rounds, TRUNC(…) truncates",
                    a.name(),
                    b.name()
                )
            } else {
                format!("; convert explicitly: {}_TO_{}(…)", a.name(), b.name())
            }
        }
        _ => match (types.get(from), types.elem(to)) {
            (Type::RealLit, Some(b)) if b.is_int() => {
                format!("; write an integer, or REAL_TO_{}(…)", b.name())
            }
            _ => String::new(),
        },
    }
}

impl Expr {
    pub fn const_int(&self) -> Option<i128> {
        match &self.kind {
            ExprKind::Const(Value::Int(v)) => Some(*v),
            _ => None,
        }
    }

    pub fn const_real(&self) -> Option<f64> {
        match &self.kind {
            ExprKind::Const(v) => v.as_real(),
            _ => None,
        }
    }
}

/// A call's arguments bound to parameter indices.
#[derive(Default)]
pub struct Bound {
    pub inputs: Vec<(VarId, Expr)>,
    pub in_outs: Vec<(VarId, Place)>,
    pub outputs: Vec<(VarId, Place, bool)>,
}
