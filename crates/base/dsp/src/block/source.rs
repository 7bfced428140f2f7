//! The `source` block: test signals for a live PLC (sine, square, triangle, step, ramp) as
//! functions of the module's time.

use std::f64::consts::PI;

/// The waveform.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wave {
    Sine,
    Square,
    Triangle,
    Step,
    Ramp,
}

impl Wave {
    pub fn parse(word: &str) -> Option<Wave> {
        Some(match word {
            "sine" => Wave::Sine,
            "square" => Wave::Square,
            "triangle" => Wave::Triangle,
            "step" => Wave::Step,
            "ramp" => Wave::Ramp,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Wave::Sine => "sine",
            Wave::Square => "square",
            Wave::Triangle => "triangle",
            Wave::Step => "step",
            Wave::Ramp => "ramp",
        }
    }
}

/// A signal generator: `offset` before `start` s, then the wave. Periodic waves start at
/// phase 0 going up (square: +amplitude for the first half period); `step` adds `amplitude`;
/// `ramp` rises `amplitude` per second.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    pub wave: Wave,
    pub amplitude: f64,
    /// Hz, for the periodic waves.
    pub frequency: f64,
    pub offset: f64,
    /// s.
    pub start: f64,
}

impl Source {
    /// The value at time `t` s.
    pub fn step(&self, t: f64) -> f64 {
        let t = t - self.start;
        if t < 0.0 {
            return self.offset;
        }
        let phase = (self.frequency * t).fract();
        let shape = match self.wave {
            Wave::Sine => (2.0 * PI * self.frequency * t).sin(),
            Wave::Square => {
                if phase < 0.5 {
                    1.0
                } else {
                    -1.0
                }
            }
            Wave::Triangle => {
                if phase < 0.25 {
                    4.0 * phase
                } else if phase < 0.75 {
                    2.0 - 4.0 * phase
                } else {
                    4.0 * phase - 4.0
                }
            }
            Wave::Step => 1.0,
            Wave::Ramp => t,
        };
        self.offset + self.amplitude * shape
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(wave: Wave, times: &[f64]) -> Vec<f64> {
        let s = Source {
            wave,
            amplitude: 2.0,
            frequency: 1.0,
            offset: 1.0,
            start: 1.0,
        };
        times.iter().map(|&t| s.step(t)).collect()
    }

    #[test]
    fn waves() {
        let t = [0.5, 1.0, 1.25, 1.5, 1.75, 2.0];
        assert_eq!(at(Wave::Square, &t), vec![1.0, 3.0, 3.0, -1.0, -1.0, 3.0]);
        assert_eq!(at(Wave::Triangle, &t), vec![1.0, 1.0, 3.0, 1.0, -1.0, 1.0]);
        assert_eq!(at(Wave::Step, &t), vec![1.0, 3.0, 3.0, 3.0, 3.0, 3.0]);
        assert_eq!(at(Wave::Ramp, &t), vec![1.0, 1.0, 1.5, 2.0, 2.5, 3.0]);
        let s = at(Wave::Sine, &t);
        assert!((s[2] - 3.0).abs() < 1e-12 && (s[4] + 1.0).abs() < 1e-12);
    }
}
