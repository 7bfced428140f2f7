//! The `delay` block: the input of N scans ago.

/// A delay line of `n` scans.
#[derive(Clone, Debug, PartialEq)]
pub struct Delay {
    line: Vec<f64>,
    head: usize,
    started: bool,
}

impl Delay {
    /// `n ≥ 1` scans.
    pub fn new(n: usize) -> Delay {
        Delay {
            line: vec![0.0; n.max(1)],
            head: 0,
            started: false,
        }
    }

    pub fn scans(&self) -> usize {
        self.line.len()
    }

    /// The input of `n` steps ago; before that many steps, the first input (a PLC that starts
    /// with a value present sees no step from 0). Values pass unchanged, NaN included.
    pub fn step(&mut self, x: f64) -> f64 {
        if !self.started {
            self.started = true;
            self.line.fill(x);
        }
        let y = self.line[self.head];
        self.line[self.head] = x;
        self.head = (self.head + 1) % self.line.len();
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn delays_by_n() {
        let mut d = Delay::new(2);
        let got: Vec<f64> = [5.0, 1.0, 2.0, 3.0].iter().map(|&x| d.step(x)).collect();
        assert_eq!(got, vec![5.0, 5.0, 5.0, 1.0]);
    }
}
