//! `petriplc run`, `petriplc status`, `petriplc stop`: the soft PLC and its control.

use std::fs::File;
use std::io::IsTerminal;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, Context};
use petriplc_plc::{ModuleState, NotStarted, Plc, PlcStatus, RunError, RunOptions};
use petriplc_runtime::module::{Factory, Module, ModuleError};
use petriplc_runtime::owner::{self, Owner, OwnerError, Probe};
use simplelog::{
    format_description, ColorChoice, CombinedLogger, ConfigBuilder, LevelFilter, SharedLogger,
    TermLogger, TerminalMode, WriteLogger,
};

use crate::args::{PlcIdArgs, RunArgs, DEFAULT_PLC_ID};
use crate::failure::{BadInputExt, Failure, RunExt};

/// Every built-in module kind of `petriplc run`, for messages.
const KINDS: &[&str] = &[
    "petrinet",
    "iec",
    "plant",
    "timeline",
    "logger",
    "shutdown",
    "dsp",
    "modbus_server",
    "modbus_client",
    "vitrine",
    "hmi",
    "mqtt",
    "opcua_server",
];

/// The built-in module kinds that a cargo feature of the binary brings (crates/cli/Cargo.toml),
/// and whether this build has it.
const FEATURES: &[(&str, &str, bool)] = &[
    ("modbus_server", "modbus", cfg!(feature = "modbus")),
    ("modbus_client", "modbus", cfg!(feature = "modbus")),
    ("vitrine", "vitrine", cfg!(feature = "vitrine")),
    ("hmi", "hmi", cfg!(feature = "hmi")),
    ("mqtt", "mqtt", cfg!(feature = "mqtt")),
    ("opcua_server", "opcua", cfg!(feature = "opcua")),
];

/// The factory of a built-in module kind, from whichever crate has it; a kind whose crate
/// this build left out gets a factory that says which feature brings it back.
fn builtin(kind: &str) -> Option<Factory> {
    let found = petriplc_modules::builtin(kind);
    #[cfg(feature = "modbus")]
    let found = found.or_else(|| petriplc_modbus::builtin(kind));
    #[cfg(feature = "vitrine")]
    let found = found.or_else(|| petriplc_vitrine::builtin(kind));
    #[cfg(feature = "hmi")]
    let found = found.or_else(|| petriplc_hmi::builtin(kind));
    #[cfg(feature = "mqtt")]
    let found = found.or_else(|| petriplc_mqtt::builtin(kind));
    #[cfg(feature = "opcua")]
    let found = found.or_else(|| petriplc_opcua::builtin(kind));
    found.or_else(|| left_out(kind).map(|_| not_built as Factory))
}

/// The feature that brings `kind` into the binary, when this build left it out.
fn left_out(kind: &str) -> Option<&'static str> {
    FEATURES
        .iter()
        .find(|(k, _, built)| *k == kind && !built)
        .map(|(_, feature, _)| *feature)
}

/// What a module of a kind this build left out is told.
fn not_built_message(module: &str, kind: &str, feature: &str) -> String {
    format!(
        "module {module}: `{kind}` is a built-in module kind, but this petriplc was built \
         without its `{feature}` feature; rebuild with `cargo build --release -p petriplc \
         --features {feature}` (it is in the default build)"
    )
}

fn not_built(decl: &petriplc_config::ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    let feature = left_out(&decl.kind).unwrap_or("default");
    Err(ModuleError::new(not_built_message(
        &decl.name, &decl.kind, feature,
    )))
}

pub fn run(args: RunArgs) -> Result<(), Failure> {
    let mut options = RunOptions {
        plc_id: String::new(),
        duration: args.duration,
        known_kinds: KINDS,
        overrides: args.overrides.clone(),
    };
    let config =
        Plc::read_config(&args.config, builtin, &options).map_err(|e| not_started(&args, e))?;
    options.plc_id = petriplc_plc::plc_id_of(&config, args.plc_id.as_deref(), DEFAULT_PLC_ID);
    // While the vitrine holds the terminal, log lines go to its footer (and are printed when
    // it gives the terminal back) instead of over the display.
    init_logging(&args, takes_terminal(&config), &options.plc_id)?;
    let stop = Arc::new(AtomicBool::new(false));
    {
        let stop = Arc::clone(&stop);
        // Ctrl-C, SIGTERM (`petriplc stop`) and SIGHUP stop the PLC cleanly; a second one
        // while stopping ends the process at once. Set before the PLC takes its id: `stop`
        // may signal it from then on, and one arriving while it starts stops it once started
        // rather than killing it half-way.
        let _ = ctrlc::set_handler(move || {
            if stop.swap(true, Ordering::SeqCst) {
                std::process::exit(130);
            }
        });
    }
    let plc = Plc::start_with(config, &args.config, builtin, &options)
        .map_err(|e| not_started(&args, e))?;
    let failed_before = plc.failed();
    let last = plc.wait(&stop);
    // The counts of rate-limited lines not yet summed up, before the final table.
    log::logger().flush();
    eprint!("{last}");
    let failed = failed_before || last.modules.iter().any(|m| m.state == ModuleState::Failed);
    if failed {
        Err(anyhow!("a module failed; see the log above")).run_failure()
    } else {
        Ok(())
    }
}

/// Whether a vitrine module will hold the terminal (never in a build without it).
fn takes_terminal(config: &petriplc_config::PlcConfig) -> bool {
    #[cfg(feature = "vitrine")]
    return petriplc_vitrine::takes_terminal(config);
    #[cfg(not(feature = "vitrine"))]
    {
        let _ = config;
        false
    }
}

/// A PLC that could not start: exit 2 when the configuration is at fault, 3 when something
/// it needs is taken (then with the command line that avoids every clash) or the machine
/// refused it.
fn not_started(args: &RunArgs, e: RunError) -> Failure {
    match e {
        // Compiler style, as for a bad net: one problem per line (diagnostics capped, as
        // every command prints them), then one summary.
        e @ (RunError::Config(_) | RunError::Many(_)) if e.kind() == NotStarted::BadInput => {
            let mut n = 0;
            let mut text = String::new();
            for p in e.problems() {
                match p {
                    RunError::Config(c) => {
                        for d in &c.diagnostics {
                            text.push_str(&format!("{d}\n"));
                            n += 1;
                        }
                    }
                    other => {
                        text.push_str(&format!("error: {other}\n"));
                        n += 1;
                    }
                }
            }
            crate::diagnostics::eprint(text.trim_end());
            Failure::BadInput(anyhow!(
                "{} is not a valid configuration ({n} problem{}); nothing was started",
                args.config.display(),
                if n == 1 { "" } else { "s" }
            ))
        }
        RunError::Taken(taken) => {
            let fixes: Vec<&str> = taken.iter().map(|t| t.fix.as_str()).collect();
            let command = command_line_with(&fixes);
            Failure::CannotStart(anyhow!(
                "{}\na command line that avoids them:\n  {command}",
                RunError::Taken(taken)
            ))
        }
        e => match e.kind() {
            NotStarted::CouldNotStart => Failure::CannotStart(anyhow!("nothing was started: {e}")),
            NotStarted::BadInput => Failure::BadInput(anyhow!("{e}\nnothing was started")),
        },
    }
}

/// This command line with `fixes` (`--plc-id ID`, `--set M:S=V`) applied: each replaces the
/// option it overrides, if given, or is added.
fn command_line_with(fixes: &[&str]) -> String {
    let mut words: Vec<String> = std::env::args().skip(1).collect();
    for fix in fixes {
        let (option, value) = fix.split_once(' ').unwrap_or((fix, ""));
        // `--set M:S=V` overrides an earlier `--set M:S=…`; `--plc-id` any `--plc-id`.
        let key = match value.split_once('=') {
            Some((key, _)) if option == "--set" => format!("{key}="),
            _ => String::new(),
        };
        let mut i = 0;
        while i < words.len() {
            let w = &words[i];
            let joined = w.strip_prefix(&format!("{option}="));
            let matches = |v: &str| option != "--set" || v.starts_with(&key);
            if w == option && words.get(i + 1).is_some_and(|v| matches(v)) {
                words.drain(i..i + 2);
            } else if joined.is_some_and(matches) {
                words.remove(i);
            } else {
                i += 1;
            }
        }
        words.push(option.to_string());
        words.push(value.to_string());
    }
    let quoted: Vec<String> = words.iter().map(|w| shell_word(w)).collect();
    format!("petriplc {}", quoted.join(" "))
}

/// `w` as one shell word.
fn shell_word(w: &str) -> String {
    let plain = !w.is_empty()
        && w.chars()
            .all(|c| c.is_ascii_alphanumeric() || "-_./:=@,+%#".contains(c));
    if plain {
        w.to_string()
    } else {
        format!("'{}'", w.replace('\'', r"'\''"))
    }
}

fn init_logging(args: &RunArgs, vitrine: bool, plc_id: &str) -> Result<(), Failure> {
    let level = match args.log_level.as_str() {
        "error" => LevelFilter::Error,
        "warn" => LevelFilter::Warn,
        "debug" => LevelFilter::Debug,
        "trace" => LevelFilter::Trace,
        _ => LevelFilter::Info,
    };
    // A person reads the terminal: local time, short (the vitrine's log pane is as wide as
    // the terminal, 80 columns perhaps). The file keeps exact UTC times for machines.
    // The local offset can only be read while the process has one thread, as it has now.
    let short = |format| {
        let mut b = ConfigBuilder::new();
        b.set_time_format_custom(format)
            .set_thread_level(LevelFilter::Off)
            .set_target_level(LevelFilter::Off);
        let _ = b.set_time_offset_to_local();
        b.build()
    };
    let config = ConfigBuilder::new()
        .set_time_format_rfc3339()
        .set_thread_level(LevelFilter::Off)
        .set_target_level(LevelFilter::Off)
        .build();
    // Under systemd (or when asked) the journal or syslog takes the terminal's place: what
    // reaches standard error there goes to the journal anyway.
    let system = match crate::logging::system_logger(&args.log_to, level, plc_id) {
        Ok(logger) => logger,
        Err(why) if args.log_to == crate::logging::LogTo::Auto => {
            eprintln!("warning: {why}; the log goes to standard error");
            None
        }
        Err(why) => return Err(Failure::CannotStart(anyhow!("{why}; nothing was started"))),
    };
    let terminal: Box<dyn SharedLogger> = if let Some(system) = system {
        system
    } else if let Some(display) = vitrine
        .then(|| {
            vitrine_logger(
                level,
                short(format_description!("[hour]:[minute]:[second]")),
            )
        })
        .flatten()
    {
        display
    } else {
        TermLogger::new(
            level,
            short(format_description!(
                "[hour]:[minute]:[second].[subsecond digits:3]"
            )),
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
        crate::output::create_parent(path)?;
        let file = File::create(path)
            .with_context(|| format!("cannot create the log file {}", path.display()))
            .bad_input()?;
        loggers.push(WriteLogger::new(level, config, file));
    }
    // Third-party lines at the level they deserve, floods of them rate-limited: one place
    // for every crate's policy (crates/cli/src/logging.rs).
    // Behind a queue, so that a log that cannot be written (a pipe nobody reads) never
    // holds a module in its scan (crates/cli/src/log_queue.rs).
    let policed = crate::logging::Policed::new(
        Box::new(crate::log_queue::Queued::new(
            CombinedLogger::new(loggers),
            level,
        )),
        level,
        policies(),
    );
    log::set_boxed_logger(Box::new(policed))
        .context("cannot start logging")
        .run_failure()?;
    log::set_max_level(level);
    Ok(())
}

/// The log lines' way into the vitrine's footer (none in a build without it: then no
/// vitrine takes the terminal).
fn vitrine_logger(level: LevelFilter, config: simplelog::Config) -> Option<Box<dyn SharedLogger>> {
    #[cfg(feature = "vitrine")]
    return Some(WriteLogger::new(
        level,
        config,
        petriplc_vitrine::log_writer(),
    ));
    #[cfg(not(feature = "vitrine"))]
    {
        let _ = (level, config);
        None
    }
}

/// The log policies of the third-party crates in this build (crates/cli/src/logging.rs).
fn policies() -> Vec<crate::logging::Policy> {
    vec![
        #[cfg(feature = "opcua")]
        petriplc_opcua::log_policy,
    ]
}

/// `petriplc status`: 0 and the modules' table for a running PLC, 5 for one that exited
/// without stopping, 4 for none.
pub fn status(args: PlcIdArgs) -> Result<(), Failure> {
    let id = args.id();
    match owner::probe(id).bad_input()? {
        Probe::Running { pid } => {
            let text = match PlcStatus::read(id) {
                Some(s) => s.to_string(),
                // The lock is held but the first status file is not written yet (or the
                // last one is already removed).
                None => match pid {
                    Some(p) => format!("PLC {id} (process {p}) is starting or stopping\n"),
                    None => format!("PLC {id} is starting\n"),
                },
            };
            crate::output::to_stdout(|out| out.write_all(text.as_bytes()))
        }
        Probe::Dead(remains) => Err(Failure::Stale(anyhow!(
            "PLC `{id}` not running: {}; what it left ({}) is removed by `petriplc stop \
             --plc-id {id}` or by the next `petriplc run` with this id",
            remains.describe(),
            remains.object_names()
        ))),
        Probe::Absent => Err(Failure::NoSuchPlc(no_such_plc(id))),
    }
}

/// `petriplc stop`: SIGTERM to the PLC's process, proven to be it (see
/// `petriplc_runtime::owner::running_plc`), and waits until it has stopped; for a PLC that
/// exited without stopping, removes what it left. 4 if there is no such PLC.
pub fn stop(args: PlcIdArgs) -> Result<(), Failure> {
    use nix::sys::signal::Signal;
    let id = args.id();
    let started = std::time::Instant::now();
    loop {
        if let Some(plc) = owner::running_plc(id).bad_input()? {
            plc.signal(Signal::SIGTERM)
                .with_context(|| format!("cannot signal the PLC's process {}", plc.pid()))
                .run_failure()?;
            if !plc.wait_exit(Duration::from_secs(10)) {
                return Err(anyhow!(
                    "PLC {id} (process {}) did not stop within 10 s; `kill -9 {}` ends it (the \
                     next `petriplc run` with this id removes what it leaves)",
                    plc.pid(),
                    plc.pid()
                ))
                .run_failure();
            }
            // A PLC that dies while stopping may leave things behind: tidy up after it.
            let _ = clean_up(id);
            eprintln!("PLC {id} stopped");
            return Ok(());
        }
        match owner::probe(id).bad_input()? {
            Probe::Absent => return Err(Failure::NoSuchPlc(no_such_plc(id))),
            Probe::Dead(_) => match clean_up(id) {
                Ok(Some(remains)) => {
                    eprintln!(
                        "PLC {id} was not running: {}; removed what it left ({})",
                        remains.describe(),
                        remains.object_names()
                    );
                    return Ok(());
                }
                Ok(None) => return Err(Failure::NoSuchPlc(no_such_plc(id))),
                // A PLC took the id meanwhile: stop that one.
                Err(OwnerError::Running { .. }) => {}
                Err(e) => return Err(e).run_failure(),
            },
            // The lock is held, but its holder is not proven yet: a PLC starting up.
            Probe::Running { .. } => {
                if started.elapsed() > Duration::from_secs(10) {
                    return Err(anyhow!(
                        "PLC {id} holds its lock but its process cannot be identified (its \
                         lock file {} names no live process); nothing was signalled",
                        owner::lock_path(id).display()
                    ))
                    .run_failure();
                }
                std::thread::sleep(Duration::from_millis(20));
            }
        }
    }
}

/// Takes the id for a moment to remove what a PLC that died left; `Ok(None)`: nothing was
/// left.
fn clean_up(plc_id: &str) -> Result<Option<owner::Remains>, OwnerError> {
    let (me, remains) = Owner::acquire(plc_id)?;
    me.release();
    Ok(remains)
}

fn no_such_plc(plc_id: &str) -> anyhow::Error {
    anyhow!(
        "no PLC with id `{plc_id}` (nothing of it in {}); start one with `petriplc run CONFIG \
         --plc-id {plc_id}`, or pass the id it was started with (--plc-id, or `plc_id` in its \
         configuration's [PLC])",
        owner::state_dir().display()
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_has_a_factory_in_any_build() {
        for kind in KINDS {
            assert!(builtin(kind).is_some(), "{kind}");
        }
        assert!(builtin("no_such_kind").is_none());
    }

    #[test]
    fn the_feature_table_holds_the_kinds_outside_the_modules_crate() {
        for kind in KINDS {
            let in_modules = petriplc_modules::builtin(kind).is_some();
            let listed = FEATURES.iter().any(|(k, _, _)| k == kind);
            assert_ne!(in_modules, listed, "{kind}");
        }
        for (kind, _, built) in FEATURES {
            assert_eq!(left_out(kind).is_none(), *built, "{kind}");
        }
    }

    #[test]
    fn a_left_out_kind_names_the_feature_that_brings_it_back() {
        let text = not_built_message("panel", "hmi", "hmi");
        assert!(text.starts_with("module panel: `hmi`"), "{text}");
        assert!(text.contains("--features hmi"), "{text}");
    }
}
