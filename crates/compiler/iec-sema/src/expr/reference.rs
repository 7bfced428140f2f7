//! References and pointers: `NULL`, `REF(x)` and CODESYS's `ADR(x)`, `r^`, and the rule that a
//! reference only designates a variable that outlives it (docs/iec.md, "References and
//! pointers").

use petriplc_iec_syntax::ast::{self, BinaryOp, ExprKind as A, RefKind};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{Builtin, Expr, ExprKind, Place, PouKind, Root, Step, VarClass};
use crate::types::{ids, Type, TypeId};
use crate::value::Value;

use super::{err, konst};

impl<'a> Checker<'a> {
    /// The one positional argument of `call` (`ADR(x)`, `SIZEOF(x)`, `__ISVALIDREF(r)`);
    /// `None`, with `usage` reported, when there is not exactly one.
    pub(super) fn sole_argument<'c>(
        &mut self,
        call: &'c ast::Call,
        usage: impl Into<String>,
    ) -> Option<&'c ast::Expr> {
        let arg = match call.args.as_slice() {
            [a] if a.name.is_none() && !a.output => a.value.as_ref(),
            _ => None,
        };
        if arg.is_none() {
            self.error(diag::BAD_ARGUMENTS, call.span, usage);
        }
        arg
    }
    /// `NULL` (a name no declaration takes).
    pub(super) fn null(&mut self, span: Span) -> Expr {
        let t = self.types.null();
        konst(Value::Int(0), t, span)
    }

    /// `base^`: the variable the reference held by `base` designates.
    pub(super) fn deref_place(
        &mut self,
        e: &ast::Expr,
        base: &ast::Expr,
        cx: &mut Cx,
    ) -> Option<Place> {
        // The reference itself is only read, whether its target is read or written.
        let mut p = match computed(base) {
            true => self.computed_reference(base, cx)?,
            false => self.reference_place(base, cx, false)?,
        };
        if let Some(i) = self.itf_of_type(p.ty) {
            let n = self.pou_asts[i as usize].name.name.clone();
            self.error(
                diag::ITF_MISUSE,
                e.span,
                format!("an interface ({n}) is not dereferenced with `^`; call its methods and use its properties directly (x.M())"),
            );
            return None;
        }
        if let Type::Ref {
            kind: RefKind::ReferenceTo,
            ..
        } = self.types.get(p.ty)
        {
            let pointer = self.types.ref_target(p.ty).filter(|&t| {
                matches!(
                    self.types.get(t),
                    Type::Ref {
                        kind: RefKind::PointerTo | RefKind::RefTo,
                        ..
                    }
                )
            });
            match pointer {
                // A REFERENCE TO a pointer (`pNode : REFERENCE TO POINTER TO T`): the
                // reference is dereferenced where it is used, as always, and `^` follows the
                // pointer it designates.
                Some(t) => {
                    p.path.push(Step::Deref);
                    p.ty = t;
                }
                // IronPLC's reading; CODESYS refuses `^` on a reference, which is
                // dereferenced where it is used.
                None => self.diags.warning(
                    diag::REFERENCE_CARET,
                    e.span,
                    format!(
                        "this is a {}, dereferenced where it is used: the `^` is redundant (CODESYS refuses it); drop it",
                        self.types.name(p.ty)
                    ),
                ),
            }
        }
        let Some(target) = self.types.ref_target(p.ty) else {
            if p.ty != ids::ERROR {
                let t = self.types.name(p.ty);
                self.error(
                    diag::NOT_A_REFERENCE,
                    e.span,
                    format!("`^` dereferences a REF_TO or POINTER TO; this is {t}"),
                );
            }
            return None;
        };
        p.path.push(Step::Deref);
        p.ty = target;
        p.span = e.span;
        Some(p)
    }

    /// The reference an expression computes (`f()`, `obj.Get()`, `p + 2`), as the root of a
    /// place (`Root::Value`) that a dereference follows; `None` (reported) when the value is
    /// no reference.
    pub(crate) fn computed_reference(&mut self, e: &ast::Expr, cx: &mut Cx) -> Option<Place> {
        let x = match &e.kind {
            A::Call(call) => self.call_expr(call, cx, None),
            _ => self.expr(e, cx, None),
        };
        if x.ty == ids::ERROR {
            return None;
        }
        if !matches!(self.types.get(x.ty), Type::Ref { .. }) {
            let t = self.types.name(x.ty);
            self.error(
                diag::NOT_A_REFERENCE,
                e.span,
                format!("`^` dereferences a REF_TO or POINTER TO; this is {t}"),
            );
            return None;
        }
        Some(Place {
            root: Root::Value,
            ty: x.ty,
            span: e.span,
            path: vec![Step::Value(Box::new(x))],
        })
    }

    /// CODESYS's `r REF= x`: the REFERENCE TO `r` bound to the variable `x` (of the type it
    /// designates), under ADR's rules: a FUNCTION's variables and a VAR_TEMP only while the
    /// reference stays in the POU (check/escape.rs). `r REF= other` binds `r` to what the
    /// reference `other` designates; `r REF= NULL`, `r REF= 0` unbind it.
    pub(crate) fn ref_assign(
        &mut self,
        target: &ast::Expr,
        value: &ast::Expr,
        cx: &mut Cx,
    ) -> Option<(Place, Expr)> {
        let p = self.reference_place(target, cx, true)?;
        if matches!(p.root, Root::Value) && p.path.len() == 1 {
            self.error(
                diag::REF_ASSIGN,
                target.span,
                "`REF=` binds a REFERENCE TO variable; a call's result is bound inside the call (`Name REF= x;`)",
            );
            return None;
        }
        let Type::Ref {
            kind: RefKind::ReferenceTo,
            ..
        } = *self.types.get(p.ty)
        else {
            if p.ty != ids::ERROR {
                let t = self.types.name(p.ty);
                self.error(
                    diag::REF_ASSIGN,
                    target.span,
                    format!("`REF=` binds a REFERENCE TO; this is {t}: assign it with `:=`"),
                );
            }
            return None;
        };
        if !self.writable(&p, cx, target.span) {
            return None;
        }
        let x = self.ref_binding(value, p.ty, "`REF=`", cx)?;
        Some((p, x))
    }

    /// What binds a REFERENCE TO of type `rty` to `value` (`REF=`, an input of that type):
    /// the reference to the variable `value` names (NULL or 0: unbound).
    pub(crate) fn ref_binding(
        &mut self,
        value: &ast::Expr,
        rty: TypeId,
        what: &str,
        cx: &mut Cx,
    ) -> Option<Expr> {
        let designated = self.types.ref_target(rty)?;
        let unbind = matches!(&value.kind, A::Name(n) if n.is("NULL") && self.var_place(n, cx).is_none())
            || matches!(
                &value.kind,
                A::Literal(ast::Literal::Int { value: 0, ty: None })
            );
        if unbind {
            return Some(konst(Value::Int(0), rty, value.span));
        }
        if let A::Call(call) = &value.kind {
            // A call giving a REFERENCE TO of the same type (TcUnit's `r REF= suite.AddTest(…)`)
            // passes its reference on, bound or not.
            let x = self.call_expr(call, cx, None);
            if x.ty == ids::ERROR {
                return None;
            }
            if self.types.ref_target(x.ty) == Some(designated)
                && matches!(
                    self.types.get(x.ty),
                    Type::Ref {
                        kind: RefKind::ReferenceTo,
                        ..
                    }
                )
            {
                return Some(Expr { ty: rty, ..x });
            }
            let (want, got) = (self.types.name(designated), self.types.name(x.ty));
            self.error(
                diag::REF_ASSIGN,
                value.span,
                format!("{what} binds a REFERENCE TO {want} to a variable of that type, or to a call giving a REFERENCE TO {want}; this call gives {got}"),
            );
            return None;
        }
        if !matches!(
            value.kind,
            A::Name(_) | A::Field(..) | A::Index(..) | A::Deref(_) | A::Bit(..) | A::Paren(_)
        ) {
            self.error(
                diag::REF_ASSIGN,
                value.span,
                format!("{what} binds a REFERENCE TO to a variable, not to an expression's value; name a variable (or NULL to unbind)"),
            );
            return None;
        }
        let x = self.place(value, cx, false)?;
        if x.ty == ids::ERROR {
            return None;
        }
        if x.ty != designated {
            let (want, got) = (self.types.name(designated), self.types.name(x.ty));
            self.error(
                diag::REF_ASSIGN,
                value.span,
                format!(
                    "{what} binds a REFERENCE TO {want} to a variable of that type; this is {got}"
                ),
            );
            return None;
        }
        if let Some(why) = self.no_lasting_address(&x, cx, true) {
            self.error(
                diag::NO_ADDRESS,
                value.span,
                format!("{what}: {why}; docs/iec.md, \"References and pointers\""),
            );
            return None;
        }
        Some(Expr {
            kind: ExprKind::Ref(x),
            ty: rty,
            span: value.span,
        })
    }

    /// CODESYS's `__ISVALIDREF(r)`: whether the REFERENCE TO `r` is bound (a POINTER TO or
    /// REF_TO is compared with NULL or 0 instead; they are taken too).
    pub(super) fn is_valid_ref(&mut self, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let Some(arg) =
            self.sole_argument(call, "__ISVALIDREF takes one reference: __ISVALIDREF(r)")
        else {
            return err(span);
        };
        let Some(p) = self.reference_place(arg, cx, false) else {
            return err(span);
        };
        if !matches!(self.types.get(p.ty), Type::Ref { .. }) {
            if p.ty != ids::ERROR {
                let t = self.types.name(p.ty);
                self.error(
                    diag::NOT_A_REFERENCE,
                    arg.span,
                    format!("__ISVALIDREF tests a REFERENCE TO; this is {t}"),
                );
            }
            return err(span);
        }
        let ty = p.ty;
        let r = Expr {
            kind: ExprKind::Load(p),
            ty,
            span: arg.span,
        };
        Expr {
            kind: ExprKind::Binary(
                BinaryOp::Ne,
                Box::new(r),
                Box::new(konst(Value::Int(0), ty, span)),
            ),
            ty: ids::BOOL,
            span,
        }
    }

    /// `REF(x)` (IEC 61131-3) or `ADR(x)` (CODESYS): a reference to a variable, typed
    /// `REF_TO T` or `POINTER TO T` by the variable's type.
    pub(super) fn ref_of(&mut self, name: &ast::Ident, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let fname = name.name.to_ascii_uppercase();
        let Some(arg) = self.sole_argument(call, format!("{fname} takes one variable: {fname}(x)"))
        else {
            return err(span);
        };
        if !matches!(
            arg.kind,
            A::Name(_) | A::Field(..) | A::Index(..) | A::Deref(_) | A::Bit(..) | A::Part(..)
        ) {
            self.error(
                diag::NO_ADDRESS,
                arg.span,
                format!("{fname} takes a variable, not an expression: its value has no address"),
            );
            return err(span);
        }
        // ADR of a union's member is the union's address (every member starts at its byte
        // 0), as CODESYS gives it: TcUnit copies into members with MEMCPY(ADR(u.m), …).
        let place = if fname == "ADR" {
            self.place_inner(arg, cx, false)
                .filter(|p| self.union_address_ok(p))
        } else {
            self.place(arg, cx, false)
        };
        let Some(place) = place else {
            return err(span);
        };
        if self.types.is_var_array(place.ty) {
            return self.var_array_whole(arg.span);
        }
        if let Some(why) = self.no_lasting_address(&place, cx, fname == "ADR") {
            self.error(
                diag::NO_ADDRESS,
                arg.span,
                format!("{fname}: {why}; docs/iec.md, \"References and pointers\""),
            );
            return err(span);
        }
        let kind = if fname == "REF" {
            RefKind::RefTo
        } else {
            RefKind::PointerTo
        };
        let ty = self.types.reference(kind, place.ty);
        Expr {
            kind: ExprKind::Ref(place),
            ty,
            span,
        }
    }

    /// Why a place cannot be referenced (`None`: it can): a reference must never outlive
    /// what it designates, nor let a constant be written. `adr`: CODESYS's ADR, which may
    /// take a FUNCTION's variables and a VAR_TEMP (then kept in the POU: check/escape.rs).
    fn no_lasting_address(&self, p: &Place, cx: &Cx, adr: bool) -> Option<String> {
        if p.path
            .iter()
            .any(|s| matches!(s, Step::Bit(_) | Step::Bits(..)))
        {
            return Some("a single bit has no address; reference the whole variable".into());
        }
        // Behind a dereference the place is inside a variable already referenced.
        let behind_ref = p.path.iter().any(|s| matches!(s, Step::Deref));
        let var = self.var_of(p, cx);
        if behind_ref {
            return None;
        }
        if var.constant {
            return Some(format!(
                "`{}` is a CONSTANT: a reference would let it be written",
                var.name
            ));
        }
        if let Root::Var(_) = p.root {
            match var.class {
                VarClass::Temp if adr => {}
                VarClass::Temp => {
                    return Some(format!(
                        "`{}` is a VAR_TEMP, gone when the POU returns (CODESYS's ADR may take it, kept in the POU)",
                        var.name
                    ))
                }
                // The caller's variable outlives the call: CODESYS's ADR may take it, and
                // the pointer is kept in the POU as a frame's is (check/escape.rs).
                VarClass::InOut if adr => {}
                VarClass::InOut => {
                    return Some(format!(
                        "`{}` is a VAR_IN_OUT, which may be a caller's temporary; reference the caller's variable",
                        var.name
                    ))
                }
                _ => {}
            }
            if !adr
                && cx.kind == Some(PouKind::Function)
                && !matches!(var.class, VarClass::External(_))
            {
                return Some(format!(
                    "`{}` is a variable of a FUNCTION, gone when it returns (CODESYS's ADR may take it, kept in the POU)",
                    var.name
                ));
            }
        }
        None
    }

    /// Whether a type holds a reference anywhere (a RETAIN variable must not: E202).
    pub fn contains_reference(&self, ty: TypeId) -> bool {
        self.types.holds_reference(ty)
    }

    /// Two operands of which one is a reference: the type they compare as (`Err`: they do
    /// not compare), `None` when neither is a reference.
    pub(super) fn unify_refs(&self, x: &Expr, y: &Expr) -> Option<Result<TypeId, ()>> {
        let (a, b) = (self.types.get(x.ty), self.types.get(y.ty));
        if let (Some(i), Some(j)) = (self.itf_of_type(x.ty), self.itf_of_type(y.ty)) {
            // Two interfaces compare when one extends the other (the same instance is the
            // same handle whichever interface holds it).
            return Some(if self.interfaces_of(j).contains(&i) {
                Ok(x.ty)
            } else if self.interfaces_of(i).contains(&j) {
                Ok(y.ty)
            } else {
                Err(())
            });
        }
        match (a, b) {
            (Type::Null, Type::Ref { .. }) => Some(Ok(y.ty)),
            (Type::Ref { .. }, Type::Null) => Some(Ok(x.ty)),
            (Type::Ref { target: s, kind: k }, Type::Ref { target: t, kind: l }) => Some(
                if s == t || (*k == RefKind::PointerTo && *l == RefKind::PointerTo) {
                    Ok(x.ty)
                } else {
                    Err(())
                },
            ),
            (Type::Ref { .. } | Type::Null, _) | (_, Type::Ref { .. } | Type::Null) => {
                Some(Err(()))
            }
            _ => None,
        }
    }

    /// Whether `x op y` moves a CODESYS POINTER TO (`p + n`, `n + p`, `p - n`).
    pub(super) fn is_pointer_arith(&self, op: BinaryOp, x: &Expr, y: &Expr) -> bool {
        let is_ptr = |t: &Type| {
            matches!(
                t,
                Type::Ref {
                    kind: RefKind::PointerTo,
                    ..
                }
            )
        };
        let (px, py) = (is_ptr(self.types.get(x.ty)), is_ptr(self.types.get(y.ty)));
        match op {
            BinaryOp::Add => px != py,
            BinaryOp::Sub => px && !py,
            _ => false,
        }
    }

    /// `p + n`, `n + p`, `p - n` (see `is_pointer_arith`): the pointer moved by `n` bytes,
    /// checked where it is dereferenced.
    pub(super) fn pointer_arith(&mut self, op: BinaryOp, x: Expr, y: Expr, span: Span) -> Expr {
        let (p, n) = if matches!(
            self.types.get(x.ty),
            Type::Ref {
                kind: RefKind::PointerTo,
                ..
            }
        ) {
            (x, y)
        } else {
            (y, x)
        };
        let Some(n) = self.byte_count(n, span) else {
            return err(span);
        };
        if n.ty == ids::ERROR {
            return err(span);
        }
        let ty = p.ty;
        Expr {
            kind: ExprKind::Binary(op, Box::new(p), Box::new(n)),
            ty,
            span,
        }
    }

    /// CODESYS's pointer indexing `p[i]`: the `i`-th `T` after the one the POINTER TO T `p`
    /// points at, `(p + i * SIZEOF(T))^`, checked where it is dereferenced as any moved
    /// pointer is.
    pub(super) fn pointer_index(
        &mut self,
        e: &ast::Expr,
        p: Place,
        target: TypeId,
        idx: &[ast::Expr],
        cx: &mut Cx,
    ) -> Option<Place> {
        let [i] = idx else {
            self.error(
                diag::BAD_INDEX,
                e.span,
                "a pointer takes one subscript: p[i] is the i-th element after the one p points at",
            );
            return None;
        };
        let size = crate::memory::size_align(&self.types, target).map(|(n, _)| n);
        let Some(size) = size.filter(|n| *n > 0) else {
            let t = self.types.name(target);
            self.error(
                diag::BAD_INDEX,
                e.span,
                format!("{t} has no size of its own to step by; index an array, or move the pointer by bytes (p + n)"),
            );
            return None;
        };
        let x = self.expr(i, cx, Some(ids::DINT));
        if x.ty == ids::ERROR {
            return None;
        }
        if !self.is_integral(x.ty) {
            let t = self.types.name(x.ty);
            self.error(
                diag::BAD_INDEX,
                i.span,
                format!("a subscript is an integer; this is {t}"),
            );
            return None;
        }
        let span = e.span;
        let x = self.convert(x, ids::LINT);
        let n = Expr {
            kind: ExprKind::Binary(
                BinaryOp::Mul,
                Box::new(x),
                Box::new(konst(Value::Int(size as i128), ids::LINT, span)),
            ),
            ty: ids::LINT,
            span,
        };
        let ptr = Expr {
            ty: p.ty,
            kind: ExprKind::Load(p),
            span,
        };
        let moved = self.pointer_arith(BinaryOp::Add, ptr, n, span);
        if moved.ty == ids::ERROR {
            return None;
        }
        Some(Place {
            root: Root::Value,
            ty: target,
            span,
            path: vec![Step::Value(Box::new(moved)), Step::Deref],
        })
    }

    /// `SIZEOF(x)` (CODESYS): the bytes of a variable's or a type's image, a constant.
    pub(super) fn size_of(&mut self, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let Some(arg) = self.sole_argument(call, "SIZEOF takes one variable or type: SIZEOF(x)")
        else {
            return err(span);
        };
        let ty = match &arg.kind {
            A::Name(id) if self.var_place(id, cx).is_none() && !id.is("NULL") => {
                let (t, _) = self.type_by_name(id);
                t
            }
            // A union's member has a size like any variable.
            _ => match self.place_inner(arg, cx, false) {
                Some(p) => p.ty,
                None => return err(span),
            },
        };
        if ty == ids::ERROR {
            return err(span);
        }
        if self.types.is_var_array(ty) {
            // Its size is the caller's array's, which SIZEOF (a constant) cannot give.
            return self.var_array_whole(arg.span);
        }
        let size = crate::memory::size_align(&self.types, ty)
            .map(|(n, _)| n)
            .or_else(|| self.instance_size(ty, 0));
        match size {
            Some(n) => konst(Value::Int(i128::from(n)), ids::INT_LIT, span),
            None => {
                let t = self.types.name(ty);
                self.error(
                    diag::BAD_ARGUMENTS,
                    arg.span,
                    format!("SIZEOF: {t} has no byte image (a function block instance)"),
                );
                err(span)
            }
        }
    }

    /// CODESYS's and TwinCAT's SIZEOF of a function block instance: petriplc's own measure,
    /// its variables (not VAR_TEMP) laid out as a structure's fields, an in-out as a pointer;
    /// the vendors add hidden fields of their own, so their numbers are larger.
    fn instance_size(&mut self, ty: TypeId, depth: u32) -> Option<u64> {
        let Type::Fb(crate::types::FbRef::User(q)) = *self.types.get(ty) else {
            return None;
        };
        if !self.dialect.is_codesys_family() || depth > 32 {
            return None;
        }
        self.interface(q);
        let vars: Vec<(crate::types::TypeId, VarClass)> = self.pous[q as usize]
            .vars
            .iter()
            .map(|v| (v.ty, v.class))
            .collect();
        let (mut off, mut align) = (0u64, 1u64);
        for (t, class) in vars {
            let (s, a) = match class {
                VarClass::Temp | VarClass::External(_) | VarClass::Global => continue,
                VarClass::InOut => (8, 8),
                _ => match crate::memory::size_align(&self.types, t) {
                    Some(x) => x,
                    None => (self.instance_size(t, depth + 1)?, 8),
                },
            };
            off = off.div_ceil(a) * a + s;
            align = align.max(a);
        }
        Some(off.div_ceil(align) * align)
    }

    /// `MEMCPY(dest, src, n)`, `MEMSET(dest, fill, n)`, `MEMCMP(a, b, n)` (TwinCAT
    /// Tc2_System, CODESYS MemoryUtils): bytes through pointers, checked when they run.
    pub(super) fn mem_call(&mut self, name: &ast::Ident, call: &ast::Call, cx: &mut Cx) -> Expr {
        let span = call.span;
        let f = name.name.to_ascii_uppercase();
        let (b, second, rt) = match f.as_str() {
            "MEMCPY" => (Builtin::MemCpy, "a source pointer", ids::UDINT),
            "MEMSET" => (Builtin::MemSet, "the fill BYTE", ids::UDINT),
            _ => (Builtin::MemCmp, "a second pointer", ids::DINT),
        };
        let args: Vec<&ast::Expr> = call
            .args
            .iter()
            .filter(|a| !a.output)
            .filter_map(|a| a.value.as_ref())
            .collect();
        if args.len() != 3 || call.args.iter().any(|a| a.output) {
            self.error(
                diag::BAD_ARGUMENTS,
                span,
                format!(
                    "{f} takes a pointer, {second} and a byte count: {f}(ADR(x), …, SIZEOF(x))"
                ),
            );
            return err(span);
        }
        let mut out = Vec::new();
        for (k, a) in args.iter().enumerate() {
            let x = self.expr(a, cx, None);
            if x.ty == ids::ERROR {
                return err(span);
            }
            let x = if k == 1 && b == Builtin::MemSet {
                self.coerce(x, ids::BYTE, "the fill value")
            } else if k == 2 {
                match self.byte_count(x, span) {
                    Some(x) => x,
                    None => return err(span),
                }
            } else if matches!(self.types.get(x.ty), Type::Ref { .. }) {
                x
            } else {
                let t = self.types.name(x.ty);
                self.error(
                    diag::BAD_ARGUMENTS,
                    a.span,
                    format!("{f}: argument {} is a pointer (ADR(x)), not {t}", k + 1),
                );
                return err(span);
            };
            if x.ty == ids::ERROR {
                return err(span);
            }
            out.push(x);
        }
        Expr {
            kind: ExprKind::Builtin(b, out),
            ty: rt,
            span,
        }
    }

    /// An integer count of bytes as LINT (`None` once reported).
    fn byte_count(&mut self, n: Expr, span: Span) -> Option<Expr> {
        if n.ty == ids::INT_LIT {
            let x = self.coerce(n, ids::LINT, "the byte count");
            return (x.ty != ids::ERROR).then_some(x);
        }
        if self
            .types
            .elem(n.ty)
            .is_some_and(|e| e.is_int() || e.is_bitstring())
        {
            if n.ty == ids::LINT {
                return Some(n);
            }
            let s = n.span;
            return Some(Expr {
                kind: ExprKind::Convert(Box::new(n)),
                ty: ids::LINT,
                span: s,
            });
        }
        if n.ty != ids::ERROR {
            let t = self.types.name(n.ty);
            self.error(
                diag::OPERAND_TYPE,
                span,
                format!("a pointer moves by a whole number of bytes, not {t}"),
            );
        }
        None
    }
}

/// Whether `e` computes a value rather than naming a variable: a call, arithmetic (`p + 2`),
/// either in parentheses.
pub(crate) fn computed(e: &ast::Expr) -> bool {
    match &e.kind {
        A::Call(_) | A::Binary(..) | A::Unary(..) => true,
        A::Paren(inner) => computed(inner),
        _ => false,
    }
}
