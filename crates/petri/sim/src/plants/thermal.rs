//! A heated vessel as a first-order-plus-dead-time (FOPDT) process, the model process
//! control is tuned against: `τ·dT/dt = T_amb + K·u(t − θ) − T`. The heater power `u` holds
//! between steps, so each step integrates exactly (`T` relaxes exponentially toward the
//! steady state of each stretch of constant delayed power).
//!
//! Signals carry real values in fixed point: `heater` in thousandths of a percent (0 to
//! 100 000, clamped), `temp` in thousandths of a degree; the `plant` module binds them to
//! f32 points as percent and °C.

use std::time::Duration;

use crate::plant::{Plant, PlantError};

/// Thousandths: the fixed-point scale of both signals.
pub const SCALE: f64 = 1000.0;

/// The process's constants.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThermalParams {
    /// Process gain K: °C of steady-state rise per % of heater power.
    pub gain: f64,
    /// Time constant τ in seconds.
    pub time_constant: f64,
    /// Dead time θ in seconds.
    pub dead_time: f64,
    /// Ambient temperature in °C (the temperature with the heater off).
    pub ambient: f64,
    /// The temperature at the start, °C.
    pub initial: f64,
}

impl Default for ThermalParams {
    /// A small oven: 2 °C per % (up to 220 °C), τ = 60 s, θ = 5 s, from 20 °C.
    fn default() -> Self {
        ThermalParams {
            gain: 2.0,
            time_constant: 60.0,
            dead_time: 5.0,
            ambient: 20.0,
            initial: 20.0,
        }
    }
}

/// The settings of the `thermal` plant ([`ThermalParams::parse`]), in the order they are
/// listed.
pub const THERMAL_SETTINGS: &[&str] = &["gain", "time_constant", "dead_time", "ambient", "initial"];

impl ThermalParams {
    /// The defaults with `settings` (name, value) applied: `gain` (°C per %),
    /// `time_constant` (s, above 0), `dead_time` (s, 0 to 3600), `ambient` (°C) and `initial`
    /// (°C, the ambient when not given). An error names the setting and what it takes.
    pub fn parse<'a>(
        settings: impl IntoIterator<Item = (&'a str, &'a str)>,
    ) -> Result<ThermalParams, String> {
        let mut p = ThermalParams::default();
        let mut initial = None;
        for (key, text) in settings {
            if !THERMAL_SETTINGS.contains(&key) {
                return Err(format!(
                    "the thermal plant has no setting `{key}`; its settings are {}",
                    THERMAL_SETTINGS.join(", ")
                ));
            }
            let value = text
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| format!("`{key} = {text}` is not a number"))?;
            match key {
                "gain" => p.gain = value,
                "time_constant" if value > 0.0 => p.time_constant = value,
                "time_constant" => return Err(format!("`{key} = {text}` must be above 0")),
                "dead_time" if (0.0..=3600.0).contains(&value) => p.dead_time = value,
                "dead_time" => return Err(format!("`{key} = {text}` must be from 0 to 3600 s")),
                "ambient" => p.ambient = value,
                _ => initial = Some(value),
            }
        }
        p.initial = initial.unwrap_or(p.ambient);
        Ok(p)
    }
}

/// Reads `heater` (power, thousandths of a percent); drives `temp` (thousandths of a °C).
#[derive(Clone, Debug, PartialEq)]
pub struct Thermal {
    params: ThermalParams,
    temp: f64,
    last: Option<Duration>,
    /// (from when, power in %) of the heater as applied, oldest first; before the first
    /// entry the power was 0.
    applied: Vec<(Duration, f64)>,
}

impl Thermal {
    pub fn new(params: ThermalParams) -> Thermal {
        Thermal {
            temp: params.initial,
            params,
            last: None,
            applied: Vec::new(),
        }
    }

    pub fn params(&self) -> &ThermalParams {
        &self.params
    }

    /// The temperature in °C.
    pub fn temperature(&self) -> f64 {
        self.temp
    }

    /// The power (%) acting on the vessel at `t`: what was applied at `t − θ`.
    fn acting(&self, t: Duration) -> f64 {
        let theta = Duration::from_secs_f64(self.params.dead_time);
        let Some(at) = t.checked_sub(theta) else {
            return 0.0;
        };
        let n = self.applied.partition_point(|&(from, _)| from <= at);
        n.checked_sub(1).map_or(0.0, |i| self.applied[i].1)
    }

    /// Relaxes the temperature over `[from, to]`, cut where the delayed power changes.
    fn integrate(&mut self, from: Duration, to: Duration) {
        let theta = Duration::from_secs_f64(self.params.dead_time);
        let mut cuts: Vec<Duration> = self
            .applied
            .iter()
            .map(|&(t, _)| t + theta)
            .filter(|&t| t > from && t < to)
            .collect();
        cuts.push(to);
        let mut t = from;
        for cut in cuts {
            let u = self.acting(t);
            let steady = self.params.ambient + self.params.gain * u;
            let dt = (cut - t).as_secs_f64();
            self.temp = steady + (self.temp - steady) * (-dt / self.params.time_constant).exp();
            t = cut;
        }
    }
}

impl Plant for Thermal {
    fn name(&self) -> &str {
        "thermal"
    }
    fn inputs(&self) -> Vec<String> {
        vec!["heater".into()]
    }
    fn outputs(&self) -> Vec<String> {
        vec!["temp".into()]
    }

    fn step(
        &mut self,
        now: Duration,
        inputs: &[i64],
        outputs: &mut [i64],
    ) -> Result<(), PlantError> {
        // As the tank does: the power the controller left at its previous scan has been on
        // for the whole interval since.
        let u = (inputs[0] as f64 / SCALE).clamp(0.0, 100.0);
        if let Some(last) = self.last {
            if now > last {
                if self.applied.last().is_none_or(|&(_, p)| p != u) {
                    self.applied.push((last, u));
                }
                self.integrate(last, now);
            }
            // What no longer acts can go: keep the entry in force at now − θ.
            let theta = Duration::from_secs_f64(self.params.dead_time);
            if let Some(at) = now.checked_sub(theta) {
                let n = self.applied.partition_point(|&(from, _)| from <= at);
                if n > 1 {
                    self.applied.drain(..n - 1);
                }
            }
        }
        self.last = Some(now);
        outputs[0] = (self.temp * SCALE).round() as i64;
        Ok(())
    }

    fn summary(&self) -> String {
        format!(
            "thermal {:.2} °C (K {} °C/%, τ {} s, θ {} s, ambient {} °C)",
            self.temp,
            self.params.gain,
            self.params.time_constant,
            self.params.dead_time,
            self.params.ambient
        )
    }

    fn scale(&self, signal: &str) -> Option<f64> {
        matches!(signal, "heater" | "temp").then_some(SCALE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(p: &mut Thermal, ms: u64, power: f64) -> f64 {
        let mut out = [0];
        p.step(
            Duration::from_millis(ms),
            &[(power * SCALE) as i64],
            &mut out,
        )
        .unwrap();
        out[0] as f64 / SCALE
    }

    /// A heater step: nothing for θ, then 1 − e^(−t/τ) toward K·u above ambient, whatever
    /// the step size.
    fn check(step_ms: u64) {
        let params = ThermalParams {
            gain: 2.0,
            time_constant: 10.0,
            dead_time: 1.0,
            ambient: 20.0,
            initial: 20.0,
        };
        let mut p = Thermal::new(params);
        let mut t = 0;
        while t <= 30_000 {
            let got = step(&mut p, t, 50.0);
            let s = t as f64 / 1000.0;
            let expect = if s <= 1.0 {
                20.0
            } else {
                20.0 + 100.0 * (1.0 - (-(s - 1.0) / 10.0).exp())
            };
            assert!((got - expect).abs() <= 0.0015, "at {s}s: {got} vs {expect}");
            t += step_ms;
        }
    }

    #[test]
    fn fopdt_step_response_at_any_step_size() {
        check(100);
        check(7);
        check(1000);
        check(2500);
    }

    #[test]
    fn power_is_clamped_and_cooling_returns_to_ambient() {
        let mut p = Thermal::new(ThermalParams {
            dead_time: 0.0,
            time_constant: 1.0,
            ..ThermalParams::default()
        });
        step(&mut p, 0, 500.0);
        let hot = step(&mut p, 20_000, 500.0);
        assert!((hot - 220.0).abs() < 1e-3, "{hot}");
        step(&mut p, 20_001, -5.0);
        let cold = step(&mut p, 40_000, -5.0);
        assert!((cold - 20.0).abs() < 1e-3, "{cold}");
        assert!(p.summary().starts_with("thermal 20.00 °C"));
    }
}
