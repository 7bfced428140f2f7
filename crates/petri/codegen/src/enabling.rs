//! A transition's test, lowered once: what every backend checks before a transition fires
//! (guard, delays, read and inhibitor arcs, preset, room in the postset), as [`Enabling`]
//! groups of [`Cond`]s already specialised to the step rule and the markings; and
//! [`Syntax`], the one walk of a condition that every backend implements to print it (ST and
//! C as text, IL as instructions, LD as contacts). A backend chooses spelling only: which
//! copy of a marking a count reads (`Avail`, `New`) is decided here, in [`render`].

use petriplc_net::{Net, PlaceId, TransitionId};

use crate::lower::{PlaceVar, Program, TransitionCode};

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

/// `place` holds at least `weight` tokens (its `Avail` copy when `avail` and it has one).
pub(crate) fn holds(place: &PlaceVar, p: usize, weight: u32, avail: bool) -> Cond {
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

pub(crate) fn enabling(
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

/// How one backend spells the elementary conditions of a [`Cond`]; [`render`] does the walk.
pub trait Syntax {
    type Out;
    /// The program the conditions' indices refer to.
    fn program(&self) -> &Program;
    fn constant(&self, value: bool) -> Self::Out;
    /// The disjunction of `items` (at least one).
    fn any(&self, items: Vec<Self::Out>) -> Self::Out;
    /// Transition `t`'s guard over the input signals, or its negation.
    fn guard(&self, t: usize, negated: bool) -> Self::Out;
    /// Timer `i`'s output (its arc's delay has elapsed), or its negation.
    fn timer(&self, i: usize, negated: bool) -> Self::Out;
    /// A BOOL place is marked (empty when `negated`).
    fn marked(&self, place: &PlaceVar, negated: bool) -> Self::Out;
    /// A transition fired in this pass (did not, when `negated`).
    fn fired(&self, t: &TransitionCode, negated: bool) -> Self::Out;
    /// An integer place holds at least `tokens` (fewer, when `negated`): its marking, or the
    /// `avail` copy (the variable named) when the pass judges on the tokens not yet taken.
    fn at_least(
        &self,
        place: &PlaceVar,
        avail: Option<&str>,
        tokens: u32,
        negated: bool,
    ) -> Self::Out;
    /// An integer place's marking, plus the `produced` counter (the variable named) when the
    /// pass has one, is at most `limit` (more, when `negated`).
    fn at_most(
        &self,
        place: &PlaceVar,
        produced: Option<&str>,
        limit: u64,
        negated: bool,
    ) -> Self::Out;
}

/// `c` in the syntax of `s`.
pub fn render<S: Syntax>(s: &S, c: &Cond) -> S::Out {
    let p = s.program();
    match c {
        Cond::Const(b) => s.constant(*b),
        Cond::Any(items) => s.any(items.iter().map(|c| render(s, c)).collect()),
        Cond::Lit { atom, negated } => {
            let neg = *negated;
            match atom {
                Atom::Guard(t) => s.guard(*t, neg),
                Atom::Timer(i) => s.timer(*i, neg),
                Atom::Marked(pl) => s.marked(&p.places[*pl], neg),
                Atom::Fired(t) => s.fired(&p.transitions[*t], neg),
                Atom::AtLeast {
                    place,
                    avail,
                    tokens,
                } => {
                    let pl = &p.places[*place];
                    let copy = pl.avail.as_deref().filter(|_| *avail);
                    s.at_least(pl, copy, *tokens, neg)
                }
                Atom::AtMost {
                    place,
                    produced,
                    limit,
                } => {
                    let pl = &p.places[*place];
                    let counter = pl.produced.as_deref().filter(|_| *produced);
                    s.at_most(pl, counter, *limit, neg)
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lower::Options;
    use petriplc_net::StepRule;
    use petriplc_testnet::net;

    /// Writes each elementary condition as the walk hands it over, to show what a backend
    /// is given.
    struct Spy<'p>(&'p Program);

    impl Syntax for Spy<'_> {
        type Out = String;
        fn program(&self) -> &Program {
            self.0
        }
        fn constant(&self, value: bool) -> String {
            value.to_string()
        }
        fn any(&self, items: Vec<String>) -> String {
            format!("any({})", items.join(", "))
        }
        fn guard(&self, t: usize, negated: bool) -> String {
            format!("{}guard({t})", if negated { "!" } else { "" })
        }
        fn timer(&self, i: usize, negated: bool) -> String {
            format!("{}timer({i})", if negated { "!" } else { "" })
        }
        fn marked(&self, place: &PlaceVar, negated: bool) -> String {
            format!("{}marked({})", if negated { "!" } else { "" }, place.label)
        }
        fn fired(&self, t: &TransitionCode, negated: bool) -> String {
            format!("{}fired({})", if negated { "!" } else { "" }, t.label)
        }
        fn at_least(&self, place: &PlaceVar, avail: Option<&str>, n: u32, neg: bool) -> String {
            format!(
                "{}at_least({}, {avail:?}, {n})",
                if neg { "!" } else { "" },
                place.label
            )
        }
        fn at_most(&self, place: &PlaceVar, new: Option<&str>, n: u64, neg: bool) -> String {
            format!(
                "{}at_most({}, {new:?}, {n})",
                if neg { "!" } else { "" },
                place.label
            )
        }
    }

    /// Transition 0's enabling, group by group, as the walk hands it to a backend.
    fn check(text: &str, step: StepRule, expect: &[&str]) {
        let n = net(text);
        let options = Options {
            step,
            ..Options::of(&n)
        };
        let p = Program::lower(&n, &options).unwrap();
        let spy = Spy(&p);
        let got: Vec<String> = p.transitions[0]
            .enabling
            .groups()
            .iter()
            .map(|(name, conds)| {
                let c: Vec<String> = conds.iter().map(|c| render(&spy, c)).collect();
                format!("{name}: {}", c.join(" & "))
            })
            .collect();
        assert_eq!(got, expect, "{text}");
    }

    #[test]
    fn int_maximal_step_reads_the_pass_copies() {
        let text = "s Go in bool\np a 3\np r 1\np i 0\np b 0 cap=4\n\
                    t t a*2@1s ?r !i*2 -> b*3 if Go";
        check(
            text,
            StepRule::MaximalStep,
            &[
                "input condition: guard(0)",
                "delays: timer(0)",
                r#"test arcs: at_least(r, None, 1)"#,
                r#"inhibitor arcs: !at_least(i, None, 2)"#,
                r#"preset: at_least(a, Some("aAvail"), 2)"#,
                r#"postset: at_most(b, Some("bNew"), 1)"#,
            ],
        );
        // Sequential: every count reads the marking itself.
        check(
            text,
            StepRule::Sequential,
            &[
                "input condition: guard(0)",
                "delays: timer(0)",
                "test arcs: at_least(r, None, 1)",
                "inhibitor arcs: !at_least(i, None, 2)",
                "preset: at_least(a, None, 2)",
                "postset: at_most(b, None, 1)",
            ],
        );
    }

    #[test]
    fn bool_maximal_step_names_the_higher_priority_takers() {
        check(
            "p a 1 cap=1\np b 0 cap=1\np c 0 cap=1\nt u a -> b\nt t a !b -> c",
            StepRule::MaximalStep,
            &["preset: marked(a)", "postset: !marked(b)"],
        );
        let n = net("p a 1 cap=1\np b 0 cap=1\np c 0 cap=1\nt u a -> b\nt t a !b -> c");
        let p = Program::lower(&n, &Options::of(&n)).unwrap();
        let spy = Spy(&p);
        let all: Vec<String> = p.transitions[1]
            .enabling
            .all()
            .map(|c| render(&spy, c))
            .collect();
        assert_eq!(
            all,
            ["!marked(b)", "marked(a)", "!fired(u)", "!marked(c)"],
            "{p:#?}"
        );
    }
}
