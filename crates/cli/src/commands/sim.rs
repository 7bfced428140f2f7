//! `petriplc sim`: load the controller, its inputs and its plant, run the scans, write the
//! trace and the plot.

use std::fs;
use std::io::{self, Write};
use std::path::Path;
use std::time::Duration;

use anyhow::{anyhow, Context};
use petriplc_net::ScanOptions;
use petriplc_pnml::ReadOptions;
use petriplc_sim::{NetPlant, Plant, PlotOptions, SimOptions, Simulation, Timeline};

use super::step_through;
use crate::args::SimArgs;
use crate::failure::{BadInputExt, Failure, RunExt};

pub fn run(args: SimArgs) -> Result<(), Failure> {
    let net = super::read_net(&args.net, args.names)?;
    let timeline = args
        .inputs
        .as_deref()
        .map(Timeline::read_file)
        .transpose()
        .bad_input()?;
    // A plant net is read with the plain convention: its signals are declared in the file.
    let plant_net = match &args.plant {
        Some(spec) if is_net_path(spec) => Some(
            petriplc_pnml::read_file(Path::new(spec), &ReadOptions::default())
                .bad_input()?
                .net,
        ),
        _ => None,
    };
    let plant: Option<Box<dyn Plant + '_>> = match (&args.plant, &plant_net) {
        (None, _) => None,
        (Some(_), Some(net)) => Some(Box::new(NetPlant::new(net, ScanOptions::of(net)))),
        (Some(name), None) => Some(
            petriplc_sim::builtin(name)
                .ok_or_else(|| unknown_plant(name))
                .bad_input()?,
        ),
    };
    let scan = ScanOptions {
        step: args.step.map_or(net.step, Into::into),
        evolve: args.evolve.map_or(net.evolve, Into::into),
        max_passes: args.max_passes,
    };
    let until = args.until.unwrap_or_else(|| {
        timeline.as_ref().map_or(Duration::from_secs(10), |t| {
            t.end() + Duration::from_secs(1)
        })
    });
    let options = SimOptions {
        period: args.period,
        until,
        scan,
    };
    // The likeliest cause of a timeline or plant that drives nothing: a SIPN net read with
    // plain names.
    let mut given: Vec<String> = timeline
        .as_ref()
        .map(|t| t.columns().to_vec())
        .unwrap_or_default();
    if let Some(p) = &plant_net {
        given.extend(p.outputs().map(|s| p.signal(s).name.clone()));
    }
    let hint = super::sipn_hint(&args.net, args.names, &net, &given, "the timeline or plant");
    let mut sim = match Simulation::new(&net, options, timeline, plant) {
        Ok(sim) => sim,
        Err(e) => {
            let mut message = format!("cannot simulate {}: {:#}", args.net.display(), anyhow!(e));
            if let Some(hint) = hint {
                message = format!("{message}\n{hint}");
            }
            return Err(anyhow!(message)).bad_input();
        }
    };
    if let Some(hint) = hint {
        eprintln!("warning: {hint}");
    }
    let plot_options = PlotOptions {
        signals: args.signals.clone(),
        from: args.from,
        to: args.to,
    };
    // Checked before the run: a misspelt name should not cost a whole simulation.
    plot_options.check(sim.trace()).bad_input()?;
    if args.step_through {
        // Inputs nothing drives are the user's to toggle here, so no warnings about them.
        return step_through::run(&mut sim);
    }
    for w in sim.warnings() {
        eprintln!("warning: {w}");
    }

    while sim.step().run_failure()?.is_some() {}
    let plant_summary = sim.plant_summary();
    let trace = sim.into_trace();

    match (&args.out, &args.plot) {
        (None, None) => crate::output::to_stdout(|out| trace.write_csv(out))?,
        (out, plot) => {
            if let Some(path) = out {
                crate::output::create_parent(path)?;
                let mut file = io::BufWriter::new(
                    fs::File::create(path)
                        .with_context(|| format!("cannot create {}", path.display()))
                        .run_failure()?,
                );
                trace
                    .write_csv(&mut file)
                    .and_then(|()| file.flush())
                    .with_context(|| format!("cannot write {}", path.display()))
                    .run_failure()?;
                let rows = trace.csv_rows();
                let what = format!("trace, {rows} row{}", if rows == 1 { "" } else { "s" });
                crate::output::wrote(path, &what);
            }
            if let Some(path) = plot {
                crate::output::create_parent(path)?;
                match petriplc_sim::write_svg(&trace, &plot_options, path) {
                    Ok(()) => {}
                    Err(e) if e.is_bad_input() => return Err(e).bad_input(),
                    Err(e) => {
                        return Err(e)
                            .with_context(|| format!("cannot write the plot {}", path.display()))
                            .run_failure()
                    }
                }
                crate::output::wrote(path, "plot");
            }
        }
    }
    if let Some(summary) = plant_summary {
        eprintln!("plant at the end: {summary}");
    }
    Ok(())
}

fn is_net_path(spec: &str) -> bool {
    let lower = spec.to_ascii_lowercase();
    lower.ends_with(".pnml") || lower.ends_with(".xml") || spec.contains(std::path::MAIN_SEPARATOR)
}

fn unknown_plant(name: &str) -> anyhow::Error {
    let known: Vec<String> = petriplc_sim::BUILTINS
        .iter()
        .map(|(n, d)| format!("  {n}: {d}"))
        .collect();
    anyhow!(
        "unknown plant `{name}`; give a plant net (a .pnml file) or one of the built-in plants:\n{}",
        known.join("\n")
    )
}
