//! SFC bodies of PLCopen XML read into the chart model (`crate::sfc::Chart`): steps,
//! the steps before and after each transition (through divergences, convergences and
//! jumps), conditions, actions and their associations; `crate::sfc::lower` does the rest.

use std::collections::{HashMap, HashSet};

use crate::ast::*;
use crate::diag::{self, Diagnostics};
use crate::parser;
use crate::plcopen::{text_of, Reader};
use crate::sfc::{self, Action, Assoc, Chart, Hidden, Qualifier, Step, Target, Transition};
use crate::source::Span;
use crate::xml::Element as X;

use super::ld::nested;
use super::{all_inputs, assign, boolean, connections, flag, local_id, Lower, Lowered};

/// Lowers an `<SFC>` body of POU element `pou_el`.
pub(in crate::plcopen) fn sfc(r: &mut Reader, pou: &str, pou_el: &X, body: &X) -> Lowered {
    let mut l = Lower::new(r, pou, "SFC", body);
    let (steps, step_of) = find_steps(&mut l);
    let succ = successors(&l);
    let transitions: Vec<usize> = (0..l.els.len())
        .filter(|&i| l.els[i].name == "transition")
        .collect();
    // Steps before and after each transition, as indices of `steps`.
    let index: HashMap<usize, usize> = steps.iter().enumerate().map(|(k, &s)| (s, k)).collect();
    let mut pre: HashMap<usize, Vec<usize>> = HashMap::new();
    let mut post: HashMap<usize, Vec<usize>> = HashMap::new();
    for &t in &transitions {
        let before = steps_before(&mut l, t);
        let after = steps_after(&mut l, t, &succ, &step_of);
        pre.insert(t, before.iter().map(|s| index[s]).collect());
        post.insert(t, after.iter().map(|s| index[s]).collect());
    }
    if steps.is_empty() {
        return l.finish();
    }
    let mut chart = Chart {
        steps: steps
            .iter()
            .map(|&s| {
                let span = l.span(s);
                let sn = l.els[s].attr("name").unwrap_or("").trim().to_string();
                Step {
                    name: Ident::new(&sn, span),
                    initial: flag(l.els[s], "initialStep"),
                }
            })
            .collect(),
        ..Chart::default()
    };
    chart.transitions = clear(&mut l, pou_el, &transitions, &pre, &post);
    // Networks drawn in the chart (blocks, coils, output variables) not yet run for a
    // condition run once per scan, after the conditions.
    l.network(&HashSet::new());
    chart.networks = std::mem::take(&mut l.stmts);
    associations(&mut l, pou_el, &index, &mut chart);
    let mut stmts = std::mem::take(&mut l.stmts);
    sfc::lower(
        chart,
        &mut Hidden {
            vars: &mut l.vars,
            declared: &mut l.declared,
        },
        &mut stmts,
    );
    l.stmts = stmts;
    // Elements of the chart that are not its own (a contact network feeding a condition)
    // were lowered where they were read.
    let mut out = l.finish();
    out.steps = true;
    out
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

/// The transitions in the order they are judged, each with its condition and the
/// statements computing it (read in that order, so that a value two conditions share is
/// computed before the first reads it). A transition whose condition cannot be read is
/// left out, once told why.
fn clear(
    l: &mut Lower,
    pou_el: &X,
    transitions: &[usize],
    pre: &HashMap<usize, Vec<usize>>,
    post: &HashMap<usize, Vec<usize>>,
) -> Vec<Transition> {
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
    let mut out = Vec::new();
    for &t in &ordered {
        let span = l.span(t);
        let id = local_id(l.els[t]).unwrap_or(t as u64);
        let Some(cond) = condition(l, pou_el, t) else {
            continue;
        };
        out.push(Transition {
            key: id.to_string(),
            from: pre[&t].clone(),
            to: post[&t].clone(),
            prelude: std::mem::take(&mut l.stmts),
            cond,
            span,
        });
    }
    out
}

/// The qualifier of action `a` of action block `i` and its duration; `None` once told
/// why the association is refused.
fn action_qualifier(l: &mut Lower, i: usize, a: &X) -> Option<(Qualifier, Option<Expr>)> {
    let written = a
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
    let Some(q) = Qualifier::parse(&written) else {
        l.error(
            i,
            diag::GRAPHICAL,
            format!(
                "action qualifier {written} is not one of {}",
                sfc::QUALIFIERS
            ),
        );
        return None;
    };
    if q.timed() && duration.is_none() {
        l.error(
            i,
            diag::GRAPHICAL,
            format!("qualifier {written} needs a duration attribute (duration=\"T#5s\")"),
        );
        return None;
    }
    Some((q, duration))
}

/// The action of association `a` of action block `i`, found among the chart's actions or
/// added to them: a named action, a BOOL variable or an inline ST body; `None` once told
/// why there is none.
fn action_target(
    l: &mut Lower,
    pou_el: &X,
    i: usize,
    a: &X,
    span: Span,
    keys: &mut Vec<String>,
    actions: &mut Vec<Action>,
) -> Option<usize> {
    let (key, action) = if let Some(rf) = a.child("reference") {
        let an = rf.attr("name").unwrap_or("").trim().to_string();
        let key = an.to_ascii_uppercase();
        if let Some(p) = keys.iter().position(|k| *k == key) {
            return Some(p);
        }
        let action = match named_action(l, pou_el, &an) {
            Some(t) => Action {
                name: Some(Ident::new(&an, span)),
                target: t,
                span,
            },
            None => {
                let f = l.file(i);
                let e = parser::parse_expression(f, &an, l.r.diags)?;
                Action {
                    name: None,
                    target: Target::Variable(e),
                    span,
                }
            }
        };
        (key, action)
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
        let action = Action {
            name: None,
            target: Target::Body(body),
            span,
        };
        (format!("#{}", keys.len()), action)
    } else {
        l.error(
            i,
            diag::PLCOPEN_STRUCTURE,
            "an <action> has neither <reference> nor <inline>".into(),
        );
        return None;
    };
    keys.push(key);
    actions.push(action);
    Some(actions.len() - 1)
}

/// The action associations of every action block, and their actions in first-use order.
fn associations(l: &mut Lower, pou_el: &X, index: &HashMap<usize, usize>, chart: &mut Chart) {
    let mut keys: Vec<String> = Vec::new();
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
        let Some(&step) = step.and_then(|s| index.get(&s)) else {
            l.error(i, diag::GRAPHICAL, "the action block is connected to no step; connect it to the step whose actions it lists".into());
            continue;
        };
        for a in el.children_named("action") {
            let Some((qualifier, duration)) = action_qualifier(l, i, a) else {
                continue;
            };
            let Some(action) = action_target(l, pou_el, i, a, span, &mut keys, &mut chart.actions)
            else {
                continue;
            };
            chart.assocs.push(Assoc {
                step,
                qualifier,
                duration,
                action,
            });
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
