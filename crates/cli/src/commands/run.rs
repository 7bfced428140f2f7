//! `petriplc run`, `petriplc status`, `petriplc stop`: the soft PLC and its control.

use std::fs::File;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, Context};
use petriplc_plc::{ModuleState, Plc, PlcStatus, RunError, RunOptions};
use petriplc_runtime::module::Factory;
use simplelog::{
    ColorChoice, CombinedLogger, ConfigBuilder, LevelFilter, SharedLogger, TermLogger,
    TerminalMode, WriteLogger,
};

use crate::args::{PlcIdArgs, RunArgs};
use crate::failure::{BadInputExt, Failure, RunExt};

/// Every built-in module kind of `petriplc run`, for messages.
const KINDS: &[&str] = &[
    "petrinet",
    "iec",
    "plant",
    "timeline",
    "logger",
    "shutdown",
    "modbus_server",
    "modbus_client",
    "vitrine",
    "hmi",
];

/// The factory of a built-in module kind, from whichever crate has it.
fn builtin(kind: &str) -> Option<Factory> {
    petriplc_modules::builtin(kind)
        .or_else(|| petriplc_modbus::builtin(kind))
        .or_else(|| petriplc_vitrine::builtin(kind))
        .or_else(|| petriplc_hmi::builtin(kind))
}

pub fn run(args: RunArgs) -> Result<(), Failure> {
    let options = RunOptions {
        plc_id: args.plc_id.clone(),
        duration: args.duration,
        known_kinds: KINDS,
        overrides: args.overrides.clone(),
    };
    let config = Plc::read_config(&args.config, &options).map_err(|e| not_started(&args, e))?;
    // While the vitrine holds the terminal, log lines go to its footer (and are printed when
    // it gives the terminal back) instead of over the display.
    init_logging(&args, petriplc_vitrine::takes_terminal(&config))?;
    let plc = Plc::start_with(config, &args.config, builtin, &options)
        .map_err(|e| not_started(&args, e))?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        // Ctrl-C, SIGTERM (`petriplc stop`) and SIGHUP stop the PLC cleanly; a second one
        // while stopping ends the process at once.
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    let failed_before = plc.failed();
    let last = plc.wait(&stop);
    eprint!("{last}");
    let failed = failed_before || last.modules.iter().any(|m| m.state == ModuleState::Failed);
    if failed {
        Err(anyhow!("a module failed; see the log above")).run_failure()
    } else {
        Ok(())
    }
}

/// A PLC that could not start: exit 2 when the configuration is at fault.
fn not_started(args: &RunArgs, e: RunError) -> Failure {
    if e.is_bad_input() {
        Failure::BadInput(
            anyhow!(e).context(format!("{}: nothing was started", args.config.display())),
        )
    } else {
        Failure::Run(anyhow!(e).context("the PLC could not start"))
    }
}

fn init_logging(args: &RunArgs, vitrine: bool) -> Result<(), Failure> {
    let level = match args.log_level.as_str() {
        "error" => LevelFilter::Error,
        "warn" => LevelFilter::Warn,
        "debug" => LevelFilter::Debug,
        "trace" => LevelFilter::Trace,
        _ => LevelFilter::Info,
    };
    let config = ConfigBuilder::new()
        .set_time_format_rfc3339()
        .set_thread_level(LevelFilter::Off)
        .set_target_level(LevelFilter::Off)
        .build();
    let terminal: Box<dyn SharedLogger> = if vitrine {
        WriteLogger::new(level, config.clone(), petriplc_vitrine::log_writer())
    } else {
        TermLogger::new(
            level,
            config.clone(),
            TerminalMode::Stderr,
            if std::io::stderr().is_terminal() {
                ColorChoice::Auto
            } else {
                ColorChoice::Never
            },
        )
    };
    let mut loggers: Vec<Box<dyn SharedLogger>> = vec![terminal];
    if let Some(path) = &args.log {
        let file = File::create(path)
            .with_context(|| format!("cannot create the log file {}", path.display()))
            .bad_input()?;
        loggers.push(WriteLogger::new(level, config, file));
    }
    CombinedLogger::init(loggers)
        .context("cannot start logging")
        .run_failure()
}

pub fn status(args: PlcIdArgs) -> Result<(), Failure> {
    match PlcStatus::read(&args.plc_id) {
        Some(s) => {
            print!("{s}");
            Ok(())
        }
        None => Err(not_running(&args.plc_id)).run_failure(),
    }
}

pub fn stop(args: PlcIdArgs) -> Result<(), Failure> {
    use nix::sys::signal::{kill, Signal};
    use nix::unistd::Pid;
    let Some(s) = PlcStatus::read(&args.plc_id) else {
        return Err(not_running(&args.plc_id)).run_failure();
    };
    kill(Pid::from_raw(s.pid as i32), Signal::SIGTERM)
        .with_context(|| format!("cannot signal the PLC's process {}", s.pid))
        .run_failure()?;
    for _ in 0..200 {
        if PlcStatus::read(&args.plc_id).is_none() {
            eprintln!("PLC {} stopped", args.plc_id);
            return Ok(());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Err(anyhow!(
        "PLC {} (process {}) did not stop within 10 s; `kill -9 {}` ends it",
        args.plc_id,
        s.pid,
        s.pid
    ))
    .run_failure()
}

fn not_running(plc_id: &str) -> anyhow::Error {
    anyhow!(
        "no PLC with id `{plc_id}` is running (no {}); start one with `petriplc run CONFIG --plc-id {plc_id}`",
        petriplc_runtime::status::path(plc_id).display()
    )
}
