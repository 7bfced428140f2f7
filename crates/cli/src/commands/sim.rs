//! `petriplc sim`: load the controller, its inputs and its plant, run the scans, write the
//! trace and the plot.

use std::fs;
use std::io::{self, Write};
use std::path::Path;
use std::time::Duration;

use anyhow::{anyhow, Context};
use petriplc_net::ScanOptions;
use petriplc_pnml::{Naming, ReadOptions};
use petriplc_sim::{NetPlant, Plant, SimOptions, Simulation, Timeline};

use super::step_through;
use crate::args::{Names, SimArgs};
use crate::failure::{BadInputExt, Failure, RunExt};

/// Whether the controller is an IEC 61131-3 source rather than a net.
fn is_iec(path: &Path) -> bool {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "st" {
        return true;
    }
    if ext == "xml" {
        let head = fs::read(path).unwrap_or_default();
        let head = String::from_utf8_lossy(&head[..head.len().min(4096)]).into_owned();
        return petriplc_iec::syntax::plcopen::is_plcopen(&head);
    }
    false
}

pub fn run(args: SimArgs) -> Result<(), Failure> {
    if is_iec(&args.net) {
        return run_iec(args);
    }
    if args.pou.is_some() || args.vars {
        return Err(anyhow!(
            "--pou and --vars apply to IEC 61131-3 programs (.st or a PLCopen XML project), not to nets"
        ))
        .bad_input();
    }
    let read_options = ReadOptions {
        naming: match args.names {
            Names::Plain => Naming::Plain,
            Names::Sipn => Naming::Sipn,
        },
    };
    let net = petriplc_pnml::read_file(&args.net, &read_options)
        .bad_input()?
        .net;
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
    let mut sim = Simulation::new(&net, options, timeline, plant)
        .with_context(|| format!("cannot simulate {}", args.net.display()))
        .bad_input()?;
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
                create_parent(path)?;
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
                eprintln!("trace: {} ({} rows)", path.display(), trace.csv_rows());
            }
            if let Some(path) = plot {
                create_parent(path)?;
                petriplc_sim::write_svg(&trace, path)
                    .with_context(|| format!("cannot write the plot {}", path.display()))
                    .run_failure()?;
                eprintln!("plot: {}", path.display());
            }
        }
    }
    if let Some(summary) = plant_summary {
        eprintln!("plant: {summary}");
    }
    Ok(())
}

/// `petriplc sim PROGRAM.st|PROJECT.xml`.
fn run_iec(args: SimArgs) -> Result<(), Failure> {
    if args.step_through {
        return Err(anyhow!(
            "--step-through is for nets; trace an IEC program with --vars"
        ))
        .bad_input();
    }
    if args.step.is_some() || args.evolve.is_some() || args.names != Names::Plain {
        return Err(anyhow!(
            "--step, --evolve and --names apply to nets; an IEC program's scan is its code"
        ))
        .bad_input();
    }
    let select = match &args.pou {
        Some(p) => petriplc_iec::Select::Pou(p.clone()),
        None => petriplc_iec::Select::Auto,
    };
    let build = petriplc_iec::build_file(&args.net, &select).bad_input()?;
    for w in &build.warnings {
        eprintln!("{w}");
    }
    let timeline = args
        .inputs
        .as_deref()
        .map(Timeline::read_file)
        .transpose()
        .bad_input()?;
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
    let until = args.until.unwrap_or_else(|| {
        timeline.as_ref().map_or(Duration::from_secs(10), |t| {
            t.end() + Duration::from_secs(1)
        })
    });
    let options = petriplc_iec::sim::SimOptions {
        period: args.period,
        until,
        vars: args.vars,
    };
    let sim = petriplc_iec::sim::IecSimulation::new(build.engine, options, timeline, plant)
        .with_context(|| format!("cannot simulate {}", args.net.display()))
        .bad_input()?;
    for w in sim.warnings() {
        eprintln!("warning: {w}");
    }
    let trace = sim.run().run_failure()?;
    match (&args.out, &args.plot) {
        (None, None) => crate::output::to_stdout(|out| trace.write_csv(out))?,
        (out, plot) => {
            if let Some(path) = out {
                create_parent(path)?;
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
                eprintln!("trace: {} ({} rows)", path.display(), trace.rows.len());
            }
            if let Some(path) = plot {
                create_parent(path)?;
                petriplc_sim::write_svg(&trace.to_plot_trace(), path)
                    .with_context(|| format!("cannot write the plot {}", path.display()))
                    .run_failure()?;
                eprintln!("plot: {}", path.display());
            }
        }
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

fn create_parent(path: &Path) -> Result<(), Failure> {
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(dir) => fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the folder {}", dir.display()))
            .run_failure(),
        None => Ok(()),
    }
}
