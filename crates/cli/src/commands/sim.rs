//! `petriplc sim`: load the controller, its inputs and its plant, run the scans, write the
//! trace and the plot.

use std::fs;
use std::io::{self, Write};
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, Context};
use indicatif::{ProgressBar, ProgressStyle};
use petriplc_net::{Net, ScanOptions};
use petriplc_pnml::ReadOptions;
use petriplc_sim::{NetPlant, Plant, PlotOptions, SimOptions, Simulation, Timeline};

use super::step_through;
use crate::args::{Names, OverflowArg, SimArgs};
use crate::failure::{BadInputExt, Failure, RunExt};

/// Whether the controller is an IEC 61131-3 source rather than a net.
fn is_iec(path: &Path) -> bool {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "st" || ext == "il" || petriplc_iec::project::is_iec_path(path) {
        return true;
    }
    if ext == "xml" {
        // The first 4 KiB say; a path that is not a file is reported by the reader later.
        let mut head = Vec::new();
        if petriplc_files::check(path, petriplc_files::IEC_SOURCE).is_ok() {
            if let Ok(f) = fs::File::open(path) {
                let _ = std::io::Read::read_to_end(&mut std::io::Read::take(f, 4096), &mut head);
            }
        }
        let head = String::from_utf8_lossy(&head).into_owned();
        return petriplc_iec::syntax::plcopen::is_plcopen(&head);
    }
    false
}

pub fn run(args: SimArgs) -> Result<(), Failure> {
    if is_iec(&args.net) {
        return run_iec(args);
    }
    if args.pou.is_some() || args.vars || args.overflow != OverflowArg::Wrap || !args.lib.is_empty()
    {
        return Err(anyhow!(
            "--pou, --vars, --overflow and --lib apply to IEC 61131-3 programs (.st, .il or a PLCopen XML project), not to nets"
        ))
        .bad_input();
    }
    if args.dialect.is_some() {
        return Err(anyhow!(
            "--dialect applies to IEC 61131-3 programs (.st, .il or a PLCopen XML project), not to nets"
        ))
        .bad_input();
    }
    let net = super::read_net(&args.net, args.names)?;
    let timeline = args
        .inputs
        .as_deref()
        .map(Timeline::read_file)
        .transpose()
        .bad_input()?;
    let plant_net = plant_net(&args)?;
    let plant = plant(&args, plant_net.as_ref())?;
    let scan = ScanOptions {
        step: args.step.map_or(net.step, Into::into),
        evolve: args.evolve.map_or(net.evolve, Into::into),
        max_passes: args.max_passes,
    };
    let until = until_of(&args, timeline.as_ref())?;
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
        note: None,
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

    // Ctrl-C ends the run after the current scan; what was simulated is still written.
    let interrupted = interrupt_flag();
    let progress = ScanProgress::new(sim.options().until, sim.options().period);
    let mut stopped: Option<Stopped> = None;
    loop {
        if interrupted.load(Ordering::SeqCst) {
            stopped = Some(Stopped::Interrupted(sim.now()));
            break;
        }
        match sim.step() {
            Ok(Some(_)) => progress.scan(sim.scans()),
            Ok(None) => break,
            Err(e) => {
                stopped = Some(Stopped::Failed(e));
                break;
            }
        }
    }
    progress.finish();
    let plant_summary = sim.plant_summary();
    let trace = sim.into_trace();
    // What a partial trace says about itself, last in the CSV and on the plot.
    let note = stopped.as_ref().map(Stopped::note);

    if let Some(path) = &args.inputs_out {
        crate::output::create_parent(path)?;
        let mut file = io::BufWriter::new(
            fs::File::create(path)
                .with_context(|| format!("cannot create {}", path.display()))
                .run_failure()?,
        );
        trace
            .write_inputs_csv(&mut file)
            .and_then(|()| file.flush())
            .with_context(|| format!("cannot write {}", path.display()))
            .run_failure()?;
        let what = if note.is_some() {
            "the controller's inputs as a timeline, incomplete"
        } else {
            "the controller's inputs as a timeline"
        };
        crate::output::wrote(path, what);
    }
    write_outputs(
        &args,
        &|w| trace.write_csv(w),
        trace.csv_rows(),
        &trace,
        plot_options,
        note,
    )?;
    if let Some(summary) = plant_summary {
        eprintln!("plant at the end: {summary}");
    }
    match stopped {
        None => Ok(()),
        Some(Stopped::Failed(e)) => Err(Failure::Run(anyhow!(e).context(
            "the simulation failed; what was simulated until then is written, marked incomplete",
        ))),
        Some(Stopped::Interrupted(t)) => Err(Failure::Interrupted(anyhow!(
            "interrupted at t={} s; what was simulated until then is written, marked incomplete",
            petriplc_net::time::format_seconds(t)
        ))),
    }
}

/// `--until`, else 1 s after the timeline's last row (refused when that is far off), else 10 s.
fn until_of(args: &SimArgs, timeline: Option<&Timeline>) -> Result<Duration, Failure> {
    if let Some(u) = args.until {
        return Ok(u);
    }
    let until = timeline.map_or(Duration::from_secs(10), |t| {
        t.end() + Duration::from_secs(1)
    });
    // A far-off last row would otherwise run for hours without a word.
    let scans = until.as_nanos() / args.period.as_nanos().max(1);
    if scans > IMPLIED_SCANS_LIMIT {
        return Err(anyhow!(
            "the timeline's last row is at {}, so the simulation would run {scans} \
             scans until {} at a {} period; pass --until to say how far to go (e.g. \
             --until {})",
            petriplc_net::time::format_seconds(until - Duration::from_secs(1)) + " s",
            petriplc_net::time::format_seconds(until) + " s",
            petriplc_net::time::format_seconds(args.period) + " s",
            petriplc_net::time::format_seconds(until) + "s",
        ))
        .bad_input();
    }
    Ok(until)
}

/// Writes the trace as `--out` and `--plot` ask (standard output without either), a partial
/// trace marked with `note`.
fn write_outputs(
    args: &SimArgs,
    csv: &dyn Fn(&mut dyn Write) -> io::Result<()>,
    rows: usize,
    plot_trace: &petriplc_sim::Trace,
    plot_options: PlotOptions,
    note: Option<String>,
) -> Result<(), Failure> {
    match (&args.out, &args.plot) {
        (None, None) => crate::output::to_stdout(|out| {
            csv(&mut *out)?;
            write_note(out, note.as_deref())
        })?,
        (out, plot) => {
            if let Some(path) = out {
                crate::output::create_parent(path)?;
                let mut file = io::BufWriter::new(
                    fs::File::create(path)
                        .with_context(|| format!("cannot create {}", path.display()))
                        .run_failure()?,
                );
                csv(&mut file)
                    .and_then(|()| write_note(&mut file, note.as_deref()))
                    .and_then(|()| file.flush())
                    .with_context(|| format!("cannot write {}", path.display()))
                    .run_failure()?;
                let what = format!(
                    "trace, {rows} row{}{}",
                    if rows == 1 { "" } else { "s" },
                    if note.is_some() { ", incomplete" } else { "" }
                );
                crate::output::wrote(path, &what);
            }
            if let Some(path) = plot {
                crate::output::create_parent(path)?;
                let options = PlotOptions {
                    note: note.clone(),
                    ..plot_options
                };
                match petriplc_sim::write_svg(plot_trace, &options, path) {
                    Ok(()) => {}
                    Err(e) if e.is_bad_input() => return Err(e).bad_input(),
                    Err(e) => {
                        return Err(e)
                            .with_context(|| format!("cannot write the plot {}", path.display()))
                            .run_failure()
                    }
                }
                let what = if note.is_some() {
                    "plot, incomplete"
                } else {
                    "plot"
                };
                crate::output::wrote(path, what);
            }
        }
    }
    Ok(())
}

/// Sets a Ctrl-C handler: the first ends the run after the current scan (what was simulated
/// is still written), a second exits at once.
fn interrupt_flag() -> Arc<AtomicBool> {
    let interrupted = Arc::new(AtomicBool::new(false));
    {
        let interrupted = interrupted.clone();
        let _ = ctrlc::set_handler(move || {
            if interrupted.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    interrupted
}

/// A simulation longer than this many scans needs --until when the timeline's last row sets
/// its end (a row in the far future would otherwise run for hours without a word).
const IMPLIED_SCANS_LIMIT: u128 = 1_000_000;
/// Runs longer than this many scans show their progress on a terminal.
const PROGRESS_SCANS: u128 = 100_000;

/// Why a run ended before `until`.
enum Stopped {
    Failed(petriplc_sim::SimError),
    Interrupted(Duration),
}

impl Stopped {
    fn note(&self) -> String {
        match self {
            Stopped::Failed(e) => format!(
                "incomplete: the simulation failed{}: {:#}",
                e.time()
                    .map(|t| format!(" at t={} s", petriplc_net::time::format_seconds(t)))
                    .unwrap_or_default(),
                anyhow!(e.clone())
            ),
            Stopped::Interrupted(t) => format!(
                "incomplete: interrupted (Ctrl-C) after t={} s",
                petriplc_net::time::format_seconds(*t)
            ),
        }
    }
}

/// The note of a partial trace as the CSV's last line, a `#` comment.
fn write_note(w: &mut dyn Write, note: Option<&str>) -> io::Result<()> {
    match note {
        Some(n) => writeln!(w, "# {}", n.replace('\n', " ")),
        None => Ok(()),
    }
}

/// A progress bar on a terminal for long runs (nothing otherwise).
struct ScanProgress {
    bar: Option<ProgressBar>,
}

impl ScanProgress {
    fn new(until: Duration, period: Duration) -> Self {
        let total = until.as_nanos() / period.as_nanos().max(1) + 1;
        let bar = (total > PROGRESS_SCANS && std::io::IsTerminal::is_terminal(&io::stderr()))
            .then(|| {
                let b = ProgressBar::new(u64::try_from(total).unwrap_or(u64::MAX));
                b.set_style(
                    ProgressStyle::with_template(
                        "{bar:30} {pos}/{len} scans, {elapsed} (eta {eta}; Ctrl-C stops and writes what was simulated)",
                    )
                    .unwrap_or_else(|_| ProgressStyle::default_bar()),
                );
                b
            });
        ScanProgress { bar }
    }

    fn scan(&self, done: u64) {
        if let Some(b) = &self.bar {
            if done % 4096 == 0 {
                b.set_position(done);
            }
        }
    }

    fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

/// `petriplc sim PROGRAM.st|PROJECT.xml|PROJECT.plcproj|FOLDER`.
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
    let mut sources = petriplc_iec::Sources::new();
    sources.dialect = args.dialect;
    sources.overflow = args.overflow.into();
    sources.libs = args.lib.clone();
    sources.add_path(&args.net).bad_input()?;
    let build =
        petriplc_iec::build(&sources, &select, petriplc_iec::Natives::default()).bad_input()?;
    if !build.warnings.is_empty() {
        crate::diagnostics::eprint(&build.warnings.join("\n"));
    }
    let timeline = args
        .inputs
        .as_deref()
        .map(Timeline::read_file)
        .transpose()
        .bad_input()?;
    let plant_net = plant_net(&args)?;
    let plant = plant(&args, plant_net.as_ref())?;
    let until = until_of(&args, timeline.as_ref())?;
    let options = petriplc_iec::sim::SimOptions {
        period: args.period,
        until,
        vars: args.vars,
    };
    let mut sim = petriplc_iec::sim::IecSimulation::new(build.engine, options, timeline, plant)
        .with_context(|| format!("cannot simulate {}", args.net.display()))
        .bad_input()?;
    let plot_options = PlotOptions {
        signals: args.signals.clone(),
        from: args.from,
        to: args.to,
        note: None,
    };
    plot_options
        .check(&sim.trace().to_plot_trace())
        .bad_input()?;
    for w in sim.warnings() {
        eprintln!("warning: {w}");
    }

    let interrupted = interrupt_flag();
    let progress = ScanProgress::new(until, args.period);
    let mut failed = None;
    let mut stopped_at = None;
    loop {
        if interrupted.load(Ordering::SeqCst) {
            stopped_at = Some(sim.now());
            break;
        }
        match sim.step() {
            Ok(true) => progress.scan(sim.scans()),
            Ok(false) => break,
            Err(e) => {
                failed = Some(e);
                break;
            }
        }
    }
    progress.finish();
    let plant_summary = sim.plant_summary();
    let trace = sim.into_trace();
    let note = match (&failed, stopped_at) {
        (Some(e), _) => Some(format!("incomplete: the simulation failed: {e}")),
        (None, Some(t)) => Some(format!(
            "incomplete: interrupted (Ctrl-C) after t={} s",
            petriplc_net::time::format_seconds(t)
        )),
        (None, None) => None,
    };
    write_outputs(
        &args,
        &|w| trace.write_csv(w),
        trace.csv_rows(),
        &trace.to_plot_trace(),
        plot_options,
        note,
    )?;
    if let Some(summary) = plant_summary {
        eprintln!("plant at the end: {summary}");
    }
    match (failed, stopped_at) {
        (Some(e), _) => Err(Failure::Run(anyhow!(e).context(
            "the simulation failed; what was simulated until then is written, marked incomplete",
        ))),
        (None, Some(t)) => Err(Failure::Interrupted(anyhow!(
            "interrupted at t={} s; what was simulated until then is written, marked incomplete",
            petriplc_net::time::format_seconds(t)
        ))),
        (None, None) => Ok(()),
    }
}

fn is_net_path(spec: &str) -> bool {
    let lower = spec.to_ascii_lowercase();
    lower.ends_with(".pnml") || lower.ends_with(".xml") || spec.contains(std::path::MAIN_SEPARATOR)
}

/// The plant net `--plant FILE.pnml` names, read with the plain convention (its signals are
/// declared in the file); `None` for a built-in plant or none.
fn plant_net(args: &SimArgs) -> Result<Option<Net>, Failure> {
    match &args.plant {
        Some(spec) if is_net_path(spec) => Ok(Some(
            petriplc_pnml::read_file(Path::new(spec), &ReadOptions::default())
                .bad_input()?
                .net,
        )),
        _ => Ok(None),
    }
}

/// The plant `--plant` and `--plant-set` ask for, for a net and for an IEC program alike: the
/// plant net (`net`, from [`plant_net`]) or a built-in plant with its settings.
fn plant<'a>(args: &SimArgs, net: Option<&'a Net>) -> Result<Option<Box<dyn Plant + 'a>>, Failure> {
    let settings: Vec<(&str, &str)> = args
        .plant_set
        .iter()
        .map(|(k, v)| (k.as_str(), v.as_str()))
        .collect();
    match (&args.plant, net) {
        (None, _) if !settings.is_empty() => Err(anyhow!(
            "--plant-set applies to a plant: add --plant NAME (one of the built-in plants)"
        ))
        .bad_input(),
        (None, _) => Ok(None),
        (Some(_), Some(_)) if !settings.is_empty() => Err(anyhow!(
            "--plant-set applies to a built-in plant; a plant net's behaviour is in its file"
        ))
        .bad_input(),
        (Some(_), Some(net)) => Ok(Some(Box::new(NetPlant::new(net, ScanOptions::of(net))))),
        (Some(name), None) => Ok(Some(
            petriplc_sim::builtin_with(name, &settings)
                .map_err(|e| anyhow!("--plant-set: {e}"))
                .bad_input()?
                .ok_or_else(|| unknown_plant(name))
                .bad_input()?,
        )),
    }
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
