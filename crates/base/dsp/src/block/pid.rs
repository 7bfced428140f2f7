//! The `pid` block: a positional PID controller in the parallel or the ideal (ISA) form,
//! with derivative on the measurement or on the error through a first-order filter,
//! anti-windup by conditional integration (clamping) or back-calculation, output limits and
//! rate limit, bumpless manual/auto transfer, and `dt` passed in (the measured scan time).
//!
//! Per step with `dt > 0` (`e = sp − pv`):
//!
//! ```text
//! P  = kp·e
//! D  = Tf/(Tf+dt)·D + kd/(Tf+dt)·(x − x_prev)        x = −pv (on measurement) or e
//! I  = I + ki·e·dt                                    (backward rectangle)
//!      + dt/Tt·(u_prev − v_prev)                      (back-calculation only)
//! v  = P + I + D
//! u  = v limited to [min_out, max_out], then to u_prev ± rate·dt
//! ```
//!
//! With clamping, the integration of this step is undone when `u ≠ v` and the error pushes
//! `v` further out. In manual mode `u` is the manual value (limited the same way) and
//! `I = u − P − D`, so that the return to auto starts from the output as it is.

/// The PID's form: how P, I and D are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PidForm {
    /// `u = P·e + I·∫e dt + D·de/dt` (MatPLC's).
    Parallel,
    /// `u = Kc·(e + 1/Ti·∫e dt + Td·de/dt)`: P is Kc, I is Ti in s (0: no integral action),
    /// D is Td in s.
    Ideal,
}

/// How integral windup is prevented.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AntiWindup {
    None,
    /// Conditional integration: no integration while the output is limited and the error
    /// would push it further.
    Clamp,
    /// Back-calculation: the integral is pulled toward the limited output with time
    /// constant `tt` seconds.
    BackCalculation {
        tt: f64,
    },
}

/// The settings of a PID.
#[derive(Clone, Debug, PartialEq)]
pub struct PidConfig {
    pub form: PidForm,
    pub p: f64,
    pub i: f64,
    pub d: f64,
    pub min_out: f64,
    pub max_out: f64,
    /// Derivative on the measurement (`−pv`) rather than on the error.
    pub d_on_measurement: bool,
    /// The derivative filter's time constant in s (0: none).
    pub d_filter: f64,
    pub anti_windup: AntiWindup,
    /// The largest output change per second (∞: none).
    pub rate: f64,
}

impl Default for PidConfig {
    /// MatPLC's defaults: P = 1, I = D = 0, no limits.
    fn default() -> Self {
        PidConfig {
            form: PidForm::Parallel,
            p: 1.0,
            i: 0.0,
            d: 0.0,
            min_out: f64::NEG_INFINITY,
            max_out: f64::INFINITY,
            d_on_measurement: false,
            d_filter: 0.0,
            anti_windup: AntiWindup::Clamp,
            rate: f64::INFINITY,
        }
    }
}

impl PidConfig {
    /// The parallel gains `(kp, ki, kd)` of either form.
    pub fn gains(&self) -> (f64, f64, f64) {
        match self.form {
            PidForm::Parallel => (self.p, self.i, self.d),
            PidForm::Ideal => {
                let ki = if self.i > 0.0 { self.p / self.i } else { 0.0 };
                (self.p, ki, self.p * self.d)
            }
        }
    }

    /// The back-calculation time constant practitioners start from (Åström and Hägglund):
    /// `√(Ti·Td)`, or `Ti` without derivative action; `None` when Ti is not defined
    /// (no proportional or no integral action).
    pub fn default_tracking_time(&self) -> Option<f64> {
        let (kp, ki, kd) = self.gains();
        if kp == 0.0 || ki == 0.0 {
            return None;
        }
        let ti = kp / ki;
        let td = kd / kp;
        let tt = if td > 0.0 { (ti * td).sqrt() } else { ti };
        (tt.is_finite() && tt > 0.0).then_some(tt)
    }
}

/// What a PID reads each step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PidInput {
    /// The setpoint (0 for an open-loop PID fed the error as `pv`... see `error_input`).
    pub sp: f64,
    /// The process value, or the error itself when `error_input` is set.
    pub pv: f64,
    /// `pv` is the error (MatPLC's open-loop form: the loop closed by an `add` block).
    pub error_input: bool,
    /// Automatic (true) or manual mode.
    pub auto: bool,
    /// The output wanted in manual mode.
    pub manual: f64,
}

impl PidInput {
    /// Closed loop in automatic mode.
    pub fn auto(sp: f64, pv: f64) -> PidInput {
        PidInput {
            sp,
            pv,
            error_input: false,
            auto: true,
            manual: 0.0,
        }
    }
}

/// A PID controller and its state.
#[derive(Clone, Debug, PartialEq)]
pub struct Pid {
    config: PidConfig,
    kp: f64,
    ki: f64,
    kd: f64,
    integral: f64,
    derivative: f64,
    x_prev: f64,
    /// The last output and the unlimited value it came from.
    u: f64,
    v: f64,
    started: bool,
    /// Steps whose inputs were not finite (the output was held).
    bad_inputs: u64,
}

impl Pid {
    pub fn new(config: PidConfig) -> Pid {
        let (kp, ki, kd) = config.gains();
        Pid {
            config,
            kp,
            ki,
            kd,
            integral: 0.0,
            derivative: 0.0,
            x_prev: 0.0,
            u: 0.0,
            v: 0.0,
            started: false,
            bad_inputs: 0,
        }
    }

    pub fn config(&self) -> &PidConfig {
        &self.config
    }

    /// The integral term as it stands.
    pub fn integral(&self) -> f64 {
        self.integral
    }

    pub fn bad_inputs(&self) -> u64 {
        self.bad_inputs
    }

    /// The state that evolves between steps, as numbers (for hosts that keep a block's
    /// state in their own memory, such as the IEC engine's native function blocks):
    /// integral, derivative, previous x, output, unlimited output, started (0/1), bad inputs.
    pub fn state(&self) -> [f64; 7] {
        [
            self.integral,
            self.derivative,
            self.x_prev,
            self.u,
            self.v,
            f64::from(u8::from(self.started)),
            self.bad_inputs as f64,
        ]
    }

    /// Sets the state [`Pid::state`] gave.
    pub fn set_state(&mut self, s: [f64; 7]) {
        self.integral = s[0];
        self.derivative = s[1];
        self.x_prev = s[2];
        self.u = s[3];
        self.v = s[4];
        self.started = s[5] != 0.0;
        self.bad_inputs = s[6] as u64;
    }

    fn limit(&self, v: f64, dt: f64, started: bool) -> f64 {
        let mut u = super::limit(v, self.config.min_out, self.config.max_out);
        if started && self.config.rate.is_finite() && dt > 0.0 {
            let step = self.config.rate * dt;
            u = super::limit(u, self.u - step, self.u + step);
        }
        u
    }

    /// One step `dt` seconds after the previous one (0 at the first): the new output. Inputs
    /// that are not finite (or a non-finite manual value in manual mode) hold the output and
    /// the state.
    pub fn step(&mut self, input: PidInput, dt: f64) -> f64 {
        let e = if input.error_input {
            input.pv
        } else {
            input.sp - input.pv
        };
        let manual_bad = !input.auto && !input.manual.is_finite();
        if !e.is_finite() || !dt.is_finite() || dt < 0.0 || manual_bad {
            self.bad_inputs += 1;
            return self.u;
        }
        let p = self.kp * e;
        let x = if self.config.d_on_measurement && !input.error_input {
            -input.pv
        } else {
            e
        };
        let first = !self.started;
        if first {
            self.x_prev = x;
            self.derivative = 0.0;
        } else if dt > 0.0 {
            let tf = self.config.d_filter;
            self.derivative =
                tf / (tf + dt) * self.derivative + self.kd / (tf + dt) * (x - self.x_prev);
            self.x_prev = x;
        }
        self.started = true;

        if !input.auto {
            let u = self.limit(input.manual, dt, !first);
            self.integral = u - p - self.derivative;
            self.u = u;
            self.v = u;
            return u;
        }
        if first || dt == 0.0 {
            let v = p + self.integral + self.derivative;
            let u = self.limit(v, dt, !first);
            self.u = u;
            self.v = v;
            return u;
        }
        let previous = self.integral;
        self.integral += self.ki * e * dt;
        if let AntiWindup::BackCalculation { tt } = self.config.anti_windup {
            self.integral += dt / tt * (self.u - self.v);
        }
        let mut v = p + self.integral + self.derivative;
        let mut u = self.limit(v, dt, true);
        if self.config.anti_windup == AntiWindup::Clamp && u != v && (self.ki * e) * (v - u) > 0.0 {
            self.integral = previous;
            v = p + self.integral + self.derivative;
            u = self.limit(v, dt, true);
        }
        self.u = u;
        self.v = v;
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pid(p: f64, i: f64, d: f64) -> Pid {
        Pid::new(PidConfig {
            p,
            i,
            d,
            ..PidConfig::default()
        })
    }

    #[test]
    fn parallel_terms() {
        let mut c = pid(2.0, 0.5, 0.0);
        assert_eq!(c.step(PidInput::auto(1.0, 0.0), 0.0), 2.0);
        // I += 0.5·1·0.1
        assert_eq!(c.step(PidInput::auto(1.0, 0.0), 0.1), 2.05);
        let mut d = pid(0.0, 0.0, 1.0);
        d.step(PidInput::auto(0.0, 0.0), 0.0);
        // Derivative on the error: (1 − 0)/0.5.
        assert_eq!(d.step(PidInput::auto(1.0, 0.0), 0.5), 2.0);
    }

    #[test]
    fn ideal_form_gains_and_tracking_time() {
        let c = PidConfig {
            form: PidForm::Ideal,
            p: 2.0,
            i: 4.0,
            d: 1.0,
            ..PidConfig::default()
        };
        assert_eq!(c.gains(), (2.0, 0.5, 2.0));
        assert_eq!(c.default_tracking_time(), Some(2.0));
        let no_i = PidConfig {
            form: PidForm::Ideal,
            i: 0.0,
            ..c
        };
        assert_eq!(no_i.gains(), (2.0, 0.0, 2.0));
        assert_eq!(no_i.default_tracking_time(), None);
    }

    #[test]
    fn bad_inputs_hold() {
        let mut c = pid(1.0, 1.0, 0.0);
        c.step(PidInput::auto(1.0, 0.0), 0.0);
        let u = c.step(PidInput::auto(1.0, 0.0), 0.1);
        assert_eq!(c.step(PidInput::auto(f64::NAN, 0.0), 0.1), u);
        assert_eq!(c.step(PidInput::auto(1.0, f64::INFINITY), 0.1), u);
        assert_eq!(c.bad_inputs(), 2);
    }
}
