//! The soft PLC runner behind `petriplc run`: reads a configuration, sets up the process
//! image and the synchronisation net in shared memory, initialises every module (nothing
//! starts if one fails), then runs built-in modules as threads and other programs as
//! processes, each scan framed as seed 000 frames it: period wait, `scan_beg` synch,
//! `update()`, the scan, `update()`, `scan_end` synch. Failures follow each module's
//! `on_failure`; the state and statistics of every module are published for `petriplc status`.

use std::os::fd::AsRawFd;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use petriplc_config::{
    ConfigError, Location, ModuleDecl, OnFailure, Override, PlcConfig, PointValue,
};
use petriplc_runtime::image::{GlobalMap, ImageError, Layout, ModuleMap};
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};
use petriplc_runtime::period::{self, Period, ScanStats};
use petriplc_runtime::report::{self, Receiver};
use petriplc_runtime::synch::{SharedSynch, SynchError, SynchNet, TransitionRef};

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
    #[error("--set {setting}: there is no module of that name; the configuration declares {}", .modules.join(", "))]
    Override {
        setting: String,
        modules: Vec<String>,
    },
    /// What the PLC needs and others hold: its id, the addresses its modules listen on.
    /// Every one is listed, each with the command-line option that avoids it.
    #[error("nothing was started: {}", taken_list(.0))]
    Taken(Vec<Taken>),
    #[error("module {module}: cannot start program {program}: {source}")]
    Spawn {
        module: String,
        program: String,
        #[source]
        source: std::io::Error,
    },
}

impl RunError {
    /// Whether the configuration (rather than the machine) is at fault: exit code 2.
    pub fn is_bad_input(&self) -> bool {
        !self.cannot_start()
    }

    /// Whether something the PLC needs is taken or missing (a PLC id, a port, a program
    /// that cannot be run), rather than the configuration wrong: exit code 3.
    pub fn cannot_start(&self) -> bool {
        matches!(
            self,
            RunError::Spawn { .. }
                | RunError::Taken(_)
                | RunError::Image(ImageError::AlreadyRunning { .. })
                | RunError::Synch(SynchError::Exists { .. })
        )
    }
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

/// An id to suggest when `plc_id` is taken: `ID-2`, `ID-3`, … whose PLC is not running.
fn free_plc_id(plc_id: &str) -> String {
    (2..100)
        .map(|n| format!("{plc_id}-{n}"))
        .find(|id| !status::path(id).exists())
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
    t0: Duration,
    status: Mutex<Vec<ModuleStatus>>,
    failed: AtomicBool,
}

/// A running PLC.
pub struct Plc {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    duration: Option<Duration>,
}

/// A thread module, initialised and ready.
struct Ready {
    index: usize,
    module: Box<dyn Module>,
    map: ModuleMap,
    factory: Factory,
}

impl Plc {
    /// Reads `config_path` and starts every module; returns once all run.
    pub fn start(
        config_path: &Path,
        registry: Registry,
        opts: &RunOptions,
    ) -> Result<Plc, RunError> {
        let config = Plc::read_config(config_path, opts)?;
        Plc::start_with(config, config_path, registry, opts)
    }

    /// Reads `config_path` with `opts.overrides` applied, each of which must name a module
    /// (or `PLC`).
    pub fn read_config(config_path: &Path, opts: &RunOptions) -> Result<PlcConfig, RunError> {
        let config = petriplc_config::read_file_with(config_path, &opts.overrides)?;
        for o in &opts.overrides {
            if o.section != "PLC" && !config.modules.iter().any(|m| m.name == o.section) {
                return Err(RunError::Override {
                    setting: format!("{}:{}={}", o.section, o.name, o.value),
                    modules: config.modules.iter().map(|m| m.name.clone()).collect(),
                });
            }
        }
        Ok(config)
    }

    /// Starts every module of `config`, read from `config_path` by [`Plc::read_config`]
    /// (relative paths in settings start at its directory); returns once all run.
    pub fn start_with(
        config: PlcConfig,
        config_path: &Path,
        registry: Registry,
        opts: &RunOptions,
    ) -> Result<Plc, RunError> {
        let base_dir = config_path
            .parent()
            .map_or_else(|| PathBuf::from("."), Path::to_path_buf);
        let layout = Layout::new(&config)?;
        let net = SynchNet::from_config(&config)?;

        // Every built-in module is made (its settings checked) before anything is created.
        let mut made = Vec::new();
        let mut programs = Vec::new();
        for (index, decl) in config.modules.iter().enumerate() {
            match registry(&decl.kind) {
                Some(factory) => {
                    if decl.location == Location::Isolate {
                        return Err(RunError::IsolateThread {
                            module: decl.name.clone(),
                        });
                    }
                    let module = factory(decl).map_err(|error| RunError::Init {
                        module: decl.name.clone(),
                        error,
                    })?;
                    made.push((index, factory, module));
                }
                None => {
                    let program = base_dir.join(&decl.kind);
                    if !program.is_file() {
                        return Err(RunError::UnknownKind {
                            module: decl.name.clone(),
                            kind: decl.kind.clone(),
                            known: opts.known_kinds.join(", "),
                            path: program.display().to_string(),
                        });
                    }
                    programs.push((index, program));
                }
            }
        }

        // What others may hold — the id and the addresses to listen on — is checked as a
        // whole, so that one attempt reports every clash.
        let listening: Vec<(usize, &dyn Module)> =
            made.iter().map(|(i, _, m)| (*i, m.as_ref())).collect();
        let mut taken = listen_clashes(&config, &listening);
        let global = match GlobalMap::create(&opts.plc_id, &layout) {
            Ok(g) => Some(g),
            Err(ImageError::AlreadyRunning { plc_id, shm, stale }) => {
                taken.insert(
                    0,
                    Taken {
                        what: if stale.is_empty() {
                            format!(
                                "PLC id `{plc_id}`: a PLC with this id is running (shared \
                                 memory `{shm}` exists)"
                            )
                        } else {
                            format!("PLC id `{plc_id}`: shared memory `{shm}` exists{stale}")
                        },
                        fix: format!("--plc-id {}", free_plc_id(&plc_id)),
                    },
                );
                None
            }
            Err(e) => return Err(e.into()),
        };
        let global = match global {
            Some(g) if taken.is_empty() => g,
            // The image just created is removed when dropped here.
            _ => return Err(RunError::Taken(taken)),
        };
        let synch = SharedSynch::create(&opts.plc_id, &net)?;

        // Every module is initialised before any runs: a bad setting stops everything, with
        // nothing half started.
        let mut ready = Vec::new();
        for (index, factory, mut module) in made {
            let decl = &config.modules[index];
            let mut map = ModuleMap::new(&layout, &decl.name, decl.location)?;
            module
                .init(&mut InitContext {
                    decl,
                    config: &config,
                    map: &mut map,
                    base_dir: &base_dir,
                    plc_id: &opts.plc_id,
                })
                .map_err(|error| RunError::Init {
                    module: decl.name.clone(),
                    error,
                })?;
            ready.push(Ready {
                index,
                module,
                map,
                factory,
            });
        }

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
                .map(|o| format!("{}:{}={}", o.section, o.name, o.value))
                .collect::<Vec<_>>()
                .join("\n"),
            config_path: std::fs::canonicalize(config_path)
                .unwrap_or_else(|_| config_path.to_path_buf()),
            base_dir,
            config,
            layout,
            global,
            synch,
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
        let mut threads = Vec::new();
        for r in ready {
            let shared = Arc::clone(&shared);
            let name = shared.config.modules[r.index].name.clone();
            let handle = std::thread::Builder::new()
                .name(name.clone())
                .spawn(move || run_thread(&shared, r))
                .map_err(|source| RunError::Spawn {
                    module: name,
                    program: "thread".into(),
                    source,
                })?;
            threads.push(handle);
        }
        for (index, program) in programs {
            let child = spawn(&shared, index, &program)?;
            let shared = Arc::clone(&shared);
            threads.push(std::thread::spawn(move || {
                watch_process(&shared, index, program, child)
            }));
        }
        Ok(Plc {
            shared,
            threads,
            duration: opts.duration,
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
    /// duration has passed; publishes the status meanwhile; then waits for every module.
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
        let last = self.shared.snapshot();
        let _ = std::fs::remove_file(&file);
        log::info!("PLC {} stopped", self.shared.plc_id);
        last
    }

    /// Whether a module failed (with `on_failure = stop` or `ignore`).
    pub fn failed(&self) -> bool {
        self.shared.failed.load(Ordering::Relaxed)
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
        }
    }

    /// A module failed: by its `on_failure`, say whether to try again.
    fn failure(&self, index: usize, why: &str) -> bool {
        let decl = self.decl(index);
        match decl.on_failure {
            OnFailure::Restart => {
                log::warn!("module {} failed ({why}); restarting it", decl.name);
                self.set_status(index, |s| s.restarts += 1);
                true
            }
            OnFailure::Ignore => {
                log::error!("module {} failed ({why}); the others go on", decl.name);
                self.set_status(index, |s| s.state = ModuleState::Failed);
                self.failed.store(true, Ordering::Relaxed);
                false
            }
            OnFailure::Stop => {
                log::error!(
                    "module {} failed ({why}); writing its safe values and stopping the PLC",
                    decl.name
                );
                self.set_status(index, |s| s.state = ModuleState::Failed);
                self.failed.store(true, Ordering::Relaxed);
                if let Err(e) = self.write_safe_values(decl) {
                    log::error!("module {}: safe values not written: {e}", decl.name);
                }
                self.synch.stop();
                false
            }
        }
    }

    /// Writes the module section's `safe POINT VALUE` rows through the module's own map.
    fn write_safe_values(&self, decl: &ModuleDecl) -> Result<(), String> {
        let Some(section) = self.config.sections.get(&decl.name) else {
            return Ok(());
        };
        let mut map =
            ModuleMap::new(&self.layout, &decl.name, decl.location).map_err(|e| e.to_string())?;
        map.update(&self.global);
        for row in section.rows.iter().filter(|r| r.table == "safe") {
            let [point, value] = row.cells.as_slice() else {
                return Err(format!("{}: write `safe POINT VALUE`", row.origin));
            };
            let h = map
                .handle(point)
                .map_err(|e| format!("{}: {e}", row.origin))?;
            let v = parse_value(value).ok_or_else(|| {
                format!(
                    "{}: `{value}` is not a value (write 0, 1, -3 or 2.5)",
                    row.origin
                )
            })?;
            map.set(&h, v).map_err(|e| format!("{}: {e}", row.origin))?;
            log::info!("module {}: safe value {point} = {value}", decl.name);
        }
        map.update(&self.global);
        Ok(())
    }
}

fn parse_value(text: &str) -> Option<PointValue> {
    match text {
        "true" | "TRUE" => Some(PointValue::Unsigned(1)),
        "false" | "FALSE" => Some(PointValue::Unsigned(0)),
        t if t.contains(['.', 'e', 'E']) => t.parse().ok().map(PointValue::Float),
        t if t.starts_with(['-', '+']) => t.parse().ok().map(PointValue::Signed),
        t => t.parse().ok().map(PointValue::Unsigned),
    }
}

fn make(
    factory: Factory,
    decl: &ModuleDecl,
    config: &PlcConfig,
    map: &mut ModuleMap,
    base_dir: &Path,
    plc_id: &str,
) -> Result<Box<dyn Module>, ModuleError> {
    let mut module = factory(decl)?;
    module.init(&mut InitContext {
        decl,
        config,
        map,
        base_dir,
        plc_id,
    })?;
    Ok(module)
}

/// The scan loop of a built-in module.
fn run_thread(shared: &Shared, r: Ready) {
    let Ready {
        index,
        mut module,
        mut map,
        factory,
    } = r;
    let decl = shared.decl(index);
    let name = decl.name.clone();
    for w in period::realtime(decl.priority) {
        log::warn!("module {name}: {w}");
    }
    shared.set_status(index, |s| {
        s.state = ModuleState::Running;
        s.pid = std::process::id();
    });
    let net = shared.synch.net();
    let (beg, end) = (net.scan_beg(&name), net.scan_end(&name));
    // A module's own default period is for running alone: in the synchronisation net, the
    // net paces it.
    let alone = beg == TransitionRef::Null && end == TransitionRef::Null;
    let mut period = decl
        .scan_period
        .or_else(|| module.default_scan_period().filter(|_| alone))
        .filter(|p| !p.is_zero())
        .map(|p| Period::starting_at(shared.t0, p));
    // The status file is rewritten every 50 ms: a fresh status line and marking every 25 ms
    // is enough, and a module scanning every 100 µs does not pay for formatting them.
    let mut published = Duration::ZERO;
    let mut stats = ScanStats::new();
    let mut scan = 0u64;
    'scans: loop {
        let (late, missed, started) = match &mut period {
            Some(p) => {
                let w = p.wait();
                (w.late, w.missed, w.woke())
            }
            None => (Duration::ZERO, 0, period::now()),
        };
        if shared.synch.synch(beg).is_err() {
            break;
        }
        map.update(&shared.global);
        let mut ctx = ScanContext {
            now: period::now().saturating_sub(shared.t0),
            scan,
            map: &mut map,
        };
        let outcome = catch_unwind(AssertUnwindSafe(|| module.scan(&mut ctx)))
            .unwrap_or_else(|_| Err(ModuleError::new("the module panicked")));
        match outcome {
            Ok(Control::Continue) => {}
            Ok(Control::StopPlc) => {
                log::info!("module {name} stops the PLC");
                map.update(&shared.global);
                shared.synch.stop();
                break;
            }
            Err(e) => {
                module.close();
                if !shared.failure(index, &e.0) {
                    return;
                }
                // Restart: a fresh instance and a fresh map, as a new process would get.
                loop {
                    let fresh = ModuleMap::new(&shared.layout, &name, decl.location)
                        .map_err(|e| ModuleError::new(e.to_string()))
                        .and_then(|mut m| {
                            m.update(&shared.global);
                            make(
                                factory,
                                decl,
                                &shared.config,
                                &mut m,
                                &shared.base_dir,
                                &shared.plc_id,
                            )
                            .map(|module| (module, m))
                        });
                    match fresh {
                        Ok((m, fresh_map)) => {
                            module = m;
                            map = fresh_map;
                            continue 'scans;
                        }
                        Err(e) if shared.synch.is_stopping() => {
                            log::error!("module {name} could not restart: {e}");
                            break 'scans;
                        }
                        Err(e) => {
                            log::error!("module {name} could not restart: {e}; retrying in 1 s");
                            std::thread::sleep(Duration::from_secs(1));
                        }
                    }
                }
            }
        }
        map.update(&shared.global);
        if shared.synch.synch(end).is_err() {
            break;
        }
        stats.record(period::now().saturating_sub(started), late, missed);
        scan += 1;
        let now = period::now();
        if now.saturating_sub(published) >= Duration::from_millis(25) {
            published = now;
            let (line, marking) = (module.status(), module.marking());
            shared.set_status(index, |s| s.record(&stats, line, marking));
        }
    }
    module.close();
    shared.set_status(index, |s| {
        s.record(&stats, module.status(), module.marking());
        if s.state != ModuleState::Failed {
            s.state = ModuleState::Stopped;
        }
    });
}

/// Starts a module's program, with a pipe for its scan statistics.
fn spawn(shared: &Shared, index: usize, program: &Path) -> Result<(Child, Receiver), RunError> {
    let decl = shared.decl(index);
    let failed = |source| RunError::Spawn {
        module: decl.name.clone(),
        program: program.display().to_string(),
        source,
    };
    let (stats, stats_fd) = Receiver::pipe().map_err(failed)?;
    let child = Command::new(program)
        .args(&decl.args)
        .env("PETRIPLC_CONFIG", &shared.config_path)
        .env("PETRIPLC_SET", &shared.overrides)
        .env("PETRIPLC_MODULE", &decl.name)
        .env("PETRIPLC_PLC_ID", &shared.plc_id)
        .env(report::STATS_FD, stats_fd.as_raw_fd().to_string())
        .spawn()
        .map_err(failed)?;
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

/// Watches a module process: restarts or stops the PLC when it dies unasked, and ends it
/// when the PLC stops (it should leave on its own at its next synch; else SIGTERM, SIGKILL).
fn watch_process(
    shared: &Shared,
    index: usize,
    program: PathBuf,
    (mut child, mut stats): (Child, Receiver),
) {
    let name = shared.decl(index).name.clone();
    loop {
        // Read after the exit is seen, so that the process's last report is in.
        let exited = child.try_wait();
        if let Some(r) = stats.latest() {
            shared.set_status(index, |s| r.apply(s));
        }
        match exited {
            Ok(Some(exit)) if shared.synch.is_stopping() => {
                log::info!("module {name} (process) ended: {exit}");
                shared.set_status(index, |s| {
                    if s.state != ModuleState::Failed {
                        s.state = ModuleState::Stopped;
                    }
                });
                return;
            }
            Ok(Some(exit)) => {
                if !shared.failure(index, &format!("its process ended: {exit}")) {
                    return;
                }
                match spawn(shared, index, &program) {
                    Ok(c) => (child, stats) = c,
                    Err(e) => {
                        log::error!("{e}");
                        shared.failed.store(true, Ordering::Relaxed);
                        shared.synch.stop();
                        return;
                    }
                }
            }
            Ok(None) if shared.synch.is_stopping() => {
                end_process(&name, &mut child);
                let last = stats.latest();
                shared.set_status(index, |s| {
                    if let Some(r) = last {
                        r.apply(s);
                    }
                    if s.state != ModuleState::Failed {
                        s.state = ModuleState::Stopped;
                    }
                });
                return;
            }
            Ok(None) => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => {
                log::error!("module {name}: cannot watch its process: {e}");
                return;
            }
        }
    }
}

fn end_process(name: &str, child: &mut Child) {
    use nix::sys::signal::{kill, Signal};
    use nix::unistd::Pid;
    let pid = Pid::from_raw(child.id() as i32);
    for (signal, grace) in [
        (None, 2000),
        (Some(Signal::SIGTERM), 2000),
        (Some(Signal::SIGKILL), 0),
    ] {
        if let Some(s) = signal {
            log::warn!("module {name} did not stop; sending {s}");
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
