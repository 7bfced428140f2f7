//! The `nonlinear` block (dead band around an offset, then cut-offs) and the `multiplexor`
//! (one of several inputs, chosen by a control value against increasing limits).

/// `nonlinear`: `out = clamp(f(in·gain), cutoff_bot, cutoff_top)` where `f` is `deadband_out`
/// between `deadband_bot` and `deadband_top`, and continues with slope 1 outside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Nonlinear {
    pub cutoff_top: f64,
    pub cutoff_bot: f64,
    pub deadband_top: f64,
    pub deadband_bot: f64,
    pub deadband_out: f64,
    pub gain: f64,
}

impl Default for Nonlinear {
    /// MatPLC's defaults: cut-offs at ±f32::MAX, no dead band, gain 1.
    fn default() -> Self {
        Nonlinear {
            cutoff_top: f64::from(f32::MAX),
            cutoff_bot: -f64::from(f32::MAX),
            deadband_top: 0.0,
            deadband_bot: 0.0,
            deadband_out: 0.0,
            gain: 1.0,
        }
    }
}

impl Nonlinear {
    /// NaN passes through as NaN; ±∞ end at the cut-offs.
    pub fn step(&self, x: f64) -> f64 {
        let x = x * self.gain;
        let y = if x > self.deadband_top {
            self.deadband_out + (x - self.deadband_top)
        } else if x < self.deadband_bot {
            self.deadband_out + (x - self.deadband_bot)
        } else if x.is_nan() {
            x
        } else {
            self.deadband_out
        };
        super::limit(y, self.cutoff_bot, self.cutoff_top)
    }
}

/// `multiplexor`: input 0 below `limits[0]`, input k from `limits[k−1]` up to `limits[k]`,
/// the last input from the last limit up.
#[derive(Clone, Debug, PartialEq)]
pub struct Multiplexor {
    /// Strictly increasing.
    pub limits: Vec<f64>,
}

impl Multiplexor {
    /// Which input the control value selects; `None` for NaN (the output holds).
    pub fn select(&self, control: f64) -> Option<usize> {
        if control.is_nan() {
            return None;
        }
        Some(self.limits.partition_point(|&l| control >= l))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matplc_demo_nonlinear() {
        // fblock nonlinear out_1 out_2 cutoff_top 7 cutoff_bot 2 deadband_bot 4
        //   deadband_top 5 deadband_out 4 gain 1
        let n = Nonlinear {
            cutoff_top: 7.0,
            cutoff_bot: 2.0,
            deadband_bot: 4.0,
            deadband_top: 5.0,
            deadband_out: 4.0,
            gain: 1.0,
        };
        let got: Vec<f64> = [0.0, 3.0, 4.5, 6.0, 10.0, f64::INFINITY]
            .iter()
            .map(|&x| n.step(x))
            .collect();
        assert_eq!(got, vec![2.0, 3.0, 4.0, 5.0, 7.0, 7.0]);
        assert!(n.step(f64::NAN).is_nan());
        assert_eq!(Nonlinear::default().step(-3.5), -3.5);
    }

    #[test]
    fn multiplexor_limits() {
        let m = Multiplexor {
            limits: vec![1.0, 5.0],
        };
        let got: Vec<Option<usize>> = [0.0, 1.0, 4.9, 5.0, f64::INFINITY, f64::NAN]
            .iter()
            .map(|&c| m.select(c))
            .collect();
        assert_eq!(got, vec![Some(0), Some(1), Some(1), Some(2), Some(2), None]);
    }
}
