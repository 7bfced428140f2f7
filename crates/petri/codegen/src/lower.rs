//! The one lowered form every backend renders: variables with IEC names, and for each
//! transition its enabling condition (grouped as seed 004 groups checks) and its token flow,
//! already specialised to the step rule and the marking representation.
//!
//! A backend only chooses syntax and layout. What a scan does is decided here, following
//! docs/semantics.md (labels in brackets):
//!
//! 1. *init* — on the first scan, the initial marking is set (seed 002's block d, seed 003's
//!    `IF %MW100=0`), guarded by an `Init` flag so that an empty marking reached later is never
//!    mistaken for the first scan.
//! 2. *inputs* — each input place takes its clamped signal [S1].
//! 3. *passes* — once (`one-pass`) or until a pass fires nothing (`until-stable`, at most
//!    `max_passes`, else the `Unstable` flag is set and outputs are not written) [S5, X1]:
//!    timers are sampled [T2], then the transitions are tried in priority order:
//!    - *maximal-step, int markings* [S3]: every consumed place has an `Avail` copy of its
//!      marking, every produced place a `New` counter. A transition is judged on `Avail` for
//!      preset, test and inhibitor arcs, and on marking + `New` for capacities; when it fires it
//!      takes from `Avail` and adds to `New`. At the end of the pass the marking becomes
//!      `Avail + New`.
//!    - *maximal-step, bool markings* (safe nets, seed 002's blocks a and b): a transition's
//!      fire flag is its enabling over the start marking, with the tokens taken by
//!      higher-priority members of the step spelled out as `NOT` of their fire flags; then
//!      every consumed place is reset and every produced place set (resets first, so that a
//!      place emptied and refilled in one step stays marked).
//!    - *sequential* [S4]: a transition is judged on the current marking and fires at once.
//! 4. *outputs* — a boolean output is the OR of its places, an integer output the marking of
//!    its place [S6].

use std::time::Duration;

use petriplc_net::guard::Expr;
use petriplc_net::{Evolution, Net, PlaceId, SignalDirection, SignalType, StepRule, TransitionId};
use petriplc_structure::{p_invariants, structural_bounds, structural_conflicts, Limits};

pub use crate::enabling::{Atom, Cond, Enabling};
use crate::names::Names;
use crate::CodegenError;

/// How place markings are represented in the generated code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Markings {
    /// BOOL when every place is provably safe (capacity 1 or a P-invariant bound of 1) and
    /// every arc weight is 1; else integers.
    Auto,
    /// BOOL markings as in seed 002; refused when a place is not provably safe.
    Bool,
    /// Integer (UDINT) markings as in seed 003 and seed 004.
    Int,
}

/// What to generate code for.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Options {
    pub step: StepRule,
    pub evolve: Evolution,
    /// With `until-stable`, the most passes of one scan.
    pub max_passes: u32,
    pub markings: Markings,
    /// The program's name; the net's name when absent.
    pub pou: Option<String>,
    /// The period of the task that runs the program (PLCopen XML) or of the C main's scans.
    pub period: Duration,
}

impl Options {
    /// The net's own step rule and evolution, automatic markings, a 10 ms task.
    pub fn of(net: &Net) -> Self {
        Options {
            step: net.step,
            evolve: net.evolve,
            max_passes: 1000,
            markings: Markings::Auto,
            pou: None,
            period: Duration::from_millis(10),
        }
    }
}

/// A signal of the program's interface.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Io {
    /// The signal's name in the net.
    pub name: String,
    pub ident: String,
    pub ty: SignalType,
    /// For an output: the places that drive it, in declaration order.
    pub places: Vec<usize>,
}

/// A place and the variables that hold its marking.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlaceVar {
    pub label: String,
    /// The marking variable.
    pub ident: String,
    /// BOOL (TRUE = one token) instead of an integer.
    pub boolean: bool,
    pub initial: u32,
    /// The capacity the firing rule checks, for a non-input place that has one.
    pub capacity: Option<u32>,
    /// For an input place: the index of its signal in [`Program::inputs`] and the clamp
    /// (`u32::MAX` when the place has no capacity and the signal is an integer).
    pub input: Option<(usize, u32)>,
    /// Int maximal-step only: the tokens still available in the pass, for consumed places.
    pub avail: Option<String>,
    /// Int maximal-step only: the tokens produced in the pass, for produced places.
    pub produced: Option<String>,
}

/// The TON instance of one delayed arc.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Timer {
    pub ident: String,
    /// The arc's id in the PNML file.
    pub arc: String,
    pub place: usize,
    pub weight: u32,
    pub delay: Duration,
    /// The TON's `IN`: the place holds the arc's weight.
    pub input: Cond,
}

/// One transition of the program.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TransitionCode {
    pub label: String,
    /// The fire flag, TRUE when the transition fired in the current pass.
    pub ident: String,
    /// The guard over [`Program::inputs`] indices.
    pub guard: Expr<usize>,
    /// The guard as written in the net, for comments.
    pub guard_text: String,
    pub enabling: Enabling,
    /// Tokens taken: (place, weight).
    pub consume: Vec<(usize, u32)>,
    /// Tokens added: (place, weight).
    pub produce: Vec<(usize, u32)>,
    /// A one-line picture for comments: `p1 -> p2`, with read and inhibitor arcs.
    pub summary: String,
}

impl TransitionCode {
    /// The guard as written, for the comment above the transition's code; `None` when the
    /// transition has none (TRUE), so that no backend prints `if TRUE`.
    pub fn shown_guard(&self) -> Option<&str> {
        match self.guard_text.trim() {
            "" | "TRUE" => None,
            _ => Some(&self.guard_text),
        }
    }
}

/// Two transitions that may want the same tokens; the first has priority.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Conflict {
    pub first: String,
    pub second: String,
    pub places: Vec<String>,
}

/// Names of the program's bookkeeping variables.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Helpers {
    /// TRUE once the initial marking is set.
    pub init: String,
    /// Until-stable: passes made in this scan.
    pub passes: String,
    /// Until-stable: something fired in this pass.
    pub fired: String,
    /// Until-stable: the scan hit `max_passes` still firing (an output).
    pub unstable: String,
}

/// The lowered program.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Program {
    /// The net's name (or id).
    pub net_name: String,
    pub pou: String,
    pub step: StepRule,
    pub evolve: Evolution,
    pub max_passes: u32,
    /// Whether non-input places are BOOL.
    pub boolean: bool,
    pub period: Duration,
    pub inputs: Vec<Io>,
    pub outputs: Vec<Io>,
    pub places: Vec<PlaceVar>,
    pub timers: Vec<Timer>,
    pub transitions: Vec<TransitionCode>,
    pub conflicts: Vec<Conflict>,
    pub helpers: Helpers,
    /// Names of the net that are not valid or not unique IEC identifiers, and what they
    /// became.
    pub renamed: Vec<(String, String)>,
}

impl Program {
    /// Lowers `net` for `options`.
    pub fn lower(net: &Net, options: &Options) -> Result<Program, CodegenError> {
        let boolean = choose_markings(net, options.markings)?;
        let maximal = options.step == StepRule::MaximalStep;
        let mut names = Names::new();
        let net_name = if net.name.trim().is_empty() {
            net.id.clone()
        } else {
            net.name.clone()
        };
        let pou = match &options.pou {
            Some(p) => {
                if !crate::names::mangle(p).eq(p) || names.is_taken(p) {
                    return Err(CodegenError::BadPouName { name: p.clone() });
                }
                names.claim(p, false)
            }
            None => names.claim(&net_name, true),
        };

        // The interface first: signal names are what the PLC's I/O is wired to, so they keep
        // their spelling whenever it is valid.
        let mut signal_index = vec![usize::MAX; net.signals().len()];
        let mut inputs = Vec::new();
        let mut outputs = Vec::new();
        for (i, s) in net.signals().iter().enumerate() {
            let io = Io {
                name: s.name.clone(),
                ident: names.claim(&s.name, true),
                ty: s.ty,
                places: Vec::new(),
            };
            match s.direction {
                SignalDirection::Input => {
                    signal_index[i] = inputs.len();
                    inputs.push(io);
                }
                SignalDirection::Output => {
                    signal_index[i] = outputs.len();
                    outputs.push(io);
                }
            }
        }

        let consumed: Vec<bool> = flags(net, |t| &net.arcs_of(t).consume);
        let produced: Vec<bool> = flags(net, |t| &net.arcs_of(t).produce);
        let mut places = Vec::new();
        for p in net.place_ids() {
            let place = net.place(p);
            let label = net.place_label(p).to_string();
            let ident = names.claim(&format!("{label}Local"), false);
            let input = place
                .input
                .map(|s| (signal_index[s.index()], net.capacity(p)));
            // An input place is BOOL in a BOOL program when its signal is boolean (its
            // clamped value is then 0 or 1); an integer signal keeps an integer place.
            let is_bool = boolean
                && place
                    .input
                    .is_none_or(|s| net.signal(s).ty == SignalType::Bool);
            let int_maximal = maximal && !is_bool;
            places.push(PlaceVar {
                label: label.clone(),
                ident,
                boolean: is_bool,
                initial: place.initial,
                capacity: if place.input.is_some() {
                    None
                } else {
                    place.capacity
                },
                input,
                avail: (int_maximal && consumed[p.index()])
                    .then(|| names.claim(&format!("{label}Avail"), false)),
                produced: (int_maximal && produced[p.index()])
                    .then(|| names.claim(&format!("{label}New"), false)),
            });
            if let Some(s) = place.output {
                outputs[signal_index[s.index()]].places.push(p.index());
            }
        }

        let timers: Vec<Timer> = net
            .timed_arcs()
            .iter()
            .map(|ta| {
                let arc = net.arcs()[ta.arc.index()].id.clone();
                let p = ta.place.index();
                Timer {
                    ident: names.claim(&format!("TON_{arc}"), false),
                    arc,
                    place: p,
                    weight: ta.weight,
                    delay: ta.delay,
                    input: holds(&places[p], p, ta.weight, false),
                }
            })
            .collect();

        let mut transitions = Vec::new();
        for t in net.transition_ids() {
            let label = net.transition_label(t).to_string();
            let ident = names.claim(&format!("{label}Fire"), false);
            let guard = net
                .transition(t)
                .guard
                .0
                .try_map(&mut |s| Ok::<_, std::convert::Infallible>(signal_index[s.index()]));
            let guard = match guard {
                Ok(g) => g,
                Err(never) => match never {},
            };
            transitions.push(TransitionCode {
                label,
                ident,
                guard_text: net.guard_text(t),
                guard,
                enabling: Enabling::default(),
                consume: pairs(&net.arcs_of(t).consume),
                produce: pairs(&net.arcs_of(t).produce),
                summary: summary(net, t),
            });
        }
        for t in net.transition_ids() {
            let enabling = enabling(net, t, &places, &transitions, maximal);
            transitions[t.index()].enabling = enabling;
        }

        let conflicts = structural_conflicts(net)
            .into_iter()
            .map(|c| Conflict {
                first: net.transition_label(c.a).to_string(),
                second: net.transition_label(c.b).to_string(),
                places: c
                    .places
                    .iter()
                    .map(|&p| net.place_label(p).to_string())
                    .collect(),
            })
            .collect();

        let helpers = Helpers {
            init: names.claim("Init", false),
            passes: names.claim("Passes", false),
            fired: names.claim("Fired", false),
            unstable: names.claim("Unstable", false),
        };
        Ok(Program {
            net_name,
            pou,
            step: options.step,
            evolve: options.evolve,
            max_passes: options.max_passes.max(1),
            boolean,
            period: options.period,
            inputs,
            outputs,
            places,
            timers,
            transitions,
            conflicts,
            helpers,
            renamed: names.renamed().to_vec(),
        })
    }

    /// Whether any place is an integer (input places of integer signals included).
    pub fn has_int_places(&self) -> bool {
        self.places.iter().any(|p| !p.boolean)
    }

    /// The timers of transition `t`'s delayed arcs.
    pub fn timers_of(&self, t: usize) -> impl Iterator<Item = usize> + '_ {
        self.transitions[t]
            .enabling
            .delays
            .iter()
            .filter_map(|c| match c {
                Cond::Lit {
                    atom: Atom::Timer(i),
                    ..
                } => Some(*i),
                _ => None,
            })
    }
}

fn flags<'n>(net: &'n Net, arcs: impl Fn(TransitionId) -> &'n Vec<(PlaceId, u32)>) -> Vec<bool> {
    let mut out = vec![false; net.places().len()];
    for t in net.transition_ids() {
        for &(p, _) in arcs(t) {
            out[p.index()] = true;
        }
    }
    out
}

fn pairs(v: &[(PlaceId, u32)]) -> Vec<(usize, u32)> {
    v.iter().map(|&(p, w)| (p.index(), w)).collect()
}

/// `place` holds at least `weight` tokens (its `Avail` copy when `avail` and it has one).
fn holds(place: &PlaceVar, p: usize, weight: u32, avail: bool) -> Cond {
    if place.boolean {
        if weight == 1 {
            Cond::lit(Atom::Marked(p))
        } else {
            // A BOOL place never holds two tokens.
            Cond::Const(false)
        }
    } else {
        Cond::lit(Atom::AtLeast {
            place: p,
            avail: avail && place.avail.is_some(),
            tokens: weight,
        })
    }
}

/// The negation of [`holds`]: fewer than `weight` tokens.
fn lacks(place: &PlaceVar, p: usize, weight: u32, avail: bool) -> Cond {
    match holds(place, p, weight, avail) {
        Cond::Lit { atom, negated } => Cond::Lit {
            atom,
            negated: !negated,
        },
        Cond::Const(b) => Cond::Const(!b),
        Cond::Any(_) => unreachable!("holds() returns a literal or a constant"),
    }
}

fn enabling(
    net: &Net,
    t: TransitionId,
    places: &[PlaceVar],
    transitions: &[TransitionCode],
    maximal: bool,
) -> Enabling {
    let a = net.arcs_of(t);
    let mut e = Enabling::default();
    if !net.transition(t).guard.is_true() {
        e.guard.push(Cond::lit(Atom::Guard(t.index())));
    }
    e.delays = a.timed.iter().map(|&i| Cond::lit(Atom::Timer(i))).collect();

    // Bool maximal-step: tokens of place p taken, or p filled, by higher-priority members of
    // the step, spelled out as their fire flags.
    let earlier = |p: usize, produce: bool| -> Vec<usize> {
        if !(maximal && places[p].boolean) {
            return Vec::new();
        }
        transitions[..t.index()]
            .iter()
            .enumerate()
            .filter(|(_, u)| {
                let arcs = if produce { &u.produce } else { &u.consume };
                arcs.iter().any(|&(q, _)| q == p)
            })
            .map(|(i, _)| i)
            .collect()
    };
    let not_taken = |p: usize, out: &mut Vec<Cond>, produce: bool| {
        for u in earlier(p, produce) {
            out.push(Cond::not(Atom::Fired(u)));
        }
    };

    for &(p, w) in &a.read {
        let p = p.index();
        e.test.push(holds(&places[p], p, w, maximal));
        not_taken(p, &mut e.test, false);
    }
    for &(p, w) in &a.inhibit {
        let p = p.index();
        let takers = earlier(p, false);
        let free = lacks(&places[p], p, w, maximal);
        if takers.is_empty() || free == Cond::Const(true) {
            e.inhibitor.push(free);
        } else {
            // A BOOL place is empty in the reduced marking when it was, or when a
            // higher-priority member of the step took its token.
            let mut any = vec![free];
            any.extend(takers.into_iter().map(|u| Cond::lit(Atom::Fired(u))));
            e.inhibitor.push(Cond::Any(any));
        }
    }
    for &(p, w) in &a.consume {
        let p = p.index();
        e.preset.push(holds(&places[p], p, w, maximal));
        not_taken(p, &mut e.preset, false);
    }
    for &(p, w) in &a.produce {
        let p = p.index();
        let place = &places[p];
        let Some(cap) = place.capacity else { continue };
        let own = a.consumed_from(PlaceId::from(p));
        if place.boolean {
            // Weights are 1 and the capacity is 1: an own token makes room for the new one;
            // otherwise the place must be empty.
            if own == 0 {
                e.postset.push(Cond::not(Atom::Marked(p)));
            }
            not_taken(p, &mut e.postset, true);
        } else {
            let limit = i64::from(cap) + i64::from(own) - i64::from(w);
            e.postset.push(if limit < 0 {
                Cond::Const(false)
            } else {
                Cond::lit(Atom::AtMost {
                    place: p,
                    produced: maximal && place.produced.is_some(),
                    limit: limit as u64,
                })
            });
        }
    }
    e
}

/// `a + b -> c` with `?x` for a read arc and `!x` for an inhibitor arc.
fn summary(net: &Net, t: TransitionId) -> String {
    let a = net.arcs_of(t);
    let item = |p: PlaceId, w: u32, prefix: &str| {
        let l = net.place_label(p);
        if w == 1 {
            format!("{prefix}{l}")
        } else {
            format!("{prefix}{w}*{l}")
        }
    };
    let mut pre: Vec<String> = a.consume.iter().map(|&(p, w)| item(p, w, "")).collect();
    pre.extend(a.read.iter().map(|&(p, w)| item(p, w, "?")));
    pre.extend(a.inhibit.iter().map(|&(p, w)| item(p, w, "!")));
    let post: Vec<String> = a.produce.iter().map(|&(p, w)| item(p, w, "")).collect();
    let side = |v: Vec<String>| {
        if v.is_empty() {
            "()".to_string()
        } else {
            v.join(" + ")
        }
    };
    format!("{} -> {}", side(pre), side(post))
}

/// Whether non-input places are BOOL: every one safe (capacity 1, or bounded by 1 by a
/// P-invariant) with arcs of weight 1 and at most one initial token.
fn choose_markings(net: &Net, wanted: Markings) -> Result<bool, CodegenError> {
    if wanted == Markings::Int {
        return Ok(false);
    }
    let why_not = unsafe_place(net);
    match (wanted, why_not) {
        (_, None) => Ok(true),
        (Markings::Bool, Some((place, reason))) => Err(CodegenError::NotSafe { place, reason }),
        _ => Ok(false),
    }
}

/// The first place that keeps BOOL markings from being exact, and why.
pub(crate) fn unsafe_place(net: &Net) -> Option<(String, String)> {
    let mut bounds: Option<Vec<Option<u64>>> = None;
    for p in net.place_ids() {
        let place = net.place(p);
        if place.input.is_some() {
            continue;
        }
        let label = net.place_label(p).to_string();
        if place.initial > 1 {
            return Some((label, format!("it starts with {} tokens", place.initial)));
        }
        for arc in net.arcs().iter().filter(|a| a.place == p) {
            if arc.weight != 1 {
                return Some((label, format!("arc {} has weight {}", arc.id, arc.weight)));
            }
        }
        if place.capacity == Some(1) {
            continue;
        }
        let bounds =
            bounds.get_or_insert_with(|| structural_bounds(net, &p_invariants(net, Limits::QUICK)));
        if bounds[p.index()].is_none_or(|b| b > 1) {
            return Some((
                label,
                "it has no capacity 1 and no P-invariant bounds it by 1 token".into(),
            ));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use petriplc_testnet::net;

    fn lower(text: &str, markings: Markings) -> Result<Program, CodegenError> {
        let n = net(text);
        let mut options = Options::of(&n);
        options.markings = markings;
        Program::lower(&n, &options)
    }

    #[test]
    fn names_never_collide_whatever_the_case() {
        let mut n = net(
            "s test in bool\ns Test_Local out bool\np TEST 1 >Test_Local\nt t TEST -> TEST if test",
        );
        n.name = "Test".into();
        let p = Program::lower(&n, &Options::of(&n)).unwrap();
        let mut all: Vec<String> = [p.pou.clone()]
            .into_iter()
            .chain(p.inputs.iter().map(|s| s.ident.clone()))
            .chain(p.outputs.iter().map(|s| s.ident.clone()))
            .chain(p.places.iter().map(|s| s.ident.clone()))
            .chain(p.transitions.iter().map(|s| s.ident.clone()))
            .map(|s| s.to_ascii_uppercase())
            .collect();
        let n_names = all.len();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), n_names, "{p:#?}");
        assert_eq!(p.pou, "Test");
        assert_eq!(p.inputs[0].ident, "test_2");
        assert_eq!(p.renamed, vec![("test".to_string(), "test_2".to_string())]);
    }

    #[test]
    fn bool_markings_need_a_provably_safe_net() {
        let safe = "p a 1 cap=1\np b 0 cap=1\nt t a -> b";
        assert!(lower(safe, Markings::Auto).unwrap().boolean);
        assert!(!lower(safe, Markings::Int).unwrap().boolean);
        // Bounded by the invariant a + b = 1, without capacities.
        assert!(
            lower("p a 1\np b 0\nt t a -> b\nt u b -> a", Markings::Auto)
                .unwrap()
                .boolean
        );
        let unsafe_net = "p a 1\np b 0\nt t a -> b*2";
        assert!(!lower(unsafe_net, Markings::Auto).unwrap().boolean);
        let err = lower(unsafe_net, Markings::Bool).unwrap_err();
        assert_eq!(
            err.to_string(),
            "--markings bool: place b is not provably safe (arc arc2 has weight 2); give it \
             capacity 1, or use --markings int"
        );
    }
}
