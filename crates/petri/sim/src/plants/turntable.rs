//! Seed 004's turntable (section 5, equations 1–5): a table with a conveyor belt in a flexible
//! manufacturing cell, turned between a right and a left position, taking workpieces from the
//! transport system in the south and from machine 1 in the east.
//!
//! # Geometry
//!
//! α is the table's angle: 0° is the right position, 90° the left; the motor turns it left
//! (α grows) with `ML` and right with `MR` (eq. 1: α̇ = K_α·(ML − MR)). x is a workpiece's
//! position along the belt, in the table's own frame (eq. 2: ẋ = K_x·(BF − BB)). In the right
//! position the belt runs south (−x end: the transport system's position, Fig. 5's `Msouth`)
//! to north (+x end: the rejection chute); turned left by 90° its −x end faces machine 1 in the
//! east (`Meast`) and its +x end the west, where nothing takes a workpiece. A workpiece
//! enters from a station at the −x end while the belt runs forward, and x is reset to −L/2
//! (the seed: "reset to ∓L/2 if a workpiece enters in the direction of the x-axis or against
//! it"; no station here feeds against it).
//!
//! # Sensors (eq. 3–5)
//!
//! `SR` iff |α| ≤ B_α/2, `SL` iff |α − 90°| ≤ B_α/2, `SWP` iff a workpiece is on the belt with
//! |x| ≤ B_x/2.
//!
//! # Errors (latched outputs, 1 once they happen)
//!
//! - `E_sector`: α left the allowed sector [−B_α/2, 90° + B_α/2] (turned past a sensor);
//! - `E_belt_turning`: the belt ran while the motor turned the table;
//! - `E_MR_ML`, `E_BF_BB`: contrary motor or belt signals at once;
//! - `E_fall`: a workpiece left the belt where nothing takes it: at the west end, or with the
//!   table between its positions.
//!
//! # Integration
//!
//! One step per scan, before the controller's: the inputs (the controller's outputs of its
//! previous scan) have held since the previous step, so the right-hand sides are constant
//! over the step and it is integrated exactly, in integer units (10⁻¹² ° and 10⁻¹⁵ m: a rate
//! in milli-units per second times nanoseconds), whatever the period. In the order of the
//! seed's Algorithm 1: a workpiece waiting at the station the table faces enters first (x
//! re-initialised), then α and x are integrated, then what the new state implies happens — a
//! workpiece past an end of the belt goes to the station there (or falls), sensors and errors
//! are computed. A station holds one workpiece: an arrival at an occupied station is refused
//! (counted in the summary), and a workpiece pushed towards an occupied station stays at the
//! end of the belt. Delivered workpieces are taken away at once.

use std::time::Duration;

use crate::plant::{Plant, PlantError};

/// The constants, in milli-units: m°/s, m°, µm/s, µm.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TurntableSettings {
    /// K_α, turning speed.
    pub k_alpha: i64,
    /// B_α, width of the SR and SL sensor bands.
    pub b_alpha: i64,
    /// K_x, belt speed.
    pub k_x: i64,
    /// L, belt length.
    pub length: i64,
    /// B_x, width of the SWP band.
    pub b_x: i64,
}

/// The settings: (name, unit, default, meaning), in the order the README lists them.
pub const TURNTABLE_SETTINGS: &[(&str, &str, &str, &str)] = &[
    (
        "K_alpha",
        "°/s",
        "90",
        "turning speed K_α (eq. 1): 90° in 1 s",
    ),
    (
        "B_alpha",
        "°",
        "10",
        "width B_α of the SR and SL bands (eq. 3, 4)",
    ),
    ("K_x", "mm/s", "250", "belt speed K_x (eq. 2)"),
    (
        "L",
        "mm",
        "300",
        "belt length L: a workpiece leaves past ±L/2",
    ),
    ("B_x", "mm", "30", "width B_x of the SWP band (eq. 5)"),
];

impl Default for TurntableSettings {
    fn default() -> Self {
        TurntableSettings {
            k_alpha: 90_000,
            b_alpha: 10_000,
            k_x: 250_000,
            length: 300_000,
            b_x: 30_000,
        }
    }
}

impl TurntableSettings {
    /// The defaults with `settings` (name, value) applied; values are decimal numbers in the
    /// units of [`TURNTABLE_SETTINGS`], at most three decimals.
    pub fn parse<'a>(
        settings: impl IntoIterator<Item = (&'a str, &'a str)>,
    ) -> Result<Self, String> {
        let mut s = TurntableSettings::default();
        for (name, value) in settings {
            let slot = match name {
                "K_alpha" => &mut s.k_alpha,
                "B_alpha" => &mut s.b_alpha,
                "K_x" => &mut s.k_x,
                "L" => &mut s.length,
                "B_x" => &mut s.b_x,
                _ => {
                    let known: Vec<&str> = TURNTABLE_SETTINGS.iter().map(|t| t.0).collect();
                    return Err(format!(
                        "the turntable has no setting `{name}`; its settings are {}",
                        known.join(", ")
                    ));
                }
            };
            *slot = milli(value).filter(|&v| v > 0).ok_or_else(|| {
                let unit = TURNTABLE_SETTINGS
                    .iter()
                    .find(|t| t.0 == name)
                    .map_or("", |t| t.1);
                format!(
                    "turntable setting `{name} = {value}`: give a number greater than 0 in {unit}, \
                     with at most three decimals (e.g. `{name} = 12.5`)"
                )
            })?;
        }
        if s.b_alpha >= 90_000 {
            return Err(format!(
                "turntable setting B_alpha = {}: the SR and SL bands would overlap; make it less than 90",
                show_milli(s.b_alpha)
            ));
        }
        if s.b_x >= s.length {
            return Err(format!(
                "turntable settings B_x = {} and L = {}: the SWP band must be shorter than the belt",
                show_milli(s.b_x),
                show_milli(s.length)
            ));
        }
        Ok(s)
    }
}

/// `12.5` → 12 500; at most three decimals, no sign.
fn milli(text: &str) -> Option<i64> {
    let text = text.trim();
    let (int, frac) = text.split_once('.').unwrap_or((text, ""));
    if int.is_empty() && frac.is_empty()
        || frac.len() > 3
        || !int.bytes().chain(frac.bytes()).all(|b| b.is_ascii_digit())
    {
        return None;
    }
    let int: i64 = if int.is_empty() { 0 } else { int.parse().ok()? };
    let frac: i64 = format!("{frac:0<3}").parse().ok()?;
    int.checked_mul(1000)?.checked_add(frac)
}

/// 12 500 → `12.5`, −500 → `-0.5`.
fn show_milli(v: i64) -> String {
    let sign = if v < 0 { "-" } else { "" };
    let a = v.unsigned_abs();
    let s = format!("{}.{:03}", a / 1000, a % 1000);
    format!("{sign}{}", s.trim_end_matches('0').trim_end_matches('.'))
}

/// Internal units per milli-unit: state is in 10⁻¹² ° and 10⁻¹⁵ m, settings in 10⁻³.
const PER_MILLI: i128 = 1_000_000_000;

/// Which end of the belt.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum End {
    Minus,
    Plus,
}

/// The turntable plant. Inputs `MR`, `ML`, `BF`, `BB` (the controller's outputs) and
/// `arrive_south`, `arrive_east` (a rising edge puts a workpiece at that station, e.g. from a
/// timeline); outputs in [`Turntable::OUTPUTS`] order.
#[derive(Clone, Debug)]
pub struct Turntable {
    settings: TurntableSettings,
    /// α in 10⁻¹² °.
    alpha: i128,
    /// The workpiece on the belt: x in 10⁻¹⁵ m.
    x: Option<i128>,
    waiting_south: bool,
    waiting_east: bool,
    arrivals: [i64; 2],
    last: Option<Duration>,
    delivered_south: u64,
    delivered_east: u64,
    rejected: u64,
    refused: u64,
    errors: [bool; 5],
}

const E_SECTOR: usize = 0;
const E_BELT_TURNING: usize = 1;
const E_MR_ML: usize = 2;
const E_BF_BB: usize = 3;
const E_FALL: usize = 4;

impl Default for Turntable {
    fn default() -> Self {
        Turntable::new(TurntableSettings::default())
    }
}

impl Turntable {
    pub const INPUTS: &'static [&'static str] =
        &["MR", "ML", "BF", "BB", "arrive_south", "arrive_east"];
    /// The sensors, then what a display or a test looks at: `M` (a workpiece on the table),
    /// `Msouth`/`Meast` (one waiting at the station), `alpha` in 0.01°, `x` in 0.1 mm (0 with
    /// no workpiece), the delivery counters and the error outputs.
    pub const OUTPUTS: &'static [&'static str] = &[
        "SR",
        "SL",
        "SWP",
        "M",
        "Msouth",
        "Meast",
        "alpha",
        "x",
        "delivered_south",
        "delivered_east",
        "rejected",
        "E_sector",
        "E_belt_turning",
        "E_MR_ML",
        "E_BF_BB",
        "E_fall",
    ];

    /// At rest in the right position (α = 0), no workpiece anywhere.
    pub fn new(settings: TurntableSettings) -> Self {
        Turntable {
            settings,
            alpha: 0,
            x: None,
            waiting_south: false,
            waiting_east: false,
            arrivals: [0; 2],
            last: None,
            delivered_south: 0,
            delivered_east: 0,
            rejected: 0,
            refused: 0,
            errors: [false; 5],
        }
    }

    pub fn settings(&self) -> &TurntableSettings {
        &self.settings
    }
    /// α in 10⁻¹² °.
    pub fn alpha_picodegrees(&self) -> i128 {
        self.alpha
    }
    /// The workpiece's x in 10⁻¹⁵ m, if one is on the belt.
    pub fn x_femtometres(&self) -> Option<i128> {
        self.x
    }
    /// Workpieces waiting at the south and east stations.
    pub fn waiting(&self) -> (bool, bool) {
        (self.waiting_south, self.waiting_east)
    }
    /// (to the south, to the east, rejected to the north).
    pub fn delivered(&self) -> (u64, u64, u64) {
        (self.delivered_south, self.delivered_east, self.rejected)
    }

    fn half_band_alpha(&self) -> i128 {
        i128::from(self.settings.b_alpha) * PER_MILLI / 2
    }
    fn in_sr(&self) -> bool {
        self.alpha.abs() <= self.half_band_alpha()
    }
    fn in_sl(&self) -> bool {
        (self.alpha - 90 * 1000 * PER_MILLI).abs() <= self.half_band_alpha()
    }
    fn half_length(&self) -> i128 {
        i128::from(self.settings.length) * PER_MILLI / 2
    }

    /// Where a workpiece pushed past `end` goes.
    fn leave(&mut self, end: End) {
        let half = self.half_length();
        match (end, self.in_sr(), self.in_sl()) {
            (End::Minus, true, _) if self.waiting_south => self.x = Some(-half),
            (End::Minus, true, _) => {
                self.delivered_south += 1;
                self.x = None;
            }
            (End::Minus, _, true) if self.waiting_east => self.x = Some(-half),
            (End::Minus, _, true) => {
                self.delivered_east += 1;
                self.x = None;
            }
            (End::Plus, true, _) => {
                self.rejected += 1;
                self.x = None;
            }
            _ => {
                self.errors[E_FALL] = true;
                self.x = None;
            }
        }
    }
}

impl Plant for Turntable {
    fn name(&self) -> &str {
        "turntable"
    }
    fn inputs(&self) -> Vec<String> {
        Self::INPUTS.iter().map(|s| s.to_string()).collect()
    }
    fn outputs(&self) -> Vec<String> {
        Self::OUTPUTS.iter().map(|s| s.to_string()).collect()
    }

    fn step(
        &mut self,
        now: Duration,
        inputs: &[i64],
        outputs: &mut [i64],
    ) -> Result<(), PlantError> {
        let on = |i: usize| inputs[i] != 0;
        let (mr, ml, bf, bb) = (on(0), on(1), on(2), on(3));
        let elapsed = self
            .last
            .map_or(Duration::ZERO, |last| now.saturating_sub(last));
        self.last = Some(now);
        let dt = i128::try_from(elapsed.as_nanos()).unwrap_or(i128::MAX);

        if mr && ml {
            self.errors[E_MR_ML] = true;
        }
        if bf && bb {
            self.errors[E_BF_BB] = true;
        }
        if (mr || ml) && (bf || bb) {
            self.errors[E_BELT_TURNING] = true;
        }

        // Algorithm 1: re-initialise x for a workpiece that enters, then integrate.
        if self.x.is_none() && bf && !bb {
            if self.in_sr() && self.waiting_south {
                self.waiting_south = false;
                self.x = Some(-self.half_length());
            } else if self.in_sl() && self.waiting_east {
                self.waiting_east = false;
                self.x = Some(-self.half_length());
            }
        }
        let turn = i128::from(ml) - i128::from(mr);
        self.alpha = self
            .alpha
            .saturating_add((turn * i128::from(self.settings.k_alpha)).saturating_mul(dt));
        if let Some(x) = &mut self.x {
            let belt = i128::from(bf) - i128::from(bb);
            *x = x.saturating_add((belt * i128::from(self.settings.k_x)).saturating_mul(dt));
        }
        let half = self.half_length();
        match self.x {
            Some(x) if x > half => self.leave(End::Plus),
            Some(x) if x < -half => self.leave(End::Minus),
            _ => {}
        }
        let edge = 90 * 1000 * PER_MILLI + self.half_band_alpha();
        if self.alpha < -self.half_band_alpha() || self.alpha > edge {
            self.errors[E_SECTOR] = true;
        }

        // Arrivals at the end of the step: they can enter from the next one on.
        for (k, slot) in [4usize, 5].into_iter().enumerate() {
            let rising = inputs[slot] != 0 && self.arrivals[k] == 0;
            self.arrivals[k] = inputs[slot];
            if rising {
                let waiting = if k == 0 {
                    &mut self.waiting_south
                } else {
                    &mut self.waiting_east
                };
                if *waiting {
                    self.refused += 1;
                }
                *waiting = true;
            }
        }

        let half_bx = i128::from(self.settings.b_x) * PER_MILLI / 2;
        let values = [
            i64::from(self.in_sr()),
            i64::from(self.in_sl()),
            i64::from(self.x.is_some_and(|x| x.abs() <= half_bx)),
            i64::from(self.x.is_some()),
            i64::from(self.waiting_south),
            i64::from(self.waiting_east),
            // 0.01° and 0.1 mm, rounded down.
            i64::try_from(self.alpha.div_euclid(10 * PER_MILLI)).unwrap_or(i64::MAX),
            self.x.map_or(0, |x| {
                i64::try_from(x.div_euclid(100 * PER_MILLI)).unwrap_or(i64::MAX)
            }),
            self.delivered_south as i64,
            self.delivered_east as i64,
            self.rejected as i64,
            i64::from(self.errors[E_SECTOR]),
            i64::from(self.errors[E_BELT_TURNING]),
            i64::from(self.errors[E_MR_ML]),
            i64::from(self.errors[E_BF_BB]),
            i64::from(self.errors[E_FALL]),
        ];
        outputs.copy_from_slice(&values);
        Ok(())
    }

    fn summary(&self) -> String {
        let mut s = format!(
            "turntable at {}°, {} delivered south, {} east, {} rejected",
            show_milli(i64::try_from(self.alpha / PER_MILLI).unwrap_or(i64::MAX)),
            self.delivered_south,
            self.delivered_east,
            self.rejected
        );
        if self.x.is_some() {
            s.push_str(", a workpiece on the belt");
        }
        if self.refused > 0 {
            s.push_str(&format!(
                ", {} arrival(s) refused (station occupied)",
                self.refused
            ));
        }
        let names = ["E_sector", "E_belt_turning", "E_MR_ML", "E_BF_BB", "E_fall"];
        let errors: Vec<&str> = names
            .iter()
            .zip(self.errors)
            .filter(|(_, e)| *e)
            .map(|(n, _)| *n)
            .collect();
        if !errors.is_empty() {
            s.push_str(&format!("; ERRORS: {}", errors.join(", ")));
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Runs segments of (milliseconds, inputs "MR ML BF BB as ae" as 0/1 digits) at a 10 ms
    /// period from t = 0 and lists every change of the outputs named in `watch` as
    /// `t:NAME=value` (times in ms); the first step's values are listed as changes from 0.
    fn check(settings: TurntableSettings, segments: &[(u64, &str)], watch: &[&str], expect: &str) {
        let mut plant = Turntable::new(settings);
        let mut out = vec![0; Turntable::OUTPUTS.len()];
        let mut before = out.clone();
        let mut got = Vec::new();
        let mut t = 0;
        for &(ms, bits) in segments {
            let inputs: Vec<i64> = bits.bytes().map(|b| i64::from(b - b'0')).collect();
            for _ in 0..ms / 10 {
                plant
                    .step(Duration::from_millis(t), &inputs, &mut out)
                    .unwrap();
                for (i, name) in Turntable::OUTPUTS.iter().enumerate() {
                    if watch.contains(name) && out[i] != before[i] {
                        got.push(format!("{t}:{name}={}", out[i]));
                    }
                }
                before.clone_from(&out);
                t += 10;
            }
        }
        assert_eq!(got.join(" "), expect);
    }

    fn default() -> TurntableSettings {
        TurntableSettings::default()
    }

    #[test]
    fn turns_between_the_sensors_and_past_them() {
        // ML from t = 0: α = 90°/s × (t − 0) seen at each step's end. SR holds up to 5°
        // (55.6 ms), SL from 85° (944.4 ms) to 95° (1055.6 ms), then the sector is left.
        check(
            default(),
            &[(1200, "010000")],
            &["SR", "SL", "E_sector"],
            "0:SR=1 60:SR=0 950:SL=1 1060:SL=0 1060:E_sector=1",
        );
        // Back with MR from 89.1° (the step at 0 integrates nothing): SL to 85°, SR from 5°,
        // out past −5°.
        check(
            default(),
            &[(1000, "010000"), (1200, "100000")],
            &["SR", "SL", "E_sector"],
            "0:SR=1 60:SR=0 950:SL=1 1040:SL=0 1930:SR=1 2040:SR=0 2040:E_sector=1",
        );
    }

    #[test]
    fn carries_a_workpiece_from_the_south_and_pushes_it_east() {
        // A workpiece arrives in the south at 0; the belt runs forward over the step ending at
        // 10 ms: the workpiece enters at −150 mm and moves 2.5 mm per step: at 10 ms it is at
        // −147.5 mm, at −15 mm (the SWP band) at 540 ms.
        check(
            default(),
            &[(10, "000010"), (550, "001010")],
            &["Msouth", "M", "SWP"],
            "0:Msouth=1 10:M=1 10:Msouth=0 540:SWP=1",
        );
        // Centred, turned left (1 s), then backwards: past −150 mm it is delivered east.
        check(
            default(),
            &[
                (10, "000010"),
                (550, "001010"),
                (1000, "010000"),
                (600, "000100"),
            ],
            &["M", "SWP", "SL", "delivered_east", "E_belt_turning"],
            "10:M=1 540:SWP=1 1500:SL=1 1570:SWP=0 2110:M=0 2110:delivered_east=1",
        );
    }

    #[test]
    fn rejects_north_and_drops_a_workpiece_pushed_west() {
        // Forward through the whole belt in the right position: rejected (north).
        check(
            default(),
            &[(10, "000010"), (1300, "001000")],
            &["M", "rejected", "E_fall"],
            "10:M=1 1210:M=0 1210:rejected=1",
        );
        // The same in the left position, from the east: it falls off the west end.
        check(
            default(),
            &[(1000, "010001"), (1300, "001000")],
            &["M", "SL", "E_fall", "Meast"],
            "0:Meast=1 950:SL=1 1000:M=1 1000:Meast=0 2200:M=0 2200:E_fall=1",
        );
    }

    #[test]
    fn an_occupied_station_keeps_the_workpiece_on_the_belt() {
        // Loaded from the south, a second workpiece arrives there, the belt runs backwards:
        // the workpiece stays at −150 mm; it is delivered once the station is free (never here).
        let mut plant = Turntable::default();
        let mut out = vec![0; Turntable::OUTPUTS.len()];
        let mut t = 0;
        let mut run = |plant: &mut Turntable, inputs: [i64; 6], ms: u64| {
            for _ in 0..ms / 10 {
                plant
                    .step(Duration::from_millis(t), &inputs, &mut out)
                    .unwrap();
                t += 10;
            }
        };
        run(&mut plant, [0, 0, 0, 0, 1, 0], 10);
        run(&mut plant, [0, 0, 1, 0, 0, 0], 200);
        run(&mut plant, [0, 0, 0, 0, 1, 0], 10);
        run(&mut plant, [0, 0, 0, 1, 1, 0], 2000);
        assert_eq!(plant.x_femtometres(), Some(-150 * 1_000_000_000_000));
        assert_eq!(plant.waiting(), (true, false));
        assert_eq!(plant.delivered(), (0, 0, 0));
        assert_eq!(
            plant.summary(),
            "turntable at 0°, 0 delivered south, 0 east, 0 rejected, a workpiece on the belt"
        );
    }

    #[test]
    fn contrary_and_simultaneous_signals_are_errors() {
        check(
            default(),
            &[(20, "110000")],
            &["E_MR_ML", "E_sector"],
            "0:E_MR_ML=1",
        );
        check(default(), &[(20, "001100")], &["E_BF_BB"], "0:E_BF_BB=1");
        check(
            default(),
            &[(20, "100100")],
            &["E_belt_turning", "SR"],
            "0:SR=1 0:E_belt_turning=1",
        );
        let mut plant = Turntable::default();
        let mut out = vec![0; Turntable::OUTPUTS.len()];
        plant
            .step(Duration::ZERO, &[1, 0, 1, 0, 0, 0], &mut out)
            .unwrap();
        plant
            .step(Duration::from_millis(100), &[1, 0, 1, 0, 0, 0], &mut out)
            .unwrap();
        assert_eq!(
            plant.summary(),
            "turntable at -9°, 0 delivered south, 0 east, 0 rejected; ERRORS: E_sector, E_belt_turning"
        );
    }

    /// α and x are exact sums of rate × time, whatever the period: 0.35 s of ML then 0.2 s of
    /// MR leave α = 90 × 0.15 = 13.5° at every period that divides the switching times.
    #[test]
    fn the_state_does_not_depend_on_the_period() {
        for period_us in [1_000u64, 5_000, 25_000, 50_000] {
            let mut plant = Turntable::default();
            let mut out = vec![0; Turntable::OUTPUTS.len()];
            let mut t = 0;
            while t <= 550_000 {
                // The step at t integrates the inputs held since the previous step.
                let inputs = if t <= 350_000 {
                    [0, 1, 0, 0, 0, 0]
                } else {
                    [1, 0, 0, 0, 0, 0]
                };
                plant
                    .step(Duration::from_micros(t), &inputs, &mut out)
                    .unwrap();
                t += period_us;
            }
            assert_eq!(
                plant.alpha_picodegrees(),
                13_500_000_000_000,
                "period {period_us} us"
            );
            assert_eq!(out[6], 1350, "alpha in 0.01°");
        }
    }

    #[test]
    fn settings_have_defaults_units_and_checks() {
        assert_eq!(
            TurntableSettings::parse([]).unwrap(),
            TurntableSettings::default()
        );
        let s =
            TurntableSettings::parse([("K_alpha", "22.5"), ("L", "400"), ("B_x", ".5")]).unwrap();
        assert_eq!((s.k_alpha, s.length, s.b_x), (22_500, 400_000, 500));
        let err =
            |pairs: &[(&str, &str)]| TurntableSettings::parse(pairs.iter().copied()).unwrap_err();
        assert_eq!(
            err(&[("K_x", "-3")]),
            "turntable setting `K_x = -3`: give a number greater than 0 in mm/s, with at most three decimals (e.g. `K_x = 12.5`)"
        );
        assert!(err(&[("K_x", "1.2345")]).contains("at most three decimals"));
        assert!(err(&[("B_alpha", "0")]).contains("greater than 0"));
        assert_eq!(
            err(&[("speed", "3")]),
            "the turntable has no setting `speed`; its settings are K_alpha, B_alpha, K_x, L, B_x"
        );
        assert_eq!(
            err(&[("B_alpha", "90")]),
            "turntable setting B_alpha = 90: the SR and SL bands would overlap; make it less than 90"
        );
        assert_eq!(
            err(&[("B_x", "300")]),
            "turntable settings B_x = 300 and L = 300: the SWP band must be shorter than the belt"
        );
    }
}
