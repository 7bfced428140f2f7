//! Building a net: the specs an importer gives ([`PlaceSpec`], [`TransitionSpec`],
//! [`ArcSpec`]), [`NetBuilder`]'s checks of them, and the [`ModelError`]s it collects.

use std::collections::{BTreeMap, HashMap};
use std::time::Duration;

use super::{
    Arc, ArcDirection, ArcKind, Evolution, Net, Place, Signal, SignalDirection, SignalType,
    StepRule, TimedArc, Transition, TransitionArcs,
};
use crate::guard::{Expr, Guard};
use crate::ids::{ArcId, PlaceId, SignalId, TransitionId};

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
