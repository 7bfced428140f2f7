//! The pins of a graphical block: `negated="true"` (the inverting circle) and
//! `edge="rising"`/`"falling"` on its inputs and outputs (PLCopen TC6 `<variable>`), as
//! Beremiz and CODESYS export them. An edge is detected as R_TRIG/F_TRIG detect it, with a
//! hidden previous value, the same way as a contact's: `e := v AND NOT m; m := v;`. On an
//! input the circle sits outside the block, so the value is negated before its edge is
//! taken; on an output the edge is the block's and the circle outside it, so the other way.

use crate::ast::*;
use crate::xml::Element as X;

use super::{and, assign, flag, local_id, not, Lower};

impl<'r, 'a, 'x> Lower<'r, 'a, 'x> {
    /// An input pin's value after its circle and edge.
    pub(super) fn pin_in(&mut self, i: usize, fpn: &str, v: &X, e: Expr) -> Expr {
        let e = if flag(v, "negated") { not(e) } else { e };
        match v.attr("edge") {
            Some(edge @ ("rising" | "falling")) => self.edge(i, fpn, e, edge == "rising"),
            _ => e,
        }
    }

    /// The `<variable>` of block `i`'s output `fp`, if the block lists it.
    fn out_pin(&self, i: usize, fp: &str) -> Option<&'x X> {
        self.els[i]
            .child("outputVariables")?
            .children_named("variable")
            .find(|v| {
                v.attr("formalParameter")
                    .is_some_and(|f| f.trim().eq_ignore_ascii_case(fp))
            })
    }

    /// An output pin's value after its edge and circle (computed once per scan: an edge's
    /// previous value is updated where it is taken).
    pub(super) fn pin_out(&mut self, i: usize, fp: &str, e: Expr) -> Expr {
        let Some(v) = self.out_pin(i, fp) else {
            return e;
        };
        let key = (i, format!("PIN:{}", fp.to_ascii_uppercase()));
        if let Some(x) = self.memo.get(&key) {
            return x.clone();
        }
        let e = match v.attr("edge") {
            Some(edge @ ("rising" | "falling")) => self.edge(i, fp, e, edge == "rising"),
            _ => e,
        };
        let e = if flag(v, "negated") { not(e) } else { e };
        self.memo.insert(key, e.clone());
        e
    }

    /// `t := v AND NOT m; m := v;` (falling: `NOT v AND m`), `t` returned.
    fn edge(&mut self, i: usize, pin: &str, v: Expr, rising: bool) -> Expr {
        let span = self.span(i);
        let id = local_id(self.els[i]).unwrap_or(i as u64);
        let stem = format!("{}{id}_{pin}", self.prefix);
        let v = match v.kind {
            ExprKind::Name(_) => v,
            _ => {
                let x = self.hidden(&format!("{stem}_v"), "BOOL", None, span);
                self.stmts.push(assign(x.clone(), v));
                x
            }
        };
        let m = self.hidden(&format!("{stem}_m"), "BOOL", None, span);
        let t = self.hidden(&format!("{stem}_e"), "BOOL", None, span);
        let edge = if rising {
            and(v.clone(), not(m.clone()))
        } else {
            and(not(v.clone()), m.clone())
        };
        self.stmts.push(assign(t.clone(), edge));
        self.stmts.push(assign(m, v));
        t
    }
}
