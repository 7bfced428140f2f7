//! SFC bodies: steps and their times, transitions cleared on the steps active at the start of
//! the scan, the evolution, and actions by qualifier.

use std::collections::{HashMap, HashSet};

use crate::ast::*;
use crate::diag::{self, Diagnostics};
use crate::parser;
use crate::plcopen::{text_of, Reader};
use crate::source::Span;
use crate::xml::Element as X;

use super::ld::nested;
use super::{
    all, all_inputs, and, any, arg, assign, bin, boolean, call, connections, field, flag, local_id,
    not, time, when, Lower, Lowered, STEP_TYPE,
};

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
pub(in crate::plcopen) fn sfc(r: &mut Reader, pou: &str, pou_el: &X, body: &X) -> Lowered {
    let mut l = Lower::new(r, pou, "SFC", body);
    let (steps, step_of) = find_steps(&mut l);
    let succ = successors(&l);
    let transitions: Vec<usize> = (0..l.els.len())
        .filter(|&i| l.els[i].name == "transition")
        .collect();
    // Steps before and after each transition.
    let mut pre: HashMap<usize, Vec<usize>> = HashMap::new();
    let mut post: HashMap<usize, Vec<usize>> = HashMap::new();
    for &t in &transitions {
        let before = steps_before(&mut l, t);
        let after = steps_after(&mut l, t, &succ, &step_of);
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
    let svar = step_vars(&mut l, &steps);
    step_times(&mut l, clock, &now, &steps, &svar, any_span);
    let cleared = clear(&mut l, pou_el, &transitions, &pre, &svar);
    // Networks drawn in the chart (blocks, coils, output variables) not yet run for a
    // condition run once per scan, here.
    l.network(&HashSet::new());
    let chart = Chart {
        steps,
        pre,
        post,
        svar,
    };
    evolve(&mut l, &chart, &cleared, started, &now, any_span);
    let (targets, assocs) = associations(&mut l, pou_el, &chart.svar);
    actions(&mut l, targets, &assocs, &chart.svar);
    // Elements of the chart that are not its own (a contact network feeding a condition)
    // were lowered where they were read.
    let mut out = l.finish();
    out.steps = true;
    out
}

/// A step's variables: the step (`X`, `T`), when it was last activated, and whether this
/// scan activated or deactivated it.
type StepVars = HashMap<usize, (Expr, Expr, Expr, Expr)>;

/// The structure of a chart with a step: its steps and the steps before and after each
/// transition, with their variables.
struct Chart {
    steps: Vec<usize>,
    pre: HashMap<usize, Vec<usize>>,
    post: HashMap<usize, Vec<usize>>,
    svar: StepVars,
}

/// The transitions that may clear, in the order they are judged, each with the hidden
/// variable holding whether it cleared this scan.
struct Cleared {
    order: Vec<usize>,
    fire: HashMap<usize, Expr>,
}

/// The steps of the chart and each by its upper-case name; a step without a name, a name
/// drawn twice, a macro step and a chart without an initial step are told.
fn find_steps(l: &mut Lower) -> (Vec<usize>, HashMap<String, usize>) {
    let mut steps: Vec<usize> = Vec::new();
    let mut step_of: HashMap<String, usize> = HashMap::new();
    for i in 0..l.els.len() {
        match l.els[i].name.as_str() {
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
    (steps, step_of)
}

/// Successors of every element, by connection (action blocks aside).
fn successors(l: &Lower) -> Vec<Vec<usize>> {
    let n = l.els.len();
    let mut succ: Vec<Vec<usize>> = vec![Vec::new(); n];
    for i in 0..n {
        if l.els[i].name == "actionBlock" {
            continue;
        }
        for (rf, _, _) in all_inputs(l.els[i]) {
            if let Some(j) = rf.and_then(|rf| l.by_id.get(&rf).copied()) {
                succ[j].push(i);
            }
        }
    }
    succ
}

/// The steps transition `t` follows, through selection divergences and simultaneous
/// convergences, sorted.
fn steps_before(l: &mut Lower, t: usize) -> Vec<usize> {
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
        match l.els[j].name.as_str() {
            "step" => before.push(j),
            "selectionDivergence" | "simultaneousConvergence" => {
                for (rf, _, _) in all_inputs(l.els[j]) {
                    if let Some(k) = rf.and_then(|rf| l.by_id.get(&rf).copied()) {
                        stack.push(k);
                    }
                }
            }
            other => {
                let other = other.to_string();
                l.error(
                    t,
                    diag::GRAPHICAL,
                    format!("a transition must follow a step, a selection divergence or a simultaneous convergence, not <{other}>"),
                )
            }
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
    before
}

/// The steps transition `t` leads to, through simultaneous divergences, selection
/// convergences and jumps, sorted and each once.
fn steps_after(
    l: &mut Lower,
    t: usize,
    succ: &[Vec<usize>],
    step_of: &HashMap<String, usize>,
) -> Vec<usize> {
    let mut after = Vec::new();
    let mut stack: Vec<usize> = succ[t].clone();
    let mut seen = HashSet::new();
    while let Some(j) = stack.pop() {
        if !seen.insert(j) {
            continue;
        }
        match l.els[j].name.as_str() {
            "step" => after.push(j),
            "jumpStep" => {
                let target = l.els[j].attr("targetName").unwrap_or("").trim().to_string();
                match step_of.get(&target.to_ascii_uppercase()) {
                    Some(&s) => after.push(s),
                    None => l.error(
                        j,
                        diag::GRAPHICAL,
                        format!("the jump goes to step {target}, which the chart does not have"),
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
    after
}

/// The hidden variables of every step (`StepVars`); an initial step starts active.
fn step_vars(l: &mut Lower, steps: &[usize]) -> StepVars {
    let mut svar = HashMap::new();
    for &s in steps {
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
    svar
}

/// The chart's clock run and every active step's time `T` updated from it.
fn step_times(
    l: &mut Lower,
    clock: Expr,
    now: &Expr,
    steps: &[usize],
    svar: &StepVars,
    any_span: Span,
) {
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
    for &s in steps {
        let (v, t0, _, _) = svar[&s].clone();
        l.stmts.push(when(
            field(v.clone(), "X"),
            vec![assign(field(v, "T"), bin(BinaryOp::Sub, now.clone(), t0))],
        ));
    }
}

/// Transition conditions, judged on the steps active now: a transition clears if its steps
/// are active, its condition holds and no transition judged before it took one of its steps.
fn clear(
    l: &mut Lower,
    pou_el: &X,
    transitions: &[usize],
    pre: &HashMap<usize, Vec<usize>>,
    svar: &StepVars,
) -> Cleared {
    let mut ordered = transitions.to_vec();
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
        let cond = condition(l, pou_el, t);
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
    Cleared { order: done, fire }
}

/// Evolution: every cleared transition at once, its steps before deactivated and its steps
/// after activated; the initial steps are activated in the first scan.
fn evolve(
    l: &mut Lower,
    chart: &Chart,
    cleared: &Cleared,
    started: Expr,
    now: &Expr,
    any_span: Span,
) {
    let svar = &chart.svar;
    for &s in &chart.steps {
        let (_, _, act, deact) = svar[&s].clone();
        let span = act.span;
        l.stmts.push(assign(act, boolean(false, span)));
        l.stmts.push(assign(deact, boolean(false, span)));
    }
    let initial: Vec<Stmt> = chart
        .steps
        .iter()
        .filter(|&&s| flag(l.els[s], "initialStep"))
        .map(|s| assign(svar[s].2.clone(), boolean(true, any_span)))
        .chain([assign(started.clone(), boolean(true, any_span))])
        .collect();
    l.stmts.push(when(not(started), initial));
    for &t in &cleared.order {
        let body = chart.pre[&t]
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
        l.stmts.push(when(cleared.fire[&t].clone(), body));
    }
    for &t in &cleared.order {
        let body = chart.post[&t]
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
        l.stmts.push(when(cleared.fire[&t].clone(), body));
    }
}

/// The qualifier of action `a` of action block `i` and its duration; `None` once told
/// why the association is refused.
fn action_qualifier(l: &mut Lower, i: usize, a: &X) -> Option<(String, Option<Expr>)> {
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
                l.error(
                    i,
                    diag::GRAPHICAL,
                    format!("duration `{d}` of an action is not a TIME literal; write e.g. T#5s"),
                );
            }
            e
        }
        None => None,
    };
    if !matches!(q.as_str(), "N" | "S" | "R" | "P" | "P0" | "P1" | "L" | "D") {
        l.error(
            i,
            diag::UNSUPPORTED,
            format!("action qualifier {q} is not supported yet (N, S, R, P, P0, P1, L and D are)"),
        );
        return None;
    }
    if matches!(q.as_str(), "L" | "D") && duration.is_none() {
        l.error(
            i,
            diag::GRAPHICAL,
            format!("qualifier {q} needs a duration attribute (duration=\"T#5s\")"),
        );
        return None;
    }
    Some((q, duration))
}

/// The target of action `a` of action block `i`, found among `targets` or added to them: a
/// named action, a BOOL variable or an inline ST body; `None` once told why there is none.
fn action_target(
    l: &mut Lower,
    pou_el: &X,
    i: usize,
    a: &X,
    span: Span,
    targets: &mut Vec<(String, Target, Span)>,
) -> Option<usize> {
    Some(if let Some(rf) = a.child("reference") {
        let an = rf.attr("name").unwrap_or("").trim().to_string();
        let key = an.to_ascii_uppercase();
        match targets.iter().position(|(k, _, _)| *k == key) {
            Some(p) => p,
            None => {
                let t = match named_action(l, pou_el, &an) {
                    Some(t) => t,
                    None => {
                        let f = l.file(i);
                        match parser::parse_expression(f, &an, l.r.diags) {
                            Some(e) => Target::Variable(e),
                            None => return None,
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
            return None;
        };
        let (text, at) = text_of(st);
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
        return None;
    })
}

/// The action associations of every action block, and their targets in first-use order.
fn associations(
    l: &mut Lower,
    pou_el: &X,
    svar: &StepVars,
) -> (Vec<(String, Target, Span)>, Vec<Assoc>) {
    let mut targets: Vec<(String, Target, Span)> = Vec::new();
    let mut assocs: Vec<Assoc> = Vec::new();
    for i in 0..l.els.len() {
        if l.els[i].name != "actionBlock" {
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
            let Some((q, duration)) = action_qualifier(l, i, a) else {
                continue;
            };
            let Some(target) = action_target(l, pou_el, i, a, span, &mut targets) else {
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
    (targets, assocs)
}

/// Every action run by its qualifiers: N, P, P0, P1, L and D while their step is, S and R
/// through a stored flag.
fn actions(l: &mut Lower, targets: Vec<(String, Target, Span)>, assocs: &[Assoc], svar: &StepVars) {
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
        let (text, at) = text_of(st);
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
        let (text, at) = text_of(st);
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
            let (text, at) = text_of(lang);
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
