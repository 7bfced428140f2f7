//! The one walk of a lowered condition ([`Cond`]) that every backend implements to print it:
//! ST and C as text, IL as instructions, LD as contacts. A backend chooses spelling only:
//! which copy of a marking a count reads (`Avail`, `New`) is decided here, in [`render`].

use crate::enabling::{Atom, Cond};
use crate::lower::{PlaceVar, Program, TransitionCode};
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
