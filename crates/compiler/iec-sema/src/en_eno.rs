//! EN/ENO (IEC 61131-3 §6.6.1.7; 2nd edition §2.5.1.2), with matiec's meaning: a call
//! given `EN := c` runs only when `c` is TRUE and tells through `ENO => ok` whether it ran.
//!
//! A POU that declares `EN : BOOL` (VAR_INPUT) and `ENO : BOOL` (VAR_OUTPUT), or reads
//! or writes those names without declaring them (they are then implicit, as matiec adds
//! them to every function and function block), controls its own execution: its body starts
//! with `IF NOT EN THEN ENO := FALSE; RETURN; END_IF; ENO := TRUE;` and a call binds EN and
//! ENO as ordinary parameters. Any other callee (standard functions, native function blocks,
//! POUs that never mention EN/ENO) is guarded by the caller instead, as a statement:
//! `y := F(EN := c, …, ENO => ok)` becomes `IF c THEN y := F(…); ok := TRUE; ELSE y := the
//! result's initial value; ok := FALSE; END_IF` (matiec's functions return their result
//! variable's initial value, `__INIT_type` for the standard ones), and `inst(EN := c, …)`
//! stores the inputs and copies the outputs in both branches but runs the body only in the
//! first (matiec assigns inputs before the body's own EN test and copies outputs after).

use petriplc_iec_syntax::ast::{self, ExprKind as A, StmtKind as S};
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::ir::{self, Expr, ExprKind, Place, PouId, Stmt, StmtKind, VarClass, VarId};
use crate::types::{ids, FbRef, TypeTable};
use crate::value::Value;

/// The EN and ENO arguments of a call, and its other arguments.
struct EnArgs<'c> {
    en: Option<&'c ast::Arg>,
    eno: Option<&'c ast::Arg>,
    rest: Vec<ast::Arg>,
}

fn split(call: &ast::Call) -> Option<EnArgs<'_>> {
    let is = |a: &ast::Arg, n: &str| a.name.as_ref().is_some_and(|x| x.is(n));
    if !call.args.iter().any(|a| is(a, "EN") || is(a, "ENO")) {
        return None;
    }
    let mut out = EnArgs {
        en: None,
        eno: None,
        rest: Vec::new(),
    };
    for a in &call.args {
        if is(a, "EN") && out.en.is_none() {
            out.en = Some(a);
        } else if is(a, "ENO") && out.eno.is_none() {
            out.eno = Some(a);
        } else {
            out.rest.push(a.clone());
        }
    }
    Some(out)
}

fn load(p: Place) -> Expr {
    let (ty, span) = (p.ty, p.span);
    Expr {
        kind: ExprKind::Load(p),
        ty,
        span,
    }
}

fn boolean(b: bool, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Const(Value::Int(b as i128)),
        ty: ids::BOOL,
        span,
    }
}

fn not(e: Expr) -> Expr {
    let span = e.span;
    Expr {
        kind: ExprKind::Unary(ir::UnaryOp::Not, Box::new(e)),
        ty: ids::BOOL,
        span,
    }
}

fn assign(target: Place, value: Expr, span: Span) -> Stmt {
    Stmt {
        kind: StmtKind::Assign { target, value },
        span,
    }
}

fn var_place(id: VarId, span: Span) -> Place {
    Place {
        root: ir::Root::Var(id),
        path: Vec::new(),
        ty: ids::BOOL,
        span,
    }
}

/// The call an assigned value is (in parentheses or not).
pub(crate) fn called(value: &ast::Expr) -> Option<&ast::Call> {
    let mut v = value;
    while let A::Paren(x) = &v.kind {
        v = x;
    }
    match &v.kind {
        A::Call(c) => Some(c),
        _ => None,
    }
}

/// Whether a body names `EN` or `ENO` (read or written), which gives the POU the implicit
/// EN/ENO parameters.
pub(crate) fn mentions_en_eno(body: &ast::Body) -> bool {
    fn expr(e: &ast::Expr) -> bool {
        match &e.kind {
            A::Name(n) => n.is("EN") || n.is("ENO"),
            A::Field(x, _)
            | A::Bit(x, _)
            | A::Part(x, ..)
            | A::Unary(_, x)
            | A::Paren(x)
            | A::Deref(x) => expr(x),
            A::Index(x, ix) => expr(x) || ix.iter().any(expr),
            A::Call(c) => call(c),
            A::Binary(_, a, b) => expr(a) || expr(b),
            A::Literal(_) | A::Direct(_) | A::Error => false,
        }
    }
    fn args(a: &[ast::Arg]) -> bool {
        a.iter().any(|a| a.value.as_ref().is_some_and(expr))
    }
    fn call(c: &ast::Call) -> bool {
        expr(&c.callee) || args(&c.args)
    }
    fn stmts(s: &[ast::Stmt]) -> bool {
        s.iter().any(stmt)
    }
    fn stmt(s: &ast::Stmt) -> bool {
        match &s.kind {
            S::Assign { target, value } | S::RefAssign { target, value } => {
                expr(target) || expr(value)
            }
            S::Call(c) => call(c),
            S::If {
                branches,
                else_body,
            } => {
                branches.iter().any(|(c, b)| expr(c) || stmts(b))
                    || else_body.as_deref().is_some_and(stmts)
            }
            S::Case {
                selector,
                arms,
                else_body,
            } => {
                expr(selector)
                    || arms.iter().any(|a| stmts(&a.body))
                    || else_body.as_deref().is_some_and(stmts)
            }
            S::For {
                from, to, by, body, ..
            } => expr(from) || expr(to) || by.as_ref().is_some_and(expr) || stmts(body),
            S::While { cond, body } => expr(cond) || stmts(body),
            S::Repeat { body, until } => stmts(body) || expr(until),
            S::Exit | S::Continue | S::Return | S::Empty => false,
        }
    }
    match body {
        ast::Body::St(s) => stmts(s),
        ast::Body::Il { code, .. } => code.iter().any(|i| match &i.kind {
            ast::IlKind::Op { operand, .. } => operand.as_ref().is_some_and(expr),
            ast::IlKind::Call {
                instance, args: a, ..
            } => expr(instance) || args(a),
            ast::IlKind::FbInput { instance, .. } => expr(instance),
            ast::IlKind::Function { args: a, .. } => args(a),
            _ => false,
        }),
        ast::Body::Graphical { .. } | ast::Body::Missing(_) => false,
    }
}

/// The implicit `EN : BOOL := TRUE` input and `ENO : BOOL := TRUE` output (matiec's
/// initial values), for a function or function block whose body names them without
/// declaring them.
pub(crate) fn implicit_vars(pou: &ast::Pou) -> Vec<ir::Var> {
    if pou.kind == ast::PouKind::Program || !mentions_en_eno(&pou.body) {
        return Vec::new();
    }
    let declared = |n: &str| {
        pou.var_blocks
            .iter()
            .flat_map(|b| &b.vars)
            .flat_map(|d| &d.names)
            .any(|x| x.is(n))
    };
    let mut out = Vec::new();
    for (n, class) in [("EN", VarClass::Input), ("ENO", VarClass::Output)] {
        if !declared(n) {
            out.push(ir::Var {
                name: n.into(),
                ty: ids::BOOL,
                class,
                init: Some(Value::Int(1)),
                constant: false,
                retain: false,
                location: None,
                span: pou.name.span,
            });
        }
    }
    out
}

impl Checker<'_> {
    /// `f`, a statement checked with room for statements that run before it (the calls
    /// given EN inside its value); they and it are held together in an `IF TRUE`.
    pub(crate) fn with_pre(
        &mut self,
        cx: &mut Cx,
        f: impl FnOnce(&mut Self, &mut Cx) -> Option<Stmt>,
    ) -> Option<Stmt> {
        let outer = cx.pre.replace(Vec::new());
        let s = f(self, cx);
        let pre = std::mem::replace(&mut cx.pre, outer).unwrap_or_default();
        if pre.is_empty() {
            return s;
        }
        let s = s?;
        let span = s.span;
        let mut body = pre;
        body.push(s);
        Some(Stmt {
            kind: StmtKind::If {
                branches: vec![(boolean(true, span), body)],
                else_body: Vec::new(),
            },
            span,
        })
    }

    /// A call given EN or ENO inside an expression, to a callee without EN/ENO of its own:
    /// run before the statement, into a hidden variable whose load is returned (`None`:
    /// not such a call).
    pub(crate) fn en_nested(
        &mut self,
        call: &ast::Call,
        cx: &mut Cx,
        expected: Option<crate::types::TypeId>,
    ) -> Option<Expr> {
        let A::Name(n) = &call.callee.kind else {
            return None;
        };
        let parts = split(call)?;
        if let Some(&p) = self.pou_names.get(&n.key()) {
            self.interface(p);
            if self.own_en_eno(p).is_some() {
                return None;
            }
        }
        let span = call.span;
        if cx.pre.is_none() || cx.pou.is_none() {
            self.error(
                diag::UNSUPPORTED,
                n.span,
                format!("{} has no EN/ENO of its own, and a call given EN or ENO is supported as an assignment's or a call's value, not in a condition, a loop's bounds or a declaration; assign it to a variable first (y := {}(EN := …, ENO => ok);)", n.name, n.name),
            );
            return Some(crate::expr::err(span));
        }
        // The guarded call, built as a statement `$tmp := F(EN := …)` once the type is known.
        let stripped = ast::Call {
            callee: call.callee.clone(),
            args: parts.rest.clone(),
            span,
        };
        let whole = ast::Expr {
            kind: A::Call(stripped),
            span,
        };
        let x = self.expr(&whole, cx, expected);
        if x.ty == crate::types::ids::ERROR {
            return Some(x);
        }
        if matches!(self.types.get(x.ty), crate::types::Type::Void) {
            self.error(
                diag::TYPE_MISMATCH,
                span,
                format!("{} gives no value to use here", n.name),
            );
            return Some(crate::expr::err(span));
        }
        let ty = self.settle_type(x.ty, expected);
        let id = cx.vars.len() as VarId;
        cx.vars.push(ir::Var::hidden(format!("$en{id}"), ty, span));
        let tmp = Place {
            root: ir::Root::Var(id),
            path: Vec::new(),
            ty,
            span,
        };
        let x = self.coerce(x, ty, "the result");
        let run = assign(tmp.clone(), x, span);
        // The arguments were checked once above; EN and ENO are checked by the guard, which
        // is given the checked call rather than the call's text.
        let Some(guarded) = self.en_guard(span, call, parts, move |_, _| Some(run), cx) else {
            return Some(crate::expr::err(span));
        };
        cx.pre.get_or_insert_with(Vec::new).push(guarded);
        Some(load(tmp))
    }

    /// The POU's EN and ENO when it controls its own execution (EN a BOOL input, ENO a
    /// BOOL output, declared or implicit).
    fn own_en_eno(&self, p: PouId) -> Option<(VarId, VarId)> {
        let pou = &self.pous[p as usize];
        let en = pou.var_by_name("EN")?;
        let eno = pou.var_by_name("ENO")?;
        let (a, b) = (&pou.vars[en as usize], &pou.vars[eno as usize]);
        (a.class == VarClass::Input
            && b.class == VarClass::Output
            && a.ty == ids::BOOL
            && b.ty == ids::BOOL)
            .then_some((en, eno))
    }

    /// `IF NOT EN THEN ENO := FALSE; RETURN; END_IF; ENO := TRUE;` for a POU with its own
    /// EN and ENO (none otherwise).
    pub(crate) fn en_prologue(&self, p: PouId, span: Span) -> Vec<Stmt> {
        let Some((en, eno)) = self.own_en_eno(p) else {
            return Vec::new();
        };
        let skip = vec![
            assign(var_place(eno, span), boolean(false, span), span),
            Stmt {
                kind: StmtKind::Return,
                span,
            },
        ];
        vec![
            Stmt {
                kind: StmtKind::If {
                    branches: vec![(not(load(var_place(en, span))), skip)],
                    else_body: Vec::new(),
                },
                span,
            },
            assign(var_place(eno, span), boolean(true, span), span),
        ]
    }

    /// A statement whose call passes EN or ENO to a callee without its own: `target :=
    /// call` (`target` given) or `call;`, lowered here (`Some`, `Some(None)` once an error
    /// is reported); `None` for any other call.
    pub(crate) fn en_stmt(
        &mut self,
        target: Option<&ast::Expr>,
        call: &ast::Call,
        span: Span,
        cx: &mut Cx,
    ) -> Option<Option<Stmt>> {
        let parts = split(call)?;
        if let A::Name(n) = &call.callee.kind {
            if let Some(&p) = self.pou_names.get(&n.key()) {
                self.interface(p);
                if self.own_en_eno(p).is_some() {
                    return None;
                }
            }
        }
        let stripped = ast::Call {
            callee: call.callee.clone(),
            args: parts.rest.clone(),
            span: call.span,
        };
        let run = move |ck: &mut Self, cx: &mut Cx| match target {
            Some(t) => {
                let inner = ast::Stmt {
                    kind: S::Assign {
                        target: t.clone(),
                        value: ast::Expr {
                            kind: A::Call(stripped),
                            span: call.span,
                        },
                    },
                    span,
                };
                // In the statement's own scope: a call given EN among the arguments runs
                // before this guard, as matiec evaluates every argument before the call.
                ck.stmt_here(&inner, cx)
            }
            None => ck.call_stmt(&stripped, cx),
        };
        Some(self.en_guard(span, call, parts, run, cx))
    }

    /// The call `run` makes, guarded by the EN and told through the ENO of `parts`.
    fn en_guard(
        &mut self,
        span: Span,
        call: &ast::Call,
        parts: EnArgs<'_>,
        run: impl FnOnce(&mut Self, &mut Cx) -> Option<Stmt>,
        cx: &mut Cx,
    ) -> Option<Stmt> {
        let mut ok = true;
        if let Some(a) = call
            .args
            .iter()
            .filter(|a| a.name.as_ref().is_some_and(|n| n.is("EN") || n.is("ENO")))
            .nth(2)
            .or_else(|| {
                let twice = |n: &str| {
                    call.args
                        .iter()
                        .filter(|a| a.name.as_ref().is_some_and(|x| x.is(n)))
                        .nth(1)
                };
                twice("EN").or_else(|| twice("ENO"))
            })
        {
            self.error(
                diag::BAD_ARGUMENTS,
                a.span,
                "EN and ENO are given once each in a call",
            );
            return None;
        }
        if parts.rest.iter().any(|a| a.name.is_none()) {
            self.error(
                diag::BAD_ARGUMENTS,
                call.span,
                "a call that passes EN or ENO names all its arguments (x := …); EN/ENO cannot be mixed with positional arguments",
            );
            return None;
        }
        let cond = match parts.en {
            Some(a) if a.output => {
                self.error(
                    diag::BAD_ARGUMENTS,
                    a.span,
                    "EN is an input: give it a BOOL value with `EN := condition`",
                );
                ok = false;
                None
            }
            Some(a) => match &a.value {
                Some(v) => {
                    let c = self.cond(v, cx);
                    ok &= c.ty != ids::ERROR;
                    Some(c)
                }
                None => None,
            },
            None => None,
        };
        let eno = match parts.eno {
            Some(a) if !a.output => {
                self.error(
                    diag::BAD_ARGUMENTS,
                    a.span,
                    "ENO is an output: connect it to a BOOL variable with `ENO => ok`",
                );
                ok = false;
                None
            }
            Some(a) => match &a.value {
                Some(v) => match self.place(v, cx, true) {
                    Some(pl) if self.writable(&pl, cx, v.span) => {
                        if pl.ty != ids::BOOL {
                            if pl.ty != ids::ERROR {
                                let t = self.types.name(pl.ty);
                                self.error(
                                    diag::TYPE_MISMATCH,
                                    v.span,
                                    format!("ENO is BOOL and cannot be stored in {t}"),
                                );
                            }
                            ok = false;
                            None
                        } else {
                            Some((pl, a.negated))
                        }
                    }
                    _ => {
                        ok = false;
                        None
                    }
                },
                None => None,
            },
            None => None,
        };
        let run = run(self, cx);
        let run = run?;
        if !ok {
            return None;
        }
        // A function block with its own EN/ENO binds them as parameters.
        if let StmtKind::CallFb(fb) = &run.kind {
            if let FbRef::User(p) = fb.fb {
                if let Some((en, eno_id)) = self.own_en_eno(p) {
                    let mut run = run;
                    if let StmtKind::CallFb(fb) = &mut run.kind {
                        if let Some(c) = cond {
                            fb.inputs.push((en, c));
                        }
                        if let Some((pl, neg)) = eno {
                            fb.outputs.push((eno_id, pl, neg));
                        }
                    }
                    return Some(run);
                }
            }
        }
        let eno_set = |v: bool| {
            eno.as_ref()
                .map(|(pl, neg)| assign(pl.clone(), boolean(v != *neg, span), span))
        };
        let Some(cond) = cond else {
            // No EN: the call always runs and ENO is TRUE; `IF TRUE` holds the two
            // statements in one.
            let mut body = vec![run];
            body.extend(eno_set(true));
            return Some(Stmt {
                kind: StmtKind::If {
                    branches: vec![(boolean(true, span), body)],
                    else_body: Vec::new(),
                },
                span,
            });
        };
        let mut skipped = self.skipped(&run);
        skipped.extend(eno_set(false));
        let mut body = vec![run];
        body.extend(eno_set(true));
        Some(Stmt {
            kind: StmtKind::If {
                branches: vec![(cond, body)],
                else_body: skipped,
            },
            span,
        })
    }

    /// What a call not executed still does: a function's result is its initial value; a
    /// function block instance takes its inputs and gives its (unchanged) outputs.
    fn skipped(&mut self, run: &Stmt) -> Vec<Stmt> {
        let span = run.span;
        match &run.kind {
            StmtKind::Assign { target, value } => {
                let mut v = value;
                while let ExprKind::Convert(x) = &v.kind {
                    v = x;
                }
                let init = match &v.kind {
                    ExprKind::Call(c) => {
                        let pou = &self.pous[c.pou as usize];
                        pou.result.map(|r| {
                            let var = &pou.vars[r as usize];
                            (var.init.clone(), var.ty)
                        })
                    }
                    _ => None,
                };
                let x = match init {
                    Some((i, ty)) => {
                        let i = i.unwrap_or_else(|| self.default_value(ty));
                        let k = Expr {
                            kind: ExprKind::Const(i),
                            ty,
                            span,
                        };
                        self.assign_coerce(k, target.ty, "the result")
                    }
                    None => Expr {
                        kind: ExprKind::Const(self.default_value(target.ty)),
                        ty: target.ty,
                        span,
                    },
                };
                vec![assign(target.clone(), x, span)]
            }
            StmtKind::CallFb(fb) => {
                let member = |id: VarId, ty| {
                    let mut p = fb.instance.clone();
                    p.path.push(ir::Step::Member(id));
                    p.ty = ty;
                    p
                };
                let ty_of = |ck: &Self, id: VarId| match fb.fb {
                    FbRef::User(p) => ck.pous[p as usize].vars[id as usize].ty,
                    FbRef::Native(k) => {
                        TypeTable::elem_id(ck.natives[k as usize].vars[id as usize].ty)
                    }
                };
                let mut out = Vec::new();
                for (id, x) in &fb.inputs {
                    let ty = ty_of(self, *id);
                    out.push(assign(member(*id, ty), x.clone(), span));
                }
                for (id, pl, neg) in &fb.outputs {
                    let ty = ty_of(self, *id);
                    let mut x = load(member(*id, ty));
                    if *neg {
                        x = not(x);
                    }
                    let x = self.assign_coerce(x, pl.ty, "the output");
                    out.push(assign(pl.clone(), x, span));
                }
                out
            }
            _ => Vec::new(),
        }
    }
}
