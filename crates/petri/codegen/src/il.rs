//! IEC 61131-3 Instruction List: the lowered [`Program`] rendered block by block, doing what
//! the ST backend does statement for statement (see the module doc of [`crate::lower`] for
//! what a scan does).
//!
//! IL has one accumulator (the *current result*), so conditions are flattened into `LD`,
//! `AND`/`OR`/`XOR` with the `N` modifier for plain operands and deferred `AND( … )` for
//! anything computed (comparisons, nested disjunctions). Conditional blocks (the first scan,
//! token flow, the until-stable loop) are `JMPC`/`JMPCN` jumps to labels, which are claimed
//! like any other identifier so that they never clash with a variable.
//!
//! Only the plainest forms are written, the ones every IEC compiler handles (Beremiz's
//! matiec, CODESYS, TwinCAT; docs/codegen.md): markings are stored with `LD`/`ST` behind a
//! jump, never with the `S`/`R` operators; a timer's `IN` and `PT` are stored into the
//! instance before a plain `CAL`, never passed in a formal call; every label is followed by
//! an instruction.

use std::fmt::Write as _;

use petriplc_net::guard::{CmpOp, Expr, Operand};
use petriplc_net::{Evolution, SignalType, StepRule};

use crate::enabling::Cond;
use crate::lower::{PlaceVar, Program, TransitionCode};
use crate::names::Names;
use crate::plcopen::{program_interface, Interface};
use crate::spell::{render, Syntax};
use crate::text::comment;

/// One IL instruction, or a deferred operation whose operand is computed by `body`.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Ins {
    Op(String, Option<String>),
    Deferred(String, Vec<Ins>),
}

fn op(name: &str, arg: impl Into<String>) -> Ins {
    Ins::Op(name.to_string(), Some(arg.into()))
}

fn bare(name: &str) -> Ins {
    Ins::Op(name.to_string(), None)
}

/// A boolean value before it is flattened into instructions.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Node {
    /// A BOOL operand (variable or literal), negated when the flag is set.
    Var(String, bool),
    /// Instructions that load a BOOL into the current result, starting with a load.
    Code(Vec<Ins>),
    Not(Box<Node>),
    And(Vec<Node>),
    Or(Vec<Node>),
    Xor(Box<Node>, Box<Node>),
}

fn constant(b: bool) -> Node {
    Node::Var(if b { "TRUE" } else { "FALSE" }.into(), false)
}

fn negate(n: Node) -> Node {
    match n {
        Node::Var(v, neg) => Node::Var(v, !neg),
        Node::Not(inner) => *inner,
        other => Node::Not(Box::new(other)),
    }
}

/// Conjunction or disjunction, flattened, so `a AND (b AND c)` needs no parentheses.
fn chain(items: Vec<Node>, and: bool) -> Node {
    let mut flat = Vec::new();
    for n in items {
        match (n, and) {
            (Node::And(v), true) | (Node::Or(v), false) => flat.extend(v),
            (n, _) => flat.push(n),
        }
    }
    match flat.len() {
        0 => constant(and),
        1 => flat.pop().expect("one item"),
        _ if and => Node::And(flat),
        _ => Node::Or(flat),
    }
}

/// Instructions that put `n` into the current result.
fn load(n: &Node) -> Vec<Ins> {
    let mut out = Vec::new();
    match n {
        Node::Var(v, neg) => out.push(op(if *neg { "LDN" } else { "LD" }, v.clone())),
        Node::Code(code) => out.extend(code.iter().cloned()),
        Node::Not(inner) => {
            out.extend(load(inner));
            out.push(bare("NOT"));
        }
        Node::And(items) | Node::Or(items) => {
            let name = if matches!(n, Node::And(_)) {
                "AND"
            } else {
                "OR"
            };
            out.extend(load(&items[0]));
            for item in &items[1..] {
                out.push(apply(name, item));
            }
        }
        Node::Xor(a, b) => {
            out.extend(load(a));
            out.push(apply("XOR", b));
        }
    }
    out
}

/// `name` (AND, OR, XOR) of the current result and `n`.
fn apply(name: &str, n: &Node) -> Ins {
    match n {
        Node::Var(v, neg) => op(&format!("{name}{}", if *neg { "N" } else { "" }), v.clone()),
        Node::Not(inner) => Ins::Deferred(format!("{name}N"), load(inner)),
        other => Ins::Deferred(name.to_string(), load(other)),
    }
}

/// Where the renderer writes: labels in column 0, instructions indented by nesting depth.
struct Out {
    text: String,
}

impl Out {
    fn line(&mut self, depth: usize, op: &str, arg: Option<&str>) {
        let indent = "    ".repeat(depth + 1);
        match arg {
            Some(a) => {
                let _ = writeln!(self.text, "{indent}{op:<6}{a}");
            }
            None => {
                let _ = writeln!(self.text, "{indent}{op}");
            }
        }
    }

    fn ins(&mut self, code: &[Ins]) {
        self.ins_at(0, code);
    }

    fn ins_at(&mut self, depth: usize, code: &[Ins]) {
        for i in code {
            match i {
                Ins::Op(name, arg) => self.line(depth, name, arg.as_deref()),
                Ins::Deferred(name, body) => {
                    // `AND( x` is `AND(` followed by `LD x`, one line shorter.
                    let (first, rest) = match body.split_first() {
                        Some((Ins::Op(ld, Some(x)), rest)) if ld == "LD" => (Some(x), rest),
                        _ => (None, &body[..]),
                    };
                    self.line(depth, &format!("{name}("), first.map(String::as_str));
                    self.ins_at(depth + 1, rest);
                    self.line(depth, ")", None);
                }
            }
        }
    }

    fn op(&mut self, name: &str, arg: impl AsRef<str>) {
        self.line(0, name, Some(arg.as_ref()));
    }

    fn bare(&mut self, name: &str) {
        self.line(0, name, None);
    }

    fn label(&mut self, label: &str) {
        let _ = writeln!(self.text, "{label}:");
    }

    fn comment(&mut self, text: &str) {
        let _ = writeln!(self.text, "    (* {} *)", comment(text));
    }

    fn section(&mut self, title: &str) {
        if !self.text.is_empty() {
            self.text.push('\n');
        }
        let _ = writeln!(self.text, "(* --- {} --- *)", comment(title));
    }
}

/// A guard over the input signals as a BOOL node.
fn guard_node(p: &Program, e: &Expr<usize>) -> Node {
    match e {
        Expr::Const(b) => constant(*b),
        Expr::Signal(s) => {
            let io = &p.inputs[*s];
            match io.ty {
                SignalType::Bool => Node::Var(io.ident.clone(), false),
                // An integer read as a boolean is TRUE when not 0.
                SignalType::Int => Node::Code(vec![op("LD", io.ident.clone()), op("NE", "0")]),
            }
        }
        Expr::Not(inner) => negate(guard_node(p, inner)),
        Expr::And(a, b) => chain(vec![guard_node(p, a), guard_node(p, b)], true),
        Expr::Or(a, b) => chain(vec![guard_node(p, a), guard_node(p, b)], false),
        Expr::Xor(a, b) => Node::Xor(Box::new(guard_node(p, a)), Box::new(guard_node(p, b))),
        Expr::Cmp(a, o, b) => compare(p, a, *o, b),
    }
}

fn cmp_name(o: CmpOp) -> &'static str {
    match o {
        CmpOp::Eq => "EQ",
        CmpOp::Ne => "NE",
        CmpOp::Lt => "LT",
        CmpOp::Le => "LE",
        CmpOp::Gt => "GT",
        CmpOp::Ge => "GE",
    }
}

/// A comparison on DINT values: integer signals are DINT, BOOL ones are converted.
fn compare(p: &Program, a: &Operand<usize>, o: CmpOp, b: &Operand<usize>) -> Node {
    let dint = i64::from(i32::MIN)..=i64::from(i32::MAX);
    // Signals are DINT (or 0/1), so a literal outside DINT's range decides the comparison
    // alone; written out, it would not even type-check against a DINT.
    match (a, b) {
        (Operand::Literal(x), Operand::Literal(y)) => return constant(o.apply(*x, *y)),
        (Operand::Signal(_), Operand::Literal(l)) if !dint.contains(l) => {
            let v = if *l > 0 { *dint.end() } else { *dint.start() };
            return constant(o.apply(v, *l));
        }
        (Operand::Literal(l), Operand::Signal(_)) if !dint.contains(l) => {
            let v = if *l > 0 { *dint.end() } else { *dint.start() };
            return constant(o.apply(*l, v));
        }
        _ => {}
    }
    let value = |x: &Operand<usize>| -> Vec<Ins> {
        match x {
            Operand::Literal(v) => vec![op("LD", v.to_string())],
            Operand::Signal(s) => {
                let io = &p.inputs[*s];
                let mut v = vec![op("LD", io.ident.clone())];
                if io.ty == SignalType::Bool {
                    v.push(bare("BOOL_TO_DINT"));
                }
                v
            }
        }
    };
    let mut code = value(a);
    let rhs = value(b);
    code.push(match rhs.as_slice() {
        [Ins::Op(_, Some(x))] => op(cmp_name(o), x.clone()),
        _ => Ins::Deferred(cmp_name(o).to_string(), rhs),
    });
    Node::Code(code)
}

fn cond_node(p: &Program, c: &Cond) -> Node {
    render(&Il(p), c)
}

/// Instruction List's spelling of conditions: BOOL operands, or code that loads a BOOL.
struct Il<'p>(&'p Program);

impl Syntax for Il<'_> {
    type Out = Node;

    fn program(&self) -> &Program {
        self.0
    }

    fn constant(&self, value: bool) -> Node {
        constant(value)
    }

    fn any(&self, items: Vec<Node>) -> Node {
        chain(items, false)
    }

    fn guard(&self, t: usize, negated: bool) -> Node {
        let n = guard_node(self.0, &self.0.transitions[t].guard);
        if negated {
            negate(n)
        } else {
            n
        }
    }

    fn timer(&self, i: usize, negated: bool) -> Node {
        Node::Var(format!("{}.Q", self.0.timers[i].ident), negated)
    }

    fn marked(&self, place: &PlaceVar, negated: bool) -> Node {
        Node::Var(place.ident.clone(), negated)
    }

    fn fired(&self, t: &TransitionCode, negated: bool) -> Node {
        Node::Var(t.ident.clone(), negated)
    }

    fn at_least(&self, place: &PlaceVar, avail: Option<&str>, tokens: u32, negated: bool) -> Node {
        Node::Code(vec![
            op("LD", avail.unwrap_or(&place.ident)),
            op(if negated { "LT" } else { "GE" }, tokens.to_string()),
        ])
    }

    fn at_most(&self, place: &PlaceVar, produced: Option<&str>, limit: u64, negated: bool) -> Node {
        // A UDINT never exceeds u32::MAX, and the literal would not fit one.
        if limit >= u64::from(u32::MAX) {
            return constant(!negated);
        }
        let mut code = vec![op("LD", place.ident.clone())];
        if let Some(n) = produced {
            code.push(op("ADD", n));
        }
        code.push(op(if negated { "GT" } else { "LE" }, limit.to_string()));
        Node::Code(code)
    }
}

/// The IL that loads `c` into the current result (one instruction per line).
pub fn cond_text(p: &Program, c: &Cond) -> String {
    let mut out = Out {
        text: String::new(),
    };
    out.ins(&load(&cond_node(p, c)));
    out.text
}

/// The IL that loads the conjunction of `conds` (TRUE when empty).
pub fn conjunction_text(p: &Program, conds: &[Cond]) -> String {
    let mut out = Out {
        text: String::new(),
    };
    out.ins(&conjunction(p, conds.iter()));
    out.text
}

fn conjunction<'a>(p: &Program, conds: impl Iterator<Item = &'a Cond>) -> Vec<Ins> {
    load(&chain(conds.map(|c| cond_node(p, c)).collect(), true))
}

/// Labels, unique among themselves and against every variable (IEC names are
/// case-insensitive, and some compilers keep labels and variables in one namespace).
struct Labels {
    names: Names,
}

impl Labels {
    fn new(p: &Program, interface: &Interface) -> Self {
        let mut names = Names::new();
        names.claim(&p.pou, false);
        for v in interface
            .inputs
            .iter()
            .chain(&interface.outputs)
            .chain(&interface.locals)
        {
            names.claim(&v.name, false);
        }
        Labels { names }
    }

    fn claim(&mut self, wanted: &str) -> String {
        self.names.claim(wanted, false)
    }
}

/// Adds `delta` tokens to (or takes them from) the integer variable `var`.
fn add(out: &mut Out, var: &str, delta: u32, take: bool) {
    out.op("LD", var);
    out.op(if take { "SUB" } else { "ADD" }, delta.to_string());
    out.op("ST", var);
}

/// The token flow of transition `t`, run when its fire flag (already the current result)
/// is TRUE: a conditional jump over plain loads and stores. `S` and `R` are avoided: they
/// are also the set/reset inputs of function blocks, and matiec crashed on them. Takes come
/// first, so that a self-loop keeps its token.
fn flow(p: &Program, labels: &mut Labels, out: &mut Out, t: usize, phase: Phase) {
    let tr = &p.transitions[t];
    let maximal = p.step == StepRule::MaximalStep;
    let (take, give) = match phase {
        Phase::Both => (true, true),
        Phase::Take => (true, false),
        Phase::Give => (false, true),
    };
    let mut moves: Vec<(usize, u32, bool)> = Vec::new();
    if take {
        moves.extend(tr.consume.iter().map(|&(pl, w)| (pl, w, true)));
    }
    if give {
        moves.extend(tr.produce.iter().map(|&(pl, w)| (pl, w, false)));
    }
    if moves.is_empty() {
        return;
    }
    let suffix = match phase {
        Phase::Both => "Done",
        Phase::Take => "Taken",
        Phase::Give => "Given",
    };
    let stem = tr.ident.strip_suffix("Fire").unwrap_or(&tr.ident);
    let done = labels.claim(&format!("{stem}{suffix}"));
    out.op("JMPCN", &done);
    let (bools, ints): (Vec<_>, Vec<_>) = moves
        .into_iter()
        .partition(|&(pl, _, _)| p.places[pl].boolean);
    // One load serves every store of the same value.
    for value in [false, true] {
        let places: Vec<&str> = bools
            .iter()
            .filter(|&&(_, _, take)| take != value)
            .map(|&(pl, _, _)| p.places[pl].ident.as_str())
            .collect();
        if places.is_empty() {
            continue;
        }
        out.op("LD", if value { "TRUE" } else { "FALSE" });
        for place in places {
            out.op("ST", place);
        }
    }
    for (pl, w, take) in ints {
        let place = &p.places[pl];
        // Int maximal-step moves tokens between the pass's counters; the marking is
        // updated once, at the end of the pass.
        let var = match (maximal, take) {
            (true, true) => place.avail.as_ref().unwrap_or(&place.ident),
            (true, false) => place.produced.as_ref().unwrap_or(&place.ident),
            (false, _) => &place.ident,
        };
        add(out, var, w, take);
    }
    out.label(&done);
}

/// Which arcs of a transition a [`flow`] block moves tokens on.
#[derive(Clone, Copy)]
enum Phase {
    Both,
    Take,
    Give,
}

fn transition_comment(p: &Program, out: &mut Out, t: usize) {
    let tr = &p.transitions[t];
    let guard = tr
        .shown_guard()
        .map(|g| format!(" if {g}"))
        .unwrap_or_default();
    out.comment(&format!("{}: {}{guard}", tr.label, tr.summary));
}

/// One pass: timers sampled, then the transitions under the step rule.
fn pass(p: &Program, labels: &mut Labels, out: &mut Out) {
    let int_maximal = p.step == StepRule::MaximalStep && !p.boolean;
    if !p.timers.is_empty() {
        out.section("pass: timers of delayed arcs, sampled before the transitions");
        for tm in &p.timers {
            out.comment(&format!(
                "arc {}: {} holds {} token(s) for {}",
                tm.arc,
                p.places[tm.place].label,
                tm.weight,
                crate::iec_time(tm.delay)
            ));
            // The inputs are stored into the instance, then a plain CAL: the formal call
            // `CAL TON_x(IN := …, PT := …)` is what made matiec crash.
            out.ins(&load(&cond_node(p, &tm.input)));
            out.op("ST", format!("{}.IN", tm.ident));
            out.op("LD", crate::iec_time(tm.delay));
            out.op("ST", format!("{}.PT", tm.ident));
            out.op("CAL", &tm.ident);
        }
    }
    if int_maximal {
        out.section("pass: tokens available and produced in this pass");
        for pl in &p.places {
            if let Some(a) = &pl.avail {
                out.op("LD", &pl.ident);
                out.op("ST", a);
            }
            if let Some(n) = &pl.produced {
                out.op("LD", "0");
                out.op("ST", n);
            }
        }
    }
    match p.step {
        StepRule::Sequential => {
            out.section("pass: transitions in priority order, each firing at once");
            for (t, tr) in p.transitions.iter().enumerate() {
                transition_comment(p, out, t);
                out.ins(&conjunction(p, tr.enabling.all()));
                out.op("ST", &tr.ident);
                flow(p, labels, out, t, Phase::Both);
            }
        }
        StepRule::MaximalStep if int_maximal => {
            out.section("pass: transitions in priority order, judged on the available tokens");
            for (t, tr) in p.transitions.iter().enumerate() {
                transition_comment(p, out, t);
                out.ins(&conjunction(p, tr.enabling.all()));
                out.op("ST", &tr.ident);
                flow(p, labels, out, t, Phase::Both);
            }
            out.section("pass: the marking becomes available + produced tokens");
            for pl in &p.places {
                if pl.avail.is_none() && pl.produced.is_none() {
                    continue;
                }
                out.op("LD", pl.avail.as_ref().unwrap_or(&pl.ident));
                if let Some(n) = &pl.produced {
                    out.op("ADD", n);
                }
                out.op("ST", &pl.ident);
            }
        }
        StepRule::MaximalStep => {
            out.section("pass: fire flags of the maximal step, over the start marking");
            for (t, tr) in p.transitions.iter().enumerate() {
                transition_comment(p, out, t);
                out.ins(&conjunction(p, tr.enabling.all()));
                out.op("ST", &tr.ident);
            }
            // Every reset before any set: a place emptied and refilled in one step stays
            // marked.
            out.section("pass: fire the step, every reset then every set");
            for give in [false, true] {
                for (t, tr) in p.transitions.iter().enumerate() {
                    let arcs = if give { &tr.produce } else { &tr.consume };
                    if arcs.is_empty() {
                        continue;
                    }
                    out.op("LD", &tr.ident);
                    flow(
                        p,
                        labels,
                        out,
                        t,
                        if give { Phase::Give } else { Phase::Take },
                    );
                }
            }
        }
    }
}

fn outputs(p: &Program, out: &mut Out) {
    if p.outputs.is_empty() {
        return;
    }
    out.section("outputs: a BOOL output is the OR of its places, an integer one the marking");
    for o in &p.outputs {
        match o.ty {
            SignalType::Bool => {
                let marked = o
                    .places
                    .iter()
                    .map(|&pl| {
                        let place = &p.places[pl];
                        if place.boolean {
                            Node::Var(place.ident.clone(), false)
                        } else {
                            Node::Code(vec![op("LD", place.ident.clone()), op("GT", "0")])
                        }
                    })
                    .collect();
                out.ins(&load(&chain(marked, false)));
            }
            SignalType::Int => match o.places.first() {
                Some(&pl) => {
                    let place = &p.places[pl];
                    out.op("LD", &place.ident);
                    if place.boolean {
                        out.bare("BOOL_TO_UDINT");
                    }
                }
                None => out.op("LD", "0"),
            },
        }
        out.op("ST", &o.ident);
    }
}

/// The IL statements of the program (no declarations).
pub fn body(p: &Program) -> String {
    let interface = program_interface(p);
    let mut labels = Labels::new(p, &interface);
    let mut out = Out {
        text: crate::st::header(p, "(*", "*)", "  "),
    };

    // Variables start at 0 (FALSE), so only marked places need a value.
    let marked: Vec<_> = p.places.iter().filter(|pl| pl.initial > 0).collect();
    if !marked.is_empty() {
        out.section("init: the initial marking, on the first scan only");
        let init_done = labels.claim("InitDone");
        out.op("LD", &p.helpers.init);
        out.op("JMPC", &init_done);
        for pl in marked {
            let value = if pl.boolean {
                "TRUE".to_string()
            } else {
                pl.initial.to_string()
            };
            out.op("LD", value);
            out.op("ST", &pl.ident);
        }
        out.label(&init_done);
    }

    if p.places.iter().any(|pl| pl.input.is_some()) {
        out.section("inputs: each input place takes its clamped signal");
        for pl in &p.places {
            let Some((s, clamp)) = pl.input else { continue };
            let io = &p.inputs[s];
            out.op("LD", &io.ident);
            match (io.ty, pl.boolean) {
                (SignalType::Bool, true) => {}
                (SignalType::Bool, false) => out.bare("BOOL_TO_UDINT"),
                (SignalType::Int, _) => {
                    out.op("MAX", "0");
                    // A DINT never exceeds i32::MAX, and a larger literal is no DINT.
                    if i64::from(clamp) < i64::from(i32::MAX) {
                        out.op("MIN", clamp.to_string());
                    }
                    out.bare("DINT_TO_UDINT");
                }
            }
            out.op("ST", &pl.ident);
        }
    }

    match p.evolve {
        Evolution::OnePass => {
            pass(p, &mut labels, &mut out);
            outputs(p, &mut out);
        }
        Evolution::UntilStable => {
            let h = &p.helpers;
            let next = labels.claim("NextPass");
            let end = labels.claim("ScanEnd");
            out.section(&format!(
                "passes until one fires nothing, at most {}",
                p.max_passes
            ));
            out.op("LD", "0");
            out.op("ST", &h.passes);
            out.label(&next);
            pass(p, &mut labels, &mut out);
            out.section("end of pass: again while something fired and passes are left");
            let fired: Vec<Node> = p
                .transitions
                .iter()
                .map(|t| Node::Var(t.ident.clone(), false))
                .collect();
            out.ins(&load(&chain(fired, false)));
            out.op("ST", &h.fired);
            out.op("LD", &h.passes);
            out.op("ADD", "1");
            out.op("ST", &h.passes);
            out.op("LT", p.max_passes.to_string());
            out.op("AND", &h.fired);
            out.op("JMPC", &next);
            // Still firing after the last pass allowed: unstable, outputs not written.
            out.op("LD", &h.fired);
            out.op("ST", &h.unstable);
            out.op("JMPC", &end);
            outputs(p, &mut out);
            out.label(&end);
        }
    }
    // Set at the end rather than in the init block, so that every label is followed by an
    // instruction (no label ends the program); nothing reads the flag before the next scan.
    out.section("end of scan: the initial marking is set");
    out.op("LD", "TRUE");
    out.op("ST", &p.helpers.init);
    out.text
}

/// A whole `PROGRAM … END_PROGRAM`: the declarations and [`body`] (which opens with the
/// header comment ST has too).
pub fn program_text(p: &Program) -> String {
    crate::st::program(p, &body(p))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lines(code: &[Ins]) -> String {
        let mut out = Out {
            text: String::new(),
        };
        out.ins(code);
        out.text
    }

    fn v(name: &str) -> Node {
        Node::Var(name.into(), false)
    }

    #[test]
    fn plain_operands_use_modifiers() {
        let n = chain(vec![v("a"), negate(v("b")), v("c")], true);
        assert_eq!(lines(&load(&n)), "    LD    a\n    ANDN  b\n    AND   c\n");
    }

    #[test]
    fn computed_operands_are_deferred() {
        let n = chain(
            vec![v("a"), chain(vec![v("b"), negate(v("c"))], false)],
            true,
        );
        assert_eq!(
            lines(&load(&n)),
            "    LD    a\n    AND(  b\n        ORN   c\n    )\n"
        );
    }

    #[test]
    fn negated_compound_uses_the_n_modifier_or_not() {
        let or = chain(vec![v("b"), v("c")], false);
        let n = chain(vec![v("a"), negate(or.clone())], true);
        assert_eq!(
            lines(&load(&n)),
            "    LD    a\n    ANDN( b\n        OR    c\n    )\n"
        );
        assert_eq!(
            lines(&load(&negate(or))),
            "    LD    b\n    OR    c\n    NOT\n"
        );
    }

    #[test]
    fn nested_chains_are_flattened() {
        let n = chain(vec![chain(vec![v("a"), v("b")], true), v("c")], true);
        assert_eq!(n, Node::And(vec![v("a"), v("b"), v("c")]));
        assert_eq!(chain(vec![], true), constant(true));
        assert_eq!(chain(vec![], false), constant(false));
    }
}
