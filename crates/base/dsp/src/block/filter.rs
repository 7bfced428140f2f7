//! The `filter` block at run time: IIR filters as a cascade of second-order sections in
//! transposed direct form II (exactly the arithmetic of `scipy.signal.sosfilt`), FIR filters
//! as a direct convolution over a ring of past inputs. Both run in `f64`; both assume the
//! block is stepped once per sampling period.

use crate::design::Section;

/// A cascade of second-order sections with its state.
#[derive(Clone, Debug, PartialEq)]
pub struct Iir {
    sections: Vec<Section>,
    state: Vec<[f64; 2]>,
    /// Start from the steady state of the first input instead of from rest.
    steady: bool,
    started: bool,
}

impl Iir {
    /// Sections normalised to `a0 = 1` (the designs are; explicit coefficients are built so).
    pub fn new(sections: Vec<Section>, steady: bool) -> Iir {
        let state = vec![[0.0; 2]; sections.len()];
        Iir {
            sections,
            state,
            steady,
            started: false,
        }
    }

    pub fn sections(&self) -> &[Section] {
        &self.sections
    }

    /// The state between steps (per section, and whether it started), for hosts that keep
    /// a block's state in their own memory (the IEC engine's native function blocks).
    pub fn state(&self) -> (&[[f64; 2]], bool) {
        (&self.state, self.started)
    }

    /// Sets the state [`Iir::state`] gave (sections beyond this filter's are ignored).
    pub fn set_state(&mut self, state: &[[f64; 2]], started: bool) {
        for (z, s) in self.state.iter_mut().zip(state) {
            *z = *s;
        }
        self.started = started;
    }

    /// The gain at DC (z = 1): ∞ or NaN when a pole sits on z = 1.
    pub fn dc_gain(&self) -> f64 {
        self.sections
            .iter()
            .map(|s| (s[0] + s[1] + s[2]) / (s[3] + s[4] + s[5]))
            .product()
    }

    /// Sets the state to what a constant input `x` leaves behind (SciPy's
    /// `sosfilt_zi(sos) * x`), when every section has a finite DC gain.
    fn settle(&mut self, x: f64) {
        let mut input = x;
        for (s, z) in self.sections.iter().zip(&mut self.state) {
            let gain = (s[0] + s[1] + s[2]) / (s[3] + s[4] + s[5]);
            if !gain.is_finite() {
                return;
            }
            let y = gain * input;
            z[1] = s[2] * input - s[5] * y;
            z[0] = s[1] * input - s[4] * y + z[1];
            input = y;
        }
    }

    /// One sample. A non-finite input leaves the state as it is and returns `None` (the
    /// caller holds its output), so that one bad sample does not poison the filter forever.
    pub fn step(&mut self, x: f64) -> Option<f64> {
        if !x.is_finite() {
            return None;
        }
        if !self.started {
            self.started = true;
            if self.steady {
                self.settle(x);
            }
        }
        let mut x = x;
        for (s, z) in self.sections.iter().zip(&mut self.state) {
            let y = s[0] * x + z[0];
            z[0] = s[1] * x - s[4] * y + z[1];
            z[1] = s[2] * x - s[5] * y;
            x = y;
        }
        Some(x)
    }
}

/// A FIR filter with its ring of past inputs.
#[derive(Clone, Debug, PartialEq)]
pub struct Fir {
    taps: Vec<f64>,
    past: Vec<f64>,
    /// Where the newest input goes next.
    head: usize,
}

impl Fir {
    pub fn new(taps: Vec<f64>) -> Fir {
        let past = vec![0.0; taps.len()];
        Fir {
            taps,
            past,
            head: 0,
        }
    }

    pub fn taps(&self) -> &[f64] {
        &self.taps
    }

    /// One sample: `Σ h[k]·x[n−k]` (inputs before the first are 0). A non-finite input is
    /// skipped as for [`Iir::step`].
    pub fn step(&mut self, x: f64) -> Option<f64> {
        if !x.is_finite() {
            return None;
        }
        let n = self.taps.len();
        self.past[self.head] = x;
        let mut y = 0.0;
        let mut i = self.head;
        for h in &self.taps {
            y += h * self.past[i];
            i = if i == 0 { n - 1 } else { i - 1 };
        }
        self.head = (self.head + 1) % n;
        Some(y)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_section_impulse_response() {
        // y[n] = x[n] + 0.5 y[n−1]: 1, 0.5, 0.25, …
        let mut f = Iir::new(vec![[1.0, 0.0, 0.0, 1.0, -0.5, 0.0]], false);
        let y: Vec<f64> = [1.0, 0.0, 0.0]
            .iter()
            .map(|&x| f.step(x).unwrap())
            .collect();
        assert_eq!(y, vec![1.0, 0.5, 0.25]);
        assert_eq!(f.step(f64::NAN), None);
        assert_eq!(f.step(0.0), Some(0.125));
        assert_eq!(f.dc_gain(), 2.0);
    }

    #[test]
    fn steady_start_has_no_transient() {
        let mut f = Iir::new(
            vec![
                [0.2, 0.4, 0.2, 1.0, -0.3, 0.1],
                [1.0, 1.0, 0.0, 1.0, -0.2, 0.0],
            ],
            true,
        );
        let dc = f.dc_gain();
        for _ in 0..5 {
            let y = f.step(10.0).unwrap();
            assert!((y - 10.0 * dc).abs() < 1e-12, "{y}");
        }
    }

    #[test]
    fn fir_convolves() {
        let mut f = Fir::new(vec![1.0, 2.0, 3.0]);
        let y: Vec<f64> = [1.0, 0.0, 0.0, 0.0, 1.0]
            .iter()
            .map(|&x| f.step(x).unwrap())
            .collect();
        assert_eq!(y, vec![1.0, 2.0, 3.0, 0.0, 1.0]);
    }
}
