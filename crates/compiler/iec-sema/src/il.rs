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
use crate::ir::{Expr, ExprKind, Place, Root, Stmt, StmtKind, UnaryOp, VarId};
use crate::types::{ids, TypeId};

mod instr;
mod result;
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
        ExprKind::Load(p) | ExprKind::Ref(p) => place_reads(p, out),
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
        match s {
            crate::ir::Step::Index(ix) => {
                for i in ix {
                    ok &= reads(i, out);
                }
            }
            // Behind a reference any variable may be read: evaluate it once.
            crate::ir::Step::Deref | crate::ir::Step::Value(_) => ok = false,
            _ => {}
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
}
