//! Sequential Function Chart: a safe net drawn as an SFC inside a PLCopen XML project,
//! following seed 002's transcription (section 3.3, Table 2).
//!
//! A non-input place is a step named after its marking variable (`L1Local`); a transition
//! is an SFC transition whose receptivity is inline ST; arcs are connections. A transition
//! with several output places is followed by a simultaneous divergence, one with several
//! input places preceded by a simultaneous convergence; a step with several output
//! transitions is followed by a selection divergence, one with several input transitions
//! preceded by a selection convergence. An arc back to a step already drawn above (a loop,
//! found by a depth-first walk from the initial step in declaration order) is a `jumpStep`.
//! A step that drives a BOOL output has an action block with an `N` action on the output:
//! the output is TRUE while the step is active, and several steps driving one output give
//! their OR, as S6 says.
//!
//! Why this means what `petriplc sim` does, and where it does not:
//!
//! - An SFC clears, once per scan, every transition whose preceding steps are all active and
//!   whose receptivity is TRUE, all judged on the steps active at the start of the scan: the
//!   maximal step, one pass. Other step rules and evolutions are refused.
//! - Conflicts: transitions taking the token of one step follow its selection divergence,
//!   left to right and with `priority` 1, 2, … in declaration order, which is our priority
//!   rule. A read or inhibitor arc on a step that a higher-priority transition empties in
//!   the same scan would see the emptied step under our rule but the active one in SFC
//!   (`S.X` is read before clearing), so such nets are refused.
//! - Input places are not steps: their read and inhibitor arcs become conditions on the
//!   input signal in the receptivity. Read and inhibitor arcs on steps become `S.X` and
//!   `NOT S.X`.
//! - A delayed arc from a step becomes `S.T >= T#…`. IEC step time starts when the step is
//!   activated, whereas our TON first samples the token at the next scan (T2): the SFC fires
//!   one scan earlier. A delayed arc from an input place (a debounce) has no SFC form.
//! - A capacity of 1 matters only where no P-invariant bounds the place by one token; then
//!   the producing transitions get `NOT S.X` (E4), and two producers are refused because an
//!   SFC would let both clear in one scan where our rule lets only the first fire.

use std::collections::BTreeSet;

use petriplc_net::guard::Expr;
use petriplc_net::{Evolution, Net, PlaceId, SignalType, StepRule, TransitionId};
use petriplc_structure::{p_invariants, Limits};

use crate::lower::Program;
use crate::plcopen::{self, Body, Interface, Var};
use crate::CodegenError;

mod chart;
use chart::Chart;

const HINT: &str = "use --step maximal-step --evolve one-pass, or --lang st, il or c";

/// The PLCopen XML project of `net` as an SFC.
pub fn project(net: &Net, p: &Program, created: &str) -> Result<String, CodegenError> {
    check_program(p)?;
    let g = Graph::new(net, p)?;
    let conditions = (0..g.nt)
        .map(|t| receptivity(net, p, &g, t))
        .collect::<Result<Vec<_>, _>>()?;
    let chart = Chart::new(&g, p);
    let content = chart.render(&g, p, &conditions);
    Ok(plcopen::project(
        p,
        &interface(p),
        &Body::Graphical {
            language: "SFC",
            content,
            pou_extra: String::new(),
        },
        created,
    ))
}

fn not_sfc(reason: String) -> CodegenError {
    CodegenError::NotSfc { reason }
}

/// The scan semantics and the outputs an SFC can express.
fn check_program(p: &Program) -> Result<(), CodegenError> {
    if p.step != StepRule::MaximalStep || p.evolve != Evolution::OnePass {
        return Err(CodegenError::Unsupported {
            lang: "SFC",
            what: format!(
                "step rule {} with evolution {} (an SFC clears every clearable transition once per scan: a maximal step, one pass)",
                p.step.as_str(),
                p.evolve.as_str()
            ),
            hint: HINT.into(),
        });
    }
    if let Some(o) = p.outputs.iter().find(|o| o.ty == SignalType::Int) {
        return Err(CodegenError::Unsupported {
            lang: "SFC",
            what: format!(
                "integer output {} (a token count; a step is only active or not)",
                o.name
            ),
            hint: "make the output bool, or use --lang st, il or c".into(),
        });
    }
    Ok(())
}

/// The variables: only the signals, since the active steps are the marking.
fn interface(p: &Program) -> Interface {
    let var = |s: &crate::lower::Io, output: bool| Var {
        name: s.ident.clone(),
        ty: plcopen::signal_type(s.ty, output),
        doc: format!("{} {}", if output { "output" } else { "input" }, s.name),
    };
    Interface {
        inputs: p.inputs.iter().map(|s| var(s, false)).collect(),
        outputs: p.outputs.iter().map(|s| var(s, true)).collect(),
        locals: Vec::new(),
    }
}

/// The net as a chart: nodes are steps (place indices) and transitions (`np + t`).
struct Graph {
    np: usize,
    nt: usize,
    init: usize,
    /// Per transition: the steps it takes a token from, and puts one on.
    pre: Vec<Vec<usize>>,
    post: Vec<Vec<usize>>,
    /// Per node: successors in declaration order (a step's transitions, a transition's
    /// steps), as node ids.
    succ: Vec<Vec<usize>>,
    /// Per place: the transitions putting a token on it.
    ins: Vec<Vec<usize>>,
    /// Links closing a loop, found by the depth-first walk: (from, to) node ids.
    back: BTreeSet<(usize, usize)>,
    preorder: Vec<usize>,
    rank: Vec<usize>,
    /// Places whose capacity 1 is not implied by a P-invariant.
    capacity_matters: Vec<bool>,
}

impl Graph {
    fn new(net: &Net, p: &Program) -> Result<Graph, CodegenError> {
        let np = p.places.len();
        let nt = p.transitions.len();
        let label = |i: usize| p.places[i].label.as_str();
        let tlabel = |t: usize| p.transitions[t].label.as_str();
        let is_step = |i: usize| p.places[i].input.is_none();

        let marked: Vec<usize> = (0..np)
            .filter(|&i| is_step(i) && p.places[i].initial > 0)
            .collect();
        let init = match marked.as_slice() {
            [] => {
                return Err(not_sfc(
                    "no place is marked initially; mark exactly one place with one token, it becomes the initial step".into(),
                ))
            }
            [one] => *one,
            many => {
                return Err(not_sfc(format!(
                    "places {} are all marked initially, but an SFC has one initial step; mark exactly one place (seed 002) and let the others be filled from it",
                    many.iter().map(|&i| label(i)).collect::<Vec<_>>().join(", ")
                )))
            }
        };
        if p.places[init].initial != 1 {
            return Err(not_sfc(format!(
                "place {} starts with {} tokens, but the initial step is only active or not; give it exactly one token",
                label(init),
                p.places[init].initial
            )));
        }
        if let Some(i) = (0..np).find(|&i| is_step(i) && !p.places[i].boolean) {
            return Err(not_sfc(match crate::lower::unsafe_place(net) {
                Some((place, why)) => format!(
                    "place {place} is not safe ({why}), but a step is only active or not; give it capacity 1, or make the net hold at most one token there"
                ),
                None => format!(
                    "place {} has an integer marking (--markings int), but a step is only active or not; use --markings auto or bool",
                    label(i)
                ),
            }));
        }

        let mut pre = vec![Vec::new(); nt];
        let mut post = vec![Vec::new(); nt];
        let mut outs = vec![Vec::new(); np];
        let mut ins = vec![Vec::new(); np];
        for t in 0..nt {
            let tc = &p.transitions[t];
            for &(q, _) in &tc.consume {
                pre[t].push(q);
                outs[q].push(t);
            }
            for &(q, _) in &tc.produce {
                post[t].push(q);
                ins[q].push(t);
            }
            if pre[t].is_empty() {
                return Err(not_sfc(format!(
                    "transition {} takes no token from any place, but an SFC transition always follows a step; give it an input place",
                    tlabel(t)
                )));
            }
            if post[t].is_empty() {
                return Err(not_sfc(format!(
                    "transition {} puts no token on any place, but an SFC transition always leads to a step; give it an output place",
                    tlabel(t)
                )));
            }
        }
        if ins[init].len() > 1 {
            return Err(not_sfc(format!(
                "the initial place {} has {} arcs into it (from transitions {}), but seed 002 allows one, which becomes the jump back to the initial step; let the loops meet in one place with a single transition back to {}",
                label(init),
                ins[init].len(),
                ins[init].iter().map(|&t| tlabel(t)).collect::<Vec<_>>().join(", "),
                label(init)
            )));
        }

        // Our rule lets a read or inhibitor arc see a token already taken by a
        // higher-priority transition of the same step; SFC reads `S.X` before clearing.
        // That matters only when both transitions can be enabled together.
        let invariants = Bounds::new(net);
        let pre_of =
            |t: usize| -> Vec<usize> { p.transitions[t].consume.iter().map(|&(q, _)| q).collect() };
        for t in 0..nt {
            let a = net.arcs_of(TransitionId::from(t));
            for &(q, _) in a.read.iter().chain(&a.inhibit) {
                let q = q.index();
                if !is_step(q) {
                    continue;
                }
                let earlier = outs[q]
                    .iter()
                    .find(|&&u| u < t && !invariants.exclusive(&pre_of(u), &pre_of(t)));
                if let Some(&u) = earlier {
                    return Err(not_sfc(format!(
                        "transition {} tests place {} with a read or inhibitor arc, and the higher-priority transition {} takes its token in the same scan; an SFC tests {}.X before any transition clears, so declare {} before {}, or remove the arc",
                        tlabel(t),
                        label(q),
                        tlabel(u),
                        p.places[q].ident,
                        tlabel(t),
                        tlabel(u)
                    )));
                }
            }
        }

        let capacity_matters = capacity_matters(p, &invariants);
        for q in 0..np {
            if capacity_matters[q] && ins[q].len() > 1 {
                return Err(not_sfc(format!(
                    "place {} has capacity 1 but no P-invariant bounds it by one token, and transitions {} all put a token on it; our rule lets only the first fire in a scan, an SFC would clear them all; make the net safe by construction (e.g. add a complementary place)",
                    label(q),
                    ins[q].iter().map(|&t| tlabel(t)).collect::<Vec<_>>().join(", ")
                )));
            }
        }

        let n = np + nt;
        let succ: Vec<Vec<usize>> = outs
            .iter()
            .map(|ts| ts.iter().map(|&t| np + t).collect())
            .chain(post.iter().cloned())
            .collect();

        // Depth-first from the initial step, in declaration order: what it cannot reach is
        // not part of the chart, and the links it finds closing a loop are the jumps.
        let mut state = vec![0u8; n];
        let mut preorder = vec![usize::MAX; n];
        let mut postorder = Vec::with_capacity(n);
        let mut back = BTreeSet::new();
        let mut stack = vec![(init, 0usize)];
        state[init] = 1;
        preorder[init] = 0;
        let mut count = 1;
        while let Some(top) = stack.last_mut() {
            let (node, i) = *top;
            if let Some(&m) = succ[node].get(i) {
                top.1 += 1;
                match state[m] {
                    0 => {
                        state[m] = 1;
                        preorder[m] = count;
                        count += 1;
                        stack.push((m, 0));
                    }
                    1 => {
                        back.insert((node, m));
                    }
                    _ => {}
                }
            } else {
                state[node] = 2;
                postorder.push(node);
                stack.pop();
            }
        }
        if let Some(q) = (0..np).find(|&q| is_step(q) && state[q] == 0) {
            return Err(not_sfc(format!(
                "place {} cannot be reached from the initial place {} along arcs, but an SFC is drawn from its initial step; connect it or remove it",
                label(q),
                label(init)
            )));
        }
        if let Some(t) = (0..nt).find(|&t| state[np + t] == 0) {
            return Err(not_sfc(format!(
                "transition {} cannot be reached from the initial place {} along arcs, but an SFC is drawn from its initial step; connect it or remove it",
                tlabel(t),
                label(init)
            )));
        }
        for (t, outputs) in post.iter().enumerate() {
            if outputs.len() > 1 {
                if let Some(&q) = outputs.iter().find(|&&q| back.contains(&(np + t, q))) {
                    return Err(not_sfc(format!(
                        "transition {} starts parallel branches, one of which goes back to place {} drawn above it; a jump cannot be a branch of a simultaneous divergence, so let the branch pass through a place of its own first",
                        tlabel(t),
                        label(q)
                    )));
                }
            }
        }

        // Rows: the longest path from the initial step without the loop-closing links, so
        // that a convergence sits below all its branches.
        let mut rank = vec![0usize; n];
        for &node in postorder.iter().rev() {
            for &m in &succ[node] {
                if !back.contains(&(node, m)) {
                    rank[m] = rank[m].max(rank[node] + 1);
                }
            }
        }
        Ok(Graph {
            np,
            nt,
            init,
            pre,
            post,
            succ,
            ins,
            back,
            preorder,
            rank,
            capacity_matters,
        })
    }

    fn is_step(&self, node: usize) -> bool {
        node < self.np
    }

    /// The links drawn into a node, as node ids: a step's input transitions other than
    /// jumps, a transition's input steps.
    fn preds(&self, node: usize) -> Vec<usize> {
        if self.is_step(node) {
            self.ins[node]
                .iter()
                .map(|&t| self.np + t)
                .filter(|&t| !self.back.contains(&(t, node)))
                .collect()
        } else {
            self.pre[node - self.np].clone()
        }
    }

    fn forward_preds(&self, node: usize) -> Vec<usize> {
        self.preds(node)
            .into_iter()
            .filter(|&q| !self.back.contains(&(q, node)))
            .collect()
    }

    fn has_div(&self, node: usize) -> bool {
        self.succ[node].len() > 1
    }

    fn has_conv(&self, node: usize) -> bool {
        self.preds(node).len() > 1
    }

    /// The transition's single output goes back up: it ends in a jump.
    fn jump(&self, node: usize) -> Option<usize> {
        if self.is_step(node) || self.succ[node].len() != 1 {
            return None;
        }
        let q = self.succ[node][0];
        self.back.contains(&(node, q)).then_some(q)
    }
}

/// What the P-invariants say about places holding tokens together.
struct Bounds {
    /// Each invariant as its weights per place and its weighted initial marking.
    laws: Vec<(Vec<(usize, u128)>, u128)>,
}

impl Bounds {
    fn new(net: &Net) -> Bounds {
        let laws = p_invariants(net, Limits::QUICK)
            .vectors
            .into_iter()
            .map(|y| {
                let total = y
                    .iter()
                    .map(|&(q, w)| u128::from(w) * u128::from(net.place(PlaceId::from(q)).initial))
                    .sum();
                (
                    y.into_iter().map(|(q, w)| (q, u128::from(w))).collect(),
                    total,
                )
            })
            .collect();
        Bounds { laws }
    }

    /// Places `a` and `b` (maybe the same) never hold a token each at once.
    fn apart(&self, a: usize, b: usize) -> bool {
        self.laws.iter().any(|(y, total)| {
            let w = |q: usize| y.iter().find(|e| e.0 == q).map_or(0, |e| e.1);
            w(a) > 0 && w(b) > 0 && w(a) + w(b) > *total
        })
    }

    /// Two transitions with these presets are never enabled together: they share a place
    /// (then only one takes its token) or an invariant keeps two of their places apart.
    fn exclusive(&self, pre_a: &[usize], pre_b: &[usize]) -> bool {
        pre_a
            .iter()
            .any(|&a| pre_b.iter().any(|&b| a == b || self.apart(a, b)))
    }
}

/// Per place, whether its capacity 1 can stop a firing: no P-invariant proves it never
/// holds two tokens.
fn capacity_matters(p: &Program, bounds: &Bounds) -> Vec<bool> {
    (0..p.places.len())
        .map(|i| {
            p.places[i].input.is_none() && p.places[i].capacity.is_some() && !bounds.apart(i, i)
        })
        .collect()
}

/// The receptivity of transition `t` as ST: guard, input-place arcs, read and inhibitor
/// arcs on steps, delays, capacities, in that order, joined with AND.
fn receptivity(net: &Net, p: &Program, g: &Graph, t: usize) -> Result<String, CodegenError> {
    let tc = &p.transitions[t];
    let a = net.arcs_of(TransitionId::from(t));
    let mut parts = Vec::new();
    let typed = crate::st::typed_guard(p, &tc.guard);
    if typed != Expr::Const(true) {
        parts.push(typed.to_iec(&|i: &usize| p.inputs[*i].ident.clone()));
    }
    let guard_binds_loosely = matches!(typed, Expr::Or(..) | Expr::Xor(..));
    for (arcs, read) in [(&a.read, true), (&a.inhibit, false)] {
        for &(q, w) in arcs {
            let place = &p.places[q.index()];
            match place.input {
                Some((s, clamp)) => {
                    let signal = &p.inputs[s];
                    // The input place holds the signal clamped to [0, clamp] (S1).
                    let part = match (read, w > clamp, signal.ty) {
                        (true, true, _) => Some("FALSE".to_string()),
                        (false, true, _) => None,
                        (true, false, SignalType::Bool) => Some(signal.ident.clone()),
                        (false, false, SignalType::Bool) => Some(format!("NOT {}", signal.ident)),
                        (true, false, SignalType::Int) => Some(format!("{} >= {w}", signal.ident)),
                        (false, false, SignalType::Int) => Some(format!("{} < {w}", signal.ident)),
                    };
                    parts.extend(part);
                }
                None if read => parts.push(format!("{}.X", place.ident)),
                None => parts.push(format!("NOT {}.X", place.ident)),
            }
        }
    }
    for &i in &a.timed {
        let ta = &net.timed_arcs()[i];
        let place = &p.places[ta.place.index()];
        if place.input.is_some() {
            return Err(CodegenError::Unsupported {
                lang: "SFC",
                what: format!(
                    "the delay on arc {} from input place {} (a debounce of its signal; SFC times steps only)",
                    net.arcs()[ta.arc.index()].id,
                    place.label
                ),
                hint: "remove the delay, or use --lang st, il or c".into(),
            });
        }
        parts.push(format!(
            "{}.T >= {}",
            place.ident,
            crate::iec_time(ta.delay)
        ));
    }
    for &q in &g.post[t] {
        if g.capacity_matters[q] && !g.pre[t].contains(&q) {
            parts.push(format!("NOT {}.X", p.places[q].ident));
        }
    }
    if guard_binds_loosely && parts.len() > 1 {
        parts[0] = format!("({})", parts[0]);
    }
    Ok(if parts.is_empty() {
        "TRUE".into()
    } else {
        parts.join(" AND ")
    })
}
