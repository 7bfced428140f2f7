//! Instruction List lowered to the checked form: the current result (the accumulator) is kept
//! as a typed expression and folded into the next instruction, so `LD a / AND b / ST x` becomes
//! the assignment `x := a AND b` that Structured Text would give (and runs as fast); it is
//! stored in a hidden variable only where its value must survive something (a store into a
//! variable it reads, a function's effects, a jump to a label whose code uses it). Jumps and
//! labels become [`StmtKind::Goto`] and [`StmtKind::Label`]; S, R, JMPC, CALC and RETC become
//! conditional statements. Operands, stores and calls are checked by the same rules as ST.
//!
//! The current result is undefined at the start of a body, after CAL (and the input
//! operators that call), after an unconditional JMP or RET, and at a label unless the code
//! after the label uses it (then every jump to the label and the fall-through store it).
//!
//! Long bodies stay cheap and shallow: a current result folded more than [`FOLD_DEPTH`]
//! operators deep is stored in a hidden variable and folding starts again from it (as the IL
//! accumulator would hold it), parenthesised operations nest at most
//! [`MAX_NESTING`](petriplc_iec_syntax::depth::MAX_NESTING) deep (`E014`), and jumps become
//! IF only that deep.

use std::collections::HashMap;

use petriplc_iec_syntax::ast::{self, IlCond, IlInstr, IlKind, IlOp};
use petriplc_iec_syntax::depth::MAX_NESTING;
use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::{Checker, Cx};
use crate::expr::err;
use crate::ir::{Expr, ExprKind, Place, Root, Stmt, StmtKind, UnaryOp, Var, VarClass, VarId};
use crate::types::{ids, Type, TypeId};
use crate::value::Value;

/// The deepest current result kept as an expression; a deeper one is stored in a hidden
/// variable. Folding `LD a / ADD b / ADD c …` into one expression is what makes IL as fast as
/// ST, and a few dozen operators are far more than a rung of IL holds; unbounded, 100 000
/// instructions would make a tree 100 000 deep (and copying it at every instruction, quadratic
/// time).
pub(crate) const FOLD_DEPTH: usize = 32;

/// The current result, or why there is none.
#[derive(Clone, Debug)]
enum Cr {
    Value(Expr),
    /// A standard function of literals (`LD 0 / LIMIT 15, 10`), checked where it is used so
    /// that it takes the type the use needs, as it would in ST.
    Pending(ast::Expr),
    None(&'static str),
}

/// An untyped literal (maybe negated).
fn is_literal(e: &ast::Expr) -> bool {
    match &e.kind {
        ast::ExprKind::Literal(l) => !matches!(l, ast::Literal::Enum { .. }),
        ast::ExprKind::Unary(_, x) | ast::ExprKind::Paren(x) => is_literal(x),
        ast::ExprKind::Call(c) => {
            matches!(&c.callee.kind, ast::ExprKind::Name(n) if crate::is_standard_function(&n.name))
                && c.args
                    .iter()
                    .all(|a| !a.output && a.value.as_ref().is_some_and(is_literal))
        }
        _ => false,
    }
}

struct Label {
    id: u32,
    /// The code after the label uses the current result.
    needs: bool,
    /// What the code after the label stores the current result into (ST, S, R), which types
    /// a literal carried to the label.
    target: Option<ast::Expr>,
    /// The hidden variable that carries the current result to the label.
    var: Option<VarId>,
    /// A way in had no current result (reported there): no more reports after the label.
    poisoned: bool,
}

/// An open `OP(`.
struct Open {
    op: IlOp,
    negated: bool,
    saved: Cr,
    span: Span,
}

struct Il<'x> {
    cr: Cr,
    out: Vec<Stmt>,
    labels: HashMap<String, Label>,
    open: Vec<Open>,
    /// `OP(` past the nesting limit (reported once), whose `)` are skipped.
    refused_open: usize,
    too_deep: bool,
    /// After an unconditional JMP or RET, until a label.
    dead: bool,
    cx: &'x mut Cx,
}

/// Does the instruction use the current result it finds?
fn consumes(k: &IlKind) -> bool {
    match k {
        IlKind::Label(_) => false,
        IlKind::Op { op, .. } => *op != IlOp::Ld,
        IlKind::Close | IlKind::FbInput { .. } => true,
        IlKind::Jump { cond, .. } | IlKind::Call { cond, .. } | IlKind::Return { cond } => {
            cond.is_some()
        }
        IlKind::Function { formal, .. } => !formal,
    }
}

/// The variables an expression reads; `false` when it calls a function (which may have
/// effects, so it must be evaluated once).
fn reads(e: &Expr, out: &mut Vec<Root>) -> bool {
    match &e.kind {
        ExprKind::Const(_) => true,
        ExprKind::Load(p) => place_reads(p, out),
        ExprKind::Unary(_, x) | ExprKind::Convert(x) | ExprKind::Trunc(x) => reads(x, out),
        ExprKind::Binary(_, a, b) => reads(a, out) & reads(b, out),
        ExprKind::Call(_) => false,
        ExprKind::Builtin(_, args) => args.iter().fold(true, |ok, a| reads(a, out) & ok),
    }
}

fn place_reads(p: &Place, out: &mut Vec<Root>) -> bool {
    out.push(p.root);
    let mut ok = true;
    for s in &p.path {
        if let crate::ir::Step::Index(ix) = s {
            for i in ix {
                ok &= reads(i, out);
            }
        }
    }
    ok
}

fn load(p: Place) -> Expr {
    Expr {
        ty: p.ty,
        span: p.span,
        kind: ExprKind::Load(p),
    }
}

fn var_place(v: VarId, ty: TypeId, span: Span) -> Place {
    Place {
        root: Root::Var(v),
        path: Vec::new(),
        ty,
        span,
    }
}

fn cond_name(base: &str, cond: IlCond) -> String {
    match cond {
        None => base.to_string(),
        Some(true) => format!("{base}C"),
        Some(false) => format!("{base}CN"),
    }
}

/// Jumps over straight code become IF: `JMPCN l … l:` is `IF c THEN … END_IF` when nothing
/// else jumps to `l` and no label or jump lies between, so structured IL compiles to exactly
/// what the same logic in ST does (the VM's fused instructions apply alike).
///
/// IFs made this way nest at most [`MAX_NESTING`] deep (deeper jumps stay jumps), which also
/// bounds the passes: each pass turns the innermost jumps left into IFs.
fn structure(mut v: Vec<Stmt>) -> Vec<Stmt> {
    let mut depth: Vec<usize> = v.iter().map(nesting).collect();
    loop {
        let mut refs: HashMap<u32, usize> = HashMap::new();
        count_jumps(&v, &mut refs);
        let mut out = Vec::with_capacity(v.len());
        let mut out_depth = Vec::with_capacity(v.len());
        let mut changed = false;
        let mut i = 0;
        while i < v.len() {
            if let StmtKind::Goto {
                label,
                cond: Some((c, flag)),
            } = &v[i].kind
            {
                // The first label or jump after this one must be its label.
                let end = (i + 1..v.len())
                    .find(|&j| matches!(v[j].kind, StmtKind::Label(_) | StmtKind::Goto { .. }))
                    .filter(|&j| {
                        refs.get(label) == Some(&1)
                            && matches!(v[j].kind, StmtKind::Label(l) if l == *label)
                    });
                let inner = end.map(|j| 1 + depth[i + 1..j].iter().copied().max().unwrap_or(0));
                if let (Some(j), Some(d)) = (end, inner.filter(|&d| d <= MAX_NESTING)) {
                    // The body runs when the jump is not taken.
                    let run = if let (true, ExprKind::Unary(UnaryOp::Not, inner)) = (*flag, &c.kind)
                    {
                        (**inner).clone()
                    } else if *flag {
                        Expr {
                            kind: ExprKind::Unary(UnaryOp::Not, Box::new(c.clone())),
                            ty: ids::BOOL,
                            span: c.span,
                        }
                    } else {
                        c.clone()
                    };
                    out.push(Stmt {
                        kind: StmtKind::If {
                            branches: vec![(run, v[i + 1..j].to_vec())],
                            else_body: Vec::new(),
                        },
                        span: v[i].span,
                    });
                    out_depth.push(d);
                    changed = true;
                    i = j + 1;
                    continue;
                }
            }
            out.push(v[i].clone());
            out_depth.push(depth[i]);
            i += 1;
        }
        v = out;
        depth = out_depth;
        if !changed {
            return v;
        }
    }
}

/// How many IFs deep a statement is (those lowering makes are shallow).
fn nesting(s: &Stmt) -> usize {
    match &s.kind {
        StmtKind::If {
            branches,
            else_body,
        } => {
            1 + branches
                .iter()
                .flat_map(|(_, b)| b)
                .chain(else_body)
                .map(nesting)
                .max()
                .unwrap_or(0)
        }
        _ => 0,
    }
}

fn count_jumps(v: &[Stmt], refs: &mut HashMap<u32, usize>) {
    for s in v {
        match &s.kind {
            StmtKind::Goto { label, .. } => *refs.entry(*label).or_default() += 1,
            StmtKind::If {
                branches,
                else_body,
            } => {
                for (_, b) in branches {
                    count_jumps(b, refs);
                }
                count_jumps(else_body, refs);
            }
            _ => {}
        }
    }
}

impl Checker<'_> {
    /// Lowers an IL body.
    pub fn il_body(&mut self, code: &[IlInstr], cx: &mut Cx) -> Vec<Stmt> {
        let mut labels: HashMap<String, Label> = HashMap::new();
        for (i, ins) in code.iter().enumerate() {
            if let IlKind::Label(id) = &ins.kind {
                let key = id.key();
                if labels.contains_key(&key) {
                    self.error(
                        diag::IL_LABEL,
                        id.span,
                        format!(
                            "label `{}` is defined twice in this body; rename one",
                            id.name
                        ),
                    );
                    continue;
                }
                let next = code[i + 1..]
                    .iter()
                    .find(|c| !matches!(c.kind, IlKind::Label(_)));
                let needs = next.is_some_and(|c| consumes(&c.kind));
                let target = match next.map(|c| &c.kind) {
                    Some(IlKind::Op {
                        op: IlOp::St | IlOp::S | IlOp::R,
                        operand: Some(t),
                        ..
                    }) => Some(t.clone()),
                    _ => None,
                };
                let n = labels.len() as u32;
                labels.insert(
                    key,
                    Label {
                        id: n,
                        needs,
                        target,
                        var: None,
                        poisoned: false,
                    },
                );
            }
        }
        let mut il = Il {
            cr: Cr::None("at the start of the body"),
            out: Vec::new(),
            labels,
            open: Vec::new(),
            refused_open: 0,
            too_deep: false,
            dead: false,
            cx,
        };
        let mut seen: Vec<String> = Vec::new();
        for ins in code {
            self.il_instr(ins, &mut il, &mut seen);
        }
        if let Some(o) = il.open.last() {
            self.error(
                diag::IL_PARENS,
                o.span,
                format!(
                    "{}( is never closed; end the operation with `)` on a line of its own",
                    o.op.name()
                ),
            );
        }
        structure(il.out)
    }

    fn il_instr(&mut self, ins: &IlInstr, il: &mut Il<'_>, seen: &mut Vec<String>) {
        let span = ins.span;
        match &ins.kind {
            IlKind::Label(id) => {
                let key = id.key();
                if seen.contains(&key) {
                    return;
                }
                seen.push(key.clone());
                if !il.open.is_empty() {
                    self.error(
                        diag::IL_NESTING,
                        span,
                        "a label inside a parenthesised operation; close it with `)` first",
                    );
                    return;
                }
                let (lid, needs) = match il.labels.get(&key) {
                    Some(l) => (l.id, l.needs),
                    None => return,
                };
                if needs && !il.dead {
                    match il.cr.clone() {
                        Cr::Value(cr) => self.il_join(il, &key, cr, span),
                        Cr::Pending(e) => {
                            let cr = self.expr(&e, il.cx, None);
                            self.il_join(il, &key, cr, span)
                        }
                        Cr::None(why) => self.error(
                            diag::IL_NO_RESULT,
                            span,
                            format!("the code after label `{}` uses the current result, but there is none when it is reached from above ({why}); load one with LD", id.name),
                        ),
                    }
                }
                il.out.push(Stmt {
                    kind: StmtKind::Label(lid),
                    span,
                });
                il.cr = match il.labels[&key].var {
                    _ if needs && il.labels[&key].poisoned => Cr::Value(err(span)),
                    Some(v) if needs => {
                        let ty = il.cx.vars[v as usize].ty;
                        Cr::Value(load(var_place(v, ty, span)))
                    }
                    _ if needs => Cr::None("at a label reached only by a jump written after it"),
                    _ => Cr::None("after a label"),
                };
                il.dead = false;
            }
            IlKind::Op {
                op,
                negated,
                deferred,
                operand,
            } => self.il_op(il, *op, *negated, *deferred, operand.as_ref(), span),
            IlKind::Close => {
                if il.refused_open > 0 {
                    il.refused_open -= 1;
                    il.cr = Cr::Value(err(span));
                    return;
                }
                let Some(o) = il.open.pop() else {
                    self.error(
                        diag::IL_PARENS,
                        span,
                        "`)` without an open operation (AND(, ADD(, …) before it",
                    );
                    return;
                };
                let saved = match o.saved {
                    Cr::Value(x) => Some(x),
                    Cr::Pending(e) => Some(self.expr(&e, il.cx, None)),
                    Cr::None(why) => {
                        self.error(
                            diag::IL_NO_RESULT,
                            o.span,
                            format!(
                                "{}( needs the current result, but there is none here ({why}); load one with LD first",
                                o.op.name()
                            ),
                        );
                        None
                    }
                };
                let hint = saved
                    .as_ref()
                    .map(|x| x.ty)
                    .filter(|t| *t != ids::INT_LIT && *t != ids::REAL_LIT);
                let inner = self.il_take_as(il, ")", span, hint);
                let (Some(saved), Some(inner)) = (saved, inner) else {
                    il.cr = Cr::Value(err(span));
                    return;
                };
                let inner = if o.negated {
                    self.il_not(inner, o.span)
                } else {
                    inner
                };
                let bin = o.op.binary().expect("a deferred operator is binary");
                let x = self.binary_checked(bin, saved, inner, o.span.to(span));
                il.cr = Cr::Value(self.il_bounded(il, x, span));
            }
            IlKind::Jump { cond, label } => {
                if !il.open.is_empty() {
                    self.error(
                        diag::IL_NESTING,
                        span,
                        "a jump inside a parenthesised operation; close it with `)` first",
                    );
                    return;
                }
                let key = label.key();
                let Some(l) = il.labels.get(&key) else {
                    self.error(
                        diag::IL_LABEL,
                        label.span,
                        format!(
                            "no label `{}` in this body; write `{}:` before the instruction to jump to",
                            label.name, label.name
                        ),
                    );
                    return;
                };
                let (lid, needs) = (l.id, l.needs);
                let name = cond_name("JMP", *cond);
                let c = match cond {
                    Some(flag) => self.il_bool(il, &name, span).map(|c| Some((c, *flag))),
                    None => Some(None),
                };
                if needs {
                    match il.cr.clone() {
                        Cr::Value(cr) => self.il_join(il, &key, cr, span),
                        Cr::Pending(e) => {
                            let cr = self.expr(&e, il.cx, None);
                            self.il_join(il, &key, cr, span)
                        }
                        Cr::None(why) => {
                            self.error(
                                diag::IL_NO_RESULT,
                                span,
                                format!("the code after label `{}` uses the current result, but there is none at this jump ({why}); load one with LD", label.name),
                            );
                            if let Some(l) = il.labels.get_mut(&key) {
                                l.poisoned = true;
                            }
                        }
                    }
                }
                if let Some(cond) = c {
                    il.out.push(Stmt {
                        kind: StmtKind::Goto { label: lid, cond },
                        span,
                    });
                }
                if cond.is_none() {
                    il.dead = true;
                    il.cr = Cr::None("after JMP");
                }
            }
            IlKind::Call {
                cond,
                instance,
                args,
            } => {
                let call = ast::Call {
                    callee: Box::new(instance.clone()),
                    args: args.clone(),
                    span,
                };
                self.il_protect(il, None, span);
                self.il_conditional(il, *cond, "CAL", span, |ck, il| {
                    ck.call_stmt(&call, il.cx).into_iter().collect()
                });
                il.cr = Cr::None("after CAL");
            }
            IlKind::FbInput { input, instance } => self.il_fb_input(il, input, instance, span),
            IlKind::Return { cond } => {
                if !il.open.is_empty() {
                    self.error(
                        diag::IL_NESTING,
                        span,
                        "a return inside a parenthesised operation; close it with `)` first",
                    );
                    return;
                }
                self.il_conditional(il, *cond, "RET", span, |_, _| {
                    vec![Stmt {
                        kind: StmtKind::Return,
                        span,
                    }]
                });
                if cond.is_none() {
                    il.dead = true;
                    il.cr = Cr::None("after RET");
                }
            }
            IlKind::Function { name, args, formal } => {
                let mut args = args.clone();
                if !formal {
                    let first = match il.cr.clone() {
                        Cr::Pending(e) => e,
                        _ => {
                            let Some(first) = self.il_take(il, &name.name, span) else {
                                il.cr = Cr::Value(err(span));
                                return;
                            };
                            self.il_as_ast(il, first, span)
                        }
                    };
                    args.insert(
                        0,
                        ast::Arg {
                            name: None,
                            output: false,
                            negated: false,
                            span: first.span,
                            value: Some(first),
                        },
                    );
                }
                let call = ast::Expr {
                    kind: ast::ExprKind::Call(ast::Call {
                        callee: Box::new(ast::Expr {
                            kind: ast::ExprKind::Name(name.clone()),
                            span: name.span,
                        }),
                        args,
                        span,
                    }),
                    span,
                };
                if is_literal(&call) {
                    il.cr = Cr::Pending(call);
                    return;
                }
                let x = self.expr(&call, il.cx, None);
                if matches!(self.types.get(x.ty), Type::Void) {
                    self.error(
                        diag::TYPE_MISMATCH,
                        span,
                        format!("{} gives no value to become the current result; call it with CAL or from ST", name.name),
                    );
                    il.cr = Cr::Value(err(span));
                    return;
                }
                let mut r = Vec::new();
                let x = if reads(&x, &mut r) {
                    x
                } else {
                    self.il_protect(il, None, span);
                    self.il_materialise(il, x, span)
                };
                il.cr = Cr::Value(x);
            }
        }
    }

    fn il_op(
        &mut self,
        il: &mut Il<'_>,
        op: IlOp,
        negated: bool,
        deferred: bool,
        operand: Option<&ast::Expr>,
        span: Span,
    ) {
        let name = if negated {
            format!("{}N", op.name())
        } else {
            op.name().to_string()
        };
        if deferred {
            if il.open.len() >= MAX_NESTING || il.refused_open > 0 {
                if !il.too_deep {
                    il.too_deep = true;
                    self.error(
                        diag::TOO_DEEP,
                        span,
                        format!("parenthesised operations nested more than {MAX_NESTING} deep; store intermediate results with ST"),
                    );
                }
                il.refused_open += 1;
                il.cr = Cr::Value(err(span));
                return;
            }
            let saved = std::mem::replace(&mut il.cr, Cr::None("after `(`"));
            il.open.push(Open {
                op,
                negated,
                saved,
                span,
            });
            if let Some(x) = operand {
                let x = self.expr(x, il.cx, None);
                il.cr = Cr::Value(x);
            }
            return;
        }
        match op {
            IlOp::Ld => {
                let Some(x) = operand else { return };
                let x = self.expr(x, il.cx, None);
                let x = if negated { self.il_not(x, span) } else { x };
                il.cr = Cr::Value(x);
            }
            IlOp::St => {
                let Some(target) = operand else { return };
                let Some(p) = self.place(target, il.cx, true) else {
                    let _ = self.il_take(il, &name, span);
                    return;
                };
                let Some(cr) = self.il_take_as(il, &name, span, Some(p.ty)) else {
                    return;
                };
                if let Cr::Pending(_) = il.cr {
                    // Typed now: the stored value is the current result from here on.
                    il.cr = Cr::Value(cr.clone());
                }
                if !self.writable(&p, il.cx, target.span) || p.ty == ids::ERROR {
                    return;
                }
                if cr.ty == ids::ERROR {
                    return;
                }
                self.il_protect(il, Some(p.root), span);
                let value = if negated {
                    let x = if cr.ty == ids::INT_LIT {
                        self.coerce(cr.clone(), p.ty, "the operand of STN")
                    } else {
                        cr.clone()
                    };
                    self.il_not(x, span)
                } else {
                    cr.clone()
                };
                // The stored value stays the current result: read back from the target when
                // it is exactly the current result, else kept (stored first if the store
                // would change what it reads).
                let same = !negated && cr.ty == p.ty && !matches!(cr.kind, ExprKind::Const(_));
                let mut r = Vec::new();
                let pure = reads(&cr, &mut r);
                let value = if !same
                    && !matches!(cr.kind, ExprKind::Const(_))
                    && (!pure || r.contains(&p.root))
                {
                    let held = self.il_materialise(il, cr, span);
                    il.cr = Cr::Value(held.clone());
                    if negated {
                        self.il_not(held, span)
                    } else {
                        held
                    }
                } else {
                    value
                };
                let value = self.assign_value(value, p.ty, &p, target);
                if value.ty == ids::ERROR {
                    return;
                }
                il.out.push(Stmt {
                    kind: StmtKind::Assign {
                        target: p.clone(),
                        value,
                    },
                    span,
                });
                if same {
                    il.cr = Cr::Value(load(p));
                }
            }
            IlOp::S | IlOp::R => {
                let Some(target) = operand else { return };
                // `S rs` / `R sr`: the input operators of the bistables.
                let mut quiet = std::mem::take(&mut self.diags);
                let read = self.place(target, il.cx, false);
                std::mem::swap(&mut quiet, &mut self.diags);
                if read.is_some_and(|p| matches!(self.types.get(p.ty), Type::Fb(_))) {
                    let input = ast::Ident::new(op.name(), span);
                    self.il_fb_input(il, &input, target, span);
                    return;
                }
                let Some(c) = self.il_bool(il, &name, span) else {
                    return;
                };
                let Some(p) = self.place(target, il.cx, true) else {
                    return;
                };
                if !self.writable(&p, il.cx, target.span) || p.ty == ids::ERROR {
                    return;
                }
                if p.ty != ids::BOOL {
                    let t = self.types.name(p.ty);
                    self.error(
                        diag::TYPE_MISMATCH,
                        target.span,
                        format!(
                            "{name} sets or resets a BOOL, not {t}; use LD and ST for other types"
                        ),
                    );
                    return;
                }
                self.il_protect(il, Some(p.root), span);
                let mut r = Vec::new();
                let c = if !reads(&c, &mut r) || r.contains(&p.root) {
                    let held = self.il_materialise(il, c, span);
                    il.cr = Cr::Value(held.clone());
                    held
                } else {
                    c
                };
                let assign = Stmt {
                    kind: StmtKind::Assign {
                        target: p,
                        value: Expr {
                            kind: ExprKind::Const(Value::Int((op == IlOp::S) as i128)),
                            ty: ids::BOOL,
                            span,
                        },
                    },
                    span,
                };
                il.out.push(Stmt {
                    kind: StmtKind::If {
                        branches: vec![(c, vec![assign])],
                        else_body: Vec::new(),
                    },
                    span,
                });
            }
            IlOp::Not => {
                let Some(cr) = self.il_take(il, "NOT", span) else {
                    return;
                };
                let x = self.il_not(cr, span);
                il.cr = Cr::Value(self.il_bounded(il, x, span));
            }
            _ => {
                let Some(x) = operand else { return };
                let Some(cr) = self.il_take(il, &name, span) else {
                    il.cr = Cr::Value(err(span));
                    return;
                };
                let hint = Some(cr.ty).filter(|t| *t != ids::INT_LIT && *t != ids::REAL_LIT);
                let y = self.expr(x, il.cx, hint);
                let y = if negated {
                    let y = match hint {
                        Some(h) if y.ty == ids::INT_LIT => {
                            self.coerce(y, h, &format!("the operand of {name}"))
                        }
                        _ => y,
                    };
                    self.il_not(y, x.span)
                } else {
                    y
                };
                let bin = op.binary().expect("an operator with an operand");
                let r = self.binary_checked(bin, cr, y, span);
                il.cr = Cr::Value(self.il_bounded(il, r, span));
            }
        }
    }

    /// `PT timer`: the instance's input set to the current result, and the instance called.
    fn il_fb_input(
        &mut self,
        il: &mut Il<'_>,
        input: &ast::Ident,
        instance: &ast::Expr,
        span: Span,
    ) {
        let member = ast::Expr {
            kind: ast::ExprKind::Field(Box::new(instance.clone()), input.clone()),
            span: instance.span,
        };
        let place = self.place(&member, il.cx, true);
        self.il_protect(il, None, span);
        let hint = place.as_ref().map(|p| p.ty);
        if let Some(cr) = self.il_take_as(il, &input.name, span, hint) {
            if let Some(p) = place {
                if self.writable(&p, il.cx, span) && cr.ty != ids::ERROR {
                    let value = self.assign_value(cr, p.ty, &p, &member);
                    if value.ty != ids::ERROR {
                        il.out.push(Stmt {
                            kind: StmtKind::Assign { target: p, value },
                            span,
                        });
                    }
                }
            }
            let call = ast::Call {
                callee: Box::new(instance.clone()),
                args: Vec::new(),
                span,
            };
            il.out.extend(self.call_stmt(&call, il.cx));
        }
        il.cr = Cr::None("after a function block's input operator (it calls the block)");
    }

    /// The current result for an instruction that needs it (reported when there is none).
    fn il_take(&mut self, il: &mut Il<'_>, what: &str, span: Span) -> Option<Expr> {
        self.il_take_as(il, what, span, None)
    }

    /// The current result, typed as `expected` when it is still a literal function.
    fn il_take_as(
        &mut self,
        il: &mut Il<'_>,
        what: &str,
        span: Span,
        expected: Option<TypeId>,
    ) -> Option<Expr> {
        match &il.cr {
            Cr::Value(x) => Some(x.clone()),
            Cr::Pending(e) => {
                let e = e.clone();
                Some(self.expr(&e, il.cx, expected))
            }
            Cr::None(why) => {
                let why = *why;
                self.error(
                    diag::IL_NO_RESULT,
                    span,
                    format!("{what} needs the current result, but there is none here ({why}); load one first: LD x"),
                );
                // One report per missing value.
                il.cr = Cr::Value(err(span));
                None
            }
        }
    }

    /// The current result as a BOOL condition.
    fn il_bool(&mut self, il: &mut Il<'_>, what: &str, span: Span) -> Option<Expr> {
        let x = self.il_take(il, what, span)?;
        if x.ty == ids::ERROR {
            return None;
        }
        if x.ty != ids::BOOL {
            let t = self.types.name(x.ty);
            self.error(
                diag::NOT_BOOL,
                span,
                format!(
                    "{what} needs a BOOL current result, not {t}; compare it first (e.g. GT 0)"
                ),
            );
            return None;
        }
        Some(x)
    }

    /// `NOT x` on BOOL and bit strings.
    fn il_not(&mut self, x: Expr, span: Span) -> Expr {
        if x.ty == ids::ERROR {
            return x;
        }
        let ok = self.types.elem(x.ty).is_some_and(|e| e.is_bit());
        if !ok {
            let t = self.types.name(x.ty);
            let hint = if x.ty == ids::INT_LIT {
                " (give the literal a type: WORD#16#0F)"
            } else {
                ""
            };
            self.error(
                diag::OPERAND_TYPE,
                span,
                format!("NOT and the N modifier apply to BOOL and bit strings, not {t}{hint}"),
            );
            return err(span);
        }
        let ty = self.base_type(x.ty);
        self.fold(Expr {
            kind: ExprKind::Unary(UnaryOp::Not, Box::new(x)),
            ty,
            span,
        })
    }

    /// Runs `body` always, when the current result is TRUE (`C`) or FALSE (`CN`).
    fn il_conditional(
        &mut self,
        il: &mut Il<'_>,
        cond: IlCond,
        base: &str,
        span: Span,
        body: impl FnOnce(&mut Self, &mut Il<'_>) -> Vec<Stmt>,
    ) {
        let Some(flag) = cond else {
            let b = body(self, il);
            il.out.extend(b);
            return;
        };
        let name = cond_name(base, cond);
        let Some(c) = self.il_bool(il, &name, span) else {
            return;
        };
        let c = if flag {
            c
        } else {
            Expr {
                kind: ExprKind::Unary(UnaryOp::Not, Box::new(c)),
                ty: ids::BOOL,
                span,
            }
        };
        let b = body(self, il);
        il.out.push(Stmt {
            kind: StmtKind::If {
                branches: vec![(c, b)],
                else_body: Vec::new(),
            },
            span,
        });
    }

    /// Before a store into `root` (or a call, `None`: anything may change), holds the current
    /// results saved by open `OP(` that read what changes, so they keep their values.
    fn il_protect(&mut self, il: &mut Il<'_>, root: Option<Root>, span: Span) {
        for i in 0..il.open.len() {
            let Cr::Value(e) = &il.open[i].saved else {
                continue;
            };
            if matches!(e.kind, ExprKind::Const(_)) {
                continue;
            }
            let mut r = Vec::new();
            let pure = reads(e, &mut r);
            if !pure || root.is_none_or(|x| r.contains(&x)) {
                let e = e.clone();
                let held = self.il_materialise(il, e, span);
                il.open[i].saved = Cr::Value(held);
            }
        }
    }

    /// A current result just folded, stored in a hidden variable when it has grown deeper than
    /// [`FOLD_DEPTH`].
    fn il_bounded(&mut self, il: &mut Il<'_>, x: Expr, span: Span) -> Expr {
        if x.depth() > FOLD_DEPTH {
            self.il_materialise(il, x, span)
        } else {
            x
        }
    }

    /// A new hidden variable of the POU.
    fn il_var(&mut self, il: &mut Il<'_>, ty: TypeId, span: Span) -> VarId {
        let id = il.cx.vars.len() as VarId;
        let name = format!("$il{id}");
        il.cx.vars.push(Var {
            name: name.clone(),
            ty,
            class: VarClass::Hidden,
            init: None,
            constant: false,
            retain: false,
            location: None,
            span,
        });
        // Reachable by name from the syntax trees this front end builds (`$` starts no
        // identifier a source can spell).
        il.cx.names.insert(name.to_ascii_uppercase(), id);
        id
    }

    /// Stores the current result in a hidden variable; returns the load of it.
    fn il_materialise(&mut self, il: &mut Il<'_>, x: Expr, span: Span) -> Expr {
        if x.ty == ids::ERROR || matches!(x.kind, ExprKind::Const(_)) {
            return x;
        }
        let ty = self.settle_type(x.ty, None);
        let x = self.coerce(x, ty, "the current result");
        let v = self.il_var(il, ty, span);
        let p = var_place(v, ty, span);
        il.out.push(Stmt {
            kind: StmtKind::Assign {
                target: p.clone(),
                value: x,
            },
            span,
        });
        load(p)
    }

    /// Stores the current result for a label whose code uses it.
    fn il_join(&mut self, il: &mut Il<'_>, key: &str, x: Expr, span: Span) {
        if x.ty == ids::ERROR {
            if let Some(l) = il.labels.get_mut(key) {
                l.poisoned = true;
            }
            return;
        }
        let var = match il.labels.get(key).and_then(|l| l.var) {
            Some(v) => v,
            None => {
                let target = il.labels.get(key).and_then(|l| l.target.clone());
                let wanted = match target {
                    Some(t) if x.ty == ids::INT_LIT || x.ty == ids::REAL_LIT => {
                        let mut quiet = std::mem::take(&mut self.diags);
                        let p = self.place(&t, il.cx, false);
                        std::mem::swap(&mut quiet, &mut self.diags);
                        p.map(|p| p.ty)
                            .filter(|t| self.types.elem(*t).is_some_and(|e| e.is_num()))
                    }
                    _ => None,
                };
                let ty = self.settle_type(x.ty, wanted);
                let v = self.il_var(il, ty, span);
                if let Some(l) = il.labels.get_mut(key) {
                    l.var = Some(v);
                }
                v
            }
        };
        let ty = il.cx.vars[var as usize].ty;
        let x = self.coerce(x, ty, "the current result carried to the label");
        if x.ty == ids::ERROR {
            return;
        }
        il.out.push(Stmt {
            kind: StmtKind::Assign {
                target: var_place(var, ty, span),
                value: x,
            },
            span,
        });
    }

    /// The current result as a syntax tree (for calls checked from syntax): a literal or a
    /// variable's name as they are, anything else through a hidden variable.
    fn il_as_ast(&mut self, il: &mut Il<'_>, x: Expr, span: Span) -> ast::Expr {
        if x.ty == ids::ERROR {
            return ast::Expr {
                kind: ast::ExprKind::Error,
                span,
            };
        }
        let lit = match (&x.kind, self.types.get(x.ty)) {
            (ExprKind::Const(Value::Int(v)), Type::IntLit) => Some(ast::Literal::Int {
                value: *v,
                ty: None,
            }),
            (ExprKind::Const(Value::Real(v)), Type::RealLit) => Some(ast::Literal::Real {
                value: *v,
                ty: None,
            }),
            (ExprKind::Const(Value::Int(v)), _) if x.ty == ids::BOOL => Some(ast::Literal::Bool {
                value: *v != 0,
                ty: None,
            }),
            _ => None,
        };
        if let Some(l) = lit {
            return ast::Expr {
                kind: ast::ExprKind::Literal(l),
                span,
            };
        }
        let held = match &x.kind {
            ExprKind::Load(p) if p.path.is_empty() && matches!(p.root, Root::Var(_)) => x,
            ExprKind::Const(_) => {
                // A typed constant (BYTE#1): held like any other value.
                let v = self.il_var(il, x.ty, span);
                let p = var_place(v, x.ty, span);
                il.out.push(Stmt {
                    kind: StmtKind::Assign {
                        target: p.clone(),
                        value: x,
                    },
                    span,
                });
                load(p)
            }
            _ => self.il_materialise(il, x, span),
        };
        let ExprKind::Load(Place {
            root: Root::Var(v), ..
        }) = held.kind
        else {
            return ast::Expr {
                kind: ast::ExprKind::Error,
                span,
            };
        };
        let name = il.cx.vars[v as usize].name.clone();
        il.cx.names.entry(name.to_ascii_uppercase()).or_insert(v);
        ast::Expr {
            kind: ast::ExprKind::Name(ast::Ident::new(name, span)),
            span,
        }
    }
}
