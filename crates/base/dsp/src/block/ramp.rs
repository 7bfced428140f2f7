//! The `ramp` block: the output follows the input with its rate of change (dx/dt) and the
//! rate of change of that (d²x/dt²) limited, rising and falling limits set apart. It brakes in
//! time to stop on the input without overshoot when the input stands still.

/// Limits in units per second (rates) and per second squared (accelerations); ∞ means none.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RampConfig {
    /// The fastest rise of x.
    pub pos_dxdt: f64,
    /// The fastest fall of x (positive number).
    pub neg_dxdt: f64,
    /// The fastest rise of dx/dt.
    pub pos_d2xdt2: f64,
    /// The fastest fall of dx/dt (positive number).
    pub neg_d2xdt2: f64,
}

impl Default for RampConfig {
    fn default() -> Self {
        RampConfig {
            pos_dxdt: f64::INFINITY,
            neg_dxdt: f64::INFINITY,
            pos_d2xdt2: f64::INFINITY,
            neg_d2xdt2: f64::INFINITY,
        }
    }
}

/// A rate- and acceleration-limited follower.
#[derive(Clone, Debug, PartialEq)]
pub struct Ramp {
    config: RampConfig,
    x: f64,
    v: f64,
    started: bool,
}

/// The fastest speed from which a deceleration of `a` (applied in steps of `a·dt`, the
/// position advancing by speed·dt after each) stops within `dist`. Braking from `(m + f)·a·dt`
/// (`m` whole, `0 ≤ f < 1`) covers `a·dt²·(m + 1)(m/2 + f)`; that is solved for the largest
/// speed covering at most `dist`, so the follower lands on a still target exactly.
fn braking_speed(dist: f64, a: f64, dt: f64) -> f64 {
    if a.is_infinite() {
        return f64::INFINITY;
    }
    let q = dist / (a * dt * dt);
    if !q.is_finite() || q > 1e12 {
        // Thousands of scans from the target: the continuous braking curve, to well within
        // rounding (and no loop over a step count that f64 cannot count in ones).
        return (2.0 * dist * a).sqrt();
    }
    let mut m = ((0.25 + 2.0 * q).sqrt() - 0.5).floor().max(0.0);
    while (m + 1.0) * (m + 2.0) / 2.0 <= q {
        m += 1.0;
    }
    while m > 0.0 && m * (m + 1.0) / 2.0 > q {
        m -= 1.0;
    }
    let f = ((q - m * (m + 1.0) / 2.0) / (m + 1.0)).clamp(0.0, 1.0);
    (m + f) * a * dt
}

use super::limit;

impl Ramp {
    pub fn new(config: RampConfig) -> Ramp {
        Ramp {
            config,
            x: 0.0,
            v: 0.0,
            started: false,
        }
    }

    /// The state between steps (output, its rate, started 0/1), for hosts that keep a
    /// block's state in their own memory (the IEC engine's native function blocks).
    pub fn state(&self) -> [f64; 3] {
        [self.x, self.v, f64::from(u8::from(self.started))]
    }

    /// Sets the state [`Ramp::state`] gave.
    pub fn set_state(&mut self, s: [f64; 3]) {
        self.x = s[0];
        self.v = s[1];
        self.started = s[2] != 0.0;
    }

    pub fn config(&self) -> &RampConfig {
        &self.config
    }

    /// The speed (dx/dt) of the last step.
    pub fn speed(&self) -> f64 {
        self.v
    }

    /// One step `dt` seconds after the previous one: the output. The first step starts at the
    /// input; a non-finite input holds the output (and stops it).
    pub fn step(&mut self, target: f64, dt: f64) -> f64 {
        if !target.is_finite() {
            return self.x;
        }
        if !self.started {
            self.started = true;
            self.x = target;
            self.v = 0.0;
            return self.x;
        }
        if !(dt > 0.0 && dt.is_finite()) {
            return self.x;
        }
        let c = self.config;
        let d = target - self.x;
        let wanted = if d > 0.0 {
            (d / dt)
                .min(c.pos_dxdt)
                .min(braking_speed(d, c.neg_d2xdt2, dt))
        } else if d < 0.0 {
            -(-d / dt)
                .min(c.neg_dxdt)
                .min(braking_speed(-d, c.pos_d2xdt2, dt))
        } else {
            0.0
        };
        let v = limit(
            limit(
                wanted,
                self.v - c.neg_d2xdt2 * dt,
                self.v + c.pos_d2xdt2 * dt,
            ),
            -c.neg_dxdt,
            c.pos_dxdt,
        );
        let next = self.x + v * dt;
        // Rounding must not carry a follower that lands on its target past it: an overshoot
        // of a few units in the last place is a landing, a larger one was forced by the
        // acceleration limit (the target moved) and is real.
        let crossed = (d > 0.0 && next > target) || (d < 0.0 && next < target);
        let rounding = 8.0 * f64::EPSILON * target.abs().max(self.x.abs());
        self.x = if v == d / dt || (crossed && (next - target).abs() <= rounding) {
            target
        } else {
            next
        };
        self.v = v;
        self.x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rate_limited_step() {
        let mut r = Ramp::new(RampConfig {
            pos_dxdt: 2.0,
            neg_dxdt: 4.0,
            ..RampConfig::default()
        });
        assert_eq!(r.step(0.0, 0.0), 0.0);
        let up: Vec<f64> = (0..4).map(|_| r.step(1.0, 0.25)).collect();
        assert_eq!(up, vec![0.5, 1.0, 1.0, 1.0]);
        let down: Vec<f64> = (0..3).map(|_| r.step(-1.0, 0.25)).collect();
        assert_eq!(down, vec![0.0, -1.0, -1.0]);
    }

    /// A step with an acceleration limit: speed and acceleration within the limits, no
    /// overshoot, and the target reached.
    #[test]
    fn acceleration_limited_step_stops_on_target() {
        let (rate, acc, dt) = (3.0, 2.0, 0.01);
        let mut r = Ramp::new(RampConfig {
            pos_dxdt: rate,
            neg_dxdt: rate,
            pos_d2xdt2: acc,
            neg_d2xdt2: acc,
        });
        r.step(0.0, 0.0);
        let (mut x, mut v) = (0.0, 0.0);
        for _ in 0..1000 {
            let nx = r.step(10.0, dt);
            let nv = (nx - x) / dt;
            assert!(nv <= rate + 1e-9 && nv >= -1e-9, "speed {nv}");
            assert!(
                (nv - v).abs() <= acc * dt + 1e-9,
                "acceleration {}",
                (nv - v) / dt
            );
            assert!(nx <= 10.0, "overshoot {nx}");
            x = nx;
            v = nv;
        }
        assert_eq!(x, 10.0);
    }
}
