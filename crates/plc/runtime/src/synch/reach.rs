//! Which modules the synchronisation net can never let scan, found before the PLC starts:
//! a net with no token where the first scan needs one would otherwise run with every module
//! at 0 scans, silently.
//!
//! The search follows the seed's modified semantics: a transition fires only when a module
//! waits on it, so the state is the marking plus, per synchronised module, whether it waits
//! on its `scan_beg` or its `scan_end`. Token counts above a small cap become "any number"
//! (ω), on which every arc is taken to be satisfied: the search then covers every behaviour
//! of the real net and more, so a module whose `scan_beg` never fires in it can truly never
//! scan. (The converse does not hold, which only means some dead nets go unreported.)

use std::collections::{HashSet, VecDeque};

use super::{SynchNet, TransitionRef};

/// A count the search no longer tracks exactly.
const OMEGA: u32 = u32::MAX;
/// Counts above this become ω: enough for the weights of real configurations, small enough
/// to keep the search finite.
const CAP: u32 = 64;
/// Beyond this many states the search gives up (and reports nothing).
const MAX_STATES: usize = 200_000;

impl SynchNet {
    /// The synchronised modules whose `scan_beg` can never fire, in configuration order;
    /// `None` if the search was too large to finish. `others_fire`: transitions may also
    /// be fired outside `scan_beg`/`scan_end` (module programs can synchronise on any
    /// transition by name), so every enabled transition is taken to fire.
    pub fn never_scanning(&self, others_fire: bool) -> Option<Vec<String>> {
        let modules: Vec<(&str, TransitionRef, TransitionRef)> = self.scans().collect();
        let start = State {
            marking: self
                .initial_marking()
                .tokens()
                .iter()
                .map(|&n| cap(n))
                .collect(),
            inside: vec![false; modules.len()],
        };
        let mut scanned = vec![false; modules.len()];
        let mut seen = HashSet::from([start.clone()]);
        let mut queue = VecDeque::from([start]);
        while let Some(state) = queue.pop_front() {
            let mut next = Vec::new();
            for (i, &(_, beg, end)) in modules.iter().enumerate() {
                let t = if state.inside[i] { end } else { beg };
                if let Some(marking) = self.fire_abstract(t, &state.marking) {
                    let mut inside = state.inside.clone();
                    inside[i] = !inside[i];
                    if !state.inside[i] {
                        scanned[i] = true;
                    }
                    next.push(State { marking, inside });
                }
            }
            if others_fire {
                for t in 0..self.transitions().len() {
                    if let Some(marking) =
                        self.fire_abstract(TransitionRef::Index(t), &state.marking)
                    {
                        next.push(State {
                            marking,
                            inside: state.inside.clone(),
                        });
                    }
                }
            }
            for s in next {
                if seen.insert(s.clone()) {
                    if seen.len() > MAX_STATES {
                        return None;
                    }
                    queue.push_back(s);
                }
            }
        }
        Some(
            modules
                .iter()
                .zip(scanned)
                .filter(|(_, s)| !s)
                .map(|((m, _, _), _)| (*m).to_string())
                .collect(),
        )
    }

    /// Fires `t` in the abstract marking if it may be enabled there.
    fn fire_abstract(&self, t: TransitionRef, marking: &[u32]) -> Option<Vec<u32>> {
        let TransitionRef::Index(t) = t else {
            return Some(marking.to_vec());
        };
        let transition = &self.transitions()[t];
        let enabled = transition.inputs.iter().all(|&(p, w)| {
            let n = marking[p];
            n == OMEGA || if w == 0 { n == 0 } else { n >= w }
        });
        if !enabled {
            return None;
        }
        let mut m = marking.to_vec();
        for &(p, w) in &transition.inputs {
            if m[p] != OMEGA {
                m[p] -= w;
            }
        }
        for &(p, w) in &transition.outputs {
            if m[p] != OMEGA {
                m[p] = cap(m[p].saturating_add(w));
            }
        }
        Some(m)
    }
}

fn cap(n: u32) -> u32 {
    if n > CAP {
        OMEGA
    } else {
        n
    }
}

#[derive(Clone, PartialEq, Eq, Hash)]
struct State {
    marking: Vec<u32>,
    inside: Vec<bool>,
}
