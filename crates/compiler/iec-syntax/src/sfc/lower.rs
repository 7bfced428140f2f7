//! The one lowering of a [`Chart`] to ST statements: step times, transitions cleared on the
//! steps active at the start of the scan, the evolution, and the actions by qualifier.

use std::collections::HashMap;

use super::{Chart, Hidden, Qualifier, Target, ACTION_TYPE, STEP_TYPE};
use crate::ast::*;
use crate::build::{all, and, any, arg, assign, bin, boolean, call, field, not, time, when};
use crate::source::Span;

/// A step's variables: the step (`X`, `T`), when it was last activated, and whether this
/// scan activated or deactivated it.
struct StepVars {
    step: Expr,
    t0: Expr,
    act: Expr,
    deact: Expr,
}

/// Appends the statements of `chart` to `stmts`, declaring its hidden variables in `h`.
pub(crate) fn lower(chart: Chart, h: &mut Hidden, stmts: &mut Vec<Stmt>) {
    let Some(first) = chart.steps.first() else {
        return;
    };
    let any_span = first.name.span;
    let clock = h.var("__sfc_clock", "TON", None, any_span);
    let now = h.var("__sfc_now", "TIME", None, any_span);
    let started = h.var("__sfc_started", "BOOL", None, any_span);
    let svar: Vec<StepVars> = chart
        .steps
        .iter()
        .map(|s| {
            let span = s.name.span;
            let sn = &s.name.name;
            StepVars {
                step: h.structure(&s.name, STEP_TYPE, s.initial.then_some("X")),
                t0: h.var(&format!("__{sn}_t0"), "TIME", None, span),
                act: h.var(&format!("__{sn}_act"), "BOOL", None, span),
                deact: h.var(&format!("__{sn}_deact"), "BOOL", None, span),
            }
        })
        .collect();
    step_times(stmts, clock, &now, &svar, any_span);
    // Conditions, judged on the steps active now: a transition clears if its steps are
    // active, its condition holds and no transition judged before it took one of its steps.
    let mut fire: Vec<Expr> = Vec::new();
    for (i, t) in chart.transitions.iter().enumerate() {
        stmts.extend(t.prelude.iter().cloned());
        let mut terms: Vec<Expr> = t
            .from
            .iter()
            .map(|&s| field(svar[s].step.clone(), "X"))
            .collect();
        terms.push(t.cond.clone());
        for (j, u) in chart.transitions[..i].iter().enumerate() {
            if u.from.iter().any(|s| t.from.contains(s)) {
                terms.push(not(fire[j].clone()));
            }
        }
        let f = h.var(&format!("__t{}", t.key), "BOOL", None, t.span);
        stmts.push(assign(f.clone(), all(terms, t.span)));
        fire.push(f);
    }
    stmts.extend(chart.networks.iter().cloned());
    evolve(stmts, &chart, &svar, &fire, started, &now, any_span);
    actions(h, stmts, chart, &svar, &now);
}

/// The chart's clock run and every active step's time `T` updated from it.
fn step_times(stmts: &mut Vec<Stmt>, clock: Expr, now: &Expr, svar: &[StepVars], span: Span) {
    // T#100000d: the clock never saturates.
    stmts.push(Stmt {
        kind: StmtKind::Call(call(
            clock.clone(),
            vec![
                arg("IN", boolean(true, span)),
                arg("PT", time(100_000 * 86_400 * 1_000_000_000, span)),
            ],
        )),
        span,
    });
    stmts.push(assign(now.clone(), field(clock, "ET")));
    for s in svar {
        stmts.push(when(
            field(s.step.clone(), "X"),
            vec![assign(
                field(s.step.clone(), "T"),
                bin(BinaryOp::Sub, now.clone(), s.t0.clone()),
            )],
        ));
    }
}

/// Evolution: every cleared transition at once, its steps before deactivated and its steps
/// after activated; the initial steps are activated in the first scan.
fn evolve(
    stmts: &mut Vec<Stmt>,
    chart: &Chart,
    svar: &[StepVars],
    fire: &[Expr],
    started: Expr,
    now: &Expr,
    any_span: Span,
) {
    for s in svar {
        let span = s.act.span;
        stmts.push(assign(s.act.clone(), boolean(false, span)));
        stmts.push(assign(s.deact.clone(), boolean(false, span)));
    }
    let initial: Vec<Stmt> = chart
        .steps
        .iter()
        .zip(svar)
        .filter(|(s, _)| s.initial)
        .map(|(_, v)| assign(v.act.clone(), boolean(true, any_span)))
        .chain([assign(started.clone(), boolean(true, any_span))])
        .collect();
    stmts.push(when(not(started), initial));
    for (t, f) in chart.transitions.iter().zip(fire) {
        let body = t
            .from
            .iter()
            .flat_map(|&s| {
                let v = &svar[s];
                let span = v.step.span;
                [
                    assign(field(v.step.clone(), "X"), boolean(false, span)),
                    assign(v.deact.clone(), boolean(true, span)),
                ]
            })
            .collect();
        stmts.push(when(f.clone(), body));
    }
    for (t, f) in chart.transitions.iter().zip(fire) {
        let body =
            t.to.iter()
                .flat_map(|&s| {
                    let v = &svar[s];
                    let span = v.step.span;
                    [
                        assign(field(v.step.clone(), "X"), boolean(true, span)),
                        assign(field(v.step.clone(), "T"), time(0, span)),
                        assign(v.t0.clone(), now.clone()),
                        assign(v.act.clone(), boolean(true, span)),
                    ]
                })
                .collect();
        stmts.push(when(f.clone(), body));
    }
}

/// What drives one action this scan: the terms of its state Q, what sets and resets its
/// stored flag, and the stored-and-timed associations (SD, DS, SL), each with its own flag.
#[derive(Default)]
struct Drive {
    on: Vec<Expr>,
    set: Vec<Expr>,
    reset: Vec<Expr>,
    /// (qualifier, step's X, step's T, duration).
    timed_stored: Vec<(Qualifier, Expr, Expr, Expr)>,
}

/// Every action run by its qualifiers, in the order the chart lists them.
fn actions(h: &mut Hidden, stmts: &mut Vec<Stmt>, chart: Chart, svar: &[StepVars], now: &Expr) {
    let mut drives: HashMap<usize, Drive> = HashMap::new();
    for a in &chart.assocs {
        let d = drives.entry(a.action).or_default();
        let v = &svar[a.step];
        let x = field(v.step.clone(), "X");
        let t = field(v.step.clone(), "T");
        let span = x.span;
        let dur = || a.duration.clone().unwrap_or_else(|| time(0, span));
        match a.qualifier {
            Qualifier::N => d.on.push(x),
            Qualifier::S => d.set.push(x),
            Qualifier::R => d.reset.push(x),
            Qualifier::P | Qualifier::P1 => d.on.push(v.act.clone()),
            Qualifier::P0 => d.on.push(and(v.deact.clone(), not(x))),
            Qualifier::L => d.on.push(and(x, bin(BinaryOp::Lt, t, dur()))),
            Qualifier::D => d.on.push(and(x, bin(BinaryOp::Ge, t, dur()))),
            q @ (Qualifier::Sd | Qualifier::Ds | Qualifier::Sl) => {
                let dur = dur();
                d.timed_stored.push((q, x, t, dur))
            }
        }
    }
    for (k, action) in chart.actions.into_iter().enumerate() {
        let span = action.span;
        let mut d = drives.remove(&k).unwrap_or_default();
        let reset = (!d.reset.is_empty()).then(|| any(std::mem::take(&mut d.reset), span));
        if !d.set.is_empty() || reset.is_some() {
            let stored = h.var(&format!("__a{k}_s"), "BOOL", None, span);
            if !d.set.is_empty() {
                stmts.push(when(
                    any(std::mem::take(&mut d.set), span),
                    vec![assign(stored.clone(), boolean(true, span))],
                ));
            }
            if let Some(r) = &reset {
                stmts.push(when(
                    r.clone(),
                    vec![assign(stored.clone(), boolean(false, span))],
                ));
            }
            d.on.push(stored);
        }
        for (j, (q, x, t, dur)) in std::mem::take(&mut d.timed_stored).into_iter().enumerate() {
            let on = timed_stored(h, stmts, (k, j), q, (x, t, dur), reset.as_ref(), now, span);
            d.on.push(on);
        }
        let q = any(d.on, span);
        match action.target {
            Target::Variable(v) => stmts.push(assign(v, q)),
            Target::Body(body) => {
                let q = match (&action.name, &q.kind) {
                    (Some(n), _) => {
                        let a = h.structure(n, ACTION_TYPE, None);
                        let aq = field(a, "Q");
                        stmts.push(assign(aq.clone(), q));
                        aq
                    }
                    (None, ExprKind::Name(_) | ExprKind::Field(..)) => q,
                    (None, _) => {
                        let qv = h.var(&format!("__a{k}_q"), "BOOL", None, span);
                        stmts.push(assign(qv.clone(), q));
                        qv
                    }
                };
                stmts.push(when(q, body));
            }
        }
    }
}

/// One SD, DS or SL association of action `k` (its `j`-th): a flag stored until the action
/// is reset, and for SD and SL the time it was stored. SD: stored while the step is active,
/// on once stored for the duration. DS: stored once the step has been active for the
/// duration, on while stored. SL: stored while the step is active, on for the duration
/// after that. R wins over all of them.
#[allow(clippy::too_many_arguments)]
fn timed_stored(
    h: &mut Hidden,
    stmts: &mut Vec<Stmt>,
    (k, j): (usize, usize),
    q: Qualifier,
    (x, t, dur): (Expr, Expr, Expr),
    reset: Option<&Expr>,
    now: &Expr,
    span: Span,
) -> Expr {
    let tag = match q {
        Qualifier::Sd => "sd",
        Qualifier::Ds => "ds",
        _ => "sl",
    };
    let stored = h.var(&format!("__a{k}_{tag}{j}"), "BOOL", None, span);
    let on = if q == Qualifier::Ds {
        stmts.push(when(
            and(x, bin(BinaryOp::Ge, t, dur)),
            vec![assign(stored.clone(), boolean(true, span))],
        ));
        None
    } else {
        let t0 = h.var(&format!("__a{k}_{tag}{j}_t0"), "TIME", None, span);
        stmts.push(when(
            and(x, not(stored.clone())),
            vec![
                assign(stored.clone(), boolean(true, span)),
                assign(t0.clone(), now.clone()),
            ],
        ));
        let since = bin(BinaryOp::Sub, now.clone(), t0);
        let op = if q == Qualifier::Sd {
            BinaryOp::Ge
        } else {
            BinaryOp::Lt
        };
        Some(bin(op, since, dur))
    };
    if let Some(r) = reset {
        stmts.push(when(
            r.clone(),
            vec![assign(stored.clone(), boolean(false, span))],
        ));
    }
    match on {
        Some(timed) => and(stored, timed),
        None => stored,
    }
}
