//! Turning what was read into a net: resolving reference nodes, applying SIPN naming,
//! building through `NetBuilder` and placing its errors at their elements.

use std::collections::{HashMap, HashSet};

use petriplc_net::guard::Expr;
use petriplc_net::{ModelError, NetBuilder, SignalDirection, TransitionSpec};

use super::{shown, starts_with_default, Kind, Reader, RefRead, SignalUse};
use crate::diag::{self, Code, Diagnostic, LineIndex, Location, Severity};
use crate::{Document, Naming, PnmlError};

impl Reader<'_> {
    /// Resolves every reference node to the place or transition it stands for (`None` when
    /// its chain is broken, which has been reported).
    fn resolve_refs(&mut self) -> HashMap<String, Option<String>> {
        let by_id: HashMap<&str, &RefRead> = self.refs.iter().map(|r| (r.id.as_str(), r)).collect();
        let mut resolved: HashMap<String, Option<String>> = HashMap::new();
        let mut errors = Vec::new();
        for r in &self.refs {
            if resolved.contains_key(&r.id) {
                continue;
            }
            let want = if r.kind == Kind::RefPlace {
                Kind::Place
            } else {
                Kind::Transition
            };
            let mut path: Vec<&str> = Vec::new();
            let mut on_path: HashSet<&str> = HashSet::new();
            let mut cur: &RefRead = r;
            let result = loop {
                if let Some(done) = resolved.get(&cur.id) {
                    break done.clone();
                }
                if !on_path.insert(&cur.id) {
                    let start = path.iter().position(|p| *p == cur.id).unwrap_or(0);
                    let mut cycle: Vec<&str> = path.get(start..).unwrap_or(&[]).to_vec();
                    cycle.push(&cur.id);
                    let cycle: Vec<String> = cycle.iter().map(|s| shown(s)).collect();
                    errors.push((
                        cur.id.clone(),
                        format!(
                            "{} `{}` is part of a cycle of references ({}); a chain of references \
                             must end at a {}",
                            r.kind.noun(),
                            shown(&cur.id),
                            cycle.join(" → "),
                            want.noun()
                        ),
                    ));
                    break None;
                }
                path.push(&cur.id);
                match (self.ids.get(&cur.target), by_id.get(cur.target.as_str())) {
                    (Some(node), _) if node.kind == want => break Some(cur.target.clone()),
                    (Some(node), Some(next)) if node.kind == r.kind => cur = next,
                    (Some(node), _) => {
                        errors.push((
                            cur.id.clone(),
                            format!(
                                "{} `{}` refers to `{}`, which is a {}; it must refer to a {} or \
                                 another {0}",
                                r.kind.noun(),
                                shown(&cur.id),
                                shown(&cur.target),
                                node.kind.noun(),
                                want.noun()
                            ),
                        ));
                        break None;
                    }
                    (None, _) => {
                        errors.push((
                            cur.id.clone(),
                            format!(
                                "{} `{}` refers to `{}`, which is not an element of this net",
                                r.kind.noun(),
                                shown(&cur.id),
                                shown(&cur.target)
                            ),
                        ));
                        break None;
                    }
                }
            };
            for p in path {
                resolved.insert(p.to_string(), result.clone());
            }
        }
        for (id, msg) in errors {
            let at = self.ids.get(&id).map_or(0, |n| n.at);
            self.error(diag::REFERENCE, at, Some(&id), msg);
        }
        resolved
    }

    /// Seed 002's NetLab convention: names carry the signals, places hold one token.
    fn apply_sipn(&mut self) {
        let mut places = std::mem::take(&mut self.places);
        for p in &mut places {
            let name = p.spec.name.trim();
            if !p.explicit_signal && !name.is_empty() && !starts_with_default(name) {
                if petriplc_net::is_signal_name(name) {
                    p.spec.output = Some(name.to_string());
                    self.uses.push(SignalUse {
                        stage: 1,
                        name: name.to_string(),
                        direction: SignalDirection::Output,
                        declared: None,
                        at: p.at,
                        element: p.spec.id.clone(),
                    });
                } else {
                    let msg = format!(
                        "place `{}`: its name `{}` is not a signal name, and SIPN naming makes a \
                         place's name its output; use letters, digits and `_`, or start the name \
                         with `default` for an internal place",
                        shown(&p.spec.id),
                        shown(name)
                    );
                    self.error(diag::SIGNAL_RULE, p.at, Some(&p.spec.id), msg);
                }
            }
            // An input place mirrors its signal; the one-token rule is for the net's own places.
            if !p.explicit_capacity && p.spec.input.is_none() {
                p.spec.capacity = Some(1);
            }
        }
        self.places = places;
        let mut transitions = std::mem::take(&mut self.transitions);
        for t in &mut transitions {
            let name = t.name.trim();
            if t.guard.is_some() || name.is_empty() || starts_with_default(name) {
                continue;
            }
            let why = " as a guard (SIPN naming reads a transition's name as its input condition)";
            let name = t.name.clone();
            t.guard = Some(
                self.guard(&name, t.name_at, &t.id, "its name", why)
                    .unwrap_or(Expr::Const(true)),
            );
        }
        self.transitions = transitions;
    }

    pub(super) fn finish(mut self) -> Result<Document, PnmlError> {
        let net = if self.net_read { self.build() } else { None };
        match net {
            Some(net) if self.diags.is_empty() => Ok(Document {
                net,
                layout: self.layout,
            }),
            _ => {
                self.diags.sort_by_key(|p| p.at);
                let lines = LineIndex::new(self.src);
                let file = self.file;
                let diags = self.diags.into_iter().map(|p| {
                    let at = |offset| {
                        let (line, column) = lines.position(offset);
                        Location::new(file, line, column)
                    };
                    let mut d = Diagnostic::new(Severity::Error, Code(p.code), at(p.at), p.message);
                    d.element = p.element;
                    if let Some((other, text)) = p.label {
                        d = d.with_label(at(other), text);
                    }
                    d
                });
                Err(PnmlError::Invalid(diags.collect()))
            }
        }
    }

    fn build(&mut self) -> Option<petriplc_net::Net> {
        let resolved = self.resolve_refs();
        if self.naming == Naming::Sipn {
            self.apply_sipn();
        }
        let mut b = NetBuilder::new(self.net_id.clone(), self.net_name.clone());
        if let Some(s) = self.step {
            b.step(s);
        }
        if let Some(e) = self.evolve {
            b.evolve(e);
        }
        for (name, direction, ty) in &self.signals {
            b.signal(name.clone(), *direction, *ty);
        }
        for p in &self.places {
            b.place(p.spec.clone());
        }
        for t in &self.transitions {
            let id = b.transition(TransitionSpec {
                id: t.id.clone(),
                name: t.name.clone(),
                guard: t.guard.clone().unwrap_or(Expr::Const(true)),
            });
            if let Some(d) = t.deadline {
                b.deadline(id, d);
            }
        }
        'arcs: for a in &self.arcs {
            let mut spec = a.clone();
            for end in [&mut spec.source, &mut spec.target] {
                match resolved.get(end.as_str()) {
                    Some(Some(node)) => *end = node.clone(),
                    // The broken reference has been reported; the arc would only repeat it.
                    Some(None) => continue 'arcs,
                    None => {}
                }
            }
            b.arc(spec);
        }
        match b.build() {
            Ok(net) => Some(net),
            Err(errors) => {
                // Signal uses by name, in the order the builder met them.
                self.uses.sort_by_key(|u| u.stage);
                let mut uses: HashMap<&str, Vec<&SignalUse>> = HashMap::new();
                for u in &self.uses {
                    uses.entry(u.name.as_str()).or_default().push(u);
                }
                let located: Vec<_> = errors.iter().map(|e| self.locate(e, &uses)).collect();
                for (e, (code, at, element)) in errors.iter().zip(located) {
                    match self.other_end(e) {
                        Some(end) => self.error_with(code, at, Some(&element), e.to_string(), end),
                        None => self.error(code, at, Some(&element), e.to_string()),
                    }
                }
                None
            }
        }
    }

    /// For an arc joining two places or two transitions, where its target is: the arc is
    /// reported at itself, the two ends are what must change.
    fn other_end(&self, e: &ModelError) -> Option<(usize, &'static str)> {
        match e {
            ModelError::PlaceToPlace { target_id, .. } => Some((
                self.ids.get(target_id.as_str())?.at,
                "its target, also a place",
            )),
            ModelError::TransitionToTransition { target_id, .. } => Some((
                self.ids.get(target_id.as_str())?.at,
                "its target, also a transition",
            )),
            _ => None,
        }
    }

    /// The code, position and element id of a model error.
    fn locate(
        &self,
        e: &ModelError,
        uses: &HashMap<&str, Vec<&SignalUse>>,
    ) -> (&'static str, usize, String) {
        use ModelError::*;
        let code = match e {
            DuplicateId { .. } => diag::DUPLICATE_ID,
            UnknownNode { .. } | PlaceToPlace { .. } | TransitionToTransition { .. } => {
                diag::ARC_ENDS
            }
            ZeroWeight { .. }
            | SpecialArcIntoPlace { .. }
            | DelayOnWrongArc { .. }
            | DelayOnOutputArc { .. }
            | FlowArcOnInputPlace { .. } => diag::ARC_RULE,
            ZeroCapacity { .. }
            | InitialAboveCapacity { .. }
            | MarkedInputPlace { .. }
            | InputAndOutput { .. } => diag::PLACE_RULE,
            DirectionConflict { .. }
            | TypeConflict { .. }
            | IntOutputTwice { .. }
            | GuardReadsOutput { .. }
            | BadSignalName { .. } => diag::SIGNAL_RULE,
            ZeroDeadline { .. } | DeadlineBeforeDelay { .. } => diag::DELAY,
        };
        // Signal errors name a signal, not an element: point at the use that went wrong.
        let of = |name: &String| uses.get(name.as_str()).into_iter().flatten();
        let signal_use = match e {
            DirectionConflict { signal, second, .. } => of(signal).find(|u| u.direction == *second),
            TypeConflict { signal, second, .. } => of(signal).find(|u| u.declared == Some(*second)),
            BadSignalName { name } => of(name).next(),
            _ => None,
        };
        if let Some(u) = signal_use {
            return (code, u.at, u.element.clone());
        }
        let id = e.element();
        match self.ids.get(id) {
            Some(node) => (code, node.at, id.to_string()),
            None => (code, 0, id.to_string()),
        }
    }
}
