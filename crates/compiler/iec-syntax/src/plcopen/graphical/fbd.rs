//! The values of a network: connections OR-ed, contacts, variables, blocks called once and
//! their outputs (LD and FBD alike).

use crate::ast::*;
use crate::diag::{self};
use crate::xml::Element as X;

use super::{
    and, any, arg, assign, boolean, call, connections, field, flag, is_true, local_id, name, not,
    Lower, MAX_CHAIN, MAX_WORK,
};

impl<'r, 'a, 'x> Lower<'r, 'a, 'x> {
    /// The power (or value) arriving at a connection point: the OR of its connections.
    pub(super) fn input(&mut self, i: usize, cpi: Option<&'x X>) -> Option<Expr> {
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
    pub(super) fn value(&mut self, i: usize, fp: Option<&str>) -> Option<Expr> {
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
                let Some(e) = self.input(i, Some(cpi)) else {
                    ok = false;
                    continue;
                };
                let e = self.pin_in(i, fpn, v, e);
                if fpn.eq_ignore_ascii_case("EN") {
                    en = Some(e);
                } else {
                    args.push(arg(fpn, e));
                }
            }
        }
        ok.then_some((args, en))
    }

    pub(super) fn instance(el: &X) -> Option<&str> {
        el.attr("instanceName")
            .map(str::trim)
            .filter(|n| !n.is_empty())
    }

    /// Calls a block instance once, before the first element that reads it.
    pub(super) fn call_block(&mut self, i: usize) -> Option<()> {
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
        let (mut args, en) = r?;
        self.called.insert(i);
        match en {
            Some(en) if !is_true(&en) => {
                // EN and ENO go to the call (the checker guards the body and tells ENO).
                let id = local_id(self.els[i]).unwrap_or(i as u64);
                let eno = self.hidden(&format!("{}{id}_ENO", self.prefix), "BOOL", None, span);
                args.insert(0, arg("EN", en));
                args.push(Arg {
                    output: true,
                    ..arg("ENO", eno.clone())
                });
                self.memo.insert((i, "ENO".into()), eno);
            }
            _ => {
                self.memo.insert((i, "ENO".into()), boolean(true, span));
            }
        }
        self.stmts.push(Stmt {
            kind: StmtKind::Call(call(name(&inst, span), args)),
            span,
        });
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
                let eno = self.memo.get(&(i, "ENO".into())).cloned()?;
                return Some(self.pin_out(i, fp, eno));
            }
            if fp.is_empty() {
                self.error(
                    i,
                    diag::GRAPHICAL,
                    format!("a connection from block {inst} names no output; give it formalParameter=\"Q\" (or the output it reads)"),
                );
                return None;
            }
            let out = field(name(&inst, span), fp);
            return Some(self.pin_out(i, fp, out));
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
        let (mut args, en) = r?;
        // With EN connected, ENO is EN (a function the caller guards runs exactly when EN
        // is TRUE), and the result is the guarded call, which the checker takes where it is
        // a statement's whole value: a variable or a coil the result is stored in.
        let en = match en {
            Some(en) if !is_true(&en) => {
                let key = (i, "ENO".to_string());
                let en = match self.memo.get(&key) {
                    Some(x) => x.clone(),
                    None => {
                        let x = match en.kind {
                            ExprKind::Name(_) => en,
                            _ => self.materialize(i, en),
                        };
                        self.memo.insert(key, x.clone());
                        x
                    }
                };
                args.insert(0, arg("EN", en.clone()));
                Some(en)
            }
            _ => None,
        };
        if fp.eq_ignore_ascii_case("ENO") {
            let eno = en.unwrap_or_else(|| boolean(true, span));
            return Some(self.pin_out(i, fp, eno));
        }
        let out = Expr {
            kind: ExprKind::Call(call(name(&ty, span), args)),
            span,
        };
        let out_fp = if fp.is_empty() { "OUT" } else { fp };
        Some(self.pin_out(i, out_fp, out))
    }
}
