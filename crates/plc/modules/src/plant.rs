//! `plant`: a simulated process for software-in-the-loop, either a Rust plant of
//! petriplc-sim or a plant net, stepped once per scan. Its inputs are read from points of the
//! same names (usually the controller's outputs) and its outputs written to points it owns
//! (usually the controller's inputs).
//!
//! ```text
//! [tank]
//! plant = tank              # tank, tape, keyboard, turntable or thermal
//! # K_alpha = 45            # the turntable's settings (docs/runtime.md)
//! # or: net = tank.pnml     # a plant net (plain naming by default; names, step, evolve,
//! #                         # max_passes as for petrinet)
//! map V1 VALVE1             # plant signal V1 is point VALVE1
//! speed = 4                 # plant time runs 4 times faster than the PLC's
//! ```
//!
//! `plant = thermal` (a heated vessel, first order plus dead time) takes its constants as
//! settings: `gain` (°C per % of heater power, default 2), `time_constant` (s, 60),
//! `dead_time` (s, 5), `ambient` (°C, 20) and `initial` (°C, the ambient). Its `heater`
//! (%) and `temp` (°C) bind to f32 points.

use petriplc_config::ModuleDecl;
use petriplc_net::SignalType;
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};
use petriplc_sim::{
    Keyboard, NetPlant, Plant, Tank, Tape, Thermal, ThermalParams, Turntable, TurntableSettings,
    TURNTABLE_SETTINGS,
};

use crate::common::{self, at, chain, error, Bound, NetSettings, Port, NET_OPTIONS};

const KIND: &str = "plant";

/// The Rust plants this module can run.
const RUST_PLANTS: &[&str] = &["tank", "tape", "keyboard", "turntable", "thermal"];

/// The settings of `plant = thermal`.
const THERMAL_SETTINGS: &[&str] = &["gain", "time_constant", "dead_time", "ambient", "initial"];

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(PlantModule::new(decl)?))
}

/// What the settings ask for.
enum Source {
    Rust(&'static str),
    Turntable(TurntableSettings),
    Thermal(ThermalParams),
    Net(NetSettings),
}

/// The plants by concrete type: `Box<dyn Plant>` is not `Send`, which a module must be.
enum Sim {
    Tank(Tank),
    Tape(Tape),
    Keyboard(Keyboard),
    Turntable(Box<Turntable>),
    Thermal(Thermal),
    Net(Box<NetPlant<'static>>),
}

impl Sim {
    fn plant(&mut self) -> &mut dyn Plant {
        match self {
            Sim::Tank(p) => p,
            Sim::Tape(p) => p,
            Sim::Keyboard(p) => p,
            Sim::Turntable(p) => p.as_mut(),
            Sim::Thermal(p) => p,
            Sim::Net(p) => p.as_mut(),
        }
    }

    fn plant_ref(&self) -> &dyn Plant {
        match self {
            Sim::Tank(p) => p,
            Sim::Tape(p) => p,
            Sim::Keyboard(p) => p,
            Sim::Turntable(p) => p.as_ref(),
            Sim::Thermal(p) => p,
            Sim::Net(p) => p.as_ref(),
        }
    }
}

/// The `plant` module.
pub struct PlantModule {
    name: String,
    source: Source,
    /// `speed = N`: the plant runs N times faster than the PLC's clock (a demo's tank fills
    /// in seconds instead of minutes); a whole number, so plant time stays exact.
    speed: u32,
    run: Option<Run>,
}

struct Run {
    sim: Sim,
    inputs: Vec<Bound>,
    outputs: Vec<Bound>,
    in_values: Vec<i64>,
    /// Kept between steps: `Plant::step` may leave an output as the previous step set it.
    out_values: Vec<i64>,
}

impl PlantModule {
    /// Checks the settings; a plant net is read by `init`.
    pub fn new(decl: &ModuleDecl) -> Result<PlantModule, ModuleError> {
        let turntable = common::setting(decl, "plant") == Some("turntable");
        let known: Vec<&str> = ["plant", "net", "speed"]
            .iter()
            .chain(NET_OPTIONS)
            .chain(THERMAL_SETTINGS)
            .copied()
            .chain(TURNTABLE_SETTINGS.iter().map(|t| t.0).filter(|_| turntable))
            .collect();
        common::check_decl(decl, KIND, &known)?;
        let source = match (common::setting(decl, "plant"), common::setting(decl, "net")) {
            (Some(_), Some(_)) => {
                return Err(error(
                    &decl.name,
                    "both `plant` and `net` are set; a plant module runs one plant: keep one",
                ))
            }
            (Some("turntable"), None) => {
                let pairs = TURNTABLE_SETTINGS
                    .iter()
                    .filter_map(|t| common::setting(decl, t.0).map(|v| (t.0, v)));
                Source::Turntable(
                    TurntableSettings::parse(pairs).map_err(|e| error(&decl.name, e))?,
                )
            }
            (Some(name), None) => match RUST_PLANTS.iter().find(|&&p| p == name) {
                Some(p) => Source::Rust(p),
                None => {
                    return Err(error(
                        &decl.name,
                        format!(
                            "`plant = {name}` is not a built-in plant; use one of {}, or \
                             `net = FILE.pnml` for a plant net",
                            RUST_PLANTS.join(", ")
                        ),
                    ))
                }
            },
            (None, Some(_)) => {
                Source::Net(NetSettings::parse(decl, common::require(decl, "net")?)?)
            }
            (None, None) => {
                return Err(error(
                    &decl.name,
                    format!(
                    "no plant given; add `plant = NAME` ({}) or `net = FILE.pnml` to section [{}]",
                    RUST_PLANTS.join(", "),
                    decl.name
                ),
                ))
            }
        };
        let speed = match common::setting(decl, "speed") {
            None => 1,
            Some(text) => text
                .parse::<u32>()
                .ok()
                .filter(|&n| n >= 1)
                .ok_or_else(|| {
                    error(
                        &decl.name,
                        format!("`speed = {text}` must be a whole number 1 or more (times faster)"),
                    )
                })?,
        };
        let source = match source {
            Source::Rust("thermal") => Source::Thermal(thermal_params(decl)?),
            other => other,
        };
        if !matches!(source, Source::Thermal(_)) {
            if let Some(k) = THERMAL_SETTINGS
                .iter()
                .find(|k| decl.settings.contains_key(**k))
            {
                return Err(error(
                    &decl.name,
                    format!("`{k}` is a setting of `plant = thermal`, not of this plant"),
                ));
            }
        }
        if let Source::Rust(_) | Source::Turntable(_) | Source::Thermal(_) = source {
            if let Some(k) = NET_OPTIONS.iter().find(|k| decl.settings.contains_key(**k)) {
                return Err(error(
                    &decl.name,
                    format!(
                        "`{k}` applies to a plant net (`net = FILE.pnml`), not to a built-in plant"
                    ),
                ));
            }
        }
        Ok(PlantModule {
            name: decl.name.clone(),
            source,
            speed,
            run: None,
        })
    }
}

/// `plant = thermal`'s constants from the section, each checked.
fn thermal_params(decl: &ModuleDecl) -> Result<ThermalParams, ModuleError> {
    let mut p = ThermalParams::default();
    let mut initial = None;
    for &key in THERMAL_SETTINGS {
        let Some(text) = common::setting(decl, key) else {
            continue;
        };
        let value = text
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| error(&decl.name, format!("`{key} = {text}` is not a number")))?;
        let positive = |v: f64| {
            if v > 0.0 {
                Ok(v)
            } else {
                Err(error(
                    &decl.name,
                    format!("`{key} = {text}` must be above 0"),
                ))
            }
        };
        match key {
            "gain" => p.gain = value,
            "time_constant" => p.time_constant = positive(value)?,
            "dead_time" => {
                if !(0.0..=3600.0).contains(&value) {
                    return Err(error(
                        &decl.name,
                        format!("`dead_time = {text}` must be from 0 to 3600 s"),
                    ));
                }
                p.dead_time = value;
            }
            "ambient" => p.ambient = value,
            _ => initial = Some(value),
        }
    }
    p.initial = initial.unwrap_or(p.ambient);
    Ok(p)
}

impl Module for PlantModule {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let (mut sim, what, types) = match &self.source {
            Source::Rust(name) => {
                let sim = match *name {
                    "tank" => Sim::Tank(Tank::new()),
                    "tape" => Sim::Tape(Tape::new()),
                    _ => Sim::Keyboard(Keyboard::new()),
                };
                (sim, format!("plant `{name}`"), None)
            }
            Source::Turntable(settings) => (
                Sim::Turntable(Box::new(Turntable::new(*settings))),
                "plant `turntable`".to_string(),
                None,
            ),
            Source::Thermal(params) => (
                Sim::Thermal(Thermal::new(*params)),
                "plant `thermal`".to_string(),
                None,
            ),
            Source::Net(settings) => {
                let net = settings.load(&self.name, ctx.base_dir)?;
                let sim = Sim::Net(Box::new(NetPlant::new(net, settings.options(net))));
                (sim, format!("plant net `{}`", settings.file), Some(net))
            }
        };
        // A Rust plant's signals carry plain values (some in fixed point); a plant net's have
        // their declared types.
        let scales: Vec<(String, f64)> = {
            let p = sim.plant();
            p.inputs()
                .into_iter()
                .chain(p.outputs())
                .filter_map(|n| p.scale(&n).map(|s| (n, s)))
                .collect()
        };
        let port = |name: String| Port {
            ty: types
                .and_then(|n| n.signal_by_name(&name).map(|s| n.signal(s).ty))
                .unwrap_or(SignalType::Int),
            scale: scales.iter().find(|(n, _)| *n == name).map(|(_, s)| *s),
            name,
        };
        let inputs: Vec<Port> = sim.plant().inputs().into_iter().map(port).collect();
        let outputs: Vec<Port> = sim.plant().outputs().into_iter().map(port).collect();
        let (inputs, outputs) = common::bind(ctx, KIND, &what, &inputs, &outputs)?;
        self.run = Some(Run {
            in_values: vec![0; inputs.len()],
            out_values: vec![0; outputs.len()],
            sim,
            inputs,
            outputs,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        for (v, b) in run.in_values.iter_mut().zip(&run.inputs) {
            *v = b.read(ctx.map);
        }
        run.sim
            .plant()
            .step(
                ctx.now.saturating_mul(self.speed),
                &run.in_values,
                &mut run.out_values,
            )
            .map_err(|e| error(&self.name, format!("{}: {}", at(ctx.now), chain(&e))))?;
        for (&v, b) in run.out_values.iter().zip(&run.outputs) {
            b.write(ctx.map, v).map_err(|e| {
                error(
                    &self.name,
                    format!("{}: plant output `{}` = {v}: {e}", at(ctx.now), b.signal),
                )
            })?;
        }
        Ok(Control::Continue)
    }

    fn default_scan_period(&self) -> Option<std::time::Duration> {
        Some(crate::common::DEFAULT_PERIOD)
    }

    fn status(&self) -> String {
        self.run
            .as_ref()
            .map_or_else(String::new, |r| r.sim.plant_ref().summary())
    }
}
