//! Calls in expressions: user functions and their arguments bound to parameters.

use petriplc_iec_syntax::ast::{self, ExprKind as A};
use petriplc_iec_syntax::diag;

use crate::check::{Checker, Cx};
use crate::ir::{Expr, ExprKind, FnCall, Place, VarClass, VarId};
use crate::types::{ids, RefKind, Type, TypeId};
use crate::value::Value;

use super::{err, konst, Bound};

impl<'a> Checker<'a> {
    pub(super) fn call_expr(
        &mut self,
        call: &ast::Call,
        cx: &mut Cx,
        expected: Option<TypeId>,
    ) -> Expr {
        let span = call.span;
        if let Some(x) = self.member_call(call, cx) {
            return x;
        }
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
        // A call given EN inside an expression runs before the statement (`en_eno`).
        if let Some(x) = self.en_nested(call, cx, expected) {
            return x;
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
            if name.is("STRING_TO_PVOID")
                && petriplc_iec_syntax::builtin::is_builtin(
                    self.pou_asts[p as usize].name.span.file,
                )
            {
                self.diags.warning(
                    diag::NO_POINTER_FROM_TEXT,
                    name.span,
                    "STRING_TO_PVOID gives NULL here: petriplc's pointers are checked handles that no text can make; keep the pointer itself",
                );
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
        if name.is("REF") || name.is("ADR") {
            return self.ref_of(name, call, cx);
        }
        if name.is("__NEW") {
            return self.heap_new(call, cx);
        }
        if name.is("__DELETE") {
            self.error(
                diag::BAD_ARGUMENTS,
                call.span,
                "__DELETE gives no value: call it as a statement, `__DELETE(p);`",
            );
            return err(call.span);
        }
        if name.is("__MEMORYAREA") {
            return self.memory_area(call, cx);
        }
        if name.is("__FORMAT") {
            return self
                .vendor_format(name, call, cx, None, "STRING")
                .unwrap_or_else(|| {
                    self.error(
                        diag::BAD_ARGUMENTS,
                        call.span,
                        "__FORMAT takes a value and a C printf format: __FORMAT(x, '%5.2f')",
                    );
                    err(call.span)
                });
        }
        if name.is("__QUERYINTERFACE") {
            return self.query_interface(call, cx);
        }
        // XSIZEOF: SIZEOF's name in CODESYS 3.5.16 and TwinCAT 3.1.4026.
        if name.is("__ISVALIDREF") {
            return self.is_valid_ref(call, cx);
        }
        if name.is("SIZEOF") || name.is("XSIZEOF") {
            return self.size_of(call, cx);
        }
        if name.is("LOWER_BOUND") || name.is("UPPER_BOUND") {
            return self.array_bound(name, call, cx);
        }
        if name.is("MEMCPY") || name.is("MEMSET") || name.is("MEMCMP") {
            return self.mem_call(name, call, cx);
        }
        if let Some(x) = self.std_call(name, call, cx, expected) {
            return x;
        }
        if let Some(x) = self.vendor_call(name, call, cx) {
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
        self.fn_call_with(p, call, cx, None)
    }

    /// A call of a FUNCTION, or of a method, property accessor or action with the instance
    /// it works on (`this`, passed to its last variable, THIS: `oop.rs`).
    pub(crate) fn fn_call_with(
        &mut self,
        p: crate::ir::PouId,
        call: &ast::Call,
        cx: &mut Cx,
        this: Option<crate::ir::Place>,
    ) -> Expr {
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
        // A member's interface ends with THIS (none after an error in it: reported).
        let Some(params) = pou.vars.len().checked_sub(usize::from(this.is_some())) else {
            return err(span);
        };
        let Some(mut bound) = self.bind_args(&pou.name, &pou.vars[..params], call, cx, false)
        else {
            return err(span);
        };
        // THIS of an interface's member is an input: the handle, checked where the call is.
        let mut itf_this = None;
        if let Some(t) = this {
            if pou.vars[params].class == VarClass::Input {
                itf_this = Some(self.itf_this(t, span));
            } else {
                bound.in_outs.push((params as VarId, t));
            }
        }
        let mut inputs = Vec::new();
        for (i, v) in pou.vars[..params].iter().enumerate() {
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
        inputs.extend(itf_this.map(|x| (params as VarId, x)));
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
    /// declaration order), mixed only in the CODESYS family (TcUnit's `File.Write(BufferPointer
    /// := ADR(Buffer), Xml.Length)`), where argument number k without a name is parameter
    /// number k. `fb`: a function block call (inputs not given keep their values; in-outs must
    /// be given).
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
        if formal && positional && !self.dialect.is_codesys_family() {
            self.error(
                diag::BAD_ARGUMENTS,
                call.span,
                format!("the call of {callee} mixes named (x := …) and positional arguments; name them all (CODESYS and TwinCAT take argument k without a name as parameter k: --dialect codesys or twincat)"),
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
                ) && !is_any_part(v)
            })
            .map(|(i, v)| (i as VarId, v))
            .collect();
        let mut ok = true;
        let mut given: Vec<VarId> = Vec::new();
        for (k, a) in call.args.iter().enumerate() {
            let Some(param) = self.arg_param(callee, &params, k, a) else {
                ok = false;
                continue;
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
            let bound = match var.class {
                VarClass::Input => self.bind_input(callee, param, a, cx, &mut out),
                VarClass::InOut => self.bind_in_out(callee, param, a, cx, &mut out),
                VarClass::Output => self.bind_output(callee, param, a, cx, &mut out),
                _ => true,
            };
            ok &= bound;
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

    /// The argument `v` of an ANY input (`id` its `x.pValue`, then `x.diSize` and
    /// `x.TypeClass`): its address, as ADR takes it, its size, as SIZEOF gives it, and the
    /// class of its type. CODESYS also takes a value there (kept in a temporary); petriplc
    /// wants a variable.
    fn bind_any(
        &mut self,
        id: VarId,
        var: &crate::ir::Var,
        v: &ast::Expr,
        cx: &mut Cx,
        out: &mut Bound,
    ) -> bool {
        let span = v.span;
        // An ANY input of the caller passed on whole: its three parts, as TwinCAT does.
        if let A::Name(n) = &v.kind {
            let fields = self.any_fields(span);
            let parts: Vec<Option<VarId>> = fields
                .iter()
                .map(|(f, _)| {
                    cx.names
                        .get(&format!("{}.{}", n.key(), f.to_ascii_uppercase()))
                        .copied()
                })
                .collect();
            if let [Some(a), Some(b), Some(c)] = parts[..] {
                for (k, part) in [a, b, c].into_iter().enumerate() {
                    let ty = cx.vars[part as usize].ty;
                    let load = Expr {
                        kind: ExprKind::Load(Place {
                            root: crate::ir::Root::Var(part),
                            path: Vec::new(),
                            ty,
                            span,
                        }),
                        ty,
                        span,
                    };
                    let value = self.coerce(load, fields[k].1, "an ANY argument passed on");
                    out.inputs.push((id + k as VarId, value));
                }
                return true;
            }
        }
        if !matches!(
            v.kind,
            A::Name(_) | A::Field(..) | A::Index(..) | A::Deref(_) | A::Part(..)
        ) {
            self.error(
                diag::BAD_ARGUMENTS,
                span,
                format!("`{}` is an ANY input: give it a variable (petriplc passes its address; CODESYS also takes a value, which it stores in a temporary)", param_name(var)),
            );
            return false;
        }
        let call = ast::Call {
            callee: Box::new(ast::Expr {
                kind: A::Name(ast::Ident::new("ADR", span)),
                span,
            }),
            args: vec![ast::Arg {
                name: None,
                output: false,
                negated: false,
                value: Some(v.clone()),
                span,
            }],
            span,
        };
        let adr = self.ref_of(&ast::Ident::new("ADR", span), &call, cx);
        let Some(target) = self.types.ref_target(adr.ty) else {
            return false;
        };
        let size = self.size_of(&call, cx);
        let size = self.coerce(size, ids::DINT, "the size of an ANY argument");
        let class_ty = self.any_class_ty(span);
        let class = konst(Value::Int(self.type_class(target)), class_ty, span);
        let adr = self.coerce(adr, var.ty, "the address of an ANY argument");
        out.inputs.push((id, adr));
        out.inputs.push((id + 1, size));
        out.inputs.push((id + 2, class));
        true
    }

    /// CODESYS's `__SYSTEM.TYPE_CLASS` of a type (the numbers of twincat.st's TYPE_CLASS).
    fn type_class(&self, ty: TypeId) -> i128 {
        use crate::types::Elem::*;
        match self.types.get(ty) {
            Type::Elem(e) => match e {
                Bool => 0,
                Byte => 2,
                Word => 3,
                Dword => 4,
                Lword => 5,
                Sint => 6,
                Int => 7,
                Dint => 8,
                Lint => 9,
                Usint => 10,
                Uint => 11,
                Udint => 12,
                Ulint => 13,
                Real => 14,
                Lreal => 15,
                Time => 18,
                Date => 19,
                Dt => 20,
                Tod => 21,
                Ltime => 37,
                _ => 28,
            },
            Type::Str { wide: false, .. } => 16,
            Type::Str { wide: true, .. } => 17,
            Type::Ref {
                kind: RefKind::ReferenceTo,
                ..
            } => 23,
            Type::Ref { .. } => 22,
            Type::Subrange { .. } => 24,
            Type::Enum { .. } => 25,
            Type::Array { .. } | Type::VarArray { .. } => 26,
            _ => 28,
        }
    }

    /// Whether a value of type `from` may be stored in `to` (same type, widening, any
    /// string into any string).
    pub fn assignable(&self, from: TypeId, to: TypeId) -> bool {
        if from == to {
            return true;
        }
        match (self.types.get(from), self.types.get(to)) {
            (Type::Str { wide: a, .. }, Type::Str { wide: b, .. }) => a == b,
            (Type::Elem(a), Type::Elem(b)) => a.widens_to(*b),
            (Type::Subrange { base, .. }, Type::Elem(b)) => base.widens_to(*b),
            (Type::Elem(a), Type::Subrange { base, .. }) => a.widens_to(*base),
            (Type::Subrange { base: a, .. }, Type::Subrange { base, .. }) => a.widens_to(*base),
            (Type::Null, Type::Ref { .. }) => true,
            (Type::Ref { target: a, kind: k }, Type::Ref { target: b, kind: l }) => {
                a == b || (*k == RefKind::PointerTo && *l == RefKind::PointerTo)
            }
            _ => false,
        }
    }

    /// `coerce` for a value stored into a place of type `to` (literals typed, widening).
    pub fn assign_coerce(&mut self, x: Expr, to: TypeId, what: &str) -> Expr {
        self.coerce(x, to, what)
    }

    /// The parameter argument number `k`, `a`, binds to (by name or by position); `None`
    /// once told why there is none.
    fn arg_param<'v>(
        &mut self,
        callee: &str,
        params: &[(VarId, &'v crate::ir::Var)],
        k: usize,
        a: &ast::Arg,
    ) -> Option<(VarId, &'v crate::ir::Var)> {
        Some(match &a.name {
            Some(n) => {
                match params
                    .iter()
                    .find(|(_, v)| param_name(v).eq_ignore_ascii_case(&n.name))
                {
                    Some(p) => *p,
                    None if n.is("EN") || n.is("ENO") => {
                        // A statement's call is guarded by `en_eno`; here the call is
                        // part of a larger expression.
                        self.error(
                            diag::UNSUPPORTED,
                            n.span,
                            format!("{callee} has no EN/ENO of its own, and a call given EN or ENO inside a larger expression is not supported yet; make it a statement of its own (y := {callee}(EN := …, ENO => ok);), or in LD/FBD connect the result to a variable"),
                        );
                        return None;
                    }
                    None => {
                        self.error(
                            diag::BAD_ARGUMENTS,
                            n.span,
                            format!(
                                "{callee} has no parameter `{}`; its parameters are {}",
                                n.name,
                                param_list(params)
                            ),
                        );
                        return None;
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
                            param_list(params),
                            k + 1
                        ),
                    );
                    return None;
                }
            },
        })
    }

    /// An input: its value checked and converted to the parameter's type.
    /// False once an error is told.
    fn bind_input(
        &mut self,
        callee: &str,
        (id, var): (VarId, &crate::ir::Var),
        a: &ast::Arg,
        cx: &mut Cx,
        out: &mut Bound,
    ) -> bool {
        if a.output {
            self.error(
                diag::BAD_ARGUMENTS,
                a.span,
                format!("`{}` is an input of {callee}: give it with `:=`", var.name),
            );
            return false;
        }
        let Some(v) = &a.value else { return true };
        if var.name.ends_with(".pValue") {
            return self.bind_any(id, var, v, cx, out);
        }
        if let Type::Ref {
            kind: RefKind::ReferenceTo,
            ..
        } = self.types.get(var.ty)
        {
            // CODESYS binds a REFERENCE TO input to the variable given, as `REF=` does.
            let what = format!("argument `{}`", var.name);
            let Some(x) = self.ref_binding(v, var.ty, &what, cx) else {
                return false;
            };
            out.inputs.push((id, x));
            return true;
        }
        let x = self.expr(v, cx, Some(var.ty));
        let x = self.assign_coerce(x, var.ty, &format!("argument `{}`", var.name));
        if x.ty == ids::ERROR {
            return false;
        }
        out.inputs.push((id, x));
        true
    }

    /// An in-out: a writable variable of the parameter's exact type.
    /// False once an error is told.
    fn bind_in_out(
        &mut self,
        callee: &str,
        (id, var): (VarId, &crate::ir::Var),
        a: &ast::Arg,
        cx: &mut Cx,
        out: &mut Bound,
    ) -> bool {
        if a.output {
            self.error(
                diag::BAD_ARGUMENTS,
                a.span,
                format!(
                    "`{}` is an in-out of {callee}: give a variable with `:=`",
                    var.name
                ),
            );
            return false;
        }
        let Some(v) = &a.value else { return true };
        let Some(pl) = self.bound_place(var.ty, v, cx) else {
            return false;
        };
        if !self.writable(&pl, cx, v.span) {
            return false;
        }
        // An ARRAY[*] takes any array of its element type and dimensions.
        let fits = self.types.is_var_array(var.ty)
            && self.types.array_shape(pl.ty) == self.types.array_shape(var.ty);
        if pl.ty != var.ty && pl.ty != ids::ERROR && !fits {
            let (a1, b1) = (self.types.name(pl.ty), self.types.name(var.ty));
            self.error(
                diag::TYPE_MISMATCH,
                v.span,
                format!("in-out `{}` is {b1}; this variable is {a1} (an in-out is passed by reference, so the types must be the same)", var.name),
            );
            return false;
        }
        out.in_outs.push((id, pl));
        true
    }

    /// The caller's variable an in-out or output of type `ty` is bound to. An in-out
    /// REFERENCE TO is the caller's reference itself (the callee may rebind it).
    fn bound_place(&mut self, ty: TypeId, v: &ast::Expr, cx: &mut Cx) -> Option<Place> {
        let is_ref = matches!(
            self.types.get(ty),
            Type::Ref {
                kind: RefKind::ReferenceTo,
                ..
            }
        );
        if is_ref {
            self.reference_place(v, cx, true)
        } else {
            self.place(v, cx, true)
        }
    }

    /// An output connected with `=>`: a writable variable it can be stored in.
    /// False once an error is told.
    fn bind_output(
        &mut self,
        callee: &str,
        (id, var): (VarId, &crate::ir::Var),
        a: &ast::Arg,
        cx: &mut Cx,
        out: &mut Bound,
    ) -> bool {
        if !a.output && a.name.is_some() {
            self.error(
                diag::BAD_ARGUMENTS,
                a.span,
                format!(
                    "`{}` is an output of {callee}: connect it with `=>` ({} => variable)",
                    var.name, var.name
                ),
            );
            return false;
        }
        let Some(v) = &a.value else { return true };
        let Some(pl) = self.bound_place(var.ty, v, cx) else {
            return false;
        };
        if !self.writable(&pl, cx, v.span) {
            return false;
        }
        if a.negated && var.ty != ids::BOOL {
            self.error(
                diag::BAD_ARGUMENTS,
                a.span,
                "NOT … => applies to BOOL outputs",
            );
            return false;
        }
        let assignable = self.assignable(var.ty, pl.ty);
        if !assignable {
            let (a1, b1) = (self.types.name(var.ty), self.types.name(pl.ty));
            self.error(
                diag::TYPE_MISMATCH,
                v.span,
                format!("output `{}` is {a1} and cannot be stored in {b1}", var.name),
            );
            return false;
        }
        out.outputs.push((id, pl, a.negated));
        true
    }
}

/// The names of `ps`, for messages.
fn param_list(ps: &[(VarId, &crate::ir::Var)]) -> String {
    ps.iter()
        .map(|(_, v)| param_name(v).to_string())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The second and third of an ANY input's three variables (`x.diSize`, `x.TypeClass`), which
/// a call gives with the first (`x.pValue`).
fn is_any_part(v: &crate::ir::Var) -> bool {
    v.class == VarClass::Input && (v.name.ends_with(".diSize") || v.name.ends_with(".TypeClass"))
}

/// A parameter's name as a call gives it: an ANY input's by its own name.
fn param_name(v: &crate::ir::Var) -> &str {
    match v.class {
        VarClass::Input => v.name.strip_suffix(".pValue").unwrap_or(&v.name),
        _ => &v.name,
    }
}
