//! The net itself: places, transitions, arcs and signals, built and checked by [`NetBuilder`],
//! then immutable, with per-transition arc lists precomputed for fast firing.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::ops::{Index, IndexMut};
use std::time::Duration;

use crate::guard::{Expr, Guard};
use crate::ids::{ArcId, PlaceId, SignalId, TransitionId};

/// Whether a signal comes into the net or goes out of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SignalDirection {
    Input,
    Output,
}

impl fmt::Display for SignalDirection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SignalDirection::Input => "input",
            SignalDirection::Output => "output",
        })
    }
}

/// A signal's value type. Values are carried as `i64`; a boolean is 0 or 1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum SignalType {
    #[default]
    Bool,
    Int,
}

impl fmt::Display for SignalType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            SignalType::Bool => "bool",
            SignalType::Int => "int",
        })
    }
}

/// A named input or output of the net.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Signal {
    pub name: String,
    pub direction: SignalDirection,
    pub ty: SignalType,
}

/// A place. An input place mirrors its input signal every scan; an output place drives its
/// output signal.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Place {
    pub id: String,
    pub name: String,
    pub initial: u32,
    pub capacity: Option<u32>,
    pub output: Option<SignalId>,
    pub input: Option<SignalId>,
}

/// A transition; its priority is its position (the lowest index wins, seed 004).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Transition {
    pub id: String,
    pub name: String,
    pub guard: Guard,
    /// For a net that models a process (a plant net): once enabled, the process fires this
    /// transition within this time (unless it is disabled first). Scans ignore it — they
    /// fire what is enabled at once —; the closed-loop analysis at a scan period uses it as
    /// the upper bound of the plant's timing, arc delays being the lower bounds.
    pub deadline: Option<Duration>,
}

/// What an arc does to its place.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum ArcKind {
    /// Place→transition consumes `weight` tokens; transition→place produces them.
    #[default]
    Normal,
    /// Test arc: the place must hold at least `weight` tokens; none are consumed.
    Read,
    /// The place must hold fewer than `weight` tokens.
    Inhibitor,
}

impl fmt::Display for ArcKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            ArcKind::Normal => "normal",
            ArcKind::Read => "read",
            ArcKind::Inhibitor => "inhibitor",
        })
    }
}

/// Which way an arc points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ArcDirection {
    PlaceToTransition,
    TransitionToPlace,
}

/// An arc between a place and a transition.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Arc {
    pub id: String,
    pub place: PlaceId,
    pub transition: TransitionId,
    pub direction: ArcDirection,
    pub kind: ArcKind,
    pub weight: u32,
    /// A place→transition arc holds only after its place has held `weight` tokens for this
    /// long (seed 002's arc delay, seed 003's TON).
    pub delay: Option<Duration>,
}

/// How the transitions of one pass of a scan are chosen (docs/semantics.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum StepRule {
    /// Seed 003's `filter_possible_firings`: all judged against the pass's start marking.
    #[default]
    MaximalStep,
    /// Seed 004's generated C: each transition fires at once, in priority order.
    Sequential,
}

impl StepRule {
    pub fn as_str(self) -> &'static str {
        match self {
            StepRule::MaximalStep => "maximal-step",
            StepRule::Sequential => "sequential",
        }
    }
    pub fn parse(s: &str) -> Option<Self> {
        match s.trim() {
            "maximal-step" => Some(StepRule::MaximalStep),
            "sequential" => Some(StepRule::Sequential),
            _ => None,
        }
    }
}

impl fmt::Display for StepRule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// How many passes a scan makes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum Evolution {
    /// One pass per scan (seed 002's and seed 003's generated code).
    #[default]
    OnePass,
    /// Passes repeat until none fires (seed 004 Algorithm 1, SIPN).
    UntilStable,
}

impl Evolution {
    pub fn as_str(self) -> &'static str {
        match self {
            Evolution::OnePass => "one-pass",
            Evolution::UntilStable => "until-stable",
        }
    }
    pub fn parse(s: &str) -> Option<Self> {
        match s.trim() {
            "one-pass" => Some(Evolution::OnePass),
            "until-stable" => Some(Evolution::UntilStable),
            _ => None,
        }
    }
}

impl fmt::Display for Evolution {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A marking: tokens per place, indexed by [`PlaceId`].
#[derive(Clone, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub struct Marking(pub Vec<u32>);

impl Index<PlaceId> for Marking {
    type Output = u32;
    #[inline]
    fn index(&self, p: PlaceId) -> &u32 {
        &self.0[p.index()]
    }
}

impl IndexMut<PlaceId> for Marking {
    #[inline]
    fn index_mut(&mut self, p: PlaceId) -> &mut u32 {
        &mut self.0[p.index()]
    }
}

/// A delayed place→transition arc, with the index of its timer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TimedArc {
    pub arc: ArcId,
    pub place: PlaceId,
    pub weight: u32,
    pub delay: Duration,
}

/// One transition's arcs, grouped as the firing rule reads them. Parallel arcs of the same
/// kind and direction are summed.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct TransitionArcs {
    /// Normal place→transition arcs: (place, tokens consumed).
    pub consume: Vec<(PlaceId, u32)>,
    /// Normal transition→place arcs: (place, tokens produced).
    pub produce: Vec<(PlaceId, u32)>,
    /// Read arcs: (place, tokens required).
    pub read: Vec<(PlaceId, u32)>,
    /// Inhibitor arcs: (place, bound that must not be reached).
    pub inhibit: Vec<(PlaceId, u32)>,
    /// Indices into [`Net::timed_arcs`] of this transition's delayed arcs.
    pub timed: Vec<usize>,
}

impl TransitionArcs {
    /// The tokens this transition takes from `p` (0 when `p` is not in its preset).
    pub fn consumed_from(&self, p: PlaceId) -> u32 {
        self.consume
            .iter()
            .find(|(q, _)| *q == p)
            .map_or(0, |(_, w)| *w)
    }

    /// The arc conditions every semantics shares (seed 004's check order: test arcs, inhibitor
    /// arcs, preset, postset): `tokens(p)` is what read, inhibitor and preset arcs see;
    /// `held(p)` is what counts against the capacity `limit(p)` before this firing, which then
    /// takes its own preset and adds its postset. Guards and delays are the caller's.
    ///
    /// `free(p)` lets read and inhibitor arcs on place `p` hold whatever it holds: the
    /// interleaving semantics uses it for input places, whose signals may take any value.
    #[inline]
    pub fn allow(
        &self,
        tokens: impl Fn(PlaceId) -> u32,
        held: impl Fn(PlaceId) -> u64,
        limit: impl Fn(PlaceId) -> u64,
        free: impl Fn(PlaceId) -> bool,
    ) -> bool {
        self.read.iter().all(|&(p, w)| free(p) || tokens(p) >= w)
            && self.inhibit.iter().all(|&(p, w)| free(p) || tokens(p) < w)
            && self.consume.iter().all(|&(p, w)| tokens(p) >= w)
            && self.produce.iter().all(|&(p, w)| {
                held(p).saturating_add(u64::from(w)) - u64::from(self.consumed_from(p)) <= limit(p)
            })
    }

    /// [`TransitionArcs::allow`] where one marking `m` is both `tokens` and `held`, as bounds
    /// on single places: the transition is enabled in `m` exactly when `lo ≤ m(p) ≤ hi` for
    /// every `(p, lo, hi)` returned (places in order, each once); `None` when no marking
    /// enables it. State-space searches test millions of markings with it.
    pub fn enabling_bounds(
        &self,
        limit: impl Fn(PlaceId) -> u64,
        free: impl Fn(PlaceId) -> bool,
    ) -> Option<Vec<(PlaceId, u64, u64)>> {
        let mut b: Vec<(PlaceId, u64, u64)> = Vec::new();
        for &(p, w) in &self.read {
            if !free(p) {
                b.push((p, u64::from(w), u64::MAX));
            }
        }
        for &(p, w) in &self.inhibit {
            if !free(p) {
                b.push((p, 0, u64::from(w).checked_sub(1)?));
            }
        }
        for &(p, w) in &self.consume {
            b.push((p, u64::from(w), u64::MAX));
        }
        for &(p, w) in &self.produce {
            // m + w - consumed ≤ limit, read once the preset holds (m ≥ consumed).
            let hi = limit(p)
                .saturating_add(u64::from(self.consumed_from(p)))
                .checked_sub(u64::from(w))?;
            b.push((p, 0, hi));
        }
        b.sort_unstable_by_key(|x| x.0);
        let mut out: Vec<(PlaceId, u64, u64)> = Vec::new();
        for (p, lo, hi) in b {
            match out.last_mut() {
                Some(last) if last.0 == p => {
                    last.1 = last.1.max(lo);
                    last.2 = last.2.min(hi);
                }
                _ => out.push((p, lo, hi)),
            }
        }
        if out.iter().any(|&(_, lo, hi)| lo > hi) {
            return None;
        }
        out.retain(|&(_, lo, hi)| lo > 0 || hi < u64::MAX);
        Some(out)
    }
}

/// A checked Petri net with inputs and outputs. Build one with [`NetBuilder`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Net {
    pub id: String,
    pub name: String,
    /// The step rule the net asks for; the command line may override it.
    pub step: StepRule,
    /// The evolution mode the net asks for; the command line may override it.
    pub evolve: Evolution,
    places: Vec<Place>,
    transitions: Vec<Transition>,
    arcs: Vec<Arc>,
    signals: Vec<Signal>,
    by_transition: Vec<TransitionArcs>,
    timed_arcs: Vec<TimedArc>,
}

/// Tokens could not be added without overflowing a `u32`.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("place {place}: more than {} tokens", u32::MAX)]
pub struct TokenOverflow {
    pub place: String,
}

impl Net {
    pub fn places(&self) -> &[Place] {
        &self.places
    }
    pub fn transitions(&self) -> &[Transition] {
        &self.transitions
    }
    pub fn arcs(&self) -> &[Arc] {
        &self.arcs
    }
    pub fn signals(&self) -> &[Signal] {
        &self.signals
    }
    pub fn place(&self, p: PlaceId) -> &Place {
        &self.places[p.index()]
    }
    pub fn transition(&self, t: TransitionId) -> &Transition {
        &self.transitions[t.index()]
    }
    pub fn signal(&self, s: SignalId) -> &Signal {
        &self.signals[s.index()]
    }
    pub fn arcs_of(&self, t: TransitionId) -> &TransitionArcs {
        &self.by_transition[t.index()]
    }
    pub fn timed_arcs(&self) -> &[TimedArc] {
        &self.timed_arcs
    }
    pub fn place_ids(&self) -> impl ExactSizeIterator<Item = PlaceId> {
        (0..self.places.len()).map(PlaceId::from)
    }
    pub fn transition_ids(&self) -> impl ExactSizeIterator<Item = TransitionId> {
        (0..self.transitions.len()).map(TransitionId::from)
    }
    pub fn signal_by_name(&self, name: &str) -> Option<SignalId> {
        self.signals
            .iter()
            .position(|s| s.name == name)
            .map(SignalId::from)
    }
    pub fn place_by_id(&self, id: &str) -> Option<PlaceId> {
        self.places
            .iter()
            .position(|p| p.id == id)
            .map(PlaceId::from)
    }
    pub fn transition_by_id(&self, id: &str) -> Option<TransitionId> {
        self.transitions
            .iter()
            .position(|t| t.id == id)
            .map(TransitionId::from)
    }
    /// Input signals, in declaration order.
    pub fn inputs(&self) -> impl Iterator<Item = SignalId> + '_ {
        self.signal_ids_with(SignalDirection::Input)
    }
    /// Output signals, in declaration order.
    pub fn outputs(&self) -> impl Iterator<Item = SignalId> + '_ {
        self.signal_ids_with(SignalDirection::Output)
    }
    fn signal_ids_with(&self, d: SignalDirection) -> impl Iterator<Item = SignalId> + '_ {
        self.signals
            .iter()
            .enumerate()
            .filter(move |(_, s)| s.direction == d)
            .map(|(i, _)| SignalId::from(i))
    }

    /// The initial marking M0.
    pub fn initial_marking(&self) -> Marking {
        Marking(self.places.iter().map(|p| p.initial).collect())
    }

    /// The most tokens place `p` may hold: its capacity, or for an input place the range of
    /// its signal (1 for a boolean), else unbounded (`u32::MAX`, the token counter's limit).
    pub fn capacity(&self, p: PlaceId) -> u32 {
        let place = &self.places[p.index()];
        match (place.capacity, place.input) {
            (Some(c), _) => c,
            (None, Some(s)) if self.signals[s.index()].ty == SignalType::Bool => 1,
            _ => u32::MAX,
        }
    }

    /// The capacity the firing rule enforces: [`Net::capacity`] for a place with a capacity
    /// or an input place, `None` for an unbounded place. An unbounded place is never a reason
    /// not to fire; going past `u32::MAX` tokens is an error ([`TokenOverflow`]), not a
    /// silently disabled transition.
    pub fn bound(&self, p: PlaceId) -> Option<u32> {
        let place = &self.places[p.index()];
        (place.capacity.is_some() || place.input.is_some()).then(|| self.capacity(p))
    }

    /// A label for reports: the name when it is non-empty, has no white space and no other
    /// place shares it; the id otherwise.
    pub fn place_label(&self, p: PlaceId) -> &str {
        let place = &self.places[p.index()];
        let unique = |n: &str| self.places.iter().filter(|q| q.name == n).count() == 1;
        if is_label(&place.name) && unique(&place.name) {
            &place.name
        } else {
            &place.id
        }
    }

    /// A label for reports, chosen like [`Net::place_label`].
    pub fn transition_label(&self, t: TransitionId) -> &str {
        let tr = &self.transitions[t.index()];
        let unique = |n: &str| self.transitions.iter().filter(|u| u.name == n).count() == 1;
        if is_label(&tr.name) && unique(&tr.name) {
            &tr.name
        } else {
            &tr.id
        }
    }

    /// A guard in canonical IEC text with signal names.
    pub fn guard_text(&self, t: TransitionId) -> String {
        self.transitions[t.index()]
            .guard
            .0
            .to_iec(&|s: &SignalId| self.signals[s.index()].name.clone())
    }

    /// C(p, t): tokens `t` adds to `p` minus tokens it takes (read and inhibitor arcs count 0).
    pub fn incidence(&self, p: PlaceId, t: TransitionId) -> i64 {
        let a = &self.by_transition[t.index()];
        let sum = |l: &[(PlaceId, u32)]| {
            l.iter()
                .filter(|(q, _)| *q == p)
                .map(|(_, w)| i64::from(*w))
                .sum::<i64>()
        };
        sum(&a.produce) - sum(&a.consume)
    }

    /// Interleaving enabling (analysis semantics): preset, read, inhibitor and capacity
    /// conditions in marking `m`. Inputs are abstracted: guards count as TRUE and arcs from
    /// input places always hold, as if the signals could take any value; delays are ignored.
    pub fn is_enabled(&self, m: &Marking, t: TransitionId) -> bool {
        self.by_transition[t.index()].allow(
            |p| m[p],
            |p| u64::from(m[p]),
            |p| self.bound(p).map_or(u64::MAX, u64::from),
            |p| self.places[p.index()].input.is_some(),
        )
    }

    /// [`Net::is_enabled`] as bounds on single places
    /// ([`TransitionArcs::enabling_bounds`]), for testing many markings.
    pub fn enabling_bounds(&self, t: TransitionId) -> Option<Vec<(PlaceId, u64, u64)>> {
        self.by_transition[t.index()].enabling_bounds(
            |p| self.bound(p).map_or(u64::MAX, u64::from),
            |p| self.places[p.index()].input.is_some(),
        )
    }

    /// Fires `t` in `m` (the caller has checked it is enabled). On overflow `m` is left as it
    /// was.
    pub fn fire(&self, m: &mut Marking, t: TransitionId) -> Result<(), TokenOverflow> {
        let a = &self.by_transition[t.index()];
        // Check every addition first so that an error leaves no half-fired marking.
        for &(p, w) in &a.produce {
            let after = u64::from(m[p]) - u64::from(a.consumed_from(p)) + u64::from(w);
            if after > u64::from(u32::MAX) {
                return Err(TokenOverflow {
                    place: self.place_label(p).to_string(),
                });
            }
        }
        for &(p, w) in &a.consume {
            m[p] -= w;
        }
        for &(p, w) in &a.produce {
            m[p] += w;
        }
        Ok(())
    }
}

fn is_label(name: &str) -> bool {
    !name.is_empty()
        && !name
            .chars()
            .any(|c| c.is_whitespace() || c == ',' || c == '"')
}

/// A place as an importer describes it, before ids are resolved.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PlaceSpec {
    pub id: String,
    pub name: String,
    pub initial: u32,
    pub capacity: Option<u32>,
    /// The output signal this place drives.
    pub output: Option<String>,
    /// The input signal this place mirrors (seed 004's input places).
    pub input: Option<String>,
}

/// A transition as an importer describes it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct TransitionSpec {
    pub id: String,
    pub name: String,
    pub guard: Expr<String>,
}

/// An arc as an importer describes it, its ends named by element id.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ArcSpec {
    pub id: String,
    pub source: String,
    pub target: String,
    pub kind: ArcKind,
    pub weight: u32,
    pub delay: Option<Duration>,
}

/// What is wrong with a net. Each names the element it is about ([`ModelError::element`]).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ModelError {
    #[error("id `{id}` is used twice; every place, transition and arc needs its own id")]
    DuplicateId { id: String },
    #[error("arc `{arc}`: its {end} `{node}` is not a place or transition of this net")]
    UnknownNode {
        arc: String,
        end: &'static str,
        node: String,
    },
    #[error("arc `{arc}` joins two places (`{source_id}` → `{target_id}`); an arc joins a place and a transition")]
    PlaceToPlace {
        arc: String,
        source_id: String,
        target_id: String,
    },
    #[error("arc `{arc}` joins two transitions (`{source_id}` → `{target_id}`); an arc joins a place and a transition")]
    TransitionToTransition {
        arc: String,
        source_id: String,
        target_id: String,
    },
    #[error("arc `{arc}` has weight 0; weights are whole numbers from 1")]
    ZeroWeight { arc: String },
    #[error("arc `{arc}` goes from a transition to a place but is marked {kind}; read and inhibitor arcs go from a place to a transition")]
    SpecialArcIntoPlace { arc: String, kind: ArcKind },
    #[error("arc `{arc}` has a delay but is an {kind} arc; delays go on normal or read arcs from a place")]
    DelayOnWrongArc { arc: String, kind: ArcKind },
    #[error("arc `{arc}` has a delay but goes from a transition to a place; delays go on arcs from a place")]
    DelayOnOutputArc { arc: String },
    #[error(
        "place `{place}` has capacity 0; a capacity is at least 1 (leave it out for no bound)"
    )]
    ZeroCapacity { place: String },
    #[error("place `{place}` starts with {initial} tokens but its capacity is {capacity}")]
    InitialAboveCapacity {
        place: String,
        initial: u32,
        capacity: u32,
    },
    #[error("arc `{arc}` is a normal arc on input place `{place}`; an input place mirrors its signal, so only read and inhibitor arcs may leave it")]
    FlowArcOnInputPlace { arc: String, place: String },
    #[error("input place `{place}` has an initial marking ({initial}); it mirrors its input signal, so leave the marking out")]
    MarkedInputPlace { place: String, initial: u32 },
    #[error("place `{place}` is both an input and an output place; make it one or the other")]
    InputAndOutput { place: String },
    #[error("signal `{signal}` is used as an {first} and as an {second}; rename one of them")]
    DirectionConflict {
        signal: String,
        first: SignalDirection,
        second: SignalDirection,
    },
    #[error("signal `{signal}` is declared twice with different types ({first} and {second})")]
    TypeConflict {
        signal: String,
        first: SignalType,
        second: SignalType,
    },
    #[error("integer output `{signal}` is bound to places `{first}` and `{second}`; an integer output shows one place's marking")]
    IntOutputTwice {
        signal: String,
        first: String,
        second: String,
    },
    #[error("transition `{transition}`: its guard reads output `{signal}`; guards read input signals only")]
    GuardReadsOutput { transition: String, signal: String },
    #[error("`{name}` is not a valid signal name; use letters, digits and `_`, starting with a letter or `_`")]
    BadSignalName { name: String },
    #[error("transition `{transition}` has deadline 0; a deadline is a time greater than 0 (leave it out for none)")]
    ZeroDeadline { transition: String },
    #[error("transition `{transition}` has a deadline of {} but its arc `{arc}` waits {}; a transition cannot have to fire before its delays let it (make the deadline at least the longest delay)", crate::time::format_iec(*deadline), crate::time::format_iec(*delay))]
    DeadlineBeforeDelay {
        transition: String,
        deadline: Duration,
        arc: String,
        delay: Duration,
    },
}

impl ModelError {
    /// The id of the element the error is about (a signal name for signal errors).
    pub fn element(&self) -> &str {
        use ModelError::*;
        match self {
            DuplicateId { id } => id,
            UnknownNode { arc, .. }
            | PlaceToPlace { arc, .. }
            | TransitionToTransition { arc, .. }
            | ZeroWeight { arc }
            | SpecialArcIntoPlace { arc, .. }
            | DelayOnWrongArc { arc, .. }
            | DelayOnOutputArc { arc }
            | FlowArcOnInputPlace { arc, .. } => arc,
            ZeroCapacity { place }
            | InitialAboveCapacity { place, .. }
            | MarkedInputPlace { place, .. }
            | InputAndOutput { place }
            | IntOutputTwice { first: place, .. } => place,
            GuardReadsOutput { transition, .. }
            | ZeroDeadline { transition }
            | DeadlineBeforeDelay { transition, .. } => transition,
            DirectionConflict { signal, .. } | TypeConflict { signal, .. } => signal,
            BadSignalName { name } => name,
        }
    }
}

/// Whether `name` can be a signal: an identifier as guards and PLC languages spell it.
pub fn is_signal_name(name: &str) -> bool {
    let mut chars = name.chars();
    matches!(chars.next(), Some(c) if c.is_ascii_alphabetic() || c == '_')
        && chars.all(|c| c.is_ascii_alphanumeric() || c == '_')
        && !matches!(
            name.to_ascii_uppercase().as_str(),
            "AND" | "OR" | "XOR" | "NOT" | "TRUE" | "FALSE"
        )
}

/// Collects places, transitions, arcs and signal declarations, then checks them all at once
/// in [`NetBuilder::build`], which reports every problem, not just the first.
#[derive(Clone, Debug, Default)]
pub struct NetBuilder {
    id: String,
    name: String,
    step: StepRule,
    evolve: Evolution,
    places: Vec<PlaceSpec>,
    transitions: Vec<TransitionSpec>,
    arcs: Vec<ArcSpec>,
    declared: Vec<(String, SignalDirection, SignalType)>,
    deadlines: Vec<(TransitionId, Duration)>,
}

impl NetBuilder {
    pub fn new(id: impl Into<String>, name: impl Into<String>) -> Self {
        NetBuilder {
            id: id.into(),
            name: name.into(),
            ..Default::default()
        }
    }
    pub fn step(&mut self, step: StepRule) -> &mut Self {
        self.step = step;
        self
    }
    pub fn evolve(&mut self, evolve: Evolution) -> &mut Self {
        self.evolve = evolve;
        self
    }
    /// Declares a signal's direction and type; undeclared signals are booleans whose
    /// direction follows from use (guards and input places read inputs, output places drive
    /// outputs). Declaration order comes first in the signal table.
    pub fn signal(
        &mut self,
        name: impl Into<String>,
        direction: SignalDirection,
        ty: SignalType,
    ) -> &mut Self {
        self.declared.push((name.into(), direction, ty));
        self
    }
    pub fn place(&mut self, p: PlaceSpec) -> PlaceId {
        self.places.push(p);
        PlaceId::from(self.places.len() - 1)
    }
    pub fn transition(&mut self, t: TransitionSpec) -> TransitionId {
        self.transitions.push(t);
        TransitionId::from(self.transitions.len() - 1)
    }
    pub fn arc(&mut self, a: ArcSpec) -> ArcId {
        self.arcs.push(a);
        ArcId::from(self.arcs.len() - 1)
    }
    /// Gives transition `t` (as returned by [`NetBuilder::transition`]) a deadline
    /// ([`Transition::deadline`]); the last one given counts.
    pub fn deadline(&mut self, t: TransitionId, deadline: Duration) -> &mut Self {
        self.deadlines.push((t, deadline));
        self
    }
    pub fn places_mut(&mut self) -> &mut [PlaceSpec] {
        &mut self.places
    }
    pub fn transitions_mut(&mut self) -> &mut [TransitionSpec] {
        &mut self.transitions
    }

    /// Checks everything and builds the net, or returns every error found, in element order.
    pub fn build(self) -> Result<Net, Vec<ModelError>> {
        let mut errors = Vec::new();
        let mut ids: HashMap<&str, Node> = HashMap::new();
        for (i, p) in self.places.iter().enumerate() {
            if ids.insert(&p.id, Node::Place(PlaceId::from(i))).is_some() {
                errors.push(ModelError::DuplicateId { id: p.id.clone() });
            }
        }
        for (i, t) in self.transitions.iter().enumerate() {
            if ids
                .insert(&t.id, Node::Transition(TransitionId::from(i)))
                .is_some()
            {
                errors.push(ModelError::DuplicateId { id: t.id.clone() });
            }
        }
        let mut arc_ids: BTreeMap<&str, ()> = BTreeMap::new();
        for a in &self.arcs {
            if ids.contains_key(a.id.as_str()) || arc_ids.insert(&a.id, ()).is_some() {
                errors.push(ModelError::DuplicateId { id: a.id.clone() });
            }
        }

        // PNML ids are XML IDs: the net's id must differ from every element's too.
        if ids.contains_key(self.id.as_str()) || arc_ids.contains_key(self.id.as_str()) {
            errors.push(ModelError::DuplicateId {
                id: self.id.clone(),
            });
        }

        let mut signals = SignalTable::default();
        for (name, dir, ty) in &self.declared {
            signals.declare(name, *dir, Some(*ty), &mut errors);
        }

        let mut places = Vec::with_capacity(self.places.len());
        for p in &self.places {
            if p.capacity == Some(0) {
                errors.push(ModelError::ZeroCapacity {
                    place: p.id.clone(),
                });
            }
            if let Some(c) = p.capacity.filter(|&c| c > 0 && p.initial > c) {
                errors.push(ModelError::InitialAboveCapacity {
                    place: p.id.clone(),
                    initial: p.initial,
                    capacity: c,
                });
            }
            if p.input.is_some() && p.output.is_some() {
                errors.push(ModelError::InputAndOutput {
                    place: p.id.clone(),
                });
            }
            if p.input.is_some() && p.initial > 0 {
                errors.push(ModelError::MarkedInputPlace {
                    place: p.id.clone(),
                    initial: p.initial,
                });
            }
            let output = p
                .output
                .as_deref()
                .and_then(|n| signals.declare(n, SignalDirection::Output, None, &mut errors));
            let input = p
                .input
                .as_deref()
                .and_then(|n| signals.declare(n, SignalDirection::Input, None, &mut errors));
            places.push(Place {
                id: p.id.clone(),
                name: p.name.clone(),
                initial: p.initial,
                capacity: p.capacity,
                output,
                input,
            });
        }

        let mut transitions = Vec::with_capacity(self.transitions.len());
        for t in &self.transitions {
            let mut e = Vec::new();
            let guard = t.guard.try_map(&mut |name: &String| {
                signals
                    .declare(name, SignalDirection::Input, None, &mut e)
                    .ok_or(())
            });
            for err in e {
                let err = match err {
                    ModelError::DirectionConflict {
                        signal,
                        first: SignalDirection::Output,
                        ..
                    } => ModelError::GuardReadsOutput {
                        transition: t.id.clone(),
                        signal,
                    },
                    other => other,
                };
                errors.push(err);
            }
            let guard = Guard(guard.unwrap_or(Expr::Const(false)));
            transitions.push(Transition {
                id: t.id.clone(),
                name: t.name.clone(),
                guard,
                deadline: None,
            });
        }
        for &(t, d) in &self.deadlines {
            if let Some(tr) = transitions.get_mut(t.index()) {
                tr.deadline = Some(d);
            }
        }
        for tr in &transitions {
            if tr.deadline == Some(Duration::ZERO) {
                errors.push(ModelError::ZeroDeadline {
                    transition: tr.id.clone(),
                });
            }
        }

        let mut int_outputs: HashMap<SignalId, &str> = HashMap::new();
        for p in &places {
            if let Some(s) = p
                .output
                .filter(|s| signals.table[s.index()].ty == SignalType::Int)
            {
                if let Some(first) = int_outputs.insert(s, &p.id) {
                    errors.push(ModelError::IntOutputTwice {
                        signal: signals.table[s.index()].name.clone(),
                        first: first.to_string(),
                        second: p.id.clone(),
                    });
                }
            }
        }

        let mut arcs = Vec::with_capacity(self.arcs.len());
        for a in &self.arcs {
            let find = |end: &'static str, node: &str| {
                ids.get(node)
                    .copied()
                    .ok_or_else(|| ModelError::UnknownNode {
                        arc: a.id.clone(),
                        end,
                        node: node.to_string(),
                    })
            };
            let (src, dst) = match (find("source", &a.source), find("target", &a.target)) {
                (Ok(s), Ok(d)) => (s, d),
                (s, d) => {
                    errors.extend(s.err());
                    errors.extend(d.err());
                    continue;
                }
            };
            let (place, transition, direction) = match (src, dst) {
                (Node::Place(p), Node::Transition(t)) => (p, t, ArcDirection::PlaceToTransition),
                (Node::Transition(t), Node::Place(p)) => (p, t, ArcDirection::TransitionToPlace),
                (Node::Place(_), Node::Place(_)) => {
                    errors.push(ModelError::PlaceToPlace {
                        arc: a.id.clone(),
                        source_id: a.source.clone(),
                        target_id: a.target.clone(),
                    });
                    continue;
                }
                (Node::Transition(_), Node::Transition(_)) => {
                    errors.push(ModelError::TransitionToTransition {
                        arc: a.id.clone(),
                        source_id: a.source.clone(),
                        target_id: a.target.clone(),
                    });
                    continue;
                }
            };
            if a.weight == 0 {
                errors.push(ModelError::ZeroWeight { arc: a.id.clone() });
            }
            if direction == ArcDirection::TransitionToPlace && a.kind != ArcKind::Normal {
                errors.push(ModelError::SpecialArcIntoPlace {
                    arc: a.id.clone(),
                    kind: a.kind,
                });
            }
            if a.delay.is_some() {
                if direction == ArcDirection::TransitionToPlace {
                    errors.push(ModelError::DelayOnOutputArc { arc: a.id.clone() });
                } else if a.kind == ArcKind::Inhibitor {
                    errors.push(ModelError::DelayOnWrongArc {
                        arc: a.id.clone(),
                        kind: a.kind,
                    });
                }
            }
            let pl = &places[place.index()];
            if pl.input.is_some() && a.kind == ArcKind::Normal {
                errors.push(ModelError::FlowArcOnInputPlace {
                    arc: a.id.clone(),
                    place: pl.id.clone(),
                });
            }
            arcs.push(Arc {
                id: a.id.clone(),
                place,
                transition,
                direction,
                kind: a.kind,
                weight: a.weight,
                delay: a.delay,
            });
        }
        for a in &arcs {
            let tr = &transitions[a.transition.index()];
            if let (Some(deadline), Some(delay)) = (tr.deadline, a.delay) {
                if delay > deadline && !deadline.is_zero() {
                    errors.push(ModelError::DeadlineBeforeDelay {
                        transition: tr.id.clone(),
                        deadline,
                        arc: a.id.clone(),
                        delay,
                    });
                }
            }
        }

        if !errors.is_empty() {
            return Err(errors);
        }

        let mut by_transition = vec![TransitionArcs::default(); transitions.len()];
        let mut timed_arcs = Vec::new();
        for (i, a) in arcs.iter().enumerate() {
            let ta = &mut by_transition[a.transition.index()];
            let list = match (a.direction, a.kind) {
                (ArcDirection::PlaceToTransition, ArcKind::Normal) => &mut ta.consume,
                (ArcDirection::TransitionToPlace, _) => &mut ta.produce,
                (_, ArcKind::Read) => &mut ta.read,
                (_, ArcKind::Inhibitor) => &mut ta.inhibit,
            };
            match list.iter_mut().find(|(p, _)| *p == a.place) {
                // Parallel inhibitor arcs: the strictest bound holds.
                Some((_, w)) if a.kind == ArcKind::Inhibitor => *w = (*w).min(a.weight),
                // Parallel read arcs: the largest requirement holds.
                Some((_, w)) if a.kind == ArcKind::Read => *w = (*w).max(a.weight),
                Some((_, w)) => *w = w.saturating_add(a.weight),
                None => list.push((a.place, a.weight)),
            }
            if let Some(delay) = a.delay {
                ta.timed.push(timed_arcs.len());
                timed_arcs.push(TimedArc {
                    arc: ArcId::from(i),
                    place: a.place,
                    weight: a.weight,
                    delay,
                });
            }
        }

        Ok(Net {
            id: self.id,
            name: self.name,
            step: self.step,
            evolve: self.evolve,
            places,
            transitions,
            arcs,
            signals: signals.table,
            by_transition,
            timed_arcs,
        })
    }
}

#[derive(Clone, Copy, Debug)]
enum Node {
    Place(PlaceId),
    Transition(TransitionId),
}

#[derive(Default)]
struct SignalTable {
    table: Vec<Signal>,
    by_name: HashMap<String, SignalId>,
}

impl SignalTable {
    /// Finds or adds a signal, reporting a conflicting direction or type.
    fn declare(
        &mut self,
        name: &str,
        direction: SignalDirection,
        ty: Option<SignalType>,
        errors: &mut Vec<ModelError>,
    ) -> Option<SignalId> {
        if !is_signal_name(name) {
            errors.push(ModelError::BadSignalName {
                name: name.to_string(),
            });
            return None;
        }
        if let Some(&id) = self.by_name.get(name) {
            let s = &self.table[id.index()];
            if s.direction != direction {
                errors.push(ModelError::DirectionConflict {
                    signal: name.to_string(),
                    first: s.direction,
                    second: direction,
                });
                return None;
            }
            if let Some(ty) = ty.filter(|t| *t != s.ty) {
                errors.push(ModelError::TypeConflict {
                    signal: name.to_string(),
                    first: s.ty,
                    second: ty,
                });
            }
            return Some(id);
        }
        let id = SignalId::from(self.table.len());
        self.table.push(Signal {
            name: name.to_string(),
            direction,
            ty: ty.unwrap_or_default(),
        });
        self.by_name.insert(name.to_string(), id);
        Some(id)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::guard::parse;

    /// `enabling_bounds` is `allow` on one marking: every marking of 3 places with 0..=5
    /// tokens, for transitions with every arc kind, capacities and a free place.
    #[test]
    fn enabling_bounds_are_the_firing_rule() {
        let (a, b, c) = (PlaceId(0), PlaceId(1), PlaceId(2));
        let arcs = |consume: &[(PlaceId, u32)],
                    produce: &[(PlaceId, u32)],
                    read: &[(PlaceId, u32)],
                    inhibit: &[(PlaceId, u32)]| TransitionArcs {
            consume: consume.to_vec(),
            produce: produce.to_vec(),
            read: read.to_vec(),
            inhibit: inhibit.to_vec(),
            timed: Vec::new(),
        };
        let cases = [
            arcs(&[(a, 2)], &[(b, 1)], &[], &[]),
            arcs(&[(a, 1)], &[(a, 2), (b, 3)], &[(c, 2)], &[]),
            arcs(&[(b, 1)], &[(c, 1)], &[], &[(a, 3), (c, 2)]),
            arcs(&[], &[(b, 2)], &[(a, 1)], &[(b, 1)]),
            arcs(&[(a, 1), (b, 2)], &[(b, 1)], &[(a, 2)], &[(c, 1)]),
            arcs(&[], &[(c, 4)], &[], &[]),
        ];
        let limits: [fn(PlaceId) -> u64; 3] = [
            |_| u64::MAX,
            |p| if p.0 == 1 { 3 } else { u64::MAX },
            |p| if p.0 == 2 { 2 } else { 4 },
        ];
        let frees: [fn(PlaceId) -> bool; 2] = [|_| false, |p| p.0 == 2];
        for t in &cases {
            for limit in limits {
                for free in frees {
                    let bounds = t.enabling_bounds(limit, free);
                    for m in 0..6u32.pow(3) {
                        let m = [m % 6, m / 6 % 6, m / 36];
                        let tokens = |p: PlaceId| m[p.index()];
                        let expect = t.allow(tokens, |p| u64::from(tokens(p)), limit, free);
                        let got = bounds.as_ref().is_some_and(|bs| {
                            bs.iter()
                                .all(|&(p, lo, hi)| (lo..=hi).contains(&u64::from(tokens(p))))
                        });
                        assert_eq!(got, expect, "{t:?} m {m:?}");
                    }
                }
            }
        }
    }

    fn place(id: &str, initial: u32) -> PlaceSpec {
        PlaceSpec {
            id: id.into(),
            name: id.into(),
            initial,
            ..Default::default()
        }
    }
    fn transition(id: &str, guard: &str) -> TransitionSpec {
        TransitionSpec {
            id: id.into(),
            name: id.into(),
            guard: parse(guard).unwrap(),
        }
    }
    fn arc(id: &str, s: &str, t: &str, w: u32) -> ArcSpec {
        ArcSpec {
            id: id.into(),
            source: s.into(),
            target: t.into(),
            kind: ArcKind::Normal,
            weight: w,
            delay: None,
        }
    }

    /// Builds a net and renders either its errors or a summary.
    fn check(build: impl FnOnce(&mut NetBuilder), expect: &[&str]) {
        let mut b = NetBuilder::new("n", "n");
        build(&mut b);
        let got: Vec<String> = match b.build() {
            Ok(net) => vec![format!(
                "ok: {} places, {} transitions, {} arcs, signals {:?}",
                net.places().len(),
                net.transitions().len(),
                net.arcs().len(),
                net.signals()
                    .iter()
                    .map(|s| format!("{} {} {}", s.direction, s.ty, s.name))
                    .collect::<Vec<_>>()
            )],
            Err(es) => es.iter().map(|e| format!("{}: {e}", e.element())).collect(),
        };
        assert_eq!(got, expect);
    }

    #[test]
    fn builds_and_collects_signals() {
        check(
            |b| {
                b.place(PlaceSpec { output: Some("L1".into()), ..place("p1", 1) });
                b.place(place("p2", 0));
                b.transition(transition("t1", "B1 AND NOT N2"));
                b.arc(arc("a1", "p1", "t1", 1));
                b.arc(arc("a2", "t1", "p2", 2));
            },
            &["ok: 2 places, 1 transitions, 2 arcs, signals [\"output bool L1\", \"input bool B1\", \"input bool N2\"]"],
        );
    }

    #[test]
    fn reports_every_structural_error() {
        check(
            |b| {
                b.place(PlaceSpec { capacity: Some(1), ..place("p1", 2) });
                b.place(place("p1", 0));
                b.place(place("p3", 0));
                b.transition(transition("t1", ""));
                b.arc(arc("a1", "p1", "nowhere", 1));
                b.arc(arc("a2", "p1", "p3", 1));
                b.arc(arc("a3", "t1", "t1", 1));
                b.arc(arc("a4", "p3", "t1", 0));
                b.arc(ArcSpec { kind: ArcKind::Inhibitor, ..arc("a5", "t1", "p3", 1) });
                b.arc(ArcSpec { kind: ArcKind::Inhibitor, delay: Some(Duration::from_secs(1)), ..arc("a6", "p3", "t1", 1) });
            },
            &[
                "p1: id `p1` is used twice; every place, transition and arc needs its own id",
                "p1: place `p1` starts with 2 tokens but its capacity is 1",
                "a1: arc `a1`: its target `nowhere` is not a place or transition of this net",
                "a2: arc `a2` joins two places (`p1` → `p3`); an arc joins a place and a transition",
                "a3: arc `a3` joins two transitions (`t1` → `t1`); an arc joins a place and a transition",
                "a4: arc `a4` has weight 0; weights are whole numbers from 1",
                "a5: arc `a5` goes from a transition to a place but is marked inhibitor; read and inhibitor arcs go from a place to a transition",
                "a6: arc `a6` has a delay but is an inhibitor arc; delays go on normal or read arcs from a place",
            ],
        );
    }

    #[test]
    fn deadlines_are_checked_against_delays() {
        let build = |deadline: u64, delay: u64| {
            move |b: &mut NetBuilder| {
                b.place(place("p", 1));
                let t = b.transition(transition("t", ""));
                b.deadline(t, Duration::from_millis(deadline));
                b.arc(ArcSpec {
                    delay: Some(Duration::from_millis(delay)),
                    ..arc("a", "p", "t", 1)
                });
            }
        };
        let ok = "ok: 1 places, 1 transitions, 1 arcs, signals []";
        check(build(600, 100), &[ok]);
        check(build(100, 100), &[ok]);
        check(
            build(100, 600),
            &[
                "t: transition `t` has a deadline of T#100ms but its arc `a` waits T#600ms; a \
               transition cannot have to fire before its delays let it (make the deadline at \
               least the longest delay)",
            ],
        );
        check(
            build(0, 0),
            &["t: transition `t` has deadline 0; a deadline is a time greater than 0 (leave it out for none)"],
        );
        let mut b = NetBuilder::new("n", "n");
        build(600, 100)(&mut b);
        let net = b.build().unwrap();
        assert_eq!(
            net.transition(TransitionId(0)).deadline,
            Some(Duration::from_millis(600))
        );
    }

    #[test]
    fn interleaving_abstracts_inputs() {
        let mut b = NetBuilder::new("n", "n");
        b.place(PlaceSpec {
            input: Some("Go".into()),
            ..place("go", 0)
        });
        b.place(PlaceSpec {
            input: Some("Stop".into()),
            ..place("stop", 0)
        });
        b.place(place("a", 1));
        b.transition(transition("t", "Other"));
        b.arc(ArcSpec {
            kind: ArcKind::Read,
            ..arc("r", "go", "t", 1)
        });
        b.arc(ArcSpec {
            kind: ArcKind::Inhibitor,
            ..arc("i", "stop", "t", 1)
        });
        b.arc(arc("x", "a", "t", 1));
        let net = b.build().unwrap();
        let t = TransitionId(0);
        // Whatever the input places hold, their arcs hold; the guard is not looked at.
        for m in [vec![0, 0, 1], vec![1, 1, 1], vec![0, 1, 1]] {
            assert!(net.is_enabled(&Marking(m.clone()), t), "{m:?}");
        }
        assert!(
            !net.is_enabled(&Marking(vec![1, 0, 0]), t),
            "the flow arc still counts"
        );
    }

    #[test]
    fn net_id_must_differ_from_element_ids() {
        let mut b = NetBuilder::new("p1", "n");
        b.place(place("p1", 0));
        let errors = b.build().unwrap_err();
        assert_eq!(errors, vec![ModelError::DuplicateId { id: "p1".into() }]);
    }

    #[test]
    fn reports_signal_misuse() {
        check(
            |b| {
                b.signal("Level", SignalDirection::Output, SignalType::Int);
                b.place(PlaceSpec { output: Some("Level".into()), ..place("p1", 0) });
                b.place(PlaceSpec { output: Some("Level".into()), ..place("p2", 0) });
                b.place(PlaceSpec { input: Some("I1".into()), ..place("in", 1) });
                b.transition(transition("t1", "Level"));
                b.arc(arc("a1", "in", "t1", 1));
            },
            &[
                "in: input place `in` has an initial marking (1); it mirrors its input signal, so leave the marking out",
                "t1: transition `t1`: its guard reads output `Level`; guards read input signals only",
                "p1: integer output `Level` is bound to places `p1` and `p2`; an integer output shows one place's marking",
                "a1: arc `a1` is a normal arc on input place `in`; an input place mirrors its signal, so only read and inhibitor arcs may leave it",
            ],
        );
    }

    #[test]
    fn interleaving_firing_respects_capacity_and_special_arcs() {
        let mut b = NetBuilder::new("n", "n");
        b.place(place("a", 2));
        b.place(PlaceSpec {
            capacity: Some(1),
            ..place("b", 0)
        });
        b.place(place("c", 0));
        b.transition(transition("t", ""));
        b.arc(arc("x", "a", "t", 1));
        b.arc(arc("y", "t", "b", 1));
        b.arc(ArcSpec {
            kind: ArcKind::Inhibitor,
            ..arc("z", "c", "t", 1)
        });
        let net = b.build().unwrap();
        let t = TransitionId(0);
        let mut m = net.initial_marking();
        assert!(net.is_enabled(&m, t));
        net.fire(&mut m, t).unwrap();
        assert_eq!(m.0, vec![1, 1, 0]);
        assert!(!net.is_enabled(&m, t), "capacity of b is reached");
        m.0[1] = 0;
        m.0[2] = 1;
        assert!(!net.is_enabled(&m, t), "inhibitor on c");
        assert_eq!(net.incidence(PlaceId(0), t), -1);
        assert_eq!(net.incidence(PlaceId(1), t), 1);
        assert_eq!(net.incidence(PlaceId(2), t), 0);
    }
}
