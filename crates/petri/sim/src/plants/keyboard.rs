//! The 4x3 keypad of seed 003 (`PN_device_kb_IO`): the controller powers columns and reads
//! rows; which keys are down comes from the timeline.

use std::time::Duration;

use crate::plant::{Plant, PlantError};

const ROWS: usize = 4;
const COLS: usize = 3;

/// Reads `col1`..`col3` (controller outputs) and `key1`..`key12` (timeline columns); drives
/// `line1`..`line4`. Key k sits at row (k−1)/3+1, column (k−1)%3+1, as the seed's `reshape`
/// lays them out.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Keyboard {
    pressed: [bool; ROWS * COLS],
}

impl Keyboard {
    pub fn new() -> Self {
        Keyboard::default()
    }
    /// The keys down at the last step, numbered 1..=12.
    pub fn pressed(&self) -> Vec<usize> {
        (1..=ROWS * COLS).filter(|k| self.pressed[k - 1]).collect()
    }
}

impl Plant for Keyboard {
    fn name(&self) -> &str {
        "keyboard"
    }
    fn inputs(&self) -> Vec<String> {
        let cols = (1..=COLS).map(|c| format!("col{c}"));
        cols.chain((1..=ROWS * COLS).map(|k| format!("key{k}")))
            .collect()
    }
    fn outputs(&self) -> Vec<String> {
        (1..=ROWS).map(|r| format!("line{r}")).collect()
    }

    fn step(
        &mut self,
        _now: Duration,
        inputs: &[i64],
        outputs: &mut [i64],
    ) -> Result<(), PlantError> {
        let (cols, keys) = inputs.split_at(COLS);
        for (p, &k) in self.pressed.iter_mut().zip(keys) {
            *p = k != 0;
        }
        for (r, line) in outputs.iter_mut().enumerate().take(ROWS) {
            let lit = (0..COLS).any(|c| cols[c] != 0 && self.pressed[r * COLS + c]);
            *line = i64::from(lit);
        }
        Ok(())
    }

    fn summary(&self) -> String {
        let keys = self.pressed();
        if keys.is_empty() {
            "no key pressed".to_string()
        } else {
            let list: Vec<String> = keys.iter().map(usize::to_string).collect();
            format!("keys pressed: {}", list.join(" "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Powers `cols` (1-based) with `keys` (1-based) down; compares lines 1..4 and the summary.
    fn check(cols: &[usize], keys: &[usize], expect_lines: [i64; 4], expect_summary: &str) {
        let mut kb = Keyboard::new();
        let mut inputs = vec![0; 15];
        for &c in cols {
            inputs[c - 1] = 1;
        }
        for &k in keys {
            inputs[COLS + k - 1] = 1;
        }
        let mut lines = [0; 4];
        kb.step(Duration::ZERO, &inputs, &mut lines).unwrap();
        assert_eq!(lines, expect_lines, "cols {cols:?} keys {keys:?}");
        assert_eq!(kb.summary(), expect_summary);
    }

    #[test]
    fn lines_light_where_a_powered_column_meets_a_pressed_key() {
        check(&[], &[], [0, 0, 0, 0], "no key pressed");
        check(&[1, 2, 3], &[], [0, 0, 0, 0], "no key pressed");
        // Pressed but its column is not powered: nothing to read.
        check(&[2, 3], &[1], [0, 0, 0, 0], "keys pressed: 1");
        check(&[1], &[1], [1, 0, 0, 0], "keys pressed: 1");
        check(&[2], &[5], [0, 1, 0, 0], "keys pressed: 5");
        check(&[3], &[9], [0, 0, 1, 0], "keys pressed: 9");
        check(&[3], &[1, 12], [0, 0, 0, 1], "keys pressed: 1 12");
        check(&[1, 3], &[1, 12], [1, 0, 0, 1], "keys pressed: 1 12");
        check(&[1, 2, 3], &[4, 5, 6], [0, 1, 0, 0], "keys pressed: 4 5 6");
        check(&[1], &[1, 4, 7, 10], [1, 1, 1, 1], "keys pressed: 1 4 7 10");
    }

    #[test]
    fn names_follow_the_seed() {
        let kb = Keyboard::new();
        assert_eq!(kb.inputs()[..4], ["col1", "col2", "col3", "key1"]);
        assert_eq!(kb.inputs()[14], "key12");
        assert_eq!(kb.outputs(), ["line1", "line2", "line3", "line4"]);
    }
}
