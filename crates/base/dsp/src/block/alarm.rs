//! The `alarm` block (up to ten limits on one input, each with its comparison, all sharing
//! a hysteresis band) and the `hysteresis` block (a Schmitt trigger).

/// A comparison of the input with a limit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compare {
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
}

impl Compare {
    /// MatPLC's spellings: `less lt smaller st`, `less_or_equal le smaller_or_equal se`,
    /// `greater gt`, `greater_or_equal ge`, `equal eq`, `not_equal ne`.
    pub fn parse(word: &str) -> Option<Compare> {
        Some(match word {
            "less" | "lt" | "smaller" | "st" => Compare::Lt,
            "less_or_equal" | "le" | "smaller_or_equal" | "se" => Compare::Le,
            "greater" | "gt" => Compare::Gt,
            "greater_or_equal" | "ge" => Compare::Ge,
            "equal" | "eq" => Compare::Eq,
            "not_equal" | "ne" => Compare::Ne,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Compare::Lt => "lt",
            Compare::Le => "le",
            Compare::Gt => "gt",
            Compare::Ge => "ge",
            Compare::Eq => "eq",
            Compare::Ne => "ne",
        }
    }

    /// The alarm's next state for input `x`, limit `l`, hysteresis `h` and present state
    /// `on`: it sets as the comparison says and clears only once the input is `h` back on the
    /// safe side (with `h = 0`, exactly the comparison).
    pub fn next(self, x: f64, l: f64, h: f64, on: bool) -> bool {
        match self {
            Compare::Gt => x > l || (on && x > l - h),
            Compare::Ge => x >= l || (on && x >= l - h),
            Compare::Lt => x < l || (on && x < l + h),
            Compare::Le => x <= l || (on && x <= l + h),
            Compare::Eq => x == l || (on && (x - l).abs() <= h),
            Compare::Ne => !Compare::Eq.next(x, l, h, !on),
        }
    }
}

/// One limit of an alarm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limit {
    pub compare: Compare,
    pub limit: f64,
}

/// `alarm`: compares the input (or its absolute value) with each limit.
#[derive(Clone, Debug, PartialEq)]
pub struct Alarm {
    pub absolute: bool,
    pub hysteresis: f64,
    pub limits: Vec<Limit>,
    pub states: Vec<bool>,
}

/// The most limits one alarm row holds (MatPLC's).
pub const MAX_LIMITS: usize = 10;

impl Alarm {
    pub fn new(absolute: bool, hysteresis: f64, limits: Vec<Limit>) -> Alarm {
        let states = vec![false; limits.len()];
        Alarm {
            absolute,
            hysteresis,
            limits,
            states,
        }
    }

    /// The new states. A NaN input sets every alarm (a failed measurement is not a safe one).
    pub fn step(&mut self, x: f64) -> &[bool] {
        let x = if self.absolute { x.abs() } else { x };
        for (state, l) in self.states.iter_mut().zip(&self.limits) {
            *state = x.is_nan() || l.compare.next(x, l.limit, self.hysteresis, *state);
        }
        &self.states
    }
}

/// `hysteresis`: a Schmitt trigger. With `on > off` the output sets when the input reaches
/// `on` and clears when it falls to `off`; with `on < off` it sets when the input falls to
/// `on` and clears when it rises to `off` (a heater's thermostat).
#[derive(Clone, Debug, PartialEq)]
pub struct Hysteresis {
    pub on: f64,
    pub off: f64,
    pub state: bool,
}

impl Hysteresis {
    /// The new state; a NaN input holds it.
    pub fn step(&mut self, x: f64) -> bool {
        let (set, clear) = if self.on > self.off {
            (x >= self.on, x <= self.off)
        } else {
            (x <= self.on, x >= self.off)
        };
        if set {
            self.state = true;
        } else if clear {
            self.state = false;
        }
        self.state
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn comparisons_without_hysteresis_are_exact() {
        let cases = [
            (Compare::Lt, [true, false, false]),
            (Compare::Le, [true, true, false]),
            (Compare::Gt, [false, false, true]),
            (Compare::Ge, [false, true, true]),
            (Compare::Eq, [false, true, false]),
            (Compare::Ne, [true, false, true]),
        ];
        for (c, expect) in cases {
            for on in [false, true] {
                let got = [9.0, 10.0, 11.0].map(|x| c.next(x, 10.0, 0.0, on));
                assert_eq!(got, expect, "{} from {on}", c.name());
            }
        }
    }

    #[test]
    fn hysteresis_holds_inside_the_band() {
        let mut a = Alarm::new(
            false,
            1.0,
            vec![
                Limit {
                    compare: Compare::Gt,
                    limit: 10.0,
                },
                Limit {
                    compare: Compare::Lt,
                    limit: 0.0,
                },
            ],
        );
        let got: Vec<Vec<bool>> = [10.5, 9.5, 9.0, -0.5, 0.5, 1.0, f64::NAN]
            .iter()
            .map(|&x| a.step(x).to_vec())
            .collect();
        assert_eq!(
            got,
            vec![
                vec![true, false],
                vec![true, false],
                vec![false, false],
                vec![false, true],
                vec![false, true],
                vec![false, false],
                vec![true, true],
            ]
        );
    }

    #[test]
    fn schmitt_trigger_both_ways() {
        let mut h = Hysteresis {
            on: 5.0,
            off: 1.0,
            state: false,
        };
        let got: Vec<bool> = [0.0, 4.9, 5.0, 3.0, 1.0, f64::NAN]
            .iter()
            .map(|&x| h.step(x))
            .collect();
        assert_eq!(got, vec![false, false, true, true, false, false]);
        let mut t = Hysteresis {
            on: 18.0,
            off: 22.0,
            state: false,
        };
        let got: Vec<bool> = [20.0, 18.0, 21.0, 22.0]
            .iter()
            .map(|&x| t.step(x))
            .collect();
        assert_eq!(got, vec![false, true, true, false]);
    }
}
