//! Statements: assignments, calls of function block instances, IF, CASE (labels folded and
//! checked for reachability), FOR, WHILE, REPEAT, EXIT, CONTINUE, RETURN; and the
//! configuration: tasks and program instances with their connections.

use petriplc_iec_syntax::ast::{self, StmtKind as S};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{self, CaseArm, FbCall, Place, PouKind, Root, Stmt, StmtKind, VarClass, VarId};
use crate::types::{ids, FbRef, Type, TypeTable};
use crate::value::Value;

impl Checker<'_> {
    pub fn stmts(&mut self, stmts: &[ast::Stmt], cx: &mut Cx) -> Vec<Stmt> {
        let mut out = Vec::with_capacity(stmts.len());
        for s in stmts {
            if let Some(s) = self.stmt(s, cx) {
                out.push(s);
            }
        }
        out
    }

    fn stmt(&mut self, s: &ast::Stmt, cx: &mut Cx) -> Option<Stmt> {
        if matches!(s.kind, S::Assign { .. } | S::Call(_)) {
            return self.with_pre(cx, |ck, cx| ck.stmt_here(s, cx));
        }
        self.stmt_here(s, cx)
    }

    pub(crate) fn stmt_here(&mut self, s: &ast::Stmt, cx: &mut Cx) -> Option<Stmt> {
        let span = s.span;
        let kind = match &s.kind {
            S::Empty => return None,
            S::Assign { target, value } => {
                if let Some(set) = self.property_write(target, value, cx) {
                    return set.map(|x| Stmt {
                        kind: StmtKind::Eval(x),
                        span,
                    });
                }
                if let Some(call) = crate::en_eno::called(value) {
                    if let Some(r) = self.en_stmt(Some(target), call, span, cx) {
                        return r;
                    }
                }
                let p = self.value_place(target, cx, true);
                let p = p?;
                let x = self.expr(value, cx, Some(p.ty));
                if !self.writable(&p, cx, target.span) {
                    return None;
                }
                if x.ty == ids::ERROR || p.ty == ids::ERROR {
                    return None;
                }
                if matches!(self.types.get(x.ty), Type::Void)
                    && self.dialect.is_codesys_family()
                    && matches!(x.kind, ir::ExprKind::Call(_))
                {
                    self.diags.warning(
                        diag::VOID_ASSIGNED,
                        value.span,
                        "this FUNCTION has no result: the call runs and the variable keeps what its outputs set (CODESYS and TwinCAT accept it); call the function as a statement",
                    );
                    return Some(Stmt {
                        kind: StmtKind::Eval(x),
                        span,
                    });
                }
                if matches!(self.types.get(x.ty), Type::Void) {
                    self.error(
                        diag::TYPE_MISMATCH,
                        value.span,
                        "this call gives no value to assign",
                    );
                    return None;
                }
                let x = self.assign_value(x, p.ty, &p, target);
                if x.ty == ids::ERROR {
                    return None;
                }
                StmtKind::Assign {
                    target: p,
                    value: x,
                }
            }
            S::RefAssign { target, value } => {
                let (target, value) = self.ref_assign(target, value, cx)?;
                StmtKind::Assign { target, value }
            }
            S::Call(call) => return self.call_stmt(call, cx),
            S::If {
                branches,
                else_body,
            } => {
                let mut out = Vec::new();
                for (c, body) in branches {
                    let c = self.cond(c, cx);
                    let body = self.stmts(body, cx);
                    out.push((c, body));
                }
                let else_body = else_body
                    .as_ref()
                    .map(|b| self.stmts(b, cx))
                    .unwrap_or_default();
                StmtKind::If {
                    branches: out,
                    else_body,
                }
            }
            S::Case {
                selector,
                arms,
                else_body,
            } => self.case(selector, arms, else_body.as_deref(), cx)?,
            S::For {
                var,
                from,
                to,
                by,
                body,
            } => self.for_loop(var, from, to, by.as_ref(), body, cx, span)?,
            S::While { cond, body } => {
                let cond = self.cond(cond, cx);
                cx.loops += 1;
                let body = self.stmts(body, cx);
                cx.loops -= 1;
                StmtKind::While { cond, body }
            }
            S::Repeat { body, until } => {
                cx.loops += 1;
                let body = self.stmts(body, cx);
                cx.loops -= 1;
                let until = self.cond(until, cx);
                StmtKind::Repeat { body, until }
            }
            S::Exit | S::Continue => {
                if cx.loops == 0 {
                    let w = if matches!(s.kind, S::Exit) {
                        "EXIT"
                    } else {
                        "CONTINUE"
                    };
                    self.error(
                        diag::MISPLACED,
                        span,
                        format!("{w} is only allowed inside FOR, WHILE or REPEAT"),
                    );
                    return None;
                }
                if matches!(s.kind, S::Exit) {
                    StmtKind::Exit
                } else {
                    StmtKind::Continue
                }
            }
            S::Return => StmtKind::Return,
        };
        Some(Stmt { kind, span })
    }

    /// The value stored by an assignment, converted to the target's type.
    pub(crate) fn assign_value(
        &mut self,
        x: ir::Expr,
        to: crate::types::TypeId,
        p: &Place,
        target: &ast::Expr,
    ) -> ir::Expr {
        let _ = p;
        let what = match &target.kind {
            ast::ExprKind::Name(n) => format!("the value assigned to `{}`", n.name),
            _ => "the value assigned".to_string(),
        };
        // Aggregates must have the same type (strings of any lengths: truncated).
        match (self.types.get(x.ty).clone(), self.types.get(to).clone()) {
            (Type::Array { .. }, _)
            | (Type::Struct { .. }, _)
            | (_, Type::Array { .. })
            | (_, Type::Struct { .. }) => {
                if x.ty != to {
                    let (a, b) = (self.types.name(x.ty), self.types.name(to));
                    self.error(
                        diag::TYPE_MISMATCH,
                        x.span,
                        format!("{what} is {a} but the target is {b}; aggregates are assigned only between variables of the same type"),
                    );
                    return ir::Expr {
                        ty: ids::ERROR,
                        ..x
                    };
                }
                x
            }
            _ => self.coerce(x, to, &what),
        }
    }

    fn case(
        &mut self,
        selector: &ast::Expr,
        arms: &[ast::CaseArm],
        else_body: Option<&[ast::Stmt]>,
        cx: &mut Cx,
    ) -> Option<StmtKind> {
        let sel = self.expr(selector, cx, None);
        let sel = match self.types.get(sel.ty) {
            Type::IntLit => self.coerce(sel, ids::DINT, "the CASE selector"),
            _ => sel,
        };
        let sel_ty = sel.ty;
        let valid = sel_ty == ids::ERROR
            || matches!(self.types.get(sel_ty), Type::Enum { .. })
            || self.is_integral(sel_ty) && sel_ty != ids::BOOL;
        if !valid {
            let t = self.types.name(sel_ty);
            self.error(
                diag::CASE_LABEL,
                selector.span,
                format!("a CASE selector is an integer, a bit string or an enumeration, not {t}; use IF … ELSIF for other types"),
            );
        }
        let (lo_t, hi_t) = match self.types.get(sel_ty) {
            Type::Elem(e) => e.range(),
            Type::Subrange { lo, hi, .. } => (*lo, *hi),
            Type::Enum { values, .. } => {
                let lo = values.iter().map(|v| v.1).min().unwrap_or(0) as i128;
                let hi = values.iter().map(|v| v.1).max().unwrap_or(0) as i128;
                (lo, hi)
            }
            _ => (i128::MIN, i128::MAX),
        };
        let mut seen: Vec<(i128, i128, Span)> = Vec::new();
        let mut out = Vec::new();
        for arm in arms {
            let mut ranges = Vec::new();
            for label in &arm.labels {
                let (a, b) = match label {
                    ast::CaseLabel::Value(e) => (e, e),
                    ast::CaseLabel::Range(a, b) => (a, b),
                };
                let lo = self.case_value(a, sel_ty, cx);
                let hi = if std::ptr::eq(a, b) {
                    lo
                } else {
                    self.case_value(b, sel_ty, cx)
                };
                let (Some(lo), Some(hi)) = (lo, hi) else {
                    continue;
                };
                let span = label.span();
                if lo > hi {
                    self.error(
                        diag::UNREACHABLE_CASE,
                        span,
                        format!("the range {lo}..{hi} is empty: write the lower bound first ({hi}..{lo})"),
                    );
                    continue;
                }
                if sel_ty != ids::ERROR && (hi < lo_t || lo > hi_t) {
                    let t = self.types.name(sel_ty);
                    self.error(
                        diag::UNREACHABLE_CASE,
                        span,
                        format!("this label can never match: a {t} selector is {lo_t}..{hi_t}"),
                    );
                    continue;
                }
                if let Some((_, _, first)) =
                    seen.iter().find(|(l, h, _)| lo <= *h && hi >= *l).copied()
                {
                    // Covered entirely by earlier labels: unreachable; partly: overlapping.
                    let covered = self.covered(&seen, lo, hi);
                    let line = first.start;
                    let _ = line;
                    self.error(
                        diag::UNREACHABLE_CASE,
                        span,
                        if covered {
                            "this label is unreachable: an earlier label of this CASE already selects its value(s); remove it".to_string()
                        } else {
                            "this label overlaps an earlier one: each value may select one branch only; split the range".to_string()
                        },
                    );
                    continue;
                }
                seen.push((lo, hi, span));
                ranges.push((lo, hi));
            }
            let body = self.stmts(&arm.body, cx);
            out.push(CaseArm { ranges, body });
        }
        let else_body = else_body.map(|b| self.stmts(b, cx)).unwrap_or_default();
        Some(StmtKind::Case {
            selector: sel,
            arms: out,
            else_body,
        })
    }

    fn covered(&self, seen: &[(i128, i128, Span)], lo: i128, hi: i128) -> bool {
        let mut ranges: Vec<(i128, i128)> = seen.iter().map(|(l, h, _)| (*l, *h)).collect();
        ranges.sort();
        let mut next = lo;
        for (l, h) in ranges {
            if l > next {
                break;
            }
            if h >= next {
                if h >= hi {
                    return true;
                }
                next = h + 1;
            }
        }
        false
    }

    fn case_value(
        &mut self,
        e: &ast::Expr,
        sel_ty: crate::types::TypeId,
        cx: &mut Cx,
    ) -> Option<i128> {
        let was = cx.const_only;
        cx.const_only = true;
        let x = self.expr(e, cx, Some(sel_ty));
        cx.const_only = was;
        if x.ty == ids::ERROR || sel_ty == ids::ERROR {
            return None;
        }
        let x = if matches!(self.types.get(x.ty), Type::IntLit) {
            // Out-of-range literals are reported as unreachable, not as mismatches.
            match x.const_int() {
                Some(v) => return Some(v),
                None => x,
            }
        } else {
            x
        };
        // CODESYS and TwinCAT: an enumeration's value labels an integer selector by its
        // number (TcUnit's `CASE UDINT_TO_INT(AnyTypeClass) OF TypeClass.TYPE_BOOL :`).
        let enum_label = self.dialect.is_codesys_family()
            && matches!(self.types.get(x.ty), Type::Enum { .. })
            && self
                .types
                .elem(sel_ty)
                .is_some_and(|e| e.is_int() || e.is_bitstring());
        if enum_label {
            if let (Some(Value::Int(v)), Some(el)) = (self.eval_const(&x), self.types.elem(sel_ty))
            {
                // Converted as the selector was (TYPE_INTERFACE, 16#F000, is -4096 as INT).
                return Some(crate::types::wrap(v, el));
            }
        }
        if x.ty != sel_ty && !self.assignable(x.ty, sel_ty) {
            let (a, b) = (self.types.name(x.ty), self.types.name(sel_ty));
            self.error(
                diag::CASE_LABEL,
                e.span,
                format!("a CASE label of a {b} selector must be {b}; this one is {a}"),
            );
            return None;
        }
        match self.eval_const(&x) {
            Some(Value::Int(v)) => Some(v),
            _ => {
                self.error(
                    diag::CASE_LABEL,
                    e.span,
                    "a CASE label must be a constant (a literal, an enumeration value or a CONSTANT)",
                );
                None
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn for_loop(
        &mut self,
        var: &ast::Expr,
        from: &ast::Expr,
        to: &ast::Expr,
        by: Option<&ast::Expr>,
        body: &[ast::Stmt],
        cx: &mut Cx,
        span: Span,
    ) -> Option<StmtKind> {
        let p = self.place(var, cx, true)?;
        if !self.writable(&p, cx, var.span) {
            return None;
        }
        // An element or field (TcUnit's `FOR Offset[1] :=`) has a fixed place for the
        // whole loop only with constant subscripts, which the loop's instructions need.
        let fixed = p.path.iter().all(|s| match s {
            ir::Step::Field(_) => true,
            ir::Step::Index(ix) => ix.iter().all(|i| i.const_int().is_some()),
            _ => false,
        });
        let own = match p.root {
            Root::Var(v) => cx.vars.get(v as usize).is_some_and(|x| {
                !matches!(x.class, ir::VarClass::InOut | ir::VarClass::External(_))
            }),
            _ => false,
        };
        if !fixed || (!p.path.is_empty() && !own) {
            self.error(
                diag::BAD_FOR,
                var.span,
                "the control variable of FOR is a variable of the POU, or an element (constant subscripts) or field of one",
            );
            return None;
        }
        // A subrange variable (CODESYS and TwinCAT accept it) runs as its base type: the
        // bounds are checked where the loop begins, and the step past the end leaves it one
        // step beyond, as those PLCs leave it.
        let ok_ty = self.types.elem(p.ty).is_some_and(|e| e.is_int());
        if !ok_ty {
            let t = self.types.name(p.ty);
            self.error(
                diag::BAD_FOR,
                var.span,
                format!("the control variable of FOR is SINT, INT, DINT, LINT or an unsigned integer; `{}` is {t}", control_name(var)),
            );
            return None;
        }
        let ty = p.ty;
        let f = self.expr(from, cx, Some(ty));
        let f = self.coerce(f, ty, "the FOR loop's initial value");
        // The final value is only compared with: outside a subrange it makes the loop end
        // (`FOR i := 0 TO n - 1` with n = 0 runs no time), as CODESYS and TwinCAT run it.
        let base = self.base_type(ty);
        let t = self.expr(to, cx, Some(base));
        let t = self.coerce(t, base, "the FOR loop's final value");
        let unsigned = self.types.elem(ty).is_some_and(|e| !e.is_signed());
        let b = match by {
            // CODESYS and TwinCAT count an unsigned variable down with `BY -1`
            // (TwinCAT-Dynamic-Collections' `FOR i := SHR(nSize, 2) TO 1 BY -1`): the step
            // stays the negative constant it is.
            Some(b) if unsigned && self.dialect.is_codesys_family() && negative_literal(b) => {
                let x = self.expr(b, cx, Some(ids::LINT));
                self.coerce(x, ids::LINT, "the FOR loop's step")
            }
            Some(b) => {
                let x = self.expr(b, cx, Some(ty));
                self.coerce(x, ty, "the FOR loop's step")
            }
            None => ir::Expr {
                kind: ir::ExprKind::Const(Value::Int(1)),
                ty,
                span,
            },
        };
        if b.const_int() == Some(0) {
            self.error(
                diag::BAD_FOR,
                by.map_or(span, |b| b.span),
                "a FOR loop with BY 0 never ends; give a step other than 0",
            );
            return None;
        }
        let root = match p.root {
            Root::Var(v) if p.path.is_empty() => Some(v),
            _ => None,
        };
        if let Some(v) = root {
            cx.for_vars.push(v);
        }
        cx.loops += 1;
        let body = self.stmts(body, cx);
        cx.loops -= 1;
        if root.is_some() {
            cx.for_vars.pop();
        }
        if f.ty == ids::ERROR || t.ty == ids::ERROR || b.ty == ids::ERROR {
            return None;
        }
        Some(StmtKind::For(Box::new(ir::ForLoop {
            var: p,
            from: f,
            to: t,
            by: b,
            body,
        })))
    }

    /// `inst(IN := …, Q => …);` or a function called as a statement.
    pub(crate) fn call_stmt(&mut self, call: &ast::Call, cx: &mut Cx) -> Option<Stmt> {
        let span = call.span;
        if !matches!(call.callee.kind, ast::ExprKind::Name(_)) {
            if let Some(x) = self.member_call(call, cx) {
                return (x.ty != ids::ERROR).then_some(Stmt {
                    kind: StmtKind::Eval(x),
                    span,
                });
            }
        }
        if let Some(r) = self.en_stmt(None, call, span, cx) {
            return r;
        }
        if matches!(&call.callee.kind, ast::ExprKind::Name(n) if n.is("__DELETE")) {
            return self.delete_stmt(call, cx);
        }
        // A function (user or standard) called for its effects.
        if let ast::ExprKind::Name(n) = &call.callee.kind {
            let key = n.key();
            let is_var = cx.names.contains_key(&key)
                || self
                    .global_names
                    .get(&key)
                    .is_some_and(|&g| self.global_direct[g as usize])
                || self.is_this_member(n, cx);
            if !is_var {
                let e = ast::Expr {
                    kind: ast::ExprKind::Call(call.clone()),
                    span,
                };
                let x = self.expr(&e, cx, None);
                if x.ty == ids::ERROR {
                    return None;
                }
                let effects = matches!(
                    x.kind,
                    ir::ExprKind::Call(_)
                        | ir::ExprKind::Builtin(ir::Builtin::MemCpy | ir::Builtin::MemSet, _)
                );
                if !effects {
                    self.diags.warning(
                        diag::UNUSED_RESULT,
                        span,
                        "this call computes a value that is thrown away; assign it (x := …;)",
                    );
                }
                return Some(Stmt {
                    kind: StmtKind::Eval(x),
                    span,
                });
            }
        }
        let inst = self.place(&call.callee, cx, false)?;
        let Type::Fb(fb) = *self.types.get(inst.ty) else {
            if inst.ty != ids::ERROR {
                let t = self.types.name(inst.ty);
                self.error(
                    diag::NOT_CALLABLE,
                    call.callee.span,
                    format!(
                        "only function block instances and functions can be called; this is {t}"
                    ),
                );
            }
            return None;
        };
        let (name, vars) = match fb {
            FbRef::User(p) => {
                self.interface(p);
                let pou = &self.pous[p as usize];
                if !pou.runnable {
                    let n = pou.name.clone();
                    self.error(
                        diag::UNSUPPORTED,
                        span,
                        format!("{n} is not written in Structured Text or Instruction List and cannot be called yet"),
                    );
                    return None;
                }
                (pou.name.clone(), pou.vars.clone())
            }
            FbRef::Native(k) => {
                let sig = &self.natives[k as usize];
                let vars = sig
                    .vars
                    .iter()
                    .map(|v| ir::Var {
                        name: v.name.clone(),
                        ty: TypeTable::elem_id(v.ty),
                        class: match v.kind {
                            ir::NativeVarKind::Input => VarClass::Input,
                            ir::NativeVarKind::Output => VarClass::Output,
                            ir::NativeVarKind::State => VarClass::Hidden,
                        },
                        init: Some(v.init.clone()),
                        constant: false,
                        retain: false,
                        location: None,
                        span,
                    })
                    .collect();
                (sig.name.clone(), vars)
            }
        };
        let bound = self.bind_args(&name, &vars, call, cx, true)?;
        if let FbRef::User(p) = fb {
            self.calls.push((cx.pou, p, span));
        }
        Some(Stmt {
            kind: StmtKind::CallFb(Box::new(FbCall {
                instance: inst,
                fb,
                inputs: bound.inputs,
                in_outs: bound.in_outs,
                outputs: bound.outputs,
            })),
            span,
        })
    }

    // ---- configurations ----

    pub fn configurations(&mut self) -> Option<ir::Configuration> {
        self.check_recursion();
        let lib = self.lib;
        let configs: Vec<&ast::Configuration> = lib
            .elements
            .iter()
            .filter_map(|e| match e {
                ast::Element::Configuration(c) => Some(c),
                _ => None,
            })
            .collect();
        if configs.len() > 1 {
            self.error(
                diag::CONFIG,
                configs[1].name.span,
                "a project holds one CONFIGURATION; merge the resources into one",
            );
        }
        let c = configs.first()?;
        let mut tasks: Vec<ir::Task> = Vec::new();
        let mut programs: Vec<ir::ProgramInstance> = Vec::new();
        let mut cx = Cx::global();
        for r in &c.resources {
            for t in &r.tasks {
                if tasks
                    .iter()
                    .any(|x| x.name.eq_ignore_ascii_case(&t.name.name))
                {
                    self.error(
                        diag::DUPLICATE,
                        t.name.span,
                        format!("task {} is declared twice", t.name.name),
                    );
                    continue;
                }
                let single = t
                    .single
                    .as_ref()
                    .and_then(|s| self.task_single(s, t, &mut cx));
                let interval = match &t.interval {
                    Some(e) => {
                        cx.const_only = true;
                        let x = self.expr(e, &mut cx, Some(ids::TIME));
                        cx.const_only = false;
                        let x = self.coerce(x, ids::TIME, "the task's INTERVAL");
                        match self.eval_const(&x) {
                            Some(Value::Int(ns)) if ns > 0 => Some(ns as i64),
                            Some(_) => {
                                self.error(
                                    diag::CONFIG,
                                    e.span,
                                    "a task's INTERVAL is a duration above zero (e.g. T#10ms)",
                                );
                                None
                            }
                            None => None,
                        }
                    }
                    None => None,
                };
                let priority = match &t.priority {
                    Some(e) => {
                        cx.const_only = true;
                        let x = self.expr(e, &mut cx, Some(ids::DINT));
                        cx.const_only = false;
                        match self.eval_const(&x) {
                            Some(Value::Int(p)) if (0..=i64::MAX as i128).contains(&p) => p as i64,
                            _ => {
                                if x.ty != ids::ERROR {
                                    self.error(
                                        diag::CONFIG,
                                        e.span,
                                        "a task's PRIORITY is an integer 0 or above (0 runs first)",
                                    );
                                }
                                0
                            }
                        }
                    }
                    None => 0,
                };
                tasks.push(ir::Task {
                    name: t.name.name.clone(),
                    interval,
                    priority,
                    single,
                    span: t.span,
                });
            }
        }
        for r in &c.resources {
            for pc in &r.programs {
                if let Some(p) = self.program_instance(pc, &tasks, &mut cx, &programs) {
                    programs.push(p);
                }
            }
        }
        let var_config = self.var_config(c, &programs, &mut cx);
        Some(ir::Configuration {
            name: c.name.name.clone(),
            tasks,
            programs,
            var_config,
            span: c.span,
        })
    }

    /// A task's `SINGLE := v`: the global BOOL whose rising edge runs the task once (IEC
    /// 61131-3's event task). A direct address, an expression or a task that also has an
    /// INTERVAL is refused with what to write.
    fn task_single(&mut self, s: &ast::Expr, t: &ast::Task, cx: &mut Cx) -> Option<ir::GlobalId> {
        if let Some(iv) = &t.interval {
            self.error(
                diag::UNSUPPORTED,
                iv.span,
                "a task with SINGLE runs on its rising edge and has no INTERVAL; make two tasks, one cyclic and one SINGLE",
            );
            return None;
        }
        let x = self.expr(s, cx, Some(ids::BOOL));
        if x.ty == ids::ERROR {
            return None;
        }
        match &x.kind {
            ir::ExprKind::Load(Place {
                root: Root::Global(g),
                path,
                ..
            }) if path.is_empty() && x.ty == ids::BOOL => Some(*g),
            _ => {
                self.error(
                    diag::CONFIG,
                    s.span,
                    "SINGLE names a global BOOL variable whose rising edge runs the task (SINGLE := start); declare one in VAR_GLOBAL",
                );
                None
            }
        }
    }

    fn program_instance(
        &mut self,
        pc: &ast::ProgramConfig,
        tasks: &[ir::Task],
        cx: &mut Cx,
        others: &[ir::ProgramInstance],
    ) -> Option<ir::ProgramInstance> {
        if others
            .iter()
            .any(|o| o.name.eq_ignore_ascii_case(&pc.name.name))
        {
            self.error(
                diag::DUPLICATE,
                pc.name.span,
                format!("program instance {} is declared twice", pc.name.name),
            );
            return None;
        }
        let Some(&pou) = self.pou_names.get(&pc.type_name.key()) else {
            self.error(
                diag::CONFIG,
                pc.type_name.span,
                format!(
                    "no PROGRAM named {}; the instance needs a PROGRAM declared in the project",
                    pc.type_name.name
                ),
            );
            return None;
        };
        if self.pous[pou as usize].kind != PouKind::Program {
            self.error(
                diag::CONFIG,
                pc.type_name.span,
                format!(
                    "{} is a {}; a configuration instantiates PROGRAMs",
                    pc.type_name.name,
                    self.pous[pou as usize].kind.keyword()
                ),
            );
            return None;
        }
        if !self.pous[pou as usize].runnable {
            self.error(
                diag::UNSUPPORTED,
                pc.type_name.span,
                format!(
                    "program {} is not written in Structured Text or Instruction List; the engine cannot run it yet",
                    pc.type_name.name
                ),
            );
            return None;
        }
        let task = match &pc.task {
            Some(t) => match tasks
                .iter()
                .position(|x| x.name.eq_ignore_ascii_case(&t.name))
            {
                Some(i) => Some(i as u32),
                None => {
                    self.error(
                        diag::CONFIG,
                        t.span,
                        format!("no TASK named {} in this configuration", t.name),
                    );
                    return None;
                }
            },
            None => None,
        };
        let vars = self.pous[pou as usize].vars.clone();
        let mut inputs = Vec::new();
        let mut outputs = Vec::new();
        for a in &pc.args {
            let Some(n) = &a.name else {
                self.error(
                    diag::CONFIG,
                    a.span,
                    "connect program parameters by name: PROGRAM p WITH t : main (input := global, output => global);",
                );
                continue;
            };
            let Some(v) = vars
                .iter()
                .position(|x| x.name.eq_ignore_ascii_case(&n.name))
            else {
                self.error(
                    diag::CONFIG,
                    n.span,
                    format!(
                        "program {} has no parameter `{}`",
                        pc.type_name.name, n.name
                    ),
                );
                continue;
            };
            let var = &vars[v];
            match (var.class, a.output) {
                (VarClass::Input, false) => {
                    let Some(e) = &a.value else { continue };
                    let x = self.expr(e, cx, Some(var.ty));
                    let x = self.coerce(x, var.ty, &format!("the connection of `{}`", var.name));
                    if x.ty != ids::ERROR {
                        inputs.push((v as VarId, x));
                    }
                }
                (VarClass::Output, true) => {
                    let Some(e) = &a.value else { continue };
                    let Some(p) = self.place(e, cx, true) else {
                        continue;
                    };
                    if !self.writable(&p, cx, e.span) {
                        continue;
                    }
                    if !self.assignable(var.ty, p.ty) {
                        let (x, y) = (self.types.name(var.ty), self.types.name(p.ty));
                        self.error(
                            diag::TYPE_MISMATCH,
                            e.span,
                            format!("output `{}` is {x} and cannot be stored in {y}", var.name),
                        );
                        continue;
                    }
                    outputs.push((v as VarId, p));
                }
                _ => {
                    self.error(
                        diag::CONFIG,
                        a.span,
                        format!("`{}` is not {} of program {}; connect inputs with := and outputs with =>", var.name, if a.output { "an output" } else { "an input" }, pc.type_name.name),
                    );
                }
            }
        }
        Some(ir::ProgramInstance {
            name: pc.name.name.clone(),
            pou,
            task,
            inputs,
            outputs,
            retain: pc.retain == ast::Retain::Retain,
            span: pc.span,
        })
    }
}

impl Place {
    pub fn is_var(&self, v: VarId) -> bool {
        self.path.is_empty() && self.root == Root::Var(v)
    }
}

/// How a FOR loop's control variable is named in a message: its name, else its text's kind.
fn control_name(var: &ast::Expr) -> String {
    match &var.kind {
        ast::ExprKind::Name(n) => n.name.clone(),
        _ => "this element".into(),
    }
}

/// `-1`, `-(2)`: a negated integer literal.
fn negative_literal(e: &ast::Expr) -> bool {
    match &e.kind {
        ast::ExprKind::Unary(ast::UnaryOp::Neg, x) => {
            matches!(&x.kind, ast::ExprKind::Literal(ast::Literal::Int { .. }))
                || matches!(&x.kind, ast::ExprKind::Paren(p) if matches!(p.kind, ast::ExprKind::Literal(ast::Literal::Int { .. })))
        }
        ast::ExprKind::Literal(ast::Literal::Int { value, .. }) => *value < 0,
        ast::ExprKind::Paren(p) => negative_literal(p),
        _ => false,
    }
}
