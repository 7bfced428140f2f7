//! The mixer tank of seed 002 (Fig. 2): two inlet valves, a drain valve and three level
//! sensors, integrated exactly in integer units so the result never depends on float rounding.

use std::time::Duration;

use crate::plant::{Plant, PlantError};

/// One unit of level is 10⁻⁹ %: a rate in %/s times an elapsed time in nanoseconds is then a
/// whole number of units, so integration is exact whatever the scan period.
const UNITS_PER_PERCENT: i128 = 1_000_000_000;
const FULL: i128 = 100 * UNITS_PER_PERCENT;
const INLET_RATE: i128 = 20;
const DRAIN_RATE: i128 = 25;
const N1_AT_MOST: i128 = 5 * UNITS_PER_PERCENT;
const N2_AT_LEAST: i128 = 50 * UNITS_PER_PERCENT;
const N3_AT_LEAST: i128 = 90 * UNITS_PER_PERCENT;

/// Reads `V1`, `V2` (inlets, 20 %/s each) and `V3` (drain, 25 %/s); drives `N1` (level ≤ 5 %,
/// the bottom sensor: empty), `N2` (≥ 50 %) and `N3` (≥ 90 %). The level starts at 0 and is
/// clamped to 0..=100 %.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Tank {
    level: i128,
    last: Option<Duration>,
    /// Reached N3 since it was last empty: the next time it is empty completes a cycle.
    filled: bool,
    cycles: u64,
}

impl Tank {
    pub fn new() -> Self {
        Tank::default()
    }
    /// The level in units of 10⁻⁹ %.
    pub fn level_nano_percent(&self) -> i128 {
        self.level
    }
    /// The level as a percentage with up to two decimals: `37.5`, `100`.
    pub fn level_text(&self) -> String {
        let hundredths = self.level / (UNITS_PER_PERCENT / 100);
        let (int, frac) = (hundredths / 100, hundredths % 100);
        match frac {
            0 => format!("{int}"),
            f if f % 10 == 0 => format!("{int}.{}", f / 10),
            f => format!("{int}.{f:02}"),
        }
    }
    /// Fill/drain cycles completed: filled up to N3, then drained down to N1.
    pub fn cycles(&self) -> u64 {
        self.cycles
    }
}

impl Plant for Tank {
    fn name(&self) -> &str {
        "tank"
    }
    fn inputs(&self) -> Vec<String> {
        vec!["V1".into(), "V2".into(), "V3".into()]
    }
    fn outputs(&self) -> Vec<String> {
        vec!["N1".into(), "N2".into(), "N3".into()]
    }

    fn step(
        &mut self,
        now: Duration,
        inputs: &[i64],
        outputs: &mut [i64],
    ) -> Result<(), PlantError> {
        // The valves as the controller left them at the previous scan have been open or shut
        // for the whole interval since; with a constant rate, clamping once at the end is exact.
        let elapsed = self
            .last
            .map_or(Duration::ZERO, |last| now.saturating_sub(last));
        self.last = Some(now);
        let open = |i: usize| i128::from(inputs[i] != 0);
        let rate = INLET_RATE * (open(0) + open(1)) - DRAIN_RATE * open(2);
        let delta = rate.saturating_mul(i128::try_from(elapsed.as_nanos()).unwrap_or(i128::MAX));
        self.level = self.level.saturating_add(delta).clamp(0, FULL);
        if self.level >= N3_AT_LEAST {
            self.filled = true;
        }
        if self.filled && self.level <= N1_AT_MOST {
            self.filled = false;
            self.cycles += 1;
        }
        outputs[0] = i64::from(self.level <= N1_AT_MOST);
        outputs[1] = i64::from(self.level >= N2_AT_LEAST);
        outputs[2] = i64::from(self.level >= N3_AT_LEAST);
        Ok(())
    }

    fn summary(&self) -> String {
        let c = self.cycles;
        let s = if c == 1 { "" } else { "s" };
        format!(
            "tank level {} %, {c} fill/drain cycle{s} completed",
            self.level_text()
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steps every `period` ms with the valves given per step as "V1V2V3" bits (e.g. "100"),
    /// and renders each step as `t:level:N1N2N3`.
    fn check(period_ms: u64, valves: &[&str], expect: &str) {
        let mut tank = Tank::new();
        let mut out = [0; 3];
        let mut got = Vec::new();
        for (k, v) in valves.iter().enumerate() {
            let inputs: Vec<i64> = v.bytes().map(|b| i64::from(b - b'0')).collect();
            let now = Duration::from_millis(period_ms * k as u64);
            tank.step(now, &inputs, &mut out).unwrap();
            got.push(format!(
                "{}:{}:{}{}{}",
                petriplc_net::time::format_seconds(now),
                tank.level_text(),
                out[0],
                out[1],
                out[2]
            ));
        }
        assert_eq!(got.join(" "), expect);
    }

    #[test]
    fn fills_drains_and_trips_its_sensors() {
        // The first step has no elapsed time; then each second adds 20 % per open inlet.
        check(1000, &["100", "100", "100"], "0:0:100 1:20:000 2:40:000");
        check(
            1000,
            &["110", "110", "110", "110"],
            "0:0:100 1:40:000 2:80:010 3:100:011",
        );
        // Draining 25 %/s from 100 %.
        let fill = vec!["110"; 4];
        let drain = vec!["001"; 5];
        let all: Vec<&str> = fill.into_iter().chain(drain).collect();
        check(
            1000,
            &all,
            "0:0:100 1:40:000 2:80:010 3:100:011 4:75:010 5:50:010 6:25:000 7:0:100 8:0:100",
        );
        // Inlet and drain together: 20 - 25 = -5 %/s, clamped at empty.
        check(500, &["000", "101", "101"], "0:0:100 0.5:0:100 1:0:100");
    }

    #[test]
    fn thresholds_are_inclusive() {
        // 5 % exactly is still at the bottom sensor; 50 % and 90 % exactly trip N2 and N3.
        check(250, &["100", "100"], "0:0:100 0.25:5:100");
        check(250, &["100", "100", "100"], "0:0:100 0.25:5:100 0.5:10:000");
        check(2500, &["100", "100"], "0:0:100 2.5:50:010");
        check(4500, &["100", "100"], "0:0:100 4.5:90:011");
        check(10, &["100", "100"], "0:0:100 0.01:0.2:100");
    }

    #[test]
    fn the_level_does_not_depend_on_the_period() {
        // 20 %/s for 3 s then 25 %/s for 1.7 s, at three periods that do not divide evenly.
        for period_us in [1_000u64, 7_000, 30_000] {
            let mut tank = Tank::new();
            let mut out = [0; 3];
            let mut t = 0;
            while t <= 4_700_000 {
                let v = if t <= 3_000_000 { [1, 0, 0] } else { [0, 0, 1] };
                tank.step(Duration::from_micros(t), &v, &mut out).unwrap();
                t += period_us;
            }
            // The drain takes over at the first step after 3 s, a time that depends on the
            // period; the integral over the intervals before and after it must be exact.
            let expect_units = |switch_us: i128, end_us: i128| {
                (20 * switch_us - 25 * (end_us - switch_us)) * 1_000
            };
            let last = (4_700_000 / period_us) * period_us;
            let switch = (3_000_000 / period_us) * period_us;
            assert_eq!(
                tank.level_nano_percent(),
                expect_units(switch as i128, last as i128),
                "period {period_us}us"
            );
        }
    }

    #[test]
    fn counts_completed_cycles() {
        let mut tank = Tank::new();
        let mut out = [0; 3];
        let mut t = Duration::ZERO;
        let mut run = |tank: &mut Tank, v: [i64; 3], secs: u64| {
            for _ in 0..secs {
                t += Duration::from_secs(1);
                tank.step(t, &v, &mut out).unwrap();
            }
        };
        run(&mut tank, [0, 0, 0], 1);
        assert_eq!(
            tank.summary(),
            "tank level 0 %, 0 fill/drain cycles completed"
        );
        run(&mut tank, [1, 1, 0], 2);
        // Halfway up and back down is not a cycle.
        run(&mut tank, [0, 0, 1], 4);
        assert_eq!(tank.cycles(), 0);
        run(&mut tank, [1, 1, 0], 3);
        run(&mut tank, [0, 0, 1], 4);
        assert_eq!(
            tank.summary(),
            "tank level 0 %, 1 fill/drain cycle completed"
        );
        run(&mut tank, [1, 1, 0], 3);
        run(&mut tank, [0, 0, 1], 4);
        run(&mut tank, [1, 0, 0], 1);
        assert_eq!(
            tank.summary(),
            "tank level 20 %, 2 fill/drain cycles completed"
        );
    }
}
