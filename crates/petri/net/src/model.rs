//! The net itself: places, transitions, arcs and signals, built and checked by [`NetBuilder`],
//! then immutable, with per-transition arc lists precomputed for fast firing.

use std::fmt;
use std::ops::{Index, IndexMut};
use std::time::Duration;

use crate::guard::Guard;
use crate::ids::{ArcId, PlaceId, SignalId, TransitionId};

mod build;
#[cfg(test)]
mod tests;

pub use build::{is_signal_name, ArcSpec, ModelError, NetBuilder, PlaceSpec, TransitionSpec};

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
