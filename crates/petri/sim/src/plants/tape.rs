//! The Turing-machine tape of seed 003 (`TM_tape`): unbounded both ways, the head starting at
//! cell 0 on a blank (all-zero) tape.

use std::collections::BTreeSet;
use std::time::Duration;

use crate::plant::{Plant, PlantError};

/// Reads `write`, `left`, `right`; drives `read`, the symbol under the head.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Tape {
    /// Cells holding 1; the tape only ever gets ones written, so this is the whole tape.
    ones: BTreeSet<i64>,
    head: i64,
}

/// Longer spans are summarised by their bounds: a report line should stay a line.
const SHOWN_CELLS: i64 = 64;

impl Tape {
    pub fn new() -> Self {
        Tape::default()
    }
    pub fn head(&self) -> i64 {
        self.head
    }
    /// The symbol at `cell`.
    pub fn cell(&self, cell: i64) -> i64 {
        i64::from(self.ones.contains(&cell))
    }
    pub fn ones(&self) -> usize {
        self.ones.len()
    }
    /// The cells from the leftmost to the rightmost 1, or `None` on a blank tape.
    pub fn span(&self) -> Option<(i64, i64)> {
        Some((*self.ones.first()?, *self.ones.last()?))
    }
}

impl Plant for Tape {
    fn name(&self) -> &str {
        "tape"
    }
    fn inputs(&self) -> Vec<String> {
        vec!["write".into(), "left".into(), "right".into()]
    }
    fn outputs(&self) -> Vec<String> {
        vec!["read".into()]
    }

    fn step(
        &mut self,
        _now: Duration,
        inputs: &[i64],
        outputs: &mut [i64],
    ) -> Result<(), PlantError> {
        let (write, left, right) = (inputs[0] != 0, inputs[1] != 0, inputs[2] != 0);
        // Seed 003's PN_s2act: write first, then move, left taking precedence over right.
        if write {
            self.ones.insert(self.head);
        }
        let moved = if left {
            self.head.checked_sub(1)
        } else if right {
            self.head.checked_add(1)
        } else {
            Some(self.head)
        };
        self.head = moved.ok_or_else(|| PlantError::Failed {
            plant: "tape".into(),
            message: format!("the head ran off the end of the tape at cell {}", self.head),
        })?;
        outputs[0] = self.cell(self.head);
        Ok(())
    }

    fn summary(&self) -> String {
        let head = self.head;
        let n = self.ones.len();
        match self.span() {
            None => format!("tape blank (0 ones), head at {head}"),
            Some((lo, hi)) if hi - lo < SHOWN_CELLS => {
                let cells: String = (lo..=hi)
                    .map(|c| if self.ones.contains(&c) { '1' } else { '0' })
                    .collect();
                format!("tape {cells} ({n} ones) on cells {lo}..{hi}, head at {head}")
            }
            Some((lo, hi)) => format!(
                "tape of {} cells ({n} ones) on cells {lo}..{hi}, head at {head}",
                hi - lo + 1
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Applies each (write, left, right) actuation in turn and compares the `read` outputs
    /// and the final summary.
    fn check(steps: &[(i64, i64, i64)], expect_reads: &[i64], expect_summary: &str) {
        let mut tape = Tape::new();
        let mut out = [0];
        let mut reads = Vec::new();
        for (k, &(w, l, r)) in steps.iter().enumerate() {
            tape.step(Duration::from_secs(k as u64), &[w, l, r], &mut out)
                .unwrap();
            reads.push(out[0]);
        }
        assert_eq!(reads, expect_reads);
        assert_eq!(tape.summary(), expect_summary);
    }

    #[test]
    fn writes_then_moves() {
        check(&[], &[], "tape blank (0 ones), head at 0");
        check(&[(0, 0, 0)], &[0], "tape blank (0 ones), head at 0");
        // Write and stay: the head reads what it just wrote.
        check(
            &[(1, 0, 0)],
            &[1],
            "tape 1 (1 ones) on cells 0..0, head at 0",
        );
        // Write and move right: the new cell is blank; come back left and read the 1.
        check(
            &[(1, 0, 1), (0, 1, 0), (0, 1, 0), (1, 1, 0)],
            &[0, 1, 0, 0],
            "tape 11 (2 ones) on cells -1..0, head at -2",
        );
        check(
            &[(1, 0, 1), (0, 0, 1), (1, 1, 0)],
            &[0, 0, 0],
            "tape 101 (2 ones) on cells 0..2, head at 1",
        );
        // Left wins when both directions are asked for.
        check(&[(0, 1, 1)], &[0], "tape blank (0 ones), head at -1");
    }

    #[test]
    fn is_unbounded_both_ways() {
        let mut tape = Tape::new();
        let mut out = [0];
        for _ in 0..100 {
            tape.step(Duration::ZERO, &[1, 1, 0], &mut out).unwrap();
        }
        for _ in 0..300 {
            tape.step(Duration::ZERO, &[0, 0, 1], &mut out).unwrap();
        }
        tape.step(Duration::ZERO, &[1, 0, 0], &mut out).unwrap();
        assert_eq!(tape.head(), 200);
        assert_eq!(tape.ones(), 101);
        assert_eq!(tape.span(), Some((-99, 200)));
        assert_eq!(
            tape.summary(),
            "tape of 300 cells (101 ones) on cells -99..200, head at 200"
        );
    }

    #[test]
    fn the_head_cannot_overflow() {
        let mut tape = Tape {
            ones: BTreeSet::new(),
            head: i64::MIN,
        };
        let e = tape.step(Duration::ZERO, &[0, 1, 0], &mut [0]).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!(
                "plant `tape`: the head ran off the end of the tape at cell {}",
                i64::MIN
            )
        );
    }
}
