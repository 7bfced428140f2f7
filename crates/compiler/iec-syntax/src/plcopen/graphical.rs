//! Ladder Diagram and Sequential Function Chart bodies of PLCopen XML lowered to Structured
//! Text statements, so that they are checked and compiled by the same checker and VM as ST
//! (one lowered form for every language).
//!
//! LD: the elements that do something (coils, block instances, output variables, returns) are
//! taken in document order (or by `executionOrderId` when a tool gives one); the power that
//! reaches each is built from its connections: a left rail is TRUE, a contact ANDs its
//! variable (negated, rising or falling) with its input, several connections on one input are
//! OR-ed (parallel branches), a coil passes its input on. A value read by several elements is
//! computed once into a hidden variable (`__g<localId>`), so every element sees the rung as it
//! was when the value was computed. A block with an instance name is called once per scan,
//! before the first element that reads one of its outputs; a function without instance is
//! inlined where its result is used.
//!
//! SFC: every step is a variable of the hidden structure `__SFC_STEP` (`S.X`, `S.T`). A scan
//! updates step times, clears every transition whose preceding steps are all active and whose
//! condition is TRUE, judged on the steps active at the start of the scan (in a selection
//! divergence the first by `priority`, then left to right, then document order, wins), deactivates the steps
//! before the cleared transitions and activates those after them, and then runs the actions
//! of the active steps by their qualifiers (N, S, R, P, P1, P0, L, D).
//!
//! Every generated node carries the span of its element, a source whose messages name the
//! element (`LD contact localId 3 (start)`) instead of a line and column.

use std::collections::{HashMap, HashSet};

use super::Reader;
use crate::ast::*;
use crate::diag::{self, Diagnostics};
use crate::lexer::TimeKind;
use crate::parser;
use crate::source::{FileId, Span};
use crate::xml::Element as X;

/// The longest chain of elements one value is built from (each link is a few stack frames
/// here and a level of nesting in the checker).
const MAX_CHAIN: usize = 256;

/// The most values one body may compute. A function's result is inlined where it is used, so
/// functions feeding each other on two wires each double the work: past this, the body is
/// refused rather than expanded for ever.
const MAX_WORK: usize = 200_000;

/// The hidden structure type of SFC steps.
pub(super) const STEP_TYPE: &str = "__SFC_STEP";

/// What a graphical body becomes: statements and the hidden variables they use.
pub(super) struct Lowered {
    pub stmts: Vec<Stmt>,
    pub vars: Vec<VarDecl>,
    pub steps: bool,
}

/// The declaration of [`STEP_TYPE`] (`X : BOOL; T : TIME;`).
pub(super) fn step_type(span: Span) -> TypeDecl {
    let field = |n: &str, t: &str| VarDecl {
        names: vec![Ident::new(n, span)],
        location: None,
        ty: TypeSpec::Named(Ident::new(t, span)),
        init: None,
        edge: None,
        span,
    };
    TypeDecl {
        name: Ident::new(STEP_TYPE, span),
        spec: TypeSpec::Struct {
            fields: vec![field("X", "BOOL"), field("T", "TIME")],
            span,
        },
        init: None,
        span,
    }
}

// Small builders of the tree.
fn name(n: &str, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Name(Ident::new(n, span)),
        span,
    }
}
fn field(e: Expr, f: &str) -> Expr {
    let span = e.span;
    Expr {
        kind: ExprKind::Field(Box::new(e), Ident::new(f, span)),
        span,
    }
}
fn boolean(v: bool, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Literal(Literal::Bool { value: v, ty: None }),
        span,
    }
}
fn time(nanos: i128, span: Span) -> Expr {
    Expr {
        kind: ExprKind::Literal(Literal::Time {
            kind: TimeKind::Time,
            nanos,
        }),
        span,
    }
}
fn not(e: Expr) -> Expr {
    let span = e.span;
    Expr {
        kind: ExprKind::Unary(UnaryOp::Not, Box::new(e)),
        span,
    }
}
fn bin(op: BinaryOp, a: Expr, b: Expr) -> Expr {
    let span = b.span;
    Expr {
        kind: ExprKind::Binary(op, Box::new(a), Box::new(b)),
        span,
    }
}
fn is_true(e: &Expr) -> bool {
    matches!(e.kind, ExprKind::Literal(Literal::Bool { value: true, .. }))
}
/// `a AND b`, dropping a TRUE operand (a contact right after the rail).
fn and(a: Expr, b: Expr) -> Expr {
    if is_true(&a) {
        b
    } else if is_true(&b) {
        a
    } else {
        bin(BinaryOp::And, a, b)
    }
}
/// `op` over terms: from left to right as written for a few, as a balanced tree for many, so
/// that an input wired to thousands of branches (or a step with thousands of transitions)
/// gives a tree a dozen levels deep rather than thousands.
fn fold_terms(op: BinaryOp, mut es: Vec<Expr>) -> Option<Expr> {
    const IN_A_ROW: usize = 8;
    if es.len() <= IN_A_ROW {
        let mut es = es.into_iter();
        let first = es.next()?;
        return Some(es.fold(first, |a, b| bin(op, a, b)));
    }
    let right = es.split_off(es.len() / 2);
    Some(bin(op, fold_terms(op, es)?, fold_terms(op, right)?))
}
fn any(es: Vec<Expr>, span: Span) -> Expr {
    fold_terms(BinaryOp::Or, es).unwrap_or_else(|| boolean(false, span))
}
/// The AND of the terms, TRUE ones dropped.
fn all(es: Vec<Expr>, span: Span) -> Expr {
    let es = es.into_iter().filter(|e| !is_true(e)).collect();
    fold_terms(BinaryOp::And, es).unwrap_or_else(|| boolean(true, span))
}
fn assign(target: Expr, value: Expr) -> Stmt {
    let span = target.span;
    Stmt {
        kind: StmtKind::Assign { target, value },
        span,
    }
}
fn when(cond: Expr, body: Vec<Stmt>) -> Stmt {
    let span = cond.span;
    Stmt {
        kind: StmtKind::If {
            branches: vec![(cond, body)],
            else_body: None,
        },
        span,
    }
}
fn arg(n: &str, value: Expr) -> Arg {
    let span = value.span;
    Arg {
        name: Some(Ident::new(n, span)),
        output: false,
        negated: false,
        value: Some(value),
        span,
    }
}
fn call(callee: Expr, args: Vec<Arg>) -> Call {
    let span = callee.span;
    Call {
        callee: Box::new(callee),
        args,
        span,
    }
}
fn decl(n: &str, ty: &str, init: Option<Init>, span: Span) -> VarDecl {
    VarDecl {
        names: vec![Ident::new(n, span)],
        location: None,
        ty: TypeSpec::Named(Ident::new(ty, span)),
        init,
        edge: None,
        span,
    }
}

fn local_id(el: &X) -> Option<u64> {
    el.attr("localId").and_then(|v| v.trim().parse().ok())
}
fn flag(el: &X, attr: &str) -> bool {
    matches!(el.attr(attr), Some("true" | "1"))
}

/// The connections of one `connectionPointIn`: (refLocalId, formalParameter).
fn connections(cpi: &X) -> Vec<(Option<u64>, Option<String>, &X)> {
    cpi.children_named("connection")
        .map(|c| {
            (
                c.attr("refLocalId").and_then(|v| v.trim().parse().ok()),
                c.attr("formalParameter")
                    .map(str::trim)
                    .filter(|f| !f.is_empty())
                    .map(str::to_string),
                c,
            )
        })
        .collect()
}

/// Every connection into an element, whatever its kind.
fn all_inputs(el: &X) -> Vec<(Option<u64>, Option<String>, &X)> {
    let mut out = Vec::new();
    for c in &el.children {
        match c.name.as_str() {
            "connectionPointIn" => out.extend(connections(c)),
            "inputVariables" | "inOutVariables" => {
                for v in c.children_named("variable") {
                    if let Some(cpi) = v.child("connectionPointIn") {
                        out.extend(connections(cpi));
                    }
                }
            }
            "condition" => {
                if let Some(cpi) = c.child("connectionPointIn") {
                    out.extend(connections(cpi));
                }
                out.extend(connections(c));
            }
            _ => {}
        }
    }
    out
}

/// Lowering of one body.
struct Lower<'r, 'a, 'x> {
    r: &'r mut Reader<'a>,
    pou: String,
    lang: &'static str,
    els: Vec<&'x X>,
    by_id: HashMap<u64, usize>,
    connectors: HashMap<String, usize>,
    uses: HashMap<(usize, String), u32>,
    memo: HashMap<(usize, String), Expr>,
    called: HashSet<usize>,
    visiting: HashSet<usize>,
    files: HashMap<usize, FileId>,
    stmts: Vec<Stmt>,
    vars: Vec<VarDecl>,
    declared: HashSet<String>,
    /// Prefix of hidden names (`__g`, or `__g_<action>_` for a nested body).
    prefix: String,
    /// Values computed so far (bounded by [`MAX_WORK`]).
    work: usize,
}

/// The expression text an element holds (`<variable>`, `<expression>`) and where it starts.
fn held_text(el: &X) -> (String, usize) {
    for n in ["variable", "expression"] {
        if let Some(c) = el.child(n) {
            return (c.text.clone(), c.text_start.unwrap_or(c.start));
        }
    }
    (String::new(), el.start)
}

impl<'r, 'a, 'x> Lower<'r, 'a, 'x> {
    fn new(r: &'r mut Reader<'a>, pou: &str, lang: &'static str, body: &'x X) -> Self {
        let mut els = Vec::new();
        for c in &body.children {
            if !matches!(c.name.as_str(), "comment" | "documentation" | "addData") {
                els.push(c);
            }
        }
        let mut l = Lower {
            r,
            pou: pou.to_string(),
            lang,
            els,
            by_id: HashMap::new(),
            connectors: HashMap::new(),
            uses: HashMap::new(),
            memo: HashMap::new(),
            called: HashSet::new(),
            visiting: HashSet::new(),
            files: HashMap::new(),
            stmts: Vec::new(),
            vars: Vec::new(),
            declared: HashSet::new(),
            prefix: "__g".into(),
            work: 0,
        };
        for i in 0..l.els.len() {
            let el = l.els[i];
            match local_id(el) {
                Some(id) => {
                    if l.by_id.insert(id, i).is_some() {
                        let span = l.span(i);
                        l.r.diags.error(
                            diag::GRAPHICAL,
                            span,
                            format!("localId {id} is used by two elements; give every element of the body its own localId"),
                        );
                    }
                }
                None => {
                    if el.name != "actionBlock" || el.attr("localId").is_some() {
                        let span = l.span(i);
                        l.r.diags.error(
                            diag::PLCOPEN_STRUCTURE,
                            span,
                            format!("<{}> has no localId attribute (a number)", el.name),
                        );
                    }
                }
            }
            if el.name == "connector" {
                if let Some(n) = el.attr("name") {
                    l.connectors.insert(n.trim().to_ascii_uppercase(), i);
                }
            }
        }
        for i in 0..l.els.len() {
            // The right rail reads nothing: a coil wired to it is not read again.
            if l.els[i].name == "rightPowerRail" {
                continue;
            }
            for (rf, fp, _) in all_inputs(l.els[i]) {
                if let Some(j) = rf.and_then(|rf| l.by_id.get(&rf).copied()) {
                    let key = (j, l.out_key(j, fp.as_deref()));
                    *l.uses.entry(key).or_default() += 1;
                }
            }
        }
        l
    }

    /// Only a block has several outputs; every other element has one.
    fn out_key(&self, i: usize, fp: Option<&str>) -> String {
        if self.els[i].name == "block" {
            fp.unwrap_or("").to_ascii_uppercase()
        } else {
            String::new()
        }
    }

    /// The source of element `i`: its expression text, named by the element in messages.
    fn file(&mut self, i: usize) -> FileId {
        if let Some(f) = self.files.get(&i) {
            return *f;
        }
        let el = self.els[i];
        let (text, at) = held_text(el);
        let id = el
            .attr("localId")
            .map_or_else(String::new, |v| format!(" localId {}", v.trim()));
        let what = match el.name.as_str() {
            "block" => match el.attr("instanceName").filter(|n| !n.trim().is_empty()) {
                Some(inst) => format!(" ({} {})", el.attr("typeName").unwrap_or("?"), inst),
                None => format!(" ({})", el.attr("typeName").unwrap_or("?")),
            },
            "step" | "transition" | "connector" | "continuation" | "macroStep" => {
                match el.attr("name").filter(|n| !n.trim().is_empty()) {
                    Some(n) => format!(" ({n})"),
                    None => String::new(),
                }
            }
            "jumpStep" => format!(" (to {})", el.attr("targetName").unwrap_or("?")),
            _ if !text.trim().is_empty() => format!(" ({})", text.trim()),
            _ => String::new(),
        };
        let label = format!("POU {}, {} {}{id}{what}", self.pou, self.lang, el.name);
        let (l, c) = self.r.base_of(at);
        let f = self
            .r
            .map
            .add_element(self.r.name.clone(), text, l, c, label);
        self.files.insert(i, f);
        f
    }

    fn span(&mut self, i: usize) -> Span {
        let f = self.file(i);
        Span::new(f, 0, 0)
    }

    fn error(&mut self, i: usize, code: diag::Code, msg: String) {
        let span = self.span(i);
        self.r.diags.error(code, span, msg);
    }

    /// The expression an element holds (`<variable>`, `<expression>`).
    fn held(&mut self, i: usize) -> Option<Expr> {
        let (text, _) = held_text(self.els[i]);
        if text.trim().is_empty() {
            let what = if self.els[i].name.ends_with("Variable") {
                "<expression>"
            } else {
                "<variable>"
            };
            self.error(
                i,
                diag::PLCOPEN_STRUCTURE,
                format!(
                    "<{}> has no {what} naming what it reads or writes",
                    self.els[i].name
                ),
            );
            return None;
        }
        let f = self.file(i);
        parser::parse_expression(f, &text, self.r.diags)
    }

    fn hidden(&mut self, n: &str, ty: &str, init: Option<Init>, span: Span) -> Expr {
        if self.declared.insert(n.to_ascii_uppercase()) {
            self.vars.push(decl(n, ty, init, span));
        }
        name(n, span)
    }

    /// Keeps a BOOL value in a hidden variable and returns the variable.
    fn materialize(&mut self, i: usize, e: Expr) -> Expr {
        let span = self.span(i);
        let id = local_id(self.els[i]).unwrap_or(i as u64);
        let v = self.hidden(&format!("{}{id}", self.prefix), "BOOL", None, span);
        self.stmts.push(assign(v.clone(), e));
        v
    }

    /// The power (or value) arriving at a connection point: the OR of its connections.
    fn input(&mut self, i: usize, cpi: Option<&'x X>) -> Option<Expr> {
        let span = self.span(i);
        let conns = cpi.map(connections).unwrap_or_default();
        if conns.is_empty() {
            self.error(
                i,
                diag::GRAPHICAL,
                format!("<{}> is connected to nothing on its input; connect it to a power rail or another element", self.els[i].name),
            );
            return None;
        }
        let mut es = Vec::new();
        for (rf, fp, _) in conns {
            es.push(self.value_of(i, rf, fp.as_deref())?);
        }
        Some(any(es, span))
    }

    fn value_of(&mut self, from: usize, rf: Option<u64>, fp: Option<&str>) -> Option<Expr> {
        let Some(j) = rf.and_then(|rf| self.by_id.get(&rf).copied()) else {
            self.error(
                from,
                diag::GRAPHICAL,
                format!(
                    "a connection refers to localId {}, which no element of the body has",
                    rf.map_or("(missing)".to_string(), |r| r.to_string())
                ),
            );
            return None;
        };
        self.value(j, fp)
    }

    /// The value element `i` puts on its output `fp`.
    fn value(&mut self, i: usize, fp: Option<&str>) -> Option<Expr> {
        let key = (i, self.out_key(i, fp));
        if let Some(e) = self.memo.get(&key) {
            return Some(e.clone());
        }
        let block = self.els[i].name == "block";
        self.work += 1;
        if self.work > MAX_WORK {
            if self.work == MAX_WORK + 1 {
                self.error(
                    i,
                    diag::GRAPHICAL,
                    format!("this body computes more than {MAX_WORK} values (function results used several times are inlined at every use); store shared results in variables"),
                );
            }
            return None;
        }
        if self.visiting.len() > MAX_CHAIN {
            self.error(
                i,
                diag::GRAPHICAL,
                format!("this element is more than {MAX_CHAIN} elements away from a rail or a variable; split the network with a variable"),
            );
            return None;
        }
        if !block && !self.visiting.insert(i) {
            self.error(
                i,
                diag::GRAPHICAL,
                "this element feeds its own input (a loop in the network); break the loop with a variable".into(),
            );
            return None;
        }
        let r = self.compute(i, fp);
        if !block {
            self.visiting.remove(&i);
        }
        let mut e = r?;
        let el = self.els[i];
        let shared = self.uses.get(&key).copied().unwrap_or(0) > 1;
        if el.name == "contact" && shared && !matches!(e.kind, ExprKind::Name(_)) {
            e = self.materialize(i, e);
        }
        if el.name != "block" {
            self.memo.insert(key, e.clone());
        }
        Some(e)
    }

    fn compute(&mut self, i: usize, fp: Option<&str>) -> Option<Expr> {
        let el = self.els[i];
        let span = self.span(i);
        match el.name.as_str() {
            "leftPowerRail" => Some(boolean(true, span)),
            "contact" => {
                let pw = self.input(i, el.child("connectionPointIn"))?;
                let v = self.held(i)?;
                let term = match el.attr("edge") {
                    Some("rising") | Some("falling") => {
                        let id = local_id(el).unwrap_or(i as u64);
                        let m = self.hidden(&format!("{}{id}_m", self.prefix), "BOOL", None, span);
                        let t = self.hidden(&format!("{}{id}_e", self.prefix), "BOOL", None, span);
                        let edge = if el.attr("edge") == Some("rising") {
                            and(v.clone(), not(m.clone()))
                        } else {
                            and(not(v.clone()), m.clone())
                        };
                        self.stmts.push(assign(t.clone(), edge));
                        self.stmts.push(assign(m, v));
                        t
                    }
                    _ => v,
                };
                let term = if flag(el, "negated") { not(term) } else { term };
                Some(and(pw, term))
            }
            "coil" => {
                // Read before the coil writes: the coil's own statement uses the same value.
                let pw = self.input(i, el.child("connectionPointIn"))?;
                let read = self.uses.get(&(i, String::new())).copied().unwrap_or(0) > 0;
                if !read || matches!(pw.kind, ExprKind::Name(_) | ExprKind::Literal(_)) {
                    Some(pw)
                } else {
                    Some(self.materialize(i, pw))
                }
            }
            "inVariable" | "inOutVariable" => {
                let v = self.held(i)?;
                Some(if flag(el, "negated") { not(v) } else { v })
            }
            "continuation" => {
                let n = el.attr("name").unwrap_or("").trim().to_ascii_uppercase();
                match self.connectors.get(&n).copied() {
                    Some(c) => {
                        let cpi = self.els[c].child("connectionPointIn");
                        self.input(c, cpi)
                    }
                    None => {
                        self.error(
                            i,
                            diag::GRAPHICAL,
                            format!("continuation {n} has no connector of that name; add a <connector name=\"{n}\">"),
                        );
                        None
                    }
                }
            }
            "block" => self.block_output(i, fp),
            other => {
                self.error(
                    i,
                    diag::GRAPHICAL,
                    format!("a connection reads from <{other}>, which has no output value"),
                );
                None
            }
        }
    }

    /// The inputs of a block as call arguments, and its EN input when connected.
    fn block_args(&mut self, i: usize) -> Option<(Vec<Arg>, Option<Expr>)> {
        let el = self.els[i];
        let mut args = Vec::new();
        let mut en = None;
        let mut ok = true;
        for group in ["inputVariables", "inOutVariables"] {
            for v in el
                .child(group)
                .into_iter()
                .flat_map(|g| g.children_named("variable"))
            {
                let Some(fpn) = v.attr("formalParameter").map(str::trim) else {
                    self.error(
                        i,
                        diag::PLCOPEN_STRUCTURE,
                        "a block <variable> has no formalParameter".into(),
                    );
                    ok = false;
                    continue;
                };
                let Some(cpi) = v.child("connectionPointIn") else {
                    continue;
                };
                if connections(cpi).is_empty() {
                    continue;
                }
                let Some(mut e) = self.input(i, Some(cpi)) else {
                    ok = false;
                    continue;
                };
                if flag(v, "negated") {
                    e = not(e);
                }
                if matches!(v.attr("edge"), Some("rising" | "falling")) {
                    self.error(
                        i,
                        diag::UNSUPPORTED,
                        format!("input {fpn} of this block detects an edge, which the engine does not support on block inputs; put a contact with the edge before it"),
                    );
                    ok = false;
                }
                if fpn.eq_ignore_ascii_case("EN") {
                    en = Some(e);
                } else {
                    args.push(arg(fpn, e));
                }
            }
        }
        ok.then_some((args, en))
    }

    fn instance(el: &X) -> Option<&str> {
        el.attr("instanceName")
            .map(str::trim)
            .filter(|n| !n.is_empty())
    }

    /// Calls a block instance once, before the first element that reads it.
    fn call_block(&mut self, i: usize) -> Option<()> {
        if self.called.contains(&i) {
            return Some(());
        }
        let el = self.els[i];
        let span = self.span(i);
        let inst = Self::instance(el).unwrap_or("").to_string();
        if !self.visiting.insert(i) {
            // Already being called: a block feeding itself.
            self.error(
                i,
                diag::GRAPHICAL,
                "this block feeds its own input (a loop in the network); break the loop with a variable".into(),
            );
            return None;
        }
        let r = self.block_args(i);
        self.visiting.remove(&i);
        let (args, en) = r?;
        self.called.insert(i);
        let stmt = Stmt {
            kind: StmtKind::Call(call(name(&inst, span), args)),
            span,
        };
        match en {
            Some(en) if !is_true(&en) => {
                let en = match en.kind {
                    ExprKind::Name(_) => en,
                    _ => self.materialize(i, en),
                };
                self.memo.insert((i, "ENO".into()), en.clone());
                self.stmts.push(when(en, vec![stmt]));
            }
            _ => {
                self.memo.insert((i, "ENO".into()), boolean(true, span));
                self.stmts.push(stmt);
            }
        }
        Some(())
    }

    fn block_output(&mut self, i: usize, fp: Option<&str>) -> Option<Expr> {
        let el = self.els[i];
        let span = self.span(i);
        let ty = el.attr("typeName").unwrap_or("").trim().to_string();
        if ty.is_empty() {
            self.error(i, diag::PLCOPEN_STRUCTURE, "<block> has no typeName".into());
            return None;
        }
        let fp = fp.unwrap_or("");
        if let Some(inst) = Self::instance(el) {
            let inst = inst.to_string();
            if self.visiting.contains(&i) && !fp.eq_ignore_ascii_case("ENO") && !fp.is_empty() {
                // Feedback: the output of the instance's previous call (IEC 61131-3 FBD).
                return Some(field(name(&inst, span), fp));
            }
            self.call_block(i)?;
            if fp.eq_ignore_ascii_case("ENO") {
                return self.memo.get(&(i, "ENO".into())).cloned();
            }
            if fp.is_empty() {
                self.error(
                    i,
                    diag::GRAPHICAL,
                    format!("a connection from block {inst} names no output; give it formalParameter=\"Q\" (or the output it reads)"),
                );
                return None;
            }
            return Some(field(name(&inst, span), fp));
        }
        // A function: its result, inlined where it is used.
        if !(fp.is_empty()
            || fp.eq_ignore_ascii_case("OUT")
            || fp.eq_ignore_ascii_case(&ty)
            || fp.eq_ignore_ascii_case("ENO"))
        {
            self.error(
                i,
                diag::UNSUPPORTED,
                format!("output {fp} of function {ty}: only a function's result can be connected in LD; call it from ST to use its other outputs"),
            );
            return None;
        }
        if !self.visiting.insert(usize::MAX - i) {
            return None;
        }
        let r = self.block_args(i);
        self.visiting.remove(&(usize::MAX - i));
        let (args, en) = r?;
        if let Some(en) = en {
            if !is_true(&en) {
                self.error(
                    i,
                    diag::UNSUPPORTED,
                    format!("EN of function {ty} is connected to a condition; the engine runs functions without EN/ENO: connect EN to the left rail, or use a block instance"),
                );
                return None;
            }
        }
        if fp.eq_ignore_ascii_case("ENO") {
            return Some(boolean(true, span));
        }
        Some(Expr {
            kind: ExprKind::Call(call(name(&ty, span), args)),
            span,
        })
    }

    /// Statements of the elements that act, in execution order.
    fn network(&mut self, skip: &HashSet<usize>) {
        let mut order: Vec<usize> = (0..self.els.len()).filter(|i| !skip.contains(i)).collect();
        order.sort_by_key(|&i| {
            self.els[i]
                .attr("executionOrderId")
                .and_then(|v| v.trim().parse::<u64>().ok())
                .unwrap_or(0)
        });
        for i in order {
            let el = self.els[i];
            match el.name.as_str() {
                "coil" => self.coil(i),
                "outVariable" | "inOutVariable" => {
                    let cpi = el.child("connectionPointIn");
                    if el.name == "inOutVariable"
                        && cpi.is_none_or(|c| connections(c).is_empty())
                    {
                        continue;
                    }
                    let (Some(v), Some(mut e)) = (self.held(i), self.input(i, cpi)) else {
                        continue;
                    };
                    if flag(el, "negatedIn") || (el.name == "outVariable" && flag(el, "negated"))
                    {
                        e = not(e);
                    }
                    self.stmts.push(assign(v, e));
                }
                "block" => {
                    if Self::instance(el).is_some() {
                        let _ = self.call_block(i);
                    }
                }
                "return" => {
                    let span = self.span(i);
                    if let Some(pw) = self.input(i, el.child("connectionPointIn")) {
                        let ret = Stmt {
                            kind: StmtKind::Return,
                            span,
                        };
                        if is_true(&pw) {
                            self.stmts.push(ret);
                        } else {
                            self.stmts.push(when(pw, vec![ret]));
                        }
                    }
                }
                "jump" | "label" => self.error(
                    i,
                    diag::UNSUPPORTED,
                    format!("<{}> in a graphical body is not supported yet; use a condition on the rungs instead", el.name),
                ),
                "leftPowerRail" | "rightPowerRail" | "contact" | "inVariable" | "connector"
                | "continuation" => {}
                other => {
                    if self.lang == "LD" {
                        self.error(
                            i,
                            diag::GRAPHICAL,
                            format!("<{other}> is not an element of a Ladder Diagram; LD has rails, contacts, coils, blocks, variables, connectors, jumps and returns"),
                        );
                    }
                }
            }
        }
    }

    fn coil(&mut self, i: usize) {
        let el = self.els[i];
        let span = self.span(i);
        let Some(pw) = self.value(i, None) else {
            return;
        };
        // A type error in what the coil writes is the coil's.
        let pw = Expr {
            kind: ExprKind::Paren(Box::new(pw)),
            span,
        };
        let Some(v) = self.held(i) else {
            return;
        };
        let stmt = match (el.attr("storage"), el.attr("edge")) {
            (Some("set"), _) => when(pw, vec![assign(v, boolean(true, span))]),
            (Some("reset"), _) => when(pw, vec![assign(v, boolean(false, span))]),
            (_, Some(e @ ("rising" | "falling"))) => {
                let id = local_id(el).unwrap_or(i as u64);
                let m = self.hidden(&format!("{}{id}_m", self.prefix), "BOOL", None, span);
                let edge = if e == "rising" {
                    and(pw.clone(), not(m.clone()))
                } else {
                    and(not(pw.clone()), m.clone())
                };
                let edge = if flag(el, "negated") { not(edge) } else { edge };
                self.stmts.push(assign(v, edge));
                assign(m, pw)
            }
            _ if flag(el, "negated") => assign(v, not(pw)),
            _ => assign(v, pw),
        };
        self.stmts.push(stmt);
    }

    fn finish(self) -> Lowered {
        Lowered {
            stmts: self.stmts,
            vars: self.vars,
            steps: false,
        }
    }
}

/// Lowers an `<LD>` (or `<FBD>`) body.
pub(super) fn ld(r: &mut Reader, pou: &str, body: &X) -> Lowered {
    network_body(r, pou, body, "__g")
}

fn network_body(r: &mut Reader, pou: &str, body: &X, prefix: &str) -> Lowered {
    let lang = if body.name == "FBD" { "FBD" } else { "LD" };
    let mut l = Lower::new(r, pou, lang, body);
    l.prefix = prefix.to_string();
    l.network(&HashSet::new());
    l.finish()
}

/// A nested LD/FBD body (an action's, a transition's) lowered into `l`'s statements.
fn nested(l: &mut Lower, what: &str, body: &X) -> Vec<Stmt> {
    let pou = format!("{}, {what}", l.pou);
    let key: String = what
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    let prefix = format!("__g_{key}_");
    let inner = network_body(l.r, &pou, body, &prefix);
    for v in inner.vars {
        if l.declared.insert(v.names[0].key()) {
            l.vars.push(v);
        }
    }
    inner.stmts
}

/// One action association of an action block.
struct Assoc {
    step: usize,
    qualifier: String,
    duration: Option<Expr>,
    target: usize,
}

enum Target {
    /// A BOOL variable set while the action is active.
    Variable(Expr),
    /// Statements run while the action is active.
    Body(Vec<Stmt>),
}

/// Lowers an `<SFC>` body of POU element `pou_el`.
pub(super) fn sfc(r: &mut Reader, pou: &str, pou_el: &X, body: &X) -> Lowered {
    let mut l = Lower::new(r, pou, "SFC", body);
    let n = l.els.len();
    let kind = |l: &Lower, i: usize| l.els[i].name.clone();
    // Steps.
    let mut steps: Vec<usize> = Vec::new();
    let mut step_of: HashMap<String, usize> = HashMap::new();
    for i in 0..n {
        match kind(&l, i).as_str() {
            "step" => {
                let Some(sn) = l.els[i]
                    .attr("name")
                    .map(str::trim)
                    .filter(|s| !s.is_empty())
                else {
                    l.error(i, diag::PLCOPEN_STRUCTURE, "<step> has no name".into());
                    continue;
                };
                if step_of.insert(sn.to_ascii_uppercase(), i).is_some() {
                    l.error(
                        i,
                        diag::GRAPHICAL,
                        format!("step {sn} is drawn twice; give each step its own name"),
                    );
                }
                steps.push(i);
            }
            "macroStep" => l.error(
                i,
                diag::UNSUPPORTED,
                "macro steps are not supported yet; draw the steps of the macro in the chart"
                    .into(),
            ),
            _ => {}
        }
    }
    if !steps.iter().any(|&s| flag(l.els[s], "initialStep")) && !steps.is_empty() {
        let s = steps[0];
        l.error(
            s,
            diag::GRAPHICAL,
            "the chart has no initial step; mark one step initialStep=\"true\"".into(),
        );
    }
    // Successors of every element, by connection.
    let mut succ: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in 0..n {
        if kind(&l, i) == "actionBlock" {
            continue;
        }
        for (rf, _, _) in all_inputs(l.els[i]) {
            if let Some(j) = rf.and_then(|rf| l.by_id.get(&rf).copied()) {
                succ[j].push(i);
            }
        }
    }
    let transitions: Vec<usize> = (0..n).filter(|&i| kind(&l, i) == "transition").collect();
    // Steps before and after each transition.
    let mut pre: HashMap<usize, Vec<usize>> = HashMap::new();
    let mut post: HashMap<usize, Vec<usize>> = HashMap::new();
    for &t in &transitions {
        let mut before = Vec::new();
        let mut stack: Vec<usize> = Vec::new();
        let cpi = l.els[t].child("connectionPointIn");
        for (rf, _, _) in cpi.map(connections).unwrap_or_default() {
            match rf.and_then(|rf| l.by_id.get(&rf).copied()) {
                Some(j) => stack.push(j),
                None => l.error(
                    t,
                    diag::GRAPHICAL,
                    format!(
                        "the transition is connected to localId {}, which no element has",
                        rf.map_or("(missing)".into(), |r| r.to_string())
                    ),
                ),
            }
        }
        let mut seen = HashSet::new();
        while let Some(j) = stack.pop() {
            if !seen.insert(j) {
                continue;
            }
            match kind(&l, j).as_str() {
                "step" => before.push(j),
                "selectionDivergence" | "simultaneousConvergence" => {
                    for (rf, _, _) in all_inputs(l.els[j]) {
                        if let Some(k) = rf.and_then(|rf| l.by_id.get(&rf).copied()) {
                            stack.push(k);
                        }
                    }
                }
                other => l.error(
                    t,
                    diag::GRAPHICAL,
                    format!("a transition must follow a step, a selection divergence or a simultaneous convergence, not <{other}>"),
                ),
            }
        }
        if before.is_empty() {
            l.error(
                t,
                diag::GRAPHICAL,
                "the transition follows no step; connect it below a step".into(),
            );
        }
        before.sort();
        let mut after = Vec::new();
        let mut stack: Vec<usize> = succ[t].clone();
        let mut seen = HashSet::new();
        while let Some(j) = stack.pop() {
            if !seen.insert(j) {
                continue;
            }
            match kind(&l, j).as_str() {
                "step" => after.push(j),
                "jumpStep" => {
                    let target = l.els[j].attr("targetName").unwrap_or("").trim().to_string();
                    match step_of.get(&target.to_ascii_uppercase()) {
                        Some(&s) => after.push(s),
                        None => l.error(
                            j,
                            diag::GRAPHICAL,
                            format!(
                                "the jump goes to step {target}, which the chart does not have"
                            ),
                        ),
                    }
                }
                "simultaneousDivergence" | "selectionConvergence" => {
                    stack.extend(succ[j].iter().copied())
                }
                _ => {}
            }
        }
        if after.is_empty() {
            l.error(
                t,
                diag::GRAPHICAL,
                "no step follows the transition; connect a step or a jump below it".into(),
            );
        }
        after.sort();
        after.dedup();
        pre.insert(t, before);
        post.insert(t, after);
    }
    let any_span = if let Some(&s) = steps.first() {
        l.span(s)
    } else {
        return l.finish();
    };
    // Step variables and step times.
    let clock = l.hidden("__sfc_clock", "TON", None, any_span);
    let now = l.hidden("__sfc_now", "TIME", None, any_span);
    let started = l.hidden("__sfc_started", "BOOL", None, any_span);
    let mut svar = HashMap::new();
    for &s in &steps {
        let span = l.span(s);
        let sn = l.els[s].attr("name").unwrap_or("").trim().to_string();
        let init = flag(l.els[s], "initialStep").then(|| Init::Struct {
            fields: vec![(Ident::new("X", span), Init::Expr(boolean(true, span)))],
            span,
        });
        let v = l.hidden(&sn, STEP_TYPE, init, span);
        let t0 = l.hidden(&format!("__{sn}_t0"), "TIME", None, span);
        let act = l.hidden(&format!("__{sn}_act"), "BOOL", None, span);
        let deact = l.hidden(&format!("__{sn}_deact"), "BOOL", None, span);
        svar.insert(s, (v, t0, act, deact));
    }
    // T#100000d: the clock never saturates.
    l.stmts.push(Stmt {
        kind: StmtKind::Call(call(
            clock.clone(),
            vec![
                arg("IN", boolean(true, any_span)),
                arg("PT", time(100_000 * 86_400 * 1_000_000_000, any_span)),
            ],
        )),
        span: any_span,
    });
    l.stmts.push(assign(now.clone(), field(clock, "ET")));
    for &s in &steps {
        let (v, t0, _, _) = svar[&s].clone();
        l.stmts.push(when(
            field(v.clone(), "X"),
            vec![assign(field(v, "T"), bin(BinaryOp::Sub, now.clone(), t0))],
        ));
    }
    // Transition conditions, judged on the steps active now.
    let mut ordered = transitions.clone();
    // In a selection divergence: by `priority`, else left to right (the standard's rule;
    // Beremiz writes no priority), then document order.
    ordered.sort_by_key(|&t| {
        let el = l.els[t];
        let priority = el
            .attr("priority")
            .and_then(|p| p.trim().parse::<u64>().ok())
            .unwrap_or(0);
        let x = el
            .child("position")
            .and_then(|p| p.attr("x"))
            .and_then(|x| x.trim().parse::<f64>().ok())
            .unwrap_or(0.0);
        (priority, (x * 1000.0) as i64)
    });
    let mut fire: HashMap<usize, Expr> = HashMap::new();
    let mut done: Vec<usize> = Vec::new();
    for &t in &ordered {
        let span = l.span(t);
        let id = local_id(l.els[t]).unwrap_or(t as u64);
        let cond = condition(&mut l, pou_el, t);
        let Some(cond) = cond else { continue };
        let mut terms: Vec<Expr> = pre[&t]
            .iter()
            .map(|s| field(svar[s].0.clone(), "X"))
            .collect();
        terms.push(cond);
        for &u in &done {
            if pre[&u].iter().any(|s| pre[&t].contains(s)) {
                terms.push(not(fire[&u].clone()));
            }
        }
        let e = all(terms, span);
        let f = l.hidden(&format!("__t{id}"), "BOOL", None, span);
        l.stmts.push(assign(f.clone(), e));
        fire.insert(t, f);
        done.push(t);
    }
    // Networks drawn in the chart (blocks, coils, output variables) not yet run for a
    // condition run once per scan, here.
    l.network(&HashSet::new());
    // Evolution: every cleared transition at once.
    for &s in &steps {
        let (_, _, act, deact) = svar[&s].clone();
        let span = act.span;
        l.stmts.push(assign(act, boolean(false, span)));
        l.stmts.push(assign(deact, boolean(false, span)));
    }
    let initial: Vec<Stmt> = steps
        .iter()
        .filter(|&&s| flag(l.els[s], "initialStep"))
        .map(|s| assign(svar[s].2.clone(), boolean(true, any_span)))
        .chain([assign(started.clone(), boolean(true, any_span))])
        .collect();
    l.stmts.push(when(not(started), initial));
    for &t in &done {
        let body = pre[&t]
            .iter()
            .flat_map(|s| {
                let (v, _, _, deact) = svar[s].clone();
                let span = v.span;
                [
                    assign(field(v, "X"), boolean(false, span)),
                    assign(deact, boolean(true, span)),
                ]
            })
            .collect();
        l.stmts.push(when(fire[&t].clone(), body));
    }
    for &t in &done {
        let body = post[&t]
            .iter()
            .flat_map(|s| {
                let (v, t0, act, _) = svar[s].clone();
                let span = v.span;
                [
                    assign(field(v.clone(), "X"), boolean(true, span)),
                    assign(field(v, "T"), time(0, span)),
                    assign(t0, now.clone()),
                    assign(act, boolean(true, span)),
                ]
            })
            .collect();
        l.stmts.push(when(fire[&t].clone(), body));
    }
    // Actions.
    let mut targets: Vec<(String, Target, Span)> = Vec::new();
    let mut assocs: Vec<Assoc> = Vec::new();
    for i in 0..n {
        if kind(&l, i) != "actionBlock" {
            continue;
        }
        let el = l.els[i];
        let span = l.span(i);
        let step = el
            .child("connectionPointIn")
            .map(connections)
            .unwrap_or_default()
            .into_iter()
            .find_map(|(rf, _, _)| rf.and_then(|rf| l.by_id.get(&rf).copied()));
        let Some(step) = step.filter(|s| svar.contains_key(s)) else {
            l.error(i, diag::GRAPHICAL, "the action block is connected to no step; connect it to the step whose actions it lists".into());
            continue;
        };
        for a in el.children_named("action") {
            let q = a
                .attr("qualifier")
                .unwrap_or("N")
                .trim()
                .to_ascii_uppercase();
            let duration = match a.attr("duration").map(str::trim).filter(|d| !d.is_empty()) {
                Some(d) => {
                    let f = l.file(i);
                    let mut scratch = Diagnostics::new();
                    let e = parser::parse_expression(f, d, &mut scratch);
                    if e.is_none() {
                        l.error(i, diag::GRAPHICAL, format!("duration `{d}` of an action is not a TIME literal; write e.g. T#5s"));
                    }
                    e
                }
                None => None,
            };
            if !matches!(q.as_str(), "N" | "S" | "R" | "P" | "P0" | "P1" | "L" | "D") {
                l.error(i, diag::UNSUPPORTED, format!("action qualifier {q} is not supported yet (N, S, R, P, P0, P1, L and D are)"));
                continue;
            }
            if matches!(q.as_str(), "L" | "D") && duration.is_none() {
                l.error(
                    i,
                    diag::GRAPHICAL,
                    format!("qualifier {q} needs a duration attribute (duration=\"T#5s\")"),
                );
                continue;
            }
            let target = if let Some(rf) = a.child("reference") {
                let an = rf.attr("name").unwrap_or("").trim().to_string();
                let key = an.to_ascii_uppercase();
                match targets.iter().position(|(k, _, _)| *k == key) {
                    Some(p) => p,
                    None => {
                        let t = match named_action(&mut l, pou_el, &an) {
                            Some(t) => t,
                            None => {
                                let f = l.file(i);
                                match parser::parse_expression(f, &an, l.r.diags) {
                                    Some(e) => Target::Variable(e),
                                    None => continue,
                                }
                            }
                        };
                        targets.push((key, t, span));
                        targets.len() - 1
                    }
                }
            } else if let Some(inline) = a.child("inline") {
                let Some(st) = inline.child("ST") else {
                    l.error(
                        i,
                        diag::UNSUPPORTED,
                        "an inline action body must be ST".into(),
                    );
                    continue;
                };
                let (text, at) = super::text_of(st);
                let f = l.r.embed(&text, at.unwrap_or(st.start));
                let body = parser::parse_body(f, &text, l.r.diags);
                targets.push((format!("#{}", targets.len()), Target::Body(body), span));
                targets.len() - 1
            } else {
                l.error(
                    i,
                    diag::PLCOPEN_STRUCTURE,
                    "an <action> has neither <reference> nor <inline>".into(),
                );
                continue;
            };
            assocs.push(Assoc {
                step,
                qualifier: q,
                duration,
                target,
            });
        }
    }
    for (k, (_, target, span)) in targets.into_iter().enumerate() {
        let mut on = Vec::new();
        let mut set = Vec::new();
        let mut reset = Vec::new();
        for a in assocs.iter().filter(|a| a.target == k) {
            let (v, _, act, deact) = svar[&a.step].clone();
            let x = field(v.clone(), "X");
            match a.qualifier.as_str() {
                "N" => on.push(x),
                "S" => set.push(x),
                "R" => reset.push(x),
                "P" | "P1" => on.push(act),
                "P0" => on.push(and(deact, not(x))),
                "L" => on.push(and(
                    x,
                    bin(
                        BinaryOp::Lt,
                        field(v, "T"),
                        a.duration.clone().expect("checked"),
                    ),
                )),
                "D" => on.push(and(
                    x,
                    bin(
                        BinaryOp::Ge,
                        field(v, "T"),
                        a.duration.clone().expect("checked"),
                    ),
                )),
                _ => {}
            }
        }
        if !set.is_empty() || !reset.is_empty() {
            let stored = l.hidden(&format!("__a{k}_s"), "BOOL", None, span);
            if !set.is_empty() {
                l.stmts.push(when(
                    any(set, span),
                    vec![assign(stored.clone(), boolean(true, span))],
                ));
            }
            if !reset.is_empty() {
                l.stmts.push(when(
                    any(reset, span),
                    vec![assign(stored.clone(), boolean(false, span))],
                ));
            }
            on.push(stored);
        }
        let q = any(on, span);
        match target {
            Target::Variable(v) => l.stmts.push(assign(v, q)),
            Target::Body(body) => {
                let q = match q.kind {
                    ExprKind::Name(_) | ExprKind::Field(..) => q,
                    _ => {
                        let qv = l.hidden(&format!("__a{k}_q"), "BOOL", None, span);
                        l.stmts.push(assign(qv.clone(), q));
                        qv
                    }
                };
                l.stmts.push(when(q, body));
            }
        }
    }
    // Elements of the chart that are not its own (a contact network feeding a condition)
    // were lowered where they were read.
    let mut out = l.finish();
    out.steps = true;
    out
}

/// A transition's condition: inline ST, a reference to a named transition, or a connection.
fn condition(l: &mut Lower, pou_el: &X, t: usize) -> Option<Expr> {
    let el = l.els[t];
    let Some(c) = el.child("condition") else {
        l.error(
            t,
            diag::PLCOPEN_STRUCTURE,
            "the transition has no <condition>".into(),
        );
        return None;
    };
    if let Some(inline) = c.child("inline") {
        let Some(st) = inline.child("ST") else {
            l.error(
                t,
                diag::UNSUPPORTED,
                "an inline condition must be ST (or connect the condition to a contact network)"
                    .into(),
            );
            return None;
        };
        let (text, at) = super::text_of(st);
        let f = l.r.embed(&text, at.unwrap_or(st.start));
        return parser::parse_expression(f, &text, l.r.diags);
    }
    if let Some(rf) = c.child("reference") {
        let tn = rf.attr("name").unwrap_or("").trim().to_string();
        let body = pou_el
            .child("transitions")
            .into_iter()
            .flat_map(|ts| ts.children_named("transition"))
            .find(|x| {
                x.attr("name")
                    .is_some_and(|n| n.trim().eq_ignore_ascii_case(&tn))
            })
            .and_then(|x| x.child("body"))
            .and_then(|b| b.children.iter().find(|c| c.name != "documentation"));
        let Some(st) = body else {
            l.error(t, diag::GRAPHICAL, format!("the condition refers to transition {tn}, which the POU's <transitions> do not define"));
            return None;
        };
        if matches!(st.name.as_str(), "LD" | "FBD") {
            // The body assigns the transition's name (a coil or an output variable).
            let span = l.span(t);
            let v = l.hidden(&tn, "BOOL", None, span);
            l.stmts.push(assign(v.clone(), boolean(false, span)));
            let body = nested(l, &format!("transition {tn}"), st);
            l.stmts.extend(body);
            return Some(v);
        }
        if st.name != "ST" {
            l.error(
                t,
                diag::UNSUPPORTED,
                format!(
                    "transition {tn} is written in {}; transitions in ST, LD or FBD are supported",
                    st.name
                ),
            );
            return None;
        }
        let (text, at) = super::text_of(st);
        let f = l.r.embed(&text, at.unwrap_or(st.start));
        // An expression (CODESYS), or statements assigning the transition's name.
        let mut scratch = Diagnostics::new();
        if let Some(e) = parser::parse_expression(f, &text, &mut scratch) {
            if !scratch.has_errors() {
                return Some(e);
            }
        }
        let span = l.span(t);
        let v = l.hidden(&tn, "BOOL", None, span);
        let mut body = vec![assign(v.clone(), boolean(false, span))];
        let f = l.r.embed(&text, at.unwrap_or(st.start));
        body.extend(parser::parse_body(f, &text, l.r.diags));
        l.stmts.extend(body);
        return Some(v);
    }
    let cpi = c.child("connectionPointIn").or(Some(c));
    let cpi = cpi.filter(|x| !connections(x).is_empty());
    if cpi.is_none() {
        l.error(
            t,
            diag::PLCOPEN_STRUCTURE,
            "the transition's <condition> holds neither <inline>, <reference> nor a connection"
                .into(),
        );
        return None;
    }
    l.input(t, cpi)
}

/// The body of a named action of the POU (`<actions><action name>`), in ST or LD.
fn named_action(l: &mut Lower, pou_el: &X, an: &str) -> Option<Target> {
    let action = pou_el
        .child("actions")
        .into_iter()
        .flat_map(|a| a.children_named("action"))
        .find(|x| {
            x.attr("name")
                .is_some_and(|n| n.trim().eq_ignore_ascii_case(an))
        })?;
    let body = action.child("body")?;
    let lang = body.children.iter().find(|c| c.name != "documentation")?;
    match lang.name.as_str() {
        "ST" => {
            let (text, at) = super::text_of(lang);
            let f = l.r.embed(&text, at.unwrap_or(lang.start));
            Some(Target::Body(parser::parse_body(f, &text, l.r.diags)))
        }
        "LD" | "FBD" => Some(Target::Body(nested(l, &format!("action {an}"), lang))),
        other => {
            let span = l.r.span(lang);
            l.r.diags.error(
                diag::UNSUPPORTED,
                span,
                format!(
                    "action {an} is written in {other}; actions in ST, LD or FBD are supported"
                ),
            );
            Some(Target::Body(Vec::new()))
        }
    }
}
