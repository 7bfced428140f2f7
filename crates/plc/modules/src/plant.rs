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
use petriplc_sim::{NetPlant, Plant, BUILTINS};

use crate::common::{self, at, chain, error, Bound, NetSettings, Port, NET_OPTIONS};

const KIND: &str = "plant";

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(PlantModule::new(decl)?))
}

/// What the settings ask for.
enum Source {
    /// A plant of petriplc-sim's registry, by name, with its settings (checked by `new`).
    Builtin {
        name: String,
        settings: Vec<(String, String)>,
    },
    Net(NetSettings),
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
    plant: Box<dyn Plant>,
    inputs: Vec<Bound>,
    outputs: Vec<Bound>,
    in_values: Vec<i64>,
    /// Kept between steps: `Plant::step` may leave an output as the previous step set it.
    out_values: Vec<i64>,
}

/// The built-in plants' names, for messages.
fn known_plants() -> String {
    BUILTINS.iter().map(|b| b.0).collect::<Vec<_>>().join(", ")
}

/// A built-in plant from petriplc-sim's registry.
fn build(
    module: &str,
    name: &str,
    settings: &[(String, String)],
) -> Result<Box<dyn Plant>, ModuleError> {
    let pairs: Vec<(&str, &str)> = settings
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    match petriplc_sim::builtin_with(name, &pairs) {
        Ok(Some(plant)) => Ok(plant),
        Ok(None) => Err(error(
            module,
            format!(
                "`plant = {name}` is not a built-in plant; use one of {}, or `net = FILE.pnml` \
                 for a plant net",
                known_plants()
            ),
        )),
        Err(e) => Err(error(module, e)),
    }
}

impl PlantModule {
    /// Checks the settings (a built-in plant is built once to check them); a plant net is
    /// read by `init`.
    pub fn new(decl: &ModuleDecl) -> Result<PlantModule, ModuleError> {
        // Every built-in plant's settings are known here, so that one given to the wrong
        // plant is named as such below rather than as an unknown setting.
        let plant_settings: Vec<(&str, &str)> = BUILTINS
            .iter()
            .flat_map(|b| {
                petriplc_sim::builtin_settings(b.0)
                    .into_iter()
                    .map(|k| (k, b.0))
            })
            .collect();
        let known: Vec<&str> = ["plant", "net", "speed"]
            .iter()
            .chain(NET_OPTIONS)
            .copied()
            .chain(plant_settings.iter().map(|s| s.0))
            .collect();
        common::check_decl(decl, KIND, &known)?;
        let source = match (common::setting(decl, "plant"), common::setting(decl, "net")) {
            (Some(_), Some(_)) => {
                return Err(error(
                    &decl.name,
                    "both `plant` and `net` are set; a plant module runs one plant: keep one",
                ))
            }
            (Some(name), None) => {
                // In the plant's own order of settings, so its first complaint is the same
                // whatever the order of the section's lines.
                let settings: Vec<(String, String)> = petriplc_sim::builtin_settings(name)
                    .into_iter()
                    .filter_map(|k| {
                        common::setting(decl, k).map(|v| (k.to_string(), v.to_string()))
                    })
                    .collect();
                build(&decl.name, name, &settings)?;
                Source::Builtin {
                    name: name.to_string(),
                    settings,
                }
            }
            (None, Some(_)) => {
                Source::Net(NetSettings::parse(decl, common::require(decl, "net")?)?)
            }
            (None, None) => {
                return Err(error(
                    &decl.name,
                    format!(
                    "no plant given; add `plant = NAME` ({}) or `net = FILE.pnml` to section [{}]",
                    known_plants(),
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
        let own = match &source {
            Source::Builtin { name, .. } => name.as_str(),
            Source::Net(_) => "",
        };
        if let Some((k, plant)) = plant_settings
            .iter()
            .find(|(k, plant)| *plant != own && decl.settings.contains_key(*k))
        {
            return Err(error(
                &decl.name,
                format!("`{k}` is a setting of `plant = {plant}`, not of this plant"),
            ));
        }
        if let Source::Builtin { .. } = source {
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

impl Module for PlantModule {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let (plant, what, types): (Box<dyn Plant>, _, _) = match &self.source {
            Source::Builtin { name, settings } => (
                build(&self.name, name, settings)?,
                format!("plant `{name}`"),
                None,
            ),
            Source::Net(settings) => {
                let net = settings.load(&self.name, ctx.base_dir)?;
                let plant = Box::new(NetPlant::new(net, settings.options(net)));
                (plant, format!("plant net `{}`", settings.file), Some(net))
            }
        };
        // A Rust plant's signals carry plain values (some in fixed point); a plant net's have
        // their declared types.
        let scales: Vec<(String, f64)> = {
            let p = &plant;
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
        let inputs: Vec<Port> = plant.inputs().into_iter().map(port).collect();
        let outputs: Vec<Port> = plant.outputs().into_iter().map(port).collect();
        let (inputs, outputs) = common::bind(ctx, KIND, &what, &inputs, &outputs)?;
        self.run = Some(Run {
            in_values: vec![0; inputs.len()],
            out_values: vec![0; outputs.len()],
            plant,
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
        run.plant
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
            .map_or_else(String::new, |r| r.plant.summary())
    }
}
