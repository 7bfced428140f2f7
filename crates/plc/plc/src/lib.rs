//! The soft PLC runner behind `petriplc run`: reads a configuration, checks everything it
//! can before creating anything (module kinds and programs, safe values, a synchronisation
//! net that could never let a module scan), takes the PLC id (a lock the kernel releases when
//! the process dies, so a PLC killed with `kill -9` is replaced at once: see
//! `petriplc_runtime::owner`), sets up the process image and the synchronisation net in
//! shared memory, initialises every module (nothing starts if one fails), then runs built-in
//! modules as threads and other programs as processes, each scan framed as seed 000 frames
//! it: period wait, `scan_beg` synch, `update()`, the scan, `update()`, `scan_end` synch.
//! Failures follow each module's `on_failure` (restarts paced and limited); the state and
//! statistics of every module are published for `petriplc status`. A start that fails
//! removes everything it made.

mod checks;
mod retain;
mod run;
mod start;

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use petriplc_config::{ConfigError, Location, ModuleDecl, OnFailure, Origin, Override, PlcConfig};
use petriplc_runtime::image::{GlobalMap, ImageError, Layout, ModuleMap};
use petriplc_runtime::module::{Factory, ModuleError};
use petriplc_runtime::owner::{Owner, OwnerError};
use petriplc_runtime::period;
use petriplc_runtime::retained::{self, Adopt};
use petriplc_runtime::synch::{Abandoned, SharedSynch, SynchError};
use petriplc_runtime::watchdog::{ClockError, ScanClocks};

use crate::checks::{taken_list, SafeValue};
use crate::run::{lock, show_duration, Restarts};

pub use crate::checks::Taken;
pub use petriplc_retain::RetainError;

pub use petriplc_runtime::status::{self, ModuleState, ModuleStatus, PlcStatus};

/// Finds the factory of a built-in module kind.
pub type Registry = fn(&str) -> Option<Factory>;

/// How to run.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Names the shared memory, so several PLCs run side by side.
    pub plc_id: String,
    /// Stop after this long (tests, demos); `None`: until stopped.
    pub duration: Option<Duration>,
    /// Built-in kinds, for error messages.
    pub known_kinds: &'static [&'static str],
    /// Settings given on the command line (`--set`); program modules get them in the
    /// environment (`PETRIPLC_SET`, one per line) and apply them too.
    pub overrides: Vec<Override>,
}

/// Why the PLC could not start.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Config(#[from] ConfigError),
    #[error(transparent)]
    Image(#[from] ImageError),
    #[error(transparent)]
    Synch(#[from] SynchError),
    #[error("module {module}: `{kind}` is neither a built-in module ({known}) nor a program at {path}; fix the `module {module} ...` row")]
    UnknownKind {
        module: String,
        kind: String,
        known: String,
        path: String,
    },
    #[error("module {module}: `location = isolate` is for modules that run as their own process; a built-in module runs as a thread of `petriplc run`, so use local or shared")]
    IsolateThread { module: String },
    /// The module's message names it. (Not `source`: the message is this error's own, and
    /// a source would be printed again after it.)
    #[error("{error}")]
    Init { module: String, error: ModuleError },
    /// What the PLC needs and others hold: its id, the addresses its modules listen on.
    /// Every one is listed, each with the command-line option that avoids it.
    #[error("nothing was started: {}", taken_list(.0))]
    Taken(Vec<Taken>),
    /// The OS error's text is part of this message; it is not the error's `source`, which
    /// would print it a second time.
    #[error("module {module}: cannot start program {program}: {error}")]
    Spawn {
        module: String,
        program: String,
        error: std::io::Error,
    },
    #[error("module {module}: program {path} is not executable; make it so (`chmod +x {path}`) or fix the `module {module} ...` row")]
    NotExecutable { module: String, path: String },
    #[error(transparent)]
    Owner(#[from] OwnerError),
    /// `message` starts with the row's file and line.
    #[error("{message}")]
    Safe { module: String, message: String },
    #[error(
        "the synchronisation net can never let {} scan: no marking reachable from the \
         initial one enables {}. Give the cycle a first token (`synch_start MODULE` for the \
         module that scans first, or initial tokens on a `place`)",
        list("module", .modules),
        if .modules.len() == 1 { "its scan_beg" } else { "their scan_beg" }
    )]
    DeadSynch { modules: Vec<String> },
    #[error(transparent)]
    Retain(#[from] RetainError),
    #[error(transparent)]
    Clocks(#[from] ClockError),
    #[error(
        "module {module}: `watchdog` needs `location = local`: a built-in module with \
         `location = shared` writes the process image directly, so a scan the watchdog gives \
         up on could still write to it"
    )]
    WatchdogShared { module: String },
    #[error("{origin}: plc_id = {plc_id}: {reason}")]
    BadConfigPlcId {
        origin: Origin,
        plc_id: String,
        reason: String,
    },
    /// Every problem one attempt found, so that none waits for another to be fixed.
    #[error("{}", .0.iter().map(ToString::to_string).collect::<Vec<_>>().join("\n"))]
    Many(Vec<RunError>),
}

impl RunError {
    /// One error, or [`RunError::Many`]; `problems` must not be empty.
    fn many(mut problems: Vec<RunError>) -> RunError {
        if problems.len() == 1 {
            problems.remove(0)
        } else {
            RunError::Many(problems)
        }
    }

    /// The problems, one by one (a [`RunError::Many`] unfolded).
    pub fn problems(&self) -> Vec<&RunError> {
        match self {
            RunError::Many(all) => all.iter().flat_map(RunError::problems).collect(),
            e => vec![e],
        }
    }
}

fn list(what: &str, names: &[String]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("`{n}`")).collect();
    format!(
        "{what}{} {}",
        if names.len() == 1 { "" } else { "s" },
        quoted.join(", ")
    )
}

/// Whose fault it is that the PLC did not start.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NotStarted {
    /// The configuration (or the command line): fix it.
    BadInput,
    /// The machine: the id is taken, a resource is missing or refused.
    CouldNotStart,
}

impl RunError {
    /// Whether the configuration (rather than the machine) is at fault: exit code 2.
    pub fn is_bad_input(&self) -> bool {
        self.kind() == NotStarted::BadInput
    }

    /// Whose fault it is: the configuration's (exit code 2) or the machine's (3).
    pub fn kind(&self) -> NotStarted {
        match self {
            RunError::Many(all) => {
                if all.iter().any(|e| e.kind() == NotStarted::CouldNotStart) {
                    NotStarted::CouldNotStart
                } else {
                    NotStarted::BadInput
                }
            }
            RunError::Spawn { .. }
            | RunError::Taken(_)
            | RunError::Image(ImageError::AlreadyRunning { .. } | ImageError::Os { .. })
            | RunError::Synch(SynchError::Exists { .. } | SynchError::Os { .. })
            | RunError::Owner(OwnerError::Running { .. } | OwnerError::Os { .. })
            | RunError::Clocks(_) => NotStarted::CouldNotStart,
            RunError::Retain(e) if !e.is_bad_input() => NotStarted::CouldNotStart,
            _ => NotStarted::BadInput,
        }
    }
}

/// The PLC id to run under: the one given on the command line, else `[PLC] plc_id`, else
/// `default`.
pub fn plc_id_of(config: &PlcConfig, given: Option<&str>, default: &str) -> String {
    given
        .map(str::to_string)
        .or_else(|| config.plc.get("plc_id").map(|s| s.value.clone()))
        .unwrap_or_else(|| default.to_string())
}

/// What every module thread shares.
struct Shared {
    plc_id: String,
    /// `RunOptions::overrides`, one per line, for program modules.
    overrides: String,
    config_path: PathBuf,
    base_dir: PathBuf,
    config: PlcConfig,
    layout: Layout,
    global: GlobalMap,
    synch: SharedSynch,
    /// The modules' scan clocks, for their watchdogs.
    clocks: ScanClocks,
    /// The retain file and the modules' retained data.
    retain: retain::Retain,
    /// Per module: its `safe` values, checked at start.
    safe: Vec<Vec<SafeValue>>,
    t0: Duration,
    status: Mutex<Vec<ModuleStatus>>,
    failed: AtomicBool,
}

/// A running PLC.
pub struct Plc {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    duration: Option<Duration>,
    /// Released last, once everything else of the PLC is gone.
    owner: Option<Owner>,
}

impl Plc {
    /// Stops every module at its next synchronisation point.
    pub fn stop(&self) {
        self.shared.synch.stop();
    }

    /// A snapshot of the modules' states and statistics.
    pub fn status(&self) -> PlcStatus {
        self.shared.snapshot()
    }

    /// Runs until a module stops the PLC, a failure does, `stop_requested` is set, or the
    /// duration has passed; publishes the status meanwhile; then waits for every module and
    /// removes the PLC's shared memory, status file and lock, in that order.
    pub fn wait(mut self, stop_requested: &AtomicBool) -> PlcStatus {
        let started = period::now();
        let file = status::path(&self.shared.plc_id);
        loop {
            let _ = self.shared.snapshot().write(&file);
            if self.shared.synch.is_stopping() || self.threads.iter().all(|t| t.is_finished()) {
                break;
            }
            let over = self
                .duration
                .is_some_and(|d| period::now().saturating_sub(started) >= d);
            if over || stop_requested.load(Ordering::Relaxed) {
                log::info!("stopping the PLC");
                self.shared.synch.stop();
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        self.shared.synch.stop();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        // Every module has stopped: the last values go to the retain file.
        self.shared.retain.stop();
        let last = self.shared.snapshot();
        let _ = std::fs::remove_file(&file);
        let _ = std::fs::remove_file(status::tmp_path(&file));
        self.finish();
        log::info!("PLC {} stopped", last.plc_id);
        last
    }

    /// Removes the shared memory names, then gives the id up.
    fn finish(&mut self) {
        let _ = GlobalMap::unlink(&self.shared.plc_id);
        let _ = SharedSynch::unlink(&self.shared.plc_id);
        ScanClocks::unlink(&self.shared.plc_id);
        if let Some(owner) = self.owner.take() {
            owner.release();
        }
    }

    /// Whether a module failed (with `on_failure = stop` or `ignore`).
    pub fn failed(&self) -> bool {
        self.shared.failed.load(Ordering::Relaxed)
    }
}

impl Drop for Plc {
    /// A PLC dropped without [`Plc::wait`] (an error in its caller) still stops its modules
    /// and leaves nothing behind.
    fn drop(&mut self) {
        if self.owner.is_none() {
            return;
        }
        self.shared.synch.stop();
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
        self.shared.retain.stop();
        let file = status::path(&self.shared.plc_id);
        let _ = std::fs::remove_file(&file);
        let _ = std::fs::remove_file(status::tmp_path(&file));
        self.finish();
    }
}

impl Shared {
    fn decl(&self, index: usize) -> &ModuleDecl {
        &self.config.modules[index]
    }

    fn set_status(&self, index: usize, f: impl FnOnce(&mut ModuleStatus)) {
        if let Ok(mut s) = self.status.lock() {
            f(&mut s[index]);
        }
    }

    fn snapshot(&self) -> PlcStatus {
        PlcStatus {
            plc_id: self.plc_id.clone(),
            pid: std::process::id(),
            config: self.config_path.display().to_string(),
            uptime: period::now().saturating_sub(self.t0),
            marking: self
                .synch
                .net()
                .places()
                .iter()
                .zip(self.synch.marking())
                .map(|(p, m)| format!("{}={m}", p.name))
                .collect::<Vec<_>>()
                .join(" "),
            modules: self.status.lock().map(|s| s.clone()).unwrap_or_default(),
            retain: self.retain.status(),
        }
    }

    /// Module `index` failed: ends the scan it was in (so that the modules lock-stepped
    /// with it are not left waiting), then acts on its `on_failure`. Returns how long to
    /// wait before restarting it, or `None` if it is failed for good.
    fn failure(&self, index: usize, why: &str, restarts: &mut Restarts) -> Option<Duration> {
        let decl = self.decl(index);
        if let Some(scan) = self.synch.net().scan_ref(&decl.name) {
            if self.synch.abandon_scan(&scan) == Abandoned::EndNotEnabled {
                log::warn!(
                    "module {}: its scan_end ({}) cannot fire on its behalf: the modules \
                     waiting for it will go on waiting",
                    decl.name,
                    self.synch.net().transition_name(scan.end)
                );
            }
        }
        match decl.on_failure {
            OnFailure::Restart => match restarts.next(&decl.restart) {
                Some(delay) => {
                    log::warn!(
                        "module {} failed ({why}); restarting it{}",
                        decl.name,
                        if delay.is_zero() {
                            String::new()
                        } else {
                            format!(" in {}", show_duration(delay))
                        }
                    );
                    self.set_status(index, |s| {
                        s.restarts += 1;
                        s.state = ModuleState::Starting;
                    });
                    Some(delay)
                }
                None => {
                    log::error!(
                        "module {} failed ({why}) after {} restarts in a row \
                         (restart_limit = {}); it stays failed: writing its safe values and \
                         stopping the PLC",
                        decl.name,
                        restarts.in_a_row,
                        decl.restart.limit
                    );
                    self.fail(index);
                    self.synch.stop();
                    None
                }
            },
            OnFailure::Ignore => {
                log::error!(
                    "module {} failed ({why}); writing its safe values, the others go on",
                    decl.name
                );
                self.fail(index);
                None
            }
            OnFailure::Stop => {
                log::error!(
                    "module {} failed ({why}); writing its safe values and stopping the PLC",
                    decl.name
                );
                self.fail(index);
                self.synch.stop();
                None
            }
        }
    }

    /// Module `index` has stopped for good (its thread or process is done): unless it
    /// failed (its safe values are written already), its safe values are written now, so
    /// that a PLC that stops (SIGTERM, `petriplc stop`, Ctrl-C) leaves every output safe.
    fn stopped(&self, index: usize) {
        let failed = lock(&self.status)[index].state == ModuleState::Failed;
        if !failed {
            if let Err(e) = self.write_safe_values(index) {
                log::error!(
                    "module {}: safe values not written: {e}",
                    self.decl(index).name
                );
            }
        }
        self.set_status(index, |s| {
            if s.state != ModuleState::Failed {
                s.state = ModuleState::Stopped;
            }
        });
    }

    /// Marks module `index` failed for good and writes its safe values.
    fn fail(&self, index: usize) {
        self.set_status(index, |s| s.state = ModuleState::Failed);
        self.failed.store(true, Ordering::Relaxed);
        if let Err(e) = self.write_safe_values(index) {
            log::error!(
                "module {}: safe values not written: {e}",
                self.decl(index).name
            );
        }
    }

    /// Writes the module's `safe` values through a map of its own points.
    fn write_safe_values(&self, index: usize) -> Result<(), ImageError> {
        let safe = &self.safe[index];
        if safe.is_empty() {
            return Ok(());
        }
        let decl = self.decl(index);
        // Local whatever the module's location: the runner writes the image itself.
        let mut map = ModuleMap::new(&self.layout, &decl.name, Location::Local)?;
        // The module's other points keep their values: only the safe rows change.
        retained::adopt(&mut map, &self.global, Adopt::All);
        map.update(&self.global);
        for s in safe {
            map.set(&s.handle, s.value)?;
            log::info!("module {}: safe value {}", decl.name, s.text);
        }
        map.update(&self.global);
        Ok(())
    }

    /// Sleeps `delay` before a restart, waking early if the PLC stops; says whether to go on.
    fn pause(&self, delay: Duration) -> bool {
        let until = Instant::now() + delay;
        while !self.synch.is_stopping() {
            let now = Instant::now();
            if now >= until {
                return true;
            }
            std::thread::sleep((until - now).min(Duration::from_millis(50)));
        }
        false
    }
}
