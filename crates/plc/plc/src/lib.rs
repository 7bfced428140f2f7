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

mod retain;

use std::os::fd::AsRawFd;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nix::sys::signal::Signal;
use petriplc_config::{
    ConfigError, Location, ModuleDecl, OnFailure, Origin, Override, PlcConfig, PointKind,
    PointValue,
};
use petriplc_runtime::image::{GlobalMap, Handle, ImageError, Layout, ModuleMap, PointId};
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};
use petriplc_runtime::owner::{self, Owner, OwnerError, Probe};
use petriplc_runtime::period::{self, Period, ScanStats};
use petriplc_runtime::process::{self as proc, Pidfd};
use petriplc_runtime::report::{self, Receiver};
use petriplc_runtime::retained::{self, Adopt};
use petriplc_runtime::synch::{
    Abandoned, ScanRef, SharedSynch, SynchError, SynchNet, TransitionRef,
};
use petriplc_runtime::watchdog::{ClockError, ScanClock, ScanClocks};

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

/// One thing the PLC needs that is taken, and how to do without it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Taken {
    /// What is taken and by whom, as far as known.
    pub what: String,
    /// The command-line option that avoids it: `--plc-id ID` or `--set MODULE:listen=ADDR`.
    pub fix: String,
}

fn taken_list(taken: &[Taken]) -> String {
    let lines: Vec<String> = taken
        .iter()
        .map(|t| format!("\n  {}; use {}", t.what, t.fix))
        .collect();
    let n = taken.len();
    if n == 1 {
        format!("something this PLC needs is taken:{}", lines.concat())
    } else {
        format!("{n} things this PLC needs are taken:{}", lines.concat())
    }
}

/// The addresses the modules will listen on that another program (or another module of
/// this configuration) holds, each with a free address to use instead.
fn listen_clashes(config: &PlcConfig, modules: &[(usize, &dyn Module)]) -> Vec<Taken> {
    use std::net::{SocketAddr, TcpListener};
    // Modules that do not say (kinds added later) are taken at their `listen` setting's word.
    let mut wanted: Vec<(&str, &'static str, SocketAddr)> = Vec::new();
    for &(index, module) in modules {
        let decl = &config.modules[index];
        let mut listens = module.listens();
        if listens.is_empty() {
            if let Some(a) = decl
                .settings
                .get("listen")
                .and_then(|s| s.value.parse().ok())
            {
                listens.push(("listen", a));
            }
        }
        wanted.extend(
            listens
                .into_iter()
                .filter(|(_, a): &(_, SocketAddr)| a.port() != 0)
                .map(|(setting, a)| (decl.name.as_str(), setting, a)),
        );
    }
    let mut used: Vec<SocketAddr> = wanted.iter().map(|w| w.2).collect();
    // The next free port after `addr`'s, and not below 1024 (which needs privileges).
    let mut free = |addr: SocketAddr| {
        let mut a = addr;
        a.set_port(a.port().max(1023));
        for _ in 0..200 {
            a.set_port(a.port().checked_add(1).unwrap_or(1024));
            if !used.contains(&a) && TcpListener::bind(a).is_ok() {
                used.push(a);
                return Some(a);
            }
        }
        None
    };
    let mut taken = Vec::new();
    for (i, &(module, setting, addr)) in wanted.iter().enumerate() {
        let why = match wanted[..i].iter().find(|w| w.2 == addr) {
            Some(other) => format!("module {} listens there too", other.0),
            None => match TcpListener::bind(addr) {
                Ok(_) => continue,
                Err(e) if e.kind() == std::io::ErrorKind::AddrInUse => {
                    "another program (another PLC?) listens there".to_string()
                }
                Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied => {
                    "ports below 1024 need root or CAP_NET_BIND_SERVICE".to_string()
                }
                Err(e) => e.to_string(),
            },
        };
        let fix = match free(addr) {
            Some(a) => format!("--set {module}:{setting}={a}"),
            None => format!("--set {module}:{setting}=HOST:PORT"),
        };
        taken.push(Taken {
            what: format!("module {module}: {setting} = {addr}: {why}"),
            fix,
        });
    }
    taken
}

/// An id to suggest when `plc_id` is taken: `ID-2`, `ID-3`, … that no live PLC holds (one
/// a dead PLC left is free: the run that takes it removes the remains).
fn free_plc_id(plc_id: &str) -> String {
    (2..100)
        .map(|n| format!("{plc_id}-{n}"))
        .find(|id| !matches!(owner::probe(id), Ok(Probe::Running { .. })))
        .unwrap_or_else(|| format!("{plc_id}-other"))
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

/// One `safe POINT VALUE` row, checked against the layout.
#[derive(Clone, Debug)]
struct SafeValue {
    handle: Handle,
    value: PointValue,
    text: String,
}

/// A running PLC.
pub struct Plc {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    duration: Option<Duration>,
    /// Released last, once everything else of the PLC is gone.
    owner: Option<Owner>,
}

/// A thread module, initialised and ready.
struct Ready {
    index: usize,
    module: Box<dyn Module>,
    map: ModuleMap,
    factory: Factory,
}

/// What a PLC that is starting has made so far; whatever is left when it is dropped before
/// the PLC runs is undone: threads stopped and joined, processes ended, shared memory and
/// lock removed (by their own `Drop`s, in the reverse order of creation).
struct Starting {
    shared: Option<Arc<Shared>>,
    threads: Vec<JoinHandle<()>>,
    /// Started programs, with their statistics pipes.
    children: Vec<(String, (Child, Receiver))>,
}

impl Starting {
    fn shared(&self) -> &Arc<Shared> {
        self.shared.as_ref().expect("taken only by `done`")
    }

    /// Everything started: the PLC runs.
    fn done(mut self) -> (Arc<Shared>, Vec<JoinHandle<()>>) {
        let shared = self.shared.take().expect("taken only once");
        (shared, std::mem::take(&mut self.threads))
    }
}

impl Drop for Starting {
    fn drop(&mut self) {
        let Some(shared) = &self.shared else { return };
        shared.synch.stop();
        for (name, (child, _)) in &mut self.children {
            end_process(name, child);
        }
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

impl Plc {
    /// Reads `config_path` and starts every module; returns once all run.
    pub fn start(
        config_path: &Path,
        registry: Registry,
        opts: &RunOptions,
    ) -> Result<Plc, RunError> {
        let config = Plc::read_config(config_path, registry, opts)?;
        Plc::start_with(config, config_path, registry, opts)
    }

    /// Reads `config_path` with `opts.overrides` applied, each of which must name a module
    /// (or `PLC`). A configuration with problems has its modules' own settings checked too
    /// (each made by `registry`, or its program found), so that every problem is reported
    /// at once.
    pub fn read_config(
        config_path: &Path,
        registry: Registry,
        opts: &RunOptions,
    ) -> Result<PlcConfig, RunError> {
        let (config, diagnostics) =
            petriplc_config::read_file_partial(config_path, &opts.overrides)?;
        // An override of a module that does not exist is among them (C033).
        if diagnostics.is_empty() {
            return Ok(config);
        }
        let mut problems = vec![RunError::Config(ConfigError { diagnostics })];
        problems.extend(make_modules(&config, &base_dir_of(config_path), registry, opts).1);
        Err(RunError::many(problems))
    }

    /// Starts every module of `config`, read from `config_path` by [`Plc::read_config`]
    /// (relative paths in settings start at its directory); returns once all run. Program
    /// modules are tied to the calling thread: they are killed if it ends (call it from the
    /// thread that runs the PLC, typically the main thread).
    pub fn start_with(
        config: PlcConfig,
        config_path: &Path,
        registry: Registry,
        opts: &RunOptions,
    ) -> Result<Plc, RunError> {
        let base_dir = base_dir_of(config_path);
        if let Err(ImageError::BadPlcId { plc_id, reason }) =
            petriplc_runtime::image::shm::shm_name(&opts.plc_id)
        {
            return Err(match config.plc.get("plc_id") {
                Some(s) if s.value == plc_id => RunError::BadConfigPlcId {
                    origin: s.origin.clone(),
                    plc_id,
                    reason,
                },
                _ => RunError::Image(ImageError::BadPlcId { plc_id, reason }),
            });
        }
        let layout = Layout::new(&config)?;
        let net = SynchNet::from_config(&config)?;

        // Everything the configuration can be blamed for is checked before anything exists,
        // and reported at once: every built-in module is made (its settings checked), every
        // program found, every safe value and watchdog checked.
        let (kinds, mut problems) = make_modules(&config, &base_dir, registry, opts);
        let mut safe = Vec::new();
        for decl in &config.modules {
            match safe_values(&config, &layout, decl) {
                Ok(s) => safe.push(s),
                Err(e) => problems.push(e),
            }
        }
        for (decl, kind) in config.modules.iter().zip(&kinds) {
            if decl.watchdog.is_some() && decl.location == Location::Shared && kind.is_ok() {
                problems.push(RunError::WatchdogShared {
                    module: decl.name.clone(),
                });
            }
        }
        if !problems.is_empty() {
            return Err(RunError::many(problems));
        }
        let programs_fire = kinds.iter().any(Result::is_err);
        if let Some(dead) = net.never_scanning(programs_fire) {
            if !dead.is_empty() {
                return Err(RunError::DeadSynch { modules: dead });
            }
        }

        // What others may hold — the id and the addresses to listen on — is checked as a
        // whole, so that one attempt reports every clash. The id is taken only while a live
        // PLC holds its lock: what a dead one left is removed here, not reported.
        let listening: Vec<(usize, &dyn Module)> = kinds
            .iter()
            .enumerate()
            .filter_map(|(i, k)| k.as_ref().ok().map(|(_, m)| (i, m.as_ref())))
            .collect();
        let mut taken = listen_clashes(&config, &listening);
        let owner = match Owner::acquire(&opts.plc_id) {
            Ok((owner, remains)) => {
                if let Some(r) = remains {
                    log::warn!(
                        "PLC {}: {}; removed what it left ({})",
                        opts.plc_id,
                        r.describe(),
                        r.object_names()
                    );
                }
                Some(owner)
            }
            Err(OwnerError::Running { plc_id, pid }) => {
                taken.insert(
                    0,
                    Taken {
                        what: format!(
                            "PLC id `{plc_id}`: a PLC with this id is running ({}`petriplc \
                             stop --plc-id {plc_id}` stops it)",
                            pid.map(|p| format!("process {p}; ")).unwrap_or_default()
                        ),
                        fix: format!("--plc-id {}", free_plc_id(&plc_id)),
                    },
                );
                None
            }
            Err(e) => return Err(e.into()),
        };
        let owner = match owner {
            Some(o) if taken.is_empty() => o,
            // The id just taken is given up when dropped here.
            _ => return Err(RunError::Taken(taken)),
        };
        let canonical =
            std::fs::canonicalize(config_path).unwrap_or_else(|_| config_path.to_path_buf());
        // The retain file is checked against the configuration before anything is made.
        let data = kinds
            .iter()
            .any(|k| k.as_ref().is_ok_and(|(_, m)| m.retains_data()));
        let (retain, restore) =
            retain::Retain::open(&config, &layout, &base_dir, &canonical, &opts.plc_id, data)?;
        let global = GlobalMap::create(&opts.plc_id, &layout)?;
        let synch = SharedSynch::create(&opts.plc_id, &net)?;
        let clocks = ScanClocks::create(&opts.plc_id, config.modules.len())?;
        // Restored before any module exists: every module's first scan sees these values.
        retained::write(&global, &layout, &restore);
        let restored_points: Vec<PointId> = restore.iter().map(|&(id, _)| id).collect();
        retain.install();

        if !global.priority_inheritance() {
            log::warn!(
                "this system has no priority-inheriting locks: a real-time module waiting for \
                 the process image may wait for lower-priority ones"
            );
        }

        // Every module is initialised before any runs: a bad setting stops everything, with
        // nothing half started.
        let mut ready = Vec::new();
        let mut programs = Vec::new();
        let mut problems = Vec::new();
        for (index, (decl, kind)) in config.modules.iter().zip(kinds).enumerate() {
            let (factory, mut module) = match kind {
                Ok(made) => made,
                Err(program) => {
                    programs.push((index, program));
                    continue;
                }
            };
            let mut map = ModuleMap::new(&layout, &decl.name, decl.location)?;
            retained::adopt(&mut map, &global, Adopt::Retentive);
            retain.registry.new_instance(&decl.name);
            let init = module.init(&mut InitContext {
                decl,
                config: &config,
                map: &mut map,
                base_dir: &base_dir,
                plc_id: &opts.plc_id,
                restored_points: &restored_points,
            });
            // The other modules are initialised too, so that every problem is told at once.
            if let Err(error) = init {
                problems.push(RunError::Init {
                    module: decl.name.clone(),
                    error,
                });
                continue;
            }
            ready.push(Ready {
                index,
                module,
                map,
                factory,
            });
        }
        if !problems.is_empty() {
            for mut r in ready {
                r.module.close();
            }
            return Err(RunError::many(problems));
        }

        retain.start(&global, &layout, config.retain.write)?;

        // A program's path would not fit the kind column: it goes to the detail line.
        let status = config
            .modules
            .iter()
            .map(|m| match registry(&m.kind) {
                Some(_) => ModuleStatus::new(&m.name, &m.kind),
                None => {
                    let mut s = ModuleStatus::new(&m.name, "program");
                    s.detail = std::iter::once(m.kind.as_str())
                        .chain(m.args.iter().map(String::as_str))
                        .collect::<Vec<_>>()
                        .join(" ");
                    s
                }
            })
            .collect();
        let shared = Arc::new(Shared {
            plc_id: opts.plc_id.clone(),
            overrides: opts
                .overrides
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join("\n"),
            config_path: canonical,
            base_dir,
            config,
            layout,
            global,
            synch,
            clocks,
            retain,
            safe,
            t0: period::now(),
            status: Mutex::new(status),
            failed: AtomicBool::new(false),
        });
        let count = |n: usize, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
        log::info!(
            "PLC {} started: {} in {}, {}",
            opts.plc_id,
            count(shared.layout.points().len(), "point"),
            count(shared.layout.words(), "word"),
            count(shared.config.modules.len(), "module")
        );
        let mut starting = Starting {
            shared: Some(shared),
            threads: Vec::new(),
            children: Vec::new(),
        };
        for r in ready {
            let shared = Arc::clone(starting.shared());
            let name = shared.config.modules[r.index].name.clone();
            let handle = std::thread::Builder::new()
                .name(name.clone())
                .spawn(move || run_thread(&shared, r))
                .map_err(|error| RunError::Spawn {
                    module: name,
                    program: "thread".into(),
                    error,
                })?;
            starting.threads.push(handle);
        }
        for (index, program) in &programs {
            let child = spawn(starting.shared(), *index, program)?;
            let name = starting.shared().decl(*index).name.clone();
            starting.children.push((name, child));
        }
        let children = std::mem::take(&mut starting.children);
        for ((index, program), (_, child)) in programs.into_iter().zip(children) {
            let shared = Arc::clone(starting.shared());
            starting.threads.push(std::thread::spawn(move || {
                watch_process(&shared, index, program, child)
            }));
        }
        let (shared, threads) = starting.done();
        Ok(Plc {
            shared,
            threads,
            duration: opts.duration,
            owner: Some(owner),
        })
    }

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

/// The program of a module that is not built in: it must exist and be executable.
/// The folder relative paths of `config_path` start at. `plc.conf` has the parent "",
/// which would send a program path `prog` to a search of PATH: the folder is `.` then.
fn base_dir_of(config_path: &Path) -> PathBuf {
    config_path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// A module made from its declaration by its kind's factory, or the program it runs.
type Made = Result<(Factory, Box<dyn Module>), PathBuf>;

/// Every module of `config`: a built-in one made by its factory (which checks its
/// settings), a program found; with every problem, not only the first. The modules are in
/// declaration order when there is no problem.
fn make_modules(
    config: &PlcConfig,
    base_dir: &Path,
    registry: Registry,
    opts: &RunOptions,
) -> (Vec<Made>, Vec<RunError>) {
    let mut made = Vec::new();
    let mut problems = Vec::new();
    for decl in &config.modules {
        match registry(&decl.kind) {
            Some(_) if decl.location == Location::Isolate => {
                problems.push(RunError::IsolateThread {
                    module: decl.name.clone(),
                })
            }
            Some(factory) => match factory(decl) {
                Ok(module) => made.push(Ok((factory, module))),
                Err(error) => problems.push(RunError::Init {
                    module: decl.name.clone(),
                    error,
                }),
            },
            None => match program_of(decl, base_dir, opts) {
                Ok(program) => made.push(Err(program)),
                Err(e) => problems.push(e),
            },
        }
    }
    (made, problems)
}

fn program_of(decl: &ModuleDecl, base_dir: &Path, opts: &RunOptions) -> Result<PathBuf, RunError> {
    let program = base_dir.join(&decl.kind);
    if !program.is_file() {
        return Err(RunError::UnknownKind {
            module: decl.name.clone(),
            kind: decl.kind.clone(),
            known: opts.known_kinds.join(", "),
            path: program.display().to_string(),
        });
    }
    if nix::unistd::access(&program, nix::unistd::AccessFlags::X_OK).is_err() {
        return Err(RunError::NotExecutable {
            module: decl.name.clone(),
            path: program.display().to_string(),
        });
    }
    // Absolute, so that it is this file that runs and never one found on PATH.
    Ok(std::fs::canonicalize(&program).unwrap_or(program))
}

/// The module's `safe POINT VALUE` rows, each checked: the point exists, the module owns it,
/// the value suits it.
fn safe_values(
    config: &PlcConfig,
    layout: &Layout,
    decl: &ModuleDecl,
) -> Result<Vec<SafeValue>, RunError> {
    let Some(section) = config.sections.get(&decl.name) else {
        return Ok(Vec::new());
    };
    let mut map = ModuleMap::new(layout, &decl.name, Location::Local)?;
    let mut out = Vec::new();
    for row in section.rows.iter().filter(|r| r.table == "safe") {
        let bad = |point: &str, value: &str, reason: String| RunError::Safe {
            module: decl.name.clone(),
            message: format!(
                "{}: module {}: `safe {point} {value}`: {reason}",
                row.origin, decl.name
            ),
        };
        let [point, value] = row.cells.as_slice() else {
            return Err(bad(
                &row.cells.join(" "),
                "",
                "write `safe POINT VALUE`, one point per row".into(),
            ));
        };
        let handle = map
            .handle(point)
            .map_err(|e| bad(point, value, e.to_string()))?;
        if !map.owns(&handle) {
            let owner = &layout.slot(handle.id()).owner;
            return Err(bad(
                point,
                value,
                format!(
                    "the point belongs to module {owner}: a module's safe values are for its \
                     own points"
                ),
            ));
        }
        if layout.slot(handle.id()).retain {
            return Err(bad(
                point,
                value,
                "the point is retentive (`retain`): it keeps the value of its last scan, which \
                 a safe value would overwrite; remove the safe row or the `retain`"
                    .into(),
            ));
        }
        let v = parse_value(value, handle.kind()).ok_or_else(|| {
            bad(
                point,
                value,
                format!(
                    "not a value for a {} point (write {})",
                    match handle.kind() {
                        PointKind::Float => "float",
                        PointKind::Signed => "signed",
                        PointKind::Unsigned => "unsigned",
                    },
                    match handle.kind() {
                        PointKind::Float => "e.g. 0 or 2.5",
                        PointKind::Signed => "e.g. 0 or -3",
                        PointKind::Unsigned => "e.g. 0, 1, true or false",
                    }
                ),
            )
        })?;
        map.set(&handle, v)
            .map_err(|e| bad(point, value, e.to_string()))?;
        out.push(SafeValue {
            handle,
            value: v,
            text: format!("{point} = {value}"),
        });
    }
    Ok(out)
}

fn parse_value(text: &str, kind: PointKind) -> Option<PointValue> {
    match kind {
        PointKind::Float => text.parse().ok().map(PointValue::Float),
        PointKind::Signed => text.parse().ok().map(PointValue::Signed),
        PointKind::Unsigned => match text {
            "true" | "TRUE" => Some(PointValue::Unsigned(1)),
            "false" | "FALSE" => Some(PointValue::Unsigned(0)),
            t => t.parse().ok().map(PointValue::Unsigned),
        },
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

/// How a module's restarts go (`on_failure = restart`): the delay doubles with each
/// failure in a row up to `restart_delay_max`; a run of `restart_delay_max` without failing
/// starts over; `restart_limit` failures in a row fail the module for good.
struct Restarts {
    in_a_row: u32,
    delay: Option<Duration>,
    /// When the module last (re)started.
    since: Instant,
}

impl Restarts {
    fn new() -> Self {
        Restarts {
            in_a_row: 0,
            delay: None,
            since: Instant::now(),
        }
    }

    /// The module (re)starts now.
    fn started(&mut self) {
        self.since = Instant::now();
    }

    /// After a failure: the delay before the next restart, or `None` past the limit.
    fn next(&mut self, policy: &petriplc_config::Restart) -> Option<Duration> {
        if self.since.elapsed() >= policy.delay_max {
            self.in_a_row = 0;
            self.delay = None;
        }
        if policy.limit != 0 && self.in_a_row >= policy.limit {
            return None;
        }
        self.in_a_row += 1;
        let delay = match self.delay {
            None => policy.delay,
            Some(d) => d.saturating_mul(2).min(policy.delay_max),
        };
        self.delay = Some(delay);
        Some(delay)
    }
}

/// A scan's duration for watchdog messages: to a tenth of a millisecond.
fn show_precise(d: Duration) -> String {
    if d < Duration::from_secs(1) {
        format!("{:.1} ms", d.as_secs_f64() * 1e3)
    } else {
        format!("{:.3} s", d.as_secs_f64())
    }
}

fn show_duration(d: Duration) -> String {
    if d < Duration::from_secs(1) {
        format!("{} ms", d.as_millis())
    } else {
        format!("{:.1} s", d.as_secs_f64())
    }
}

fn make(
    factory: Factory,
    decl: &ModuleDecl,
    config: &PlcConfig,
    map: &mut ModuleMap,
    base_dir: &Path,
    plc_id: &str,
    restored_points: &[PointId],
) -> Result<Box<dyn Module>, ModuleError> {
    let mut module = factory(decl)?;
    module.init(&mut InitContext {
        decl,
        config,
        map,
        base_dir,
        plc_id,
        restored_points,
    })?;
    Ok(module)
}

/// How a module instance's run ended.
enum Ended {
    /// The PLC is stopping (or the module stopped it).
    Stopped,
    /// The module failed; the message says how.
    Failed(String),
    /// A scan ran longer than the module's watchdog; the message says how long.
    Watchdog(String),
    /// The watchdog gave up on this instance while it was in a scan (which has now
    /// returned): it must write nothing and report nothing, another instance has taken over.
    Abandoned,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A built-in module's thread: runs instances of the module until the PLC stops, handling
/// failures (errors, panics, scans past the watchdog) by its `on_failure`. With a
/// watchdog, each instance runs on a thread of its own that this one watches.
fn run_thread(shared: &Arc<Shared>, r: Ready) {
    let Ready {
        index,
        module,
        map,
        factory,
    } = r;
    let decl = shared.decl(index);
    let name = decl.name.clone();
    if decl.watchdog.is_none() {
        for w in period::realtime(decl.priority) {
            log::warn!("module {name}: {w}");
        }
    } else {
        // The watcher must get the CPU from a real-time module stuck in a loop.
        let _ = period::realtime(decl.priority.map(|p| p.saturating_add(1).min(99)));
    }
    let stats = Arc::new(Mutex::new(ScanStats::new()));
    let mut restarts = Restarts::new();
    let mut instance = Some((module, map));
    let mut first = true;
    loop {
        let (module, map) = match instance.take() {
            Some(i) => i,
            None => match fresh(shared, index, factory) {
                Ok(i) => i,
                Err(e) => {
                    let why = format!("it could not start again: {e}");
                    match shared.failure(index, &why, &mut restarts) {
                        Some(delay) if shared.pause(delay) => continue,
                        _ => break,
                    }
                }
            },
        };
        shared.set_status(index, |s| {
            s.state = ModuleState::Running;
            s.pid = std::process::id();
        });
        restarts.started();
        let (ended, close_panicked) = match decl.watchdog {
            None => run_instance(shared, index, module, map, &stats),
            Some(limit) => {
                let limit = limit + module.watchdog_grace();
                supervise(shared, index, module, map, &stats, limit, first)
            }
        };
        first = false;
        let why = match ended {
            Ended::Failed(why) => why,
            Ended::Watchdog(why) => {
                // A stuck module's outputs are stale whatever its on_failure: safe now.
                if let Err(e) = shared.write_safe_values(index) {
                    log::error!("module {name}: safe values not written: {e}");
                }
                why
            }
            Ended::Stopped | Ended::Abandoned if close_panicked && !shared.synch.is_stopping() => {
                "the module panicked while closing".to_string()
            }
            Ended::Stopped | Ended::Abandoned => break,
        };
        match shared.failure(index, &why, &mut restarts) {
            Some(delay) if shared.pause(delay) => {}
            _ => break,
        }
    }
    shared.stopped(index);
}

/// Runs one instance of a module until it ends, then closes it and publishes its status;
/// says how it ended and whether closing panicked.
fn run_instance(
    shared: &Shared,
    index: usize,
    mut module: Box<dyn Module>,
    map: ModuleMap,
    stats: &Mutex<ScanStats>,
) -> (Ended, bool) {
    let ended = catch_unwind(AssertUnwindSafe(|| {
        scan_loop(shared, index, &mut *module, map, stats)
    }))
    .unwrap_or_else(|_| Ended::Failed("the module panicked".into()));
    let closed = catch_unwind(AssertUnwindSafe(|| module.close()));
    if let Ended::Abandoned = ended {
        log::warn!(
            "module {}: the scan its watchdog gave up on has returned; that instance is closed \
             and what it did is discarded",
            shared.decl(index).name
        );
        return (Ended::Abandoned, false);
    }
    let (line, marking) =
        catch_unwind(AssertUnwindSafe(|| (module.status(), module.marking()))).unwrap_or_default();
    shared.set_status(index, |s| s.record(&lock(stats), line, marking));
    (ended, closed.is_err())
}

/// Runs one instance on a thread of its own and watches its scans: one that runs longer
/// than `limit` is taken from it (its outputs will never reach the image) and reported as
/// [`Ended::Watchdog`] at once, while the thread may still be stuck in it. A thread cannot
/// be killed: a stuck one is left behind, detached, and ends (or not) on its own; the PLC
/// goes on, and a restart runs a new instance on a new thread.
fn supervise(
    shared: &Arc<Shared>,
    index: usize,
    module: Box<dyn Module>,
    map: ModuleMap,
    stats: &Arc<Mutex<ScanStats>>,
    limit: Duration,
    first: bool,
) -> (Ended, bool) {
    let decl = shared.decl(index);
    let Some(clock) = shared.clocks.clock(index) else {
        return run_instance(shared, index, module, map, stats);
    };
    clock.reset();
    let (tx, rx) = mpsc::channel();
    let worker = {
        let (shared, stats) = (Arc::clone(shared), Arc::clone(stats));
        let (name, priority) = (decl.name.clone(), decl.priority);
        std::thread::Builder::new()
            .name(decl.name.clone())
            .spawn(move || {
                for w in period::realtime(priority) {
                    if first {
                        log::warn!("module {name}: {w}");
                    }
                }
                let _ = tx.send(run_instance(&shared, index, module, map, &stats));
            })
    };
    let worker = match worker {
        Ok(w) => w,
        Err(e) => {
            return (
                Ended::Failed(format!("cannot start its thread: {e}")),
                false,
            )
        }
    };
    // Often enough to see every scan before its deadline, then woken at the deadline.
    let poll = (limit / 2).clamp(Duration::from_millis(1), Duration::from_millis(50));
    loop {
        let wait = match clock.running() {
            Some(t) => (t.began() + limit).saturating_sub(period::now()),
            None => poll,
        };
        match rx.recv_timeout(wait) {
            Ok(ended) => {
                let _ = worker.join();
                return ended;
            }
            Err(RecvTimeoutError::Disconnected) => {
                let _ = worker.join();
                return (
                    Ended::Failed("its thread ended without a word".into()),
                    false,
                );
            }
            Err(RecvTimeoutError::Timeout) => {
                let Some(t) = clock.running() else { continue };
                let ran = period::now().saturating_sub(t.began());
                if ran >= limit && clock.expire(t) {
                    // Detached: never joined, so a stop does not wait for it either.
                    drop(worker);
                    return (
                        Ended::Watchdog(format!(
                            "its scan has run {} without ending, longer than its watchdog \
                             ({}): it is stuck or too slow; the scan is abandoned and nothing \
                             it writes reaches the image",
                            show_precise(ran),
                            show_precise(limit)
                        )),
                        false,
                    );
                }
            }
        }
    }
}

/// A fresh instance of a built-in module and a fresh map, as a new process would get.
fn fresh(
    shared: &Shared,
    index: usize,
    factory: Factory,
) -> Result<(Box<dyn Module>, ModuleMap), ModuleError> {
    let decl = shared.decl(index);
    let mut map = ModuleMap::new(&shared.layout, &decl.name, decl.location)
        .map_err(|e| ModuleError::new(e.to_string()))?;
    // Its retentive points go on from the last committed scan, not from their init values.
    retained::adopt(&mut map, &shared.global, Adopt::Retentive);
    map.update(&shared.global);
    shared.retain.registry.new_instance(&decl.name);
    // Every retentive point goes on from where the failed instance left it.
    let restored = retained::points(&shared.layout);
    let module = catch_unwind(AssertUnwindSafe(|| {
        make(
            factory,
            decl,
            &shared.config,
            &mut map,
            &shared.base_dir,
            &shared.plc_id,
            &restored,
        )
    }))
    .unwrap_or_else(|_| Err(ModuleError::new("the module panicked while starting")))?;
    Ok((module, map))
}

/// The scan loop of one instance of a built-in module.
fn scan_loop(
    shared: &Shared,
    index: usize,
    module: &mut dyn Module,
    mut map: ModuleMap,
    stats: &Mutex<ScanStats>,
) -> Ended {
    let decl = shared.decl(index);
    let name = &decl.name;
    let net = shared.synch.net();
    let scan_ref = net.scan_ref(name);
    // A module's own default period is for running alone: in the synchronisation net, the
    // net paces it.
    let mut period = decl
        .scan_period
        .or_else(|| module.default_scan_period().filter(|_| scan_ref.is_none()))
        .filter(|p| !p.is_zero())
        .map(|p| Period::starting_at(shared.t0, p));
    let watchdog: Option<(Duration, ScanClock)> = decl
        .watchdog
        .and_then(|limit| Some((limit, shared.clocks.clock(index)?)));
    // Retained data the module registered is committed with its end-of-scan update.
    let data = shared.retain.registry.module(name);
    let commits = !data.is_empty();
    let commit = |map: &mut ModuleMap| {
        if commits {
            data.commit(|| map.update(&shared.global));
        } else {
            map.update(&shared.global);
        }
    };
    // The status file is rewritten every 50 ms: a fresh status line and marking every 25 ms
    // is enough, and a module scanning every 100 µs does not pay for formatting them.
    let mut published = Duration::ZERO;
    let mut scan = 0u64;
    loop {
        let (late, missed, started) = match &mut period {
            Some(p) => {
                let w = p.wait();
                (w.late, w.missed, w.woke())
            }
            None => (Duration::ZERO, 0, period::now()),
        };
        if begin(shared, scan_ref.as_ref()).is_err() {
            return Ended::Stopped;
        }
        map.update(&shared.global);
        let token = watchdog.as_ref().map(|(_, c)| c.begin());
        let mut ctx = ScanContext {
            now: period::now().saturating_sub(shared.t0),
            scan,
            map: &mut map,
        };
        let result = module.scan(&mut ctx);
        if let (Some((limit, clock)), Some(t)) = (&watchdog, token) {
            if !clock.end(t) {
                return Ended::Abandoned;
            }
            let took = period::now().saturating_sub(t.began());
            // A module that failed its own scan for taking too long (the iec engine) says
            // where it was: its message is the better one.
            if took > *limit && result.is_ok() {
                data.discard();
                return Ended::Watchdog(format!(
                    "its scan took {}, longer than its watchdog ({}); its outputs were not \
                     written",
                    show_precise(took),
                    show_precise(*limit)
                ));
            }
        }
        match result {
            Ok(Control::Continue) => {}
            Ok(Control::StopPlc) => {
                log::info!("module {name} stops the PLC");
                commit(&mut map);
                shared.synch.stop();
                return Ended::Stopped;
            }
            // The failed scan's outputs are not written: its map is dropped unexchanged.
            Err(e) => {
                data.discard();
                return Ended::Failed(e.0);
            }
        }
        commit(&mut map);
        if end(shared, scan_ref.as_ref()).is_err() {
            return Ended::Stopped;
        }
        lock(stats).record(period::now().saturating_sub(started), late, missed);
        scan += 1;
        let now = period::now();
        if now.saturating_sub(published) >= Duration::from_millis(25) {
            published = now;
            let (line, marking) = (module.status(), module.marking());
            shared.set_status(index, |s| s.record(&lock(stats), line, marking));
        }
    }
}

fn begin(shared: &Shared, scan: Option<&ScanRef>) -> Result<(), petriplc_runtime::synch::Stopped> {
    match scan {
        Some(s) => shared.synch.begin_scan(s).map(drop),
        None => shared.synch.synch(TransitionRef::Null).map(drop),
    }
}

fn end(shared: &Shared, scan: Option<&ScanRef>) -> Result<(), petriplc_runtime::synch::Stopped> {
    match scan {
        Some(s) => shared.synch.end_scan(s).map(drop),
        None => shared.synch.synch(TransitionRef::Null).map(drop),
    }
}

/// Starts module `index`'s program, with a pipe for its scan statistics, tied to the calling
/// thread: it gets SIGKILL if that thread (the PLC) dies, so no module outlives a PLC killed
/// with `kill -9`.
fn spawn(shared: &Shared, index: usize, program: &Path) -> Result<(Child, Receiver), RunError> {
    let decl = shared.decl(index);
    let failed = |error| RunError::Spawn {
        module: decl.name.clone(),
        program: program.display().to_string(),
        error,
    };
    let (stats, stats_fd) = Receiver::pipe().map_err(failed)?;
    let mut command = Command::new(program);
    command
        .args(&decl.args)
        .env("PETRIPLC_CONFIG", &shared.config_path)
        .env("PETRIPLC_SET", &shared.overrides)
        .env("PETRIPLC_MODULE", &decl.name)
        .env("PETRIPLC_PLC_ID", &shared.plc_id)
        .env(report::STATS_FD, stats_fd.as_raw_fd().to_string());
    let child = proc::spawn_tied(&mut command, Signal::SIGKILL).map_err(failed)?;
    // The child has its copy; ours would only keep the pipe open.
    drop(stats_fd);
    let pid = child.id();
    shared.set_status(index, |s| {
        s.state = ModuleState::Running;
        s.pid = pid;
    });
    log::info!(
        "module {} runs as process {pid} ({})",
        decl.name,
        program.display()
    );
    Ok((child, stats))
}

/// Watches a module process: restarts it or stops the PLC when it dies unasked (through its
/// `on_failure`), and ends it when the PLC stops (it should leave on its own at its next
/// synch; else SIGTERM, SIGKILL). Its scan statistics come through `stats`. With a
/// watchdog, a scan that runs longer (as the process's scan clock shows) gets the process
/// killed, and the death goes through `on_failure` as a watchdog failure.
fn watch_process(
    shared: &Shared,
    index: usize,
    program: PathBuf,
    (mut child, mut stats): (Child, Receiver),
) {
    let decl = shared.decl(index);
    let name = decl.name.clone();
    let watchdog: Option<(Duration, ScanClock)> = decl
        .watchdog
        .and_then(|limit| Some((limit, shared.clocks.clock(index)?)));
    if watchdog.is_some() {
        // The watcher must get the CPU from a real-time module stuck in a loop.
        let _ = period::realtime(decl.priority.map(|p| p.saturating_add(1).min(99)));
    }
    let mut restarts = Restarts::new();
    // A pidfd wakes the watcher the moment the process exits; polling is the fallback.
    let mut pidfd = Pidfd::open(child.id()).ok();
    // Set when the watchdog killed the process: the reason its death is reported with.
    let mut killed: Option<String> = None;
    loop {
        // Read after the exit is seen, so that the process's last report is in.
        let exited = child.try_wait();
        if let Some(r) = stats.latest() {
            shared.set_status(index, |s| r.apply(s));
        }
        match exited {
            Ok(Some(exit)) if shared.synch.is_stopping() && killed.is_none() => {
                log::info!("module {name} (process) ended: {exit}");
                shared.stopped(index);
                return;
            }
            Ok(Some(exit)) => {
                let why = match killed.take() {
                    Some(why) => {
                        if let Err(e) = shared.write_safe_values(index) {
                            log::error!("module {name}: safe values not written: {e}");
                        }
                        why
                    }
                    None => format!("its process ended: {exit}"),
                };
                let delay = shared.failure(index, &why, &mut restarts);
                match delay {
                    Some(d) if shared.pause(d) => {}
                    _ => {
                        shared.stopped(index);
                        return;
                    }
                }
                if let Some((_, clock)) = &watchdog {
                    clock.reset();
                }
                match spawn(shared, index, &program) {
                    Ok(c) => {
                        (child, stats) = c;
                        pidfd = Pidfd::open(child.id()).ok();
                        restarts.started();
                    }
                    Err(e) => {
                        log::error!("{e}");
                        shared.fail(index);
                        shared.synch.stop();
                        return;
                    }
                }
            }
            Ok(None) if shared.synch.is_stopping() && killed.is_none() => {
                end_process(&name, &mut child);
                let last = stats.latest();
                shared.set_status(index, |s| {
                    if let Some(r) = last {
                        r.apply(s);
                    }
                });
                shared.stopped(index);
                return;
            }
            Ok(None) => {
                let wait = match &watchdog {
                    None => Duration::from_millis(50),
                    Some((limit, clock)) => match clock.running() {
                        Some(t) => (t.began() + *limit).saturating_sub(period::now()),
                        None => *limit / 2,
                    }
                    .clamp(Duration::from_micros(100), Duration::from_millis(50)),
                };
                match &pidfd {
                    Some(fd) => {
                        fd.wait_exit(wait);
                    }
                    None => std::thread::sleep(wait.min(Duration::from_millis(20))),
                }
                if let Some((limit, clock)) = &watchdog {
                    if let Some(t) = clock.running() {
                        let ran = period::now().saturating_sub(t.began());
                        if ran >= *limit && killed.is_none() && clock.expire(t) {
                            killed = Some(format!(
                                "its scan has run {} without ending, longer than its watchdog \
                                 ({}): it is stuck or too slow; its process is killed",
                                show_precise(ran),
                                show_precise(*limit)
                            ));
                            // Our own unreaped child: its pid cannot have been reused.
                            let _ = child.kill();
                        }
                    }
                }
            }
            Err(e) => {
                log::error!("module {name}: cannot watch its process: {e}");
                return;
            }
        }
    }
}

fn end_process(name: &str, child: &mut Child) {
    use nix::sys::signal::kill;
    use nix::unistd::Pid;
    let pid = Pid::from_raw(child.id() as i32);
    for (signal, grace) in [
        (None, 2000),
        (Some(Signal::SIGTERM), 2000),
        (Some(Signal::SIGKILL), 0),
    ] {
        if let Some(s) = signal {
            log::warn!("module {name} did not stop; sending {s}");
            // Our own unreaped child: its pid cannot have been reused.
            let _ = kill(pid, s);
        }
        for _ in 0..grace / 20 {
            if let Ok(Some(_)) = child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }
    let _ = child.wait();
}
