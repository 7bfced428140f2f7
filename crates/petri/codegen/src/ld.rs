//! Ladder Diagram: the lowered program drawn as LD rungs in a PLCopen XML (TC6 v2.01)
//! project, following seed 002 §3.1 with the scan structure of [`crate::lower`].
//!
//! Rungs, top to bottom (an LD body runs its rungs in that order):
//!
//! 1. *init* (seed 002's block d): `NOT Init` → set coils of the initially marked places,
//!    then a set coil of `Init`, all in series on one rung.
//! 2. *inputs*: per input place, a contact of its signal → a coil of its marking.
//! 3. *timers*: per delayed arc, the contacts of its `IN` condition → a `TON` block (its `PT`
//!    an `inVariable` holding the `T#…` literal) whose `Q` drives a coil of an extra BOOL
//!    local `<timer>_Q`, which the transition rungs read as a contact.
//! 4. *transitions*: under `maximal-step`, first one rung per transition, its enabling →
//!    its fire-flag coil (seed 002's block a), then for every transition every consumed place
//!    a reset coil, then for every transition every produced place a set coil (block b; all
//!    resets before all sets, so a place emptied and refilled in one step stays marked).
//!    Under `sequential`, each transition's enabling rung is followed at once by its reset and
//!    set rungs, so later transitions see the new marking.
//! 5. *outputs* (block c): per output, the contacts of its places in parallel → its coil.
//!
//! Conditions become contacts: a conjunction in series, a disjunction in parallel branches,
//! a negated literal as a negated contact. A guard is expanded into a sum of products of
//! input literals (XOR expanded, NOT pushed inward). A condition that can never hold is
//! drawn as `Init` and `NOT Init` in series, so the rung stays in the diagram but its coil is
//! never energised.
//!
//! Refused, because LD here is relay logic over BOOL variables:
//! - nets whose markings are integers ([`CodegenError::NeedsSafeNet`]);
//! - integer outputs, integer comparisons in guards and integer inputs read as booleans
//!   ([`CodegenError::Unsupported`]; they would need comparison and move blocks);
//! - the `until-stable` evolution ([`CodegenError::Unsupported`]): it is a loop inside one
//!   scan, which LD could only draw with backward jumps and counter blocks, and IDEs handle
//!   backward jumps in LD poorly.
//!
//! Layout is a fixed grid: each rung has its own left and right power rail, contacts sit in
//! 60-unit cells on 40-unit rows, parallel branches go on the rows below, and rungs are
//! stacked without overlap. Every wire lists its points from the input pin to the source pin,
//! the last point being exactly the source's position plus its pin's `relPosition`.

use std::fmt::Write as _;

use petriplc_net::guard::Expr;
use petriplc_net::{Evolution, SignalType, StepRule};

use crate::enabling::Cond;
use crate::lower::{PlaceVar, Program, TransitionCode};
use crate::plcopen::{self, Body, Var, VarType};
use crate::spell::{render, Syntax};
use crate::text::xml;
use crate::CodegenError;

/// The most products a guard's sum of products may have before LD gives up on it.
const MAX_PRODUCTS: usize = 64;

/// Sub-expressions expanded for one guard at most: an XOR expands both of its operands
/// twice, so a chain of XORs doubles the work at every operator however few branches result.
const MAX_EXPANSIONS: usize = 100_000;

/// Writes the LD project for `p`.
pub fn project(p: &Program, created: &str) -> Result<String, CodegenError> {
    check(p)?;
    let mut interface = plcopen::program_interface(p);
    let timer_q = timer_q_names(p, &interface);
    for (tm, q) in p.timers.iter().zip(&timer_q) {
        interface.locals.push(Var {
            name: q.clone(),
            ty: VarType::Bool,
            doc: format!("output Q of {} (delay of arc {} elapsed)", tm.ident, tm.arc),
        });
    }
    let items = items(p, &timer_q)?;
    let content = layout(&items);
    Ok(plcopen::project(
        p,
        &interface,
        &Body::Graphical {
            language: "LD",
            content,
            pou_extra: String::new(),
        },
        created,
    ))
}

/// The refusals that do not depend on a particular rung.
fn check(p: &Program) -> Result<(), CodegenError> {
    for pl in &p.places {
        if pl.boolean {
            continue;
        }
        let reason = match pl.input {
            Some((s, _)) if p.inputs[s].ty == SignalType::Int => {
                format!("it mirrors the integer input {}", p.inputs[s].name)
            }
            _ => "the net is not provably safe, so its markings are integers (see --markings)"
                .to_string(),
        };
        return Err(CodegenError::NeedsSafeNet {
            lang: "LD",
            place: pl.label.clone(),
            reason,
        });
    }
    if p.evolve == Evolution::UntilStable {
        return Err(CodegenError::Unsupported {
            lang: "LD",
            what: "the until-stable evolution (a loop inside one scan)".into(),
            hint: "use --evolve one-pass, or --lang st, il or c".into(),
        });
    }
    if let Some(o) = p.outputs.iter().find(|o| o.ty == SignalType::Int) {
        return Err(CodegenError::Unsupported {
            lang: "LD",
            what: format!("the integer output {} (a coil drives only a BOOL)", o.name),
            hint: "make the output bool, or use --lang st, il or c".into(),
        });
    }
    Ok(())
}

/// A BOOL local per timer that holds its `Q`, named `<timer>_Q` unless that is taken
/// (IEC names are case-insensitive).
fn timer_q_names(p: &Program, interface: &plcopen::Interface) -> Vec<String> {
    let mut taken: Vec<String> = interface
        .inputs
        .iter()
        .chain(&interface.outputs)
        .chain(&interface.locals)
        .map(|v| v.name.to_ascii_lowercase())
        .collect();
    taken.push(p.pou.to_ascii_lowercase());
    let mut out = Vec::new();
    for tm in &p.timers {
        let sep = if tm.ident.ends_with('_') { "" } else { "_" };
        let base = format!("{}{sep}Q", tm.ident);
        let mut name = base.clone();
        let mut n = 2;
        while taken.contains(&name.to_ascii_lowercase()) {
            name = format!("{base}{n}");
            n += 1;
        }
        taken.push(name.to_ascii_lowercase());
        out.push(name);
    }
    out
}

/// Contacts in series and parallel. `Parallel(vec![])` is FALSE and `Series(vec![])` TRUE
/// while rungs are built; [`finish`] replaces a FALSE that survives.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Circuit {
    Contact { var: String, negated: bool },
    Series(Vec<Circuit>),
    Parallel(Vec<Circuit>),
}

const TRUE: Circuit = Circuit::Series(Vec::new());
const FALSE: Circuit = Circuit::Parallel(Vec::new());

fn contact(var: &str, negated: bool) -> Circuit {
    Circuit::Contact {
        var: var.to_string(),
        negated,
    }
}

fn series(items: impl IntoIterator<Item = Circuit>) -> Circuit {
    let mut out = Vec::new();
    for c in items {
        match c {
            Circuit::Series(inner) => out.extend(inner),
            c if c == FALSE => return FALSE,
            c => out.push(c),
        }
    }
    if out.len() == 1 {
        out.pop().unwrap_or(TRUE)
    } else {
        Circuit::Series(out)
    }
}

fn parallel(items: impl IntoIterator<Item = Circuit>) -> Circuit {
    let mut out = Vec::new();
    for c in items {
        match c {
            Circuit::Parallel(inner) => out.extend(inner),
            c if c == TRUE => return TRUE,
            c => {
                if !out.contains(&c) {
                    out.push(c)
                }
            }
        }
    }
    if out.len() == 1 {
        out.pop().unwrap_or(FALSE)
    } else {
        Circuit::Parallel(out)
    }
}

/// A rung's circuit as drawn: a FALSE, which simplification leaves only at the top, becomes
/// a contact and its negation in series, as LD has no constant contact.
fn finish(c: Circuit, init: &str) -> Circuit {
    if c == FALSE {
        Circuit::Series(vec![contact(init, false), contact(init, true)])
    } else {
        c
    }
}

/// What a rung drives, in series after its circuit.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Out {
    Coil { var: String, storage: Storage },
    Ton { instance: String, preset: String },
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Storage {
    None,
    Set,
    Reset,
}

fn coil(var: &str, storage: Storage) -> Out {
    Out::Coil {
        var: var.to_string(),
        storage,
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
struct Rung {
    circuit: Circuit,
    outs: Vec<Out>,
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Item {
    Comment(String),
    Rung(Rung),
}

/// The rungs and comments of the body, top to bottom.
fn items(p: &Program, timer_q: &[String]) -> Result<Vec<Item>, CodegenError> {
    let init = p.helpers.init.as_str();
    let mut items = Vec::new();
    let rung = |items: &mut Vec<Item>, circuit: Circuit, outs: Vec<Out>| {
        items.push(Item::Rung(Rung {
            circuit: finish(circuit, init),
            outs,
        }))
    };

    items.push(Item::Comment(
        "Initial marking, set on the first scan only".into(),
    ));
    let mut outs: Vec<Out> = p
        .places
        .iter()
        .filter(|pl| pl.input.is_none() && pl.initial > 0)
        .map(|pl| coil(&pl.ident, Storage::Set))
        .collect();
    outs.push(coil(init, Storage::Set));
    rung(&mut items, contact(init, true), outs);

    let input_places: Vec<_> = p.places.iter().filter(|pl| pl.input.is_some()).collect();
    if !input_places.is_empty() {
        items.push(Item::Comment("Input places mirror their signals".into()));
    }
    for pl in input_places {
        if let Some((s, _)) = pl.input {
            rung(
                &mut items,
                contact(&p.inputs[s].ident, false),
                vec![coil(&pl.ident, Storage::None)],
            );
        }
    }

    if !p.timers.is_empty() {
        items.push(Item::Comment("Delays of timed arcs".into()));
    }
    for (tm, q) in p.timers.iter().zip(timer_q) {
        let circuit = cond(p, timer_q, &tm.input)?;
        rung(
            &mut items,
            circuit,
            vec![
                Out::Ton {
                    instance: tm.ident.clone(),
                    preset: crate::iec_time(tm.delay),
                },
                coil(q, Storage::None),
            ],
        );
    }

    let enabling = |t: usize| -> Result<Circuit, CodegenError> {
        let parts = p.transitions[t]
            .enabling
            .all()
            .map(|c| cond(p, timer_q, c))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(series(parts))
    };
    let flow = |items: &mut Vec<Item>, t: usize, storage: Storage| {
        let tc = &p.transitions[t];
        let arcs = if storage == Storage::Reset {
            &tc.consume
        } else {
            &tc.produce
        };
        for &(pl, _) in arcs {
            items.push(Item::Rung(Rung {
                circuit: contact(&tc.ident, false),
                outs: vec![coil(&p.places[pl].ident, storage)],
            }));
        }
    };
    match p.step {
        StepRule::MaximalStep => {
            if !p.transitions.is_empty() {
                items.push(Item::Comment(
                    "Which transitions fire in this step (over the start marking)".into(),
                ));
            }
            for (t, tc) in p.transitions.iter().enumerate() {
                items.push(Item::Comment(transition_comment(tc)));
                let circuit = enabling(t)?;
                rung(&mut items, circuit, vec![coil(&tc.ident, Storage::None)]);
            }
            if !p.transitions.is_empty() {
                items.push(Item::Comment(
                    "Token flow: every reset before every set".into(),
                ));
            }
            for t in 0..p.transitions.len() {
                flow(&mut items, t, Storage::Reset);
            }
            for t in 0..p.transitions.len() {
                flow(&mut items, t, Storage::Set);
            }
        }
        StepRule::Sequential => {
            for (t, tc) in p.transitions.iter().enumerate() {
                items.push(Item::Comment(transition_comment(tc)));
                let circuit = enabling(t)?;
                rung(&mut items, circuit, vec![coil(&tc.ident, Storage::None)]);
                flow(&mut items, t, Storage::Reset);
                flow(&mut items, t, Storage::Set);
            }
        }
    }

    if !p.outputs.is_empty() {
        items.push(Item::Comment("Outputs: OR of their places".into()));
    }
    for o in &p.outputs {
        let circuit = parallel(
            o.places
                .iter()
                .map(|&pl| contact(&p.places[pl].ident, false)),
        );
        rung(&mut items, circuit, vec![coil(&o.ident, Storage::None)]);
    }
    Ok(items)
}

fn transition_comment(tc: &TransitionCode) -> String {
    match tc.shown_guard() {
        None => format!("Transition {}: {}", tc.label, tc.summary),
        Some(g) => format!("Transition {}: {} if {g}", tc.label, tc.summary),
    }
}

/// The contacts of a lowered condition.
fn cond(p: &Program, timer_q: &[String], c: &Cond) -> Result<Circuit, CodegenError> {
    render(&Ld { p, timer_q }, c)
}

/// Ladder's spelling of conditions: contacts on BOOL variables. Counts of tokens have no
/// contact; [`check`] refused integer places before any rung is built.
struct Ld<'a> {
    p: &'a Program,
    timer_q: &'a [String],
}

impl Ld<'_> {
    fn counted(&self, place: &PlaceVar) -> Result<Circuit, CodegenError> {
        Err(CodegenError::NeedsSafeNet {
            lang: "LD",
            place: place.label.clone(),
            reason: "its marking is an integer".into(),
        })
    }
}

impl Syntax for Ld<'_> {
    type Out = Result<Circuit, CodegenError>;

    fn program(&self) -> &Program {
        self.p
    }

    fn constant(&self, value: bool) -> Self::Out {
        Ok(if value { TRUE } else { FALSE })
    }

    fn any(&self, items: Vec<Self::Out>) -> Self::Out {
        Ok(parallel(items.into_iter().collect::<Result<Vec<_>, _>>()?))
    }

    fn guard(&self, t: usize, negated: bool) -> Self::Out {
        guard(self.p, t, !negated)
    }

    fn timer(&self, i: usize, negated: bool) -> Self::Out {
        Ok(contact(&self.timer_q[i], negated))
    }

    fn marked(&self, place: &PlaceVar, negated: bool) -> Self::Out {
        Ok(contact(&place.ident, negated))
    }

    fn fired(&self, t: &TransitionCode, negated: bool) -> Self::Out {
        Ok(contact(&t.ident, negated))
    }

    fn at_least(&self, place: &PlaceVar, _: Option<&str>, _: u32, _: bool) -> Self::Out {
        self.counted(place)
    }

    fn at_most(&self, place: &PlaceVar, _: Option<&str>, _: u64, _: bool) -> Self::Out {
        self.counted(place)
    }
}

/// A literal of a guard: an input's index and whether it is negated.
type Literal = (usize, bool);

/// Transition `t`'s guard (or its negation when `!positive`) as parallel branches of series
/// contacts.
fn guard(p: &Program, t: usize, positive: bool) -> Result<Circuit, CodegenError> {
    let tc = &p.transitions[t];
    let mut budget = MAX_EXPANSIONS;
    let products = dnf(p, tc, &tc.guard, positive, &mut budget)?;
    Ok(parallel(products.into_iter().map(|prod| {
        series(
            prod.into_iter()
                .map(|(s, neg)| contact(&p.inputs[s].ident, neg)),
        )
    })))
}

/// `e` (or `NOT e`) as a sum of products: no product is FALSE, an empty product is TRUE.
fn dnf(
    p: &Program,
    tc: &TransitionCode,
    e: &Expr<usize>,
    positive: bool,
    budget: &mut usize,
) -> Result<Vec<Vec<Literal>>, CodegenError> {
    if *budget == 0 {
        return Err(CodegenError::Unsupported {
            lang: "LD",
            what: format!(
                "the guard of transition {} ({}) as contacts: expanding it takes more than {MAX_EXPANSIONS} steps",
                tc.label, tc.guard_text
            ),
            hint: "simplify the guard (fewer XORs), or use --lang st, il or c".into(),
        });
    }
    *budget -= 1;
    let unsupported = |what: String| CodegenError::Unsupported {
        lang: "LD",
        what,
        hint: "LD would need comparison blocks; use --lang st, il or c".into(),
    };
    let sum = |a: Vec<Vec<Literal>>, b: Vec<Vec<Literal>>| {
        let mut out = a;
        for prod in b {
            if !out.contains(&prod) {
                out.push(prod);
            }
        }
        out
    };
    let out = match e {
        Expr::Const(b) => {
            if *b == positive {
                vec![Vec::new()]
            } else {
                Vec::new()
            }
        }
        Expr::Signal(s) => {
            if p.inputs[*s].ty != SignalType::Bool {
                return Err(unsupported(format!(
                    "the integer input {} read as a boolean in the guard of transition {} ({})",
                    p.inputs[*s].name, tc.label, tc.guard_text
                )));
            }
            vec![vec![(*s, !positive)]]
        }
        Expr::Not(e) => dnf(p, tc, e, !positive, budget)?,
        Expr::And(a, b) | Expr::Or(a, b) => {
            let and = matches!(e, Expr::And(..)) == positive;
            let a = dnf(p, tc, a, positive, budget)?;
            let b = dnf(p, tc, b, positive, budget)?;
            if and {
                product(&a, &b)
            } else {
                sum(a, b)
            }
        }
        Expr::Xor(a, b) => {
            let (ap, an) = (dnf(p, tc, a, true, budget)?, dnf(p, tc, a, false, budget)?);
            let (bp, bn) = (dnf(p, tc, b, true, budget)?, dnf(p, tc, b, false, budget)?);
            if positive {
                sum(product(&ap, &bn), product(&an, &bp))
            } else {
                sum(product(&ap, &bp), product(&an, &bn))
            }
        }
        Expr::Cmp(..) => {
            return Err(unsupported(format!(
                "the integer comparison in the guard of transition {} ({})",
                tc.label, tc.guard_text
            )))
        }
    };
    if out.len() > MAX_PRODUCTS {
        return Err(CodegenError::Unsupported {
            lang: "LD",
            what: format!(
                "the guard of transition {} ({}) as contacts: it expands to more than {MAX_PRODUCTS} parallel branches",
                tc.label, tc.guard_text
            ),
            hint: "simplify the guard, or use --lang st, il or c".into(),
        });
    }
    Ok(out)
}

/// The conjunction of two sums of products, without contradictory products.
fn product(a: &[Vec<Literal>], b: &[Vec<Literal>]) -> Vec<Vec<Literal>> {
    let mut out: Vec<Vec<Literal>> = Vec::new();
    for x in a {
        'next: for y in b {
            let mut prod = x.clone();
            for &(s, neg) in y {
                if prod.contains(&(s, !neg)) {
                    continue 'next;
                }
                if !prod.contains(&(s, neg)) {
                    prod.push((s, neg));
                }
            }
            if !out.contains(&prod) {
                out.push(prod);
            }
        }
    }
    out
}

// Grid, in the units of the body's coordinates (scaling 1). Contacts and coils have
// Beremiz's size, 21 × 15 with pins at mid-height.
const RAIL_X: i64 = 20;
const RAIL_W: i64 = 3;
const RAIL_H: i64 = 40;
const FIRST_CELL_X: i64 = 50;
const CELL: i64 = 60;
const CELL_PAD: i64 = 20;
const ROW: i64 = 40;
const ELEM_W: i64 = 21;
const ELEM_H: i64 = 15;
const PIN_Y: i64 = 8;
/// The main row's line, below a rung's top.
const MAIN_Y: i64 = 30;
const BLOCK_W: i64 = 70;
const BLOCK_H: i64 = 70;
const BLOCK_IN_Y: i64 = 30;
const BLOCK_PT_Y: i64 = 55;
const VAR_H: i64 = 30;
const COMMENT_H: i64 = 30;
const GAP: i64 = 20;

fn width(c: &Circuit) -> i64 {
    match c {
        Circuit::Contact { .. } => 1,
        Circuit::Series(cs) => cs.iter().map(width).sum(),
        Circuit::Parallel(cs) => cs.iter().map(width).max().unwrap_or(0),
    }
}

fn rows(c: &Circuit) -> i64 {
    match c {
        Circuit::Contact { .. } => 1,
        Circuit::Series(cs) => cs.iter().map(rows).max().unwrap_or(1),
        Circuit::Parallel(cs) => cs.iter().map(rows).sum::<i64>().max(1),
    }
}

fn preset_width(preset: &str) -> i64 {
    8 * preset.len() as i64 + 16
}

fn out_width(o: &Out) -> i64 {
    match o {
        Out::Coil { .. } => CELL,
        Out::Ton { preset, .. } => CELL_PAD + preset_width(preset) + 30 + BLOCK_W + CELL_PAD,
    }
}

fn out_height(o: &Out) -> i64 {
    match o {
        Out::Coil { .. } => 0,
        Out::Ton { .. } => BLOCK_H + GAP,
    }
}

fn rung_width(r: &Rung) -> i64 {
    width(&r.circuit) * CELL + r.outs.iter().map(out_width).sum::<i64>()
}

/// An output pin wires can start from.
#[derive(Clone, Debug)]
struct Src {
    id: u64,
    at: (i64, i64),
    formal: Option<&'static str>,
}

struct Writer {
    out: String,
    next_id: u64,
}

const IND: &str = "            ";

impl Writer {
    fn id(&mut self) -> u64 {
        self.next_id += 1;
        self.next_id
    }

    /// A `connectionPointIn` at `rel` of an element at `pos`, wired to every source (several
    /// sources make a wired OR, as parallel branches join in LD).
    /// A wire from a source on another row turns at `bend` (default: just left of the pin).
    fn point_in(
        &mut self,
        pos: (i64, i64),
        rel: (i64, i64),
        sources: &[Src],
        ind: &str,
        bend: Option<i64>,
    ) {
        let pin = (pos.0 + rel.0, pos.1 + rel.1);
        let w = &mut self.out;
        let _ = writeln!(w, "{ind}<connectionPointIn>");
        let _ = writeln!(w, "{ind}  <relPosition x=\"{}\" y=\"{}\"/>", rel.0, rel.1);
        for s in sources {
            let formal = s
                .formal
                .map(|f| format!(" formalParameter=\"{f}\""))
                .unwrap_or_default();
            let _ = writeln!(w, "{ind}  <connection refLocalId=\"{}\"{formal}>", s.id);
            let mut points = vec![pin];
            if s.at.1 != pin.1 {
                let bend = bend.unwrap_or(pin.0 - 10);
                points.push((bend, pin.1));
                points.push((bend, s.at.1));
            }
            points.push(s.at);
            for (x, y) in points {
                let _ = writeln!(w, "{ind}    <position x=\"{x}\" y=\"{y}\"/>");
            }
            let _ = writeln!(w, "{ind}  </connection>");
        }
        let _ = writeln!(w, "{ind}</connectionPointIn>");
    }

    fn point_out(&mut self, rel: (i64, i64), ind: &str) {
        let _ = writeln!(
            self.out,
            "{ind}<connectionPointOut>\n{ind}  <relPosition x=\"{}\" y=\"{}\"/>\n{ind}</connectionPointOut>",
            rel.0, rel.1
        );
    }

    /// A contact or coil whose input pin is at `pin`.
    fn element(
        &mut self,
        tag: &str,
        attrs: &str,
        var: &str,
        pin: (i64, i64),
        sources: &[Src],
    ) -> Src {
        let id = self.id();
        let pos = (pin.0, pin.1 - PIN_Y);
        let _ = writeln!(
            self.out,
            "{IND}<{tag} localId=\"{id}\" height=\"{ELEM_H}\" width=\"{ELEM_W}\"{attrs}>\n{IND}  <position x=\"{}\" y=\"{}\"/>",
            pos.0, pos.1
        );
        let ind = format!("{IND}  ");
        self.point_in(pos, (0, PIN_Y), sources, &ind, None);
        self.point_out((ELEM_W, PIN_Y), &ind);
        let _ = writeln!(
            self.out,
            "{IND}  <variable>{}</variable>\n{IND}</{tag}>",
            xml(var)
        );
        Src {
            id,
            at: (pos.0 + ELEM_W, pin.1),
            formal: None,
        }
    }

    /// Draws `c` from cell column `x` (absolute) and row line `y`, fed by `sources`; returns
    /// the pins its paths end at.
    fn circuit(&mut self, c: &Circuit, x: i64, y: i64, sources: Vec<Src>) -> Vec<Src> {
        match c {
            Circuit::Contact { var, negated } => {
                let attrs = format!(" negated=\"{negated}\"");
                vec![self.element("contact", &attrs, var, (x + CELL_PAD, y), &sources)]
            }
            Circuit::Series(cs) => {
                let (mut x, mut sources) = (x, sources);
                for c in cs {
                    sources = self.circuit(c, x, y, sources);
                    x += width(c) * CELL;
                }
                sources
            }
            Circuit::Parallel(cs) => {
                let mut y = y;
                let mut out = Vec::new();
                for c in cs {
                    out.extend(self.circuit(c, x, y, sources.clone()));
                    y += rows(c) * ROW;
                }
                out
            }
        }
    }

    fn ton(&mut self, instance: &str, preset: &str, x: i64, y: i64, sources: &[Src]) -> Src {
        let var_id = self.id();
        let var_w = preset_width(preset);
        let var_x = x + CELL_PAD;
        let block_x = var_x + var_w + 30;
        let block_pos = (block_x, y - BLOCK_IN_Y);
        let var_pos = (var_x, block_pos.1 + BLOCK_PT_Y - VAR_H / 2);
        let _ = writeln!(
            self.out,
            "{IND}<inVariable localId=\"{var_id}\" height=\"{VAR_H}\" width=\"{var_w}\" negated=\"false\">\n{IND}  <position x=\"{}\" y=\"{}\"/>",
            var_pos.0, var_pos.1
        );
        self.point_out((var_w, VAR_H / 2), &format!("{IND}  "));
        let _ = writeln!(
            self.out,
            "{IND}  <expression>{}</expression>\n{IND}</inVariable>",
            xml(preset)
        );
        let preset_src = Src {
            id: var_id,
            at: (var_pos.0 + var_w, var_pos.1 + VAR_H / 2),
            formal: None,
        };

        let id = self.id();
        let _ = writeln!(
            self.out,
            "{IND}<block localId=\"{id}\" width=\"{BLOCK_W}\" height=\"{BLOCK_H}\" typeName=\"TON\" instanceName=\"{}\">\n{IND}  <position x=\"{}\" y=\"{}\"/>\n{IND}  <inputVariables>",
            xml(instance),
            block_pos.0,
            block_pos.1
        );
        let ind = format!("{IND}      ");
        for (formal, rel_y, srcs) in [
            ("IN", BLOCK_IN_Y, sources),
            ("PT", BLOCK_PT_Y, std::slice::from_ref(&preset_src)),
        ] {
            let _ = writeln!(self.out, "{IND}    <variable formalParameter=\"{formal}\">");
            // Wires from lower branches turn before the preset, not across it.
            self.point_in(block_pos, (0, rel_y), srcs, &ind, Some(x + 10));
            let _ = writeln!(self.out, "{IND}    </variable>");
        }
        let _ = writeln!(
            self.out,
            "{IND}  </inputVariables>\n{IND}  <inOutVariables/>\n{IND}  <outputVariables>"
        );
        for (formal, rel_y) in [("Q", BLOCK_IN_Y), ("ET", BLOCK_PT_Y)] {
            let _ = writeln!(self.out, "{IND}    <variable formalParameter=\"{formal}\">");
            self.point_out((BLOCK_W, rel_y), &ind);
            let _ = writeln!(self.out, "{IND}    </variable>");
        }
        let _ = writeln!(self.out, "{IND}  </outputVariables>\n{IND}</block>");
        Src {
            id,
            at: (block_pos.0 + BLOCK_W, y),
            formal: Some("Q"),
        }
    }

    fn comment(&mut self, text: &str, y: i64, w: i64) {
        let id = self.id();
        let _ = writeln!(
            self.out,
            "{IND}<comment localId=\"{id}\" height=\"{COMMENT_H}\" width=\"{w}\">\n{IND}  <position x=\"{RAIL_X}\" y=\"{y}\"/>\n{IND}  <content>\n{IND}    <xhtml:p>{}</xhtml:p>\n{IND}  </content>\n{IND}</comment>",
            xml(text)
        );
    }

    /// Draws `r` with its top at `top`, its right rail at `right_x`; returns its height.
    fn rung(&mut self, r: &Rung, top: i64, right_x: i64) -> i64 {
        let y = top + MAIN_Y;
        let rail_id = self.id();
        let rail_pos = (RAIL_X, y - RAIL_H / 2);
        let _ = writeln!(
            self.out,
            "{IND}<leftPowerRail localId=\"{rail_id}\" height=\"{RAIL_H}\" width=\"{RAIL_W}\">\n{IND}  <position x=\"{}\" y=\"{}\"/>\n{IND}  <connectionPointOut formalParameter=\"\">\n{IND}    <relPosition x=\"{RAIL_W}\" y=\"{}\"/>\n{IND}  </connectionPointOut>\n{IND}</leftPowerRail>",
            rail_pos.0,
            rail_pos.1,
            RAIL_H / 2
        );
        let rail = Src {
            id: rail_id,
            at: (RAIL_X + RAIL_W, y),
            formal: None,
        };
        let mut x = FIRST_CELL_X;
        let mut sources = self.circuit(&r.circuit, x, y, vec![rail]);
        x += width(&r.circuit) * CELL;
        for o in &r.outs {
            let src = match o {
                Out::Coil { var, storage } => {
                    let attrs = match storage {
                        Storage::None => "",
                        Storage::Set => " storage=\"set\"",
                        Storage::Reset => " storage=\"reset\"",
                    };
                    self.element("coil", attrs, var, (x + CELL_PAD, y), &sources)
                }
                Out::Ton { instance, preset } => self.ton(instance, preset, x, y, &sources),
            };
            sources = vec![src];
            x += out_width(o);
        }
        let id = self.id();
        let pos = (right_x, y - RAIL_H / 2);
        let _ = writeln!(
            self.out,
            "{IND}<rightPowerRail localId=\"{id}\" height=\"{RAIL_H}\" width=\"{RAIL_W}\">\n{IND}  <position x=\"{}\" y=\"{}\"/>",
            pos.0, pos.1
        );
        self.point_in(pos, (0, RAIL_H / 2), &sources, &format!("{IND}  "), None);
        let _ = writeln!(self.out, "{IND}</rightPowerRail>");

        let branches = (rows(&r.circuit) - 1) * ROW + MAIN_Y + PIN_Y + GAP;
        let blocks = r.outs.iter().map(out_height).max().unwrap_or(0);
        branches.max(blocks).max(MAIN_Y + RAIL_H / 2 + GAP)
    }
}

/// The body's elements, rungs stacked from the top.
fn layout(items: &[Item]) -> String {
    let widest = items
        .iter()
        .filter_map(|i| match i {
            Item::Rung(r) => Some(rung_width(r)),
            Item::Comment(_) => None,
        })
        .max()
        .unwrap_or(0);
    let right_x = FIRST_CELL_X + widest + CELL_PAD;
    let mut w = Writer {
        out: String::new(),
        next_id: 0,
    };
    let mut top = GAP;
    for item in items {
        match item {
            Item::Comment(text) => {
                w.comment(text, top, right_x + RAIL_W - RAIL_X);
                top += COMMENT_H + GAP / 2;
            }
            Item::Rung(r) => top += w.rung(r, top, right_x),
        }
    }
    w.out
}
