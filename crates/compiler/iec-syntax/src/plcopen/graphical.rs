//! Ladder Diagram, FBD and Sequential Function Chart bodies of PLCopen XML lowered to Structured
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
//! SFC: the chart is read into the model of `crate::sfc` (steps, the steps before and after
//! each transition, conditions, actions and associations) and lowered by its one lowering,
//! the one textual SFC uses too.
//!
//! Every generated node carries the span of its element, a source whose messages name the
//! element (`LD contact localId 3 (start)`) instead of a line and column.

use std::collections::{HashMap, HashSet};

use super::Reader;
use crate::ast::*;
use crate::build::{and, any, arg, assign, boolean, call, decl, field, is_true, name, not, when};
use crate::diag;
use crate::parser;
use crate::source::{FileId, Span};
use crate::xml::Element as X;

mod fbd;
pub(super) mod ld;
mod pins;
pub(super) mod sfc;

/// The longest chain of elements one value is built from (each link is a few stack frames
/// here and a level of nesting in the checker).
const MAX_CHAIN: usize = 256;

/// The most values one body may compute. A function's result is inlined where it is used, so
/// functions feeding each other on two wires each double the work: past this, the body is
/// refused rather than expanded for ever.
const MAX_WORK: usize = 200_000;

/// What a graphical body becomes: statements and the hidden variables they use.
pub(super) struct Lowered {
    pub stmts: Vec<Stmt>,
    pub vars: Vec<VarDecl>,
    pub steps: bool,
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

    fn finish(self) -> Lowered {
        Lowered {
            stmts: self.stmts,
            vars: self.vars,
            steps: false,
        }
    }
}
