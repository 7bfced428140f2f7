//! A transition's test as data: what every backend checks before a transition fires (guard,
//! delays, read and inhibitor arcs, preset, room in the postset), as [`Enabling`] groups of
//! [`Cond`]s. `lower` builds them, already specialised to the step rule and the markings;
//! every backend prints them through one walk, `spell`.

/// An elementary condition.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Atom {
    /// The transition's guard over the input signals.
    Guard(usize),
    /// A TON's `Q`.
    Timer(usize),
    /// A BOOL place is marked.
    Marked(usize),
    /// A transition fired in this pass (its fire flag).
    Fired(usize),
    /// An integer place holds at least `tokens`: its marking, or its `Avail` copy when
    /// `avail`. Negated it reads "fewer than".
    AtLeast {
        place: usize,
        avail: bool,
        tokens: u32,
    },
    /// An integer place's marking, plus what the pass produced into it when `produced`, is at
    /// most `limit` (a capacity check: C(p) + own consumption − weight).
    AtMost {
        place: usize,
        produced: bool,
        limit: u64,
    },
}

/// A condition: a possibly negated atom, a disjunction, or a constant.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Cond {
    Lit { atom: Atom, negated: bool },
    Any(Vec<Cond>),
    Const(bool),
}

impl Cond {
    pub fn lit(atom: Atom) -> Cond {
        Cond::Lit {
            atom,
            negated: false,
        }
    }
    pub fn not(atom: Atom) -> Cond {
        Cond::Lit {
            atom,
            negated: true,
        }
    }
}

/// A transition's enabling, conjunction of all groups, each a conjunction of conditions.
/// Groups follow seed 004's generated C (test, inhibitor, preset, postset), after the input
/// condition and the delays. In bool maximal-step code, a group also holds the `NOT` fire
/// flags of higher-priority transitions that take the same tokens or fill the same place.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Enabling {
    pub guard: Vec<Cond>,
    pub delays: Vec<Cond>,
    pub test: Vec<Cond>,
    pub inhibitor: Vec<Cond>,
    pub preset: Vec<Cond>,
    pub postset: Vec<Cond>,
}

impl Enabling {
    /// The groups with their names, in order, empty ones left out.
    pub fn groups(&self) -> Vec<(&'static str, &[Cond])> {
        [
            ("input condition", &self.guard),
            ("delays", &self.delays),
            ("test arcs", &self.test),
            ("inhibitor arcs", &self.inhibitor),
            ("preset", &self.preset),
            ("postset", &self.postset),
        ]
        .into_iter()
        .filter(|(_, g)| !g.is_empty())
        .map(|(n, g)| (n, g.as_slice()))
        .collect()
    }

    /// Every condition, in group order.
    pub fn all(&self) -> impl Iterator<Item = &Cond> {
        self.guard
            .iter()
            .chain(&self.delays)
            .chain(&self.test)
            .chain(&self.inhibitor)
            .chain(&self.preset)
            .chain(&self.postset)
    }
}
