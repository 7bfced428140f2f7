//! The plant side of a closed loop: the process or device the controller net drives, stepped
//! once per scan just before the controller reads its inputs.

use std::time::Duration;

use petriplc_net::ScanError;

use crate::plants::{
    Keyboard, Tank, Tape, Thermal, ThermalParams, Turntable, TurntableSettings, THERMAL_SETTINGS,
    TURNTABLE_SETTINGS,
};

/// A simulated process or device. Signals are wired to the controller by name. `Send`: the
/// soft PLC's `plant` module, which runs on a thread of its own, holds one.
pub trait Plant: Send {
    fn name(&self) -> &str;
    /// Signals it reads: controller outputs, or timeline columns.
    fn inputs(&self) -> Vec<String>;
    /// Signals it drives: controller inputs (or just observable).
    fn outputs(&self) -> Vec<String>;
    /// One step at `now`, before the controller's scan; `inputs` and `outputs` follow the order
    /// of [`Plant::inputs`] and [`Plant::outputs`]. `outputs` holds the values of the previous
    /// step (0 before the first), so a plant may leave a value unchanged.
    fn step(
        &mut self,
        now: Duration,
        inputs: &[i64],
        outputs: &mut [i64],
    ) -> Result<(), PlantError>;
    /// One line describing its state for the end-of-run report, e.g.
    /// "tape 111111 (6 ones), head at 0".
    fn summary(&self) -> String;
    /// For a signal carrying a real quantity in fixed point, how many units make one (the
    /// `thermal` plant's `temp` counts thousandths of a degree: 1000). The soft PLC's `plant`
    /// module binds such a signal to an f32 point as the real value.
    fn scale(&self, _signal: &str) -> Option<f64> {
        None
    }
}

/// Why a plant step failed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PlantError {
    #[error("plant `{plant}`")]
    Scan {
        plant: String,
        #[source]
        source: ScanError,
    },
    #[error("plant `{plant}`: {message}")]
    Failed { plant: String, message: String },
}

/// The built-in plants: (name, one-line description). The one registry: `petriplc sim
/// --plant` and the soft PLC's `plant` module both build their plants with [`builtin_with`].
pub const BUILTINS: &[(&str, &str)] = &[
    (
        "tank",
        "mixer tank (seed 002): reads V1, V2 (inlets, 20 %/s each), V3 (drain, 25 %/s); drives N1 (<= 5 %), N2 (>= 50 %), N3 (>= 90 %)",
    ),
    (
        "tape",
        "Turing-machine tape (seed 003 TM_tape): reads write, left, right; drives read",
    ),
    (
        "keyboard",
        "4x3 keypad (seed 003 PN_device_kb_IO): reads col1..col3 and timeline key1..key12; drives line1..line4",
    ),
    (
        "turntable",
        "turntable with a conveyor belt (seed 004, eq. 1-5): reads MR, ML, BF, BB, arrive_south, arrive_east; drives SR, SL, SWP, alpha, x, delivery counters and errors E_*",
    ),
    (
        "thermal",
        "heated vessel, first order plus dead time (2 degC/%, tau 60 s, dead time 5 s, from 20 degC): reads heater (0.001 %); drives temp (0.001 degC)",
    ),
];

/// The names of the settings the built-in plant `name` takes (none for an unknown name).
pub fn builtin_settings(name: &str) -> Vec<&'static str> {
    match name {
        "turntable" => TURNTABLE_SETTINGS.iter().map(|t| t.0).collect(),
        "thermal" => THERMAL_SETTINGS.to_vec(),
        _ => Vec::new(),
    }
}

/// A fresh built-in plant by name (see [`BUILTINS`]), with its default settings.
pub fn builtin(name: &str) -> Option<Box<dyn Plant>> {
    builtin_with(name, &[]).ok().flatten()
}

/// A fresh built-in plant by name with settings (name, value): `Ok(None)` for an unknown
/// name, `Err` for a setting the plant does not have or a bad value. `turntable`
/// ([`TURNTABLE_SETTINGS`]) and `thermal` ([`THERMAL_SETTINGS`]) have settings.
pub fn builtin_with(
    name: &str,
    settings: &[(&str, &str)],
) -> Result<Option<Box<dyn Plant>>, String> {
    let none = |plant: Box<dyn Plant>| match settings.first() {
        None => Ok(Some(plant)),
        Some((key, _)) => Err(format!("the plant `{name}` has no settings (got `{key}`)")),
    };
    match name {
        "tape" => none(Box::new(Tape::new())),
        "keyboard" => none(Box::new(Keyboard::new())),
        "tank" => none(Box::new(Tank::new())),
        "turntable" => Ok(Some(Box::new(Turntable::new(TurntableSettings::parse(
            settings.iter().copied(),
        )?)))),
        "thermal" => Ok(Some(Box::new(Thermal::new(ThermalParams::parse(
            settings.iter().copied(),
        )?)))),
        _ => Ok(None),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every built-in listed is constructible, reports its own name, and the reverse.
    fn check(name: &str, expect: Option<(&str, usize, usize)>) {
        let got = builtin(name).map(|p| {
            assert_eq!(p.name(), name);
            (
                BUILTINS.iter().find(|b| b.0 == name).map_or("", |b| b.0),
                p.inputs().len(),
                p.outputs().len(),
            )
        });
        assert_eq!(got, expect, "{name}");
    }

    #[test]
    fn builtins_are_listed_and_constructible() {
        check("tape", Some(("tape", 3, 1)));
        check("keyboard", Some(("keyboard", 15, 4)));
        check("tank", Some(("tank", 3, 3)));
        check("turntable", Some(("turntable", 6, 16)));
        check("thermal", Some(("thermal", 1, 1)));
        check("Tank", None);
        check("", None);
        assert_eq!(
            BUILTINS.iter().map(|b| b.0).collect::<Vec<_>>(),
            ["tank", "tape", "keyboard", "turntable", "thermal"]
        );
        for (name, _) in BUILTINS {
            let settings = builtin_settings(name);
            // Each at its default where the plant documents one.
            let value = |k: &str| {
                TURNTABLE_SETTINGS
                    .iter()
                    .find(|t| t.0 == k)
                    .map_or("1", |t| t.2)
            };
            let pairs: Vec<(&str, &str)> = settings.iter().map(|&k| (k, value(k))).collect();
            assert!(
                builtin_with(name, &pairs).is_ok(),
                "{name} takes {settings:?}"
            );
        }
        assert_eq!(builtin_settings("nope"), Vec::<&str>::new());
        let err = |name: &str, settings: &[(&str, &str)]| {
            builtin_with(name, settings).err().unwrap_or_default()
        };
        assert_eq!(
            err("tank", &[("L", "3")]),
            "the plant `tank` has no settings (got `L`)"
        );
        assert_eq!(err("turntable", &[("L", "400"), ("K_x", "100.5")]), "");
        assert_eq!(err("thermal", &[("gain", "1.5"), ("initial", "55")]), "");
        assert_eq!(
            err("thermal", &[("dead_time", "-1")]),
            "`dead_time = -1` must be from 0 to 3600 s"
        );
        assert_eq!(
            err("thermal", &[("L", "3")]),
            "the thermal plant has no setting `L`; its settings are gain, time_constant, \
             dead_time, ambient, initial"
        );
        assert!(builtin_with("nope", &[("L", "3")]).unwrap().is_none());
    }

    #[test]
    fn errors_name_the_plant() {
        let e = PlantError::Failed {
            plant: "tape".into(),
            message: "head ran off".into(),
        };
        assert_eq!(e.to_string(), "plant `tape`: head ran off");
    }
}
