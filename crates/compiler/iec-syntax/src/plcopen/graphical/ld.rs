//! LD and FBD bodies: the elements that act (coils, calls, output variables, returns) in
//! execution order; nested bodies of SFC actions and transitions.

use std::collections::HashSet;

use crate::ast::*;
use crate::diag::{self};
use crate::plcopen::Reader;
use crate::xml::Element as X;

use super::{
    and, assign, boolean, connections, flag, is_true, local_id, not, when, Lower, Lowered,
};

impl<'r, 'a, 'x> Lower<'r, 'a, 'x> {
    /// Statements of the elements that act, in execution order.
    pub(super) fn network(&mut self, skip: &HashSet<usize>) {
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
}

/// Lowers an `<LD>` (or `<FBD>`) body.
pub(in crate::plcopen) fn ld(r: &mut Reader, pou: &str, body: &X) -> Lowered {
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
pub(super) fn nested(l: &mut Lower, what: &str, body: &X) -> Vec<Stmt> {
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
