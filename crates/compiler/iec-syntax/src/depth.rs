//! Bounds on recursion over user input. Every recursive pass of the IEC front ends (the parser,
//! the PLCopen reader, the checker, the compiler) counts its levels with a [`Depth`], so that no
//! source can exhaust the stack: past a limit the input is refused with a coded diagnostic
//! (`E014` in syntax, `E116` in declared types) instead of overflowing.
//!
//! The limits are far beyond what programs need and small enough for the smallest stack the
//! engine runs on: a module thread's 2 MiB in a debug build, where a level of the deepest pass
//! (an expression checked, folded and compiled) takes about a kilobyte.
//! `petriplc-iec`'s tests build programs at every limit on such a thread.

/// Nesting of statements (IF in IF…), of expressions in parentheses, calls and unary
/// operators, of `ARRAY … OF ARRAY`, of initial values, and of Instruction List's
/// parenthesised operations.
pub const MAX_NESTING: usize = 100;

/// Depth of an expression's tree, operators and accesses in a row included: `a + b + …` with
/// more than this many operators, or `x.a.b…` with as many accesses, is refused.
pub const MAX_EXPR_DEPTH: usize = 1000;

/// Types inside types: STRUCT fields, ARRAY elements, function block instances inside
/// function blocks, and names that stand for other types.
pub const MAX_TYPE_DEPTH: usize = 100;

/// How deep a recursive pass is, and how deep it may go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Depth {
    now: usize,
    max: usize,
}

impl Depth {
    pub const fn new(max: usize) -> Self {
        Depth { now: 0, max }
    }

    /// One level down; `false` (and no level taken) when that would pass the limit.
    #[must_use]
    pub fn enter(&mut self) -> bool {
        if self.now >= self.max {
            return false;
        }
        self.now += 1;
        true
    }

    /// Back up one level (after a successful [`Depth::enter`]).
    pub fn leave(&mut self) {
        debug_assert!(self.now > 0, "leave without enter");
        self.now = self.now.saturating_sub(1);
    }

    /// Levels taken now.
    pub fn now(&self) -> usize {
        self.now
    }

    /// The limit.
    pub fn max(&self) -> usize {
        self.max
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn enters_up_to_the_limit_and_no_further() {
        let mut d = Depth::new(2);
        assert!(d.enter());
        assert!(d.enter());
        assert!(!d.enter());
        assert_eq!(d.now(), 2);
        d.leave();
        assert!(d.enter());
        d.leave();
        d.leave();
        assert_eq!(d.now(), 0);
    }
}
