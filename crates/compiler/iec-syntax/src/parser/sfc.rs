//! Sequential Function Charts in text form (IEC 61131-3 §6.7, as matiec reads them) in a
//! PROGRAM or FUNCTION_BLOCK body: `INITIAL_STEP`/`STEP … END_STEP` with action associations,
//! `TRANSITION [name] [(PRIORITY := n)] FROM … TO …` with `:= condition;` or a body
//! assigning the transition's name, and `ACTION name : … END_ACTION`. Read into the chart
//! model of `crate::sfc` (the one PLCopen XML's `<SFC>` bodies are read into) and lowered
//! by the same lowering.
//!
//! The words of charts are not reserved (a variable may be named `step`): a body is a chart
//! when it holds `INITIAL_STEP`, `END_STEP` or `END_TRANSITION`, which the standard reserves.

use std::collections::{HashMap, HashSet};

use crate::ast::*;
use crate::diag;
use crate::lexer::{Kw, Tok};
use crate::sfc::{self, Action, Assoc, Chart, Hidden, Qualifier, Step, Target, Transition};
use crate::source::Span;

use super::{PResult, Parser, Reported};

/// A step as written: its name and its associations (action name, qualifier, duration).
struct StepText {
    name: Ident,
    initial: bool,
    assocs: Vec<(Ident, Qualifier, Option<Expr>)>,
}

/// A transition as written, before its steps are resolved.
struct TransitionText {
    name: Option<Ident>,
    priority: u64,
    from: Vec<Ident>,
    to: Vec<Ident>,
    cond: Condition,
    span: Span,
}

enum Condition {
    Expr(Expr),
    /// Statements assigning the transition's name.
    Body(Vec<Stmt>),
}

/// What a chart body is read into, in the order written.
#[derive(Default)]
struct ChartText {
    steps: Vec<StepText>,
    transitions: Vec<TransitionText>,
    actions: Vec<(Ident, Vec<Stmt>)>,
}

/// The words that open an element of a chart.
const ELEMENTS: &[&str] = &["INITIAL_STEP", "STEP", "TRANSITION", "ACTION"];

impl<'a, 'd> Parser<'a, 'd> {
    fn at_element(&self) -> bool {
        ELEMENTS.iter().any(|w| self.at_word(w))
    }

    /// Whether the body from here to `end_kw` is a chart.
    pub(super) fn body_is_chart(&self, end_kw: Kw) -> bool {
        for t in &self.toks[self.pos..] {
            match t.tok {
                Tok::Eof => return false,
                Tok::Kw(k) if k == end_kw => return false,
                Tok::Ident => {
                    let w = self.text_of(t.span);
                    if ["INITIAL_STEP", "END_STEP", "END_TRANSITION"]
                        .iter()
                        .any(|k| w.eq_ignore_ascii_case(k))
                    {
                        return true;
                    }
                }
                _ => {}
            }
        }
        false
    }

    /// A chart body up to `end_kw` (not consumed), lowered: its statements and the hidden
    /// variables they use.
    pub(super) fn chart_body(&mut self, kind: PouKind, end_kw: Kw) -> (Vec<Stmt>, Vec<VarDecl>) {
        let start = self.peek().span;
        let mut text = ChartText::default();
        while !self.at_kw(end_kw) && !self.is_top_start() {
            let at = self.pos;
            let r = if self.at_word("INITIAL_STEP") || self.at_word("STEP") {
                self.step().map(|s| text.steps.push(s))
            } else if self.at_word("TRANSITION") {
                self.transition().map(|t| text.transitions.push(t))
            } else if self.at_word("ACTION") {
                self.chart_action().map(|a| text.actions.extend(a))
            } else {
                let span = self.peek().span;
                self.error_at(
                    diag::SFC_MIXED,
                    span,
                    "this body is a chart (it has steps), so it holds only STEP, TRANSITION \
                     and ACTION blocks; put these statements in an ACTION … END_ACTION and \
                     associate it with a step (`A(N);`)",
                );
                Err(Reported)
            };
            if r.is_err() {
                // Go on at the next element of the chart.
                if self.pos == at {
                    self.bump();
                }
                while !self.at_element() && !self.at_kw(end_kw) && !self.is_top_start() {
                    self.bump();
                }
            }
        }
        if kind == PouKind::Function {
            self.error_at(
                diag::SFC_STRUCTURE,
                start,
                "a FUNCTION cannot hold a chart: its steps would not be kept between calls; \
                 make it a FUNCTION_BLOCK or a PROGRAM",
            );
        }
        self.build_chart(text)
    }

    /// The name after the word opening an element.
    fn after_word(&mut self, what: &str) -> PResult<Ident> {
        self.bump();
        self.ident(what)
    }

    /// The ident `word` (a word of charts, not reserved) expected here.
    fn expect_word(&mut self, word: &str) -> PResult<Span> {
        if self.at_word(word) {
            return Ok(self.bump().span);
        }
        Err(self.expected(&format!("`{word}`")))
    }

    /// `INITIAL_STEP name : associations END_STEP` or `STEP …`.
    fn step(&mut self) -> PResult<StepText> {
        let initial = self.at_word("INITIAL_STEP");
        let name = self.after_word("the step's name")?;
        self.expect(&Tok::Colon, "`:` after the step's name")?;
        let mut assocs = Vec::new();
        while !self.at_word("END_STEP") {
            if self.at_element() || self.at(&Tok::Eof) || self.is_top_start() {
                let t = self.peek().clone();
                let msg = format!(
                    "STEP {} has no END_STEP; found {}",
                    name.name,
                    self.describe(&t)
                );
                self.error_at(diag::MISSING_END, t.span, msg);
                // Kept, so that the transitions naming it are not reported too.
                return Ok(StepText {
                    name,
                    initial,
                    assocs,
                });
            }
            match self.association() {
                Ok(a) => assocs.push(a),
                Err(Reported) => {
                    // Go on at the next association.
                    while !self.at(&Tok::Semi)
                        && !self.at_word("END_STEP")
                        && !self.at_element()
                        && !self.at(&Tok::Eof)
                        && !self.is_top_start()
                    {
                        self.bump();
                    }
                    self.eat(&Tok::Semi);
                }
            }
        }
        self.bump();
        self.eat(&Tok::Semi);
        Ok(StepText {
            name,
            initial,
            assocs,
        })
    }

    /// `action ( [qualifier [, duration]] {, indicator} ) ;`
    fn association(&mut self) -> PResult<(Ident, Qualifier, Option<Expr>)> {
        let action = self.ident("an action's name (`A(N);`)")?;
        self.expect(&Tok::LParen, "`(` and the action's qualifier: `A(N);`")?;
        let mut qualifier = Qualifier::N;
        let mut duration = None;
        if !self.at(&Tok::RParen) {
            let t = self.peek().clone();
            let q = self.ident("an action qualifier (N, S, R, L, D, P, …)")?;
            qualifier = match Qualifier::parse(&q.name) {
                Some(q) => q,
                None => {
                    self.error_at(
                        diag::SFC_STRUCTURE,
                        t.span,
                        format!(
                            "`{}` is not an action qualifier; write one of {}",
                            q.name,
                            sfc::QUALIFIERS
                        ),
                    );
                    return Err(Reported);
                }
            };
            if qualifier.timed() {
                if self.eat(&Tok::Comma).is_none() {
                    let msg = format!(
                        "qualifier {} needs a duration: `{}({}, T#2s);`",
                        q.name.to_ascii_uppercase(),
                        action.name,
                        q.name.to_ascii_uppercase()
                    );
                    self.error_at(diag::SFC_STRUCTURE, q.span, msg);
                    return Err(Reported);
                }
                duration = Some(self.expr()?);
            }
            // Indicator variables show the action's effect; they change nothing.
            while self.eat(&Tok::Comma).is_some() {
                self.expr()?;
            }
        }
        self.expect(&Tok::RParen, "`)` closing the action association")?;
        self.expect_semi()?;
        Ok((action, qualifier, duration))
    }

    /// `s` or `(s1, s2, …)`.
    fn step_names(&mut self) -> PResult<Vec<Ident>> {
        if self.eat(&Tok::LParen).is_none() {
            return Ok(vec![self.ident("a step's name")?]);
        }
        let mut out = vec![self.ident("a step's name")?];
        while self.eat(&Tok::Comma).is_some() {
            out.push(self.ident("a step's name")?);
        }
        self.expect(&Tok::RParen, "`)` closing the list of steps")?;
        Ok(out)
    }

    /// `TRANSITION [name] [(PRIORITY := n)] FROM steps TO steps (:= cond; | : body)
    /// END_TRANSITION`.
    fn transition(&mut self) -> PResult<TransitionText> {
        let start = self.bump().span;
        let name = if self.at_name() && !self.at_word("FROM") {
            Some(self.ident("the transition's name")?)
        } else {
            None
        };
        let mut priority = 0;
        if self.eat(&Tok::LParen).is_some() {
            self.expect_word("PRIORITY")?;
            self.expect(&Tok::Assign, "`:=` and the transition's priority")?;
            let t = self.peek().clone();
            match t.tok {
                Tok::Int(n) => {
                    self.bump();
                    priority = u64::try_from(n).unwrap_or(u64::MAX);
                }
                _ => return Err(self.expected("the priority, a whole number")),
            }
            self.expect(&Tok::RParen, "`)` after the priority")?;
        }
        self.expect_word("FROM")?;
        let from = self.step_names()?;
        self.expect_kw(Kw::To)?;
        let to = self.step_names()?;
        let cond = if self.eat(&Tok::Assign).is_some() {
            let e = self.expr()?;
            self.expect_semi()?;
            Condition::Expr(e)
        } else if self.eat(&Tok::Colon).is_some() {
            if self.at_word("LD") || self.at_word("LDN") {
                let span = self.peek().span;
                self.error_at(
                    diag::UNSUPPORTED,
                    span,
                    "a transition condition in IL is not supported yet; write it in ST: \
                     `:= a AND b;`",
                );
                return Err(Reported);
            }
            let what = match &name {
                Some(n) => format!("TRANSITION {}", n.name),
                None => "TRANSITION".into(),
            };
            let body = self.chart_statements("END_TRANSITION", &what)?;
            if name.is_none() {
                self.error_at(
                    diag::SFC_STRUCTURE,
                    start,
                    "a transition whose condition is a body assigns its name, so it needs one: \
                     `TRANSITION t1 FROM s1 TO s2 : t1 := a; END_TRANSITION` (or write \
                     `:= condition;`)",
                );
                return Err(Reported);
            }
            Condition::Body(body)
        } else {
            return Err(self.expected("`:=` and the transition's condition"));
        };
        let end = self.expect_word("END_TRANSITION")?;
        self.eat(&Tok::Semi);
        Ok(TransitionText {
            name,
            priority,
            from,
            to,
            cond,
            span: start.to(end),
        })
    }

    /// `ACTION name : statements END_ACTION`.
    fn chart_action(&mut self) -> PResult<Option<(Ident, Vec<Stmt>)>> {
        let name = self.after_word("the action's name")?;
        self.expect(&Tok::Colon, "`:` after the action's name")?;
        if self.il {
            let span = self.peek().span;
            self.error_at(
                diag::UNSUPPORTED,
                span,
                "an action body in IL is not supported yet; write the chart in an ST source",
            );
            return Err(Reported);
        }
        let body = self.chart_statements("END_ACTION", &format!("ACTION {}", name.name))?;
        self.expect_word("END_ACTION")?;
        self.eat(&Tok::Semi);
        Ok(Some((name, body)))
    }

    /// Statements up to the word `end` (not consumed): the word is the end of the list
    /// while they are read, as `END_IF` is for a branch.
    fn chart_statements(&mut self, end: &str, what: &str) -> PResult<Vec<Stmt>> {
        let found = self.toks[self.pos..].iter().position(|t| match t.tok {
            Tok::Ident => self.text_of(t.span).eq_ignore_ascii_case(end),
            Tok::Kw(Kw::EndProgram | Kw::EndFunctionBlock | Kw::EndFunction | Kw::Program) => true,
            _ => false,
        });
        let Some(at) = found
            .map(|k| self.pos + k)
            .filter(|&k| self.toks[k].tok == Tok::Ident)
        else {
            let span = self.peek().span;
            self.error_at(
                diag::MISSING_END,
                span,
                format!("{what} has no {end}; close it with {end}"),
            );
            return Err(Reported);
        };
        self.toks[at].tok = Tok::Eof;
        let body = self.statements(&[]);
        if self.pos < at && self.pos != self.reported_at {
            let t = self.peek().clone();
            let msg = format!("{} does not belong in {what}", self.describe(&t));
            self.error_at(diag::SYNTAX, t.span, msg);
        }
        self.toks[at].tok = Tok::Ident;
        if self.too_deep {
            // The rest of the source is skipped (see `Parser::too_deep`).
            return Err(Reported);
        }
        self.pos = at;
        Ok(body)
    }

    /// The chart read resolved into the model, checked and lowered.
    fn build_chart(&mut self, text: ChartText) -> (Vec<Stmt>, Vec<VarDecl>) {
        let mut vars = Vec::new();
        let mut declared = HashSet::new();
        let mut h = Hidden {
            vars: &mut vars,
            declared: &mut declared,
        };
        let mut chart = Chart::default();
        let mut step_of: HashMap<String, usize> = HashMap::new();
        for s in &text.steps {
            if let Some(&first) = step_of.get(&s.name.key()) {
                let msg = format!(
                    "step {} is declared twice (first at {}); give each step its own name",
                    s.name.name,
                    self.line_of(chart.steps[first].name.span)
                );
                self.error_at(diag::SFC_STRUCTURE, s.name.span, msg);
                continue;
            }
            step_of.insert(s.name.key(), chart.steps.len());
            chart.steps.push(Step {
                name: s.name.clone(),
                initial: s.initial,
            });
        }
        let resolve = |p: &mut Self, names: &[Ident], side: &str| -> Option<Vec<usize>> {
            let mut out = Vec::new();
            for n in names {
                match step_of.get(&n.key()) {
                    Some(&s) => out.push(s),
                    None => {
                        p.error_at(
                            diag::SFC_STRUCTURE,
                            n.span,
                            format!(
                                "the transition goes {side} step {}, which the chart does not \
                                 declare; declare it with `STEP {} : END_STEP`",
                                n.name, n.name
                            ),
                        );
                        return None;
                    }
                }
            }
            let n = out.len();
            out.sort();
            out.dedup();
            if out.len() != n {
                let span = names[0].span;
                p.error_at(
                    diag::SFC_STRUCTURE,
                    span,
                    format!("a step is listed twice {side} the transition; list each once"),
                );
                return None;
            }
            Some(out)
        };
        // Judged by priority (none counts as 0, as in PLCopen XML), then as written.
        let mut order: Vec<usize> = (0..text.transitions.len()).collect();
        order.sort_by_key(|&k| text.transitions[k].priority);
        let mut transitions: Vec<Option<TransitionText>> =
            text.transitions.into_iter().map(Some).collect();
        for k in order {
            let Some(t) = transitions[k].take() else {
                continue;
            };
            let from = resolve(self, &t.from, "from");
            let to = resolve(self, &t.to, "to");
            let (Some(from), Some(to)) = (from, to) else {
                continue;
            };
            let key = match &t.name {
                Some(n) => n.name.clone(),
                None => (k + 1).to_string(),
            };
            let (prelude, cond) = match t.cond {
                Condition::Expr(e) => (Vec::new(), e),
                Condition::Body(body) => {
                    let n = t.name.clone().expect("a body has a name");
                    let v = h.var(&n.name, "BOOL", None, n.span);
                    let mut prelude = vec![crate::build::assign(
                        v.clone(),
                        crate::build::boolean(false, n.span),
                    )];
                    prelude.extend(body);
                    (prelude, v)
                }
            };
            chart.transitions.push(Transition {
                key,
                from,
                to,
                prelude,
                cond,
                span: t.span,
            });
        }
        self.actions_of(&text.steps, text.actions, &step_of, &mut chart);
        self.check_chart(&chart);
        let mut stmts = Vec::new();
        sfc::lower(chart, &mut h, &mut stmts);
        (stmts, vars)
    }

    /// The chart's actions in first-use order, as PLCopen XML's are (an ACTION block, else
    /// the BOOL variable of that name), then the ACTION blocks no step uses; and every
    /// association.
    fn actions_of(
        &mut self,
        steps: &[StepText],
        blocks: Vec<(Ident, Vec<Stmt>)>,
        step_of: &HashMap<String, usize>,
        chart: &mut Chart,
    ) {
        let mut block_of: HashMap<String, (Ident, Vec<Stmt>)> = HashMap::new();
        let mut written: Vec<String> = Vec::new();
        for (name, body) in blocks {
            if let Some((first, _)) = block_of.get(&name.key()) {
                let msg = format!(
                    "action {} is declared twice (first at {}); give each action its own name",
                    name.name,
                    self.line_of(first.span)
                );
                self.error_at(diag::SFC_STRUCTURE, name.span, msg);
                continue;
            }
            written.push(name.key());
            block_of.insert(name.key(), (name, body));
        }
        let mut action_of: HashMap<String, usize> = HashMap::new();
        fn add(
            chart: &mut Chart,
            action_of: &mut HashMap<String, usize>,
            key: String,
            action: Action,
        ) -> usize {
            chart.actions.push(action);
            action_of.insert(key, chart.actions.len() - 1);
            chart.actions.len() - 1
        }
        for s in steps {
            // A step declared twice was reported; its associations are not run.
            let Some(&step) = step_of.get(&s.name.key()) else {
                continue;
            };
            if chart.steps[step].name.span != s.name.span {
                continue;
            }
            for (a, qualifier, duration) in &s.assocs {
                let action = match action_of.get(&a.key()) {
                    Some(&k) => k,
                    None => {
                        let action = match block_of.remove(&a.key()) {
                            Some((name, body)) => Action {
                                span: name.span,
                                name: Some(name),
                                target: Target::Body(body),
                            },
                            None => Action {
                                name: None,
                                target: Target::Variable(crate::build::name(&a.name, a.span)),
                                span: a.span,
                            },
                        };
                        add(chart, &mut action_of, a.key(), action)
                    }
                };
                chart.assocs.push(Assoc {
                    step,
                    qualifier: *qualifier,
                    duration: duration.clone(),
                    action,
                });
            }
        }
        for key in written {
            let Some((name, body)) = block_of.remove(&key) else {
                continue;
            };
            let msg = format!(
                "action {} is associated with no step, so it never runs; associate it with a \
                 step (`{}(N);`) or remove it",
                name.name, name.name
            );
            self.diags.warning(diag::SFC_NEVER, name.span, msg);
            // Kept, so that its flag `name.Q` (always FALSE) is declared.
            add(
                chart,
                &mut action_of,
                key,
                Action {
                    span: name.span,
                    name: Some(name),
                    target: Target::Body(body),
                },
            );
        }
    }

    /// `line:col` of a span of this source, for messages naming a first declaration.
    fn line_of(&self, span: Span) -> String {
        let before = &self.text[..span.start as usize];
        let line = before.matches('\n').count() + 1;
        let col = before.len() - before.rfind('\n').map_or(0, |k| k + 1) + 1;
        format!("{line}:{col}")
    }

    /// One initial step per network of steps joined by transitions, and every step
    /// reachable from an initial step.
    fn check_chart(&mut self, chart: &Chart) {
        let n = chart.steps.len();
        if n == 0 {
            return;
        }
        // Networks: steps joined by a transition, through a union-find.
        let mut root: Vec<usize> = (0..n).collect();
        fn find(root: &mut [usize], mut s: usize) -> usize {
            while root[s] != s {
                root[s] = root[root[s]];
                s = root[s];
            }
            s
        }
        for t in &chart.transitions {
            for &s in t.from.iter().chain(&t.to) {
                let (a, b) = (find(&mut root, s), find(&mut root, t.from[0]));
                root[a] = b;
            }
        }
        let mut initial_of: HashMap<usize, usize> = HashMap::new();
        for (k, s) in chart.steps.iter().enumerate() {
            if !s.initial {
                continue;
            }
            let r = find(&mut root, k);
            if let Some(&first) = initial_of.get(&r) {
                let msg = format!(
                    "step {} is a second initial step of the network of {} (whose initial \
                     step is {}); a network of steps has one INITIAL_STEP: make this a STEP",
                    s.name.name, chart.steps[first].name.name, chart.steps[first].name.name
                );
                self.error_at(diag::SFC_STRUCTURE, s.name.span, msg);
            } else {
                initial_of.insert(r, k);
            }
        }
        if initial_of.is_empty() {
            self.error_at(
                diag::SFC_STRUCTURE,
                chart.steps[0].name.span,
                "the chart has no INITIAL_STEP, so no step is ever active; make the first \
                 step `INITIAL_STEP`",
            );
            return;
        }
        // Reachable from an initial step (all the steps before a transition being active).
        let mut active: Vec<bool> = chart.steps.iter().map(|s| s.initial).collect();
        loop {
            let mut more = false;
            for t in &chart.transitions {
                if t.from.iter().all(|&s| active[s]) {
                    for &s in &t.to {
                        more |= !std::mem::replace(&mut active[s], true);
                    }
                }
            }
            if !more {
                break;
            }
        }
        for (k, s) in chart.steps.iter().enumerate() {
            if !active[k] {
                let msg = format!(
                    "step {} can never become active: no transition from a step reachable \
                     from an INITIAL_STEP leads to it; add a TRANSITION … TO {} or remove it",
                    s.name.name, s.name.name
                );
                self.diags.warning(diag::SFC_NEVER, s.name.span, msg);
            }
        }
    }
}
