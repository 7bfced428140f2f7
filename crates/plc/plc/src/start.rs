//! Starting a PLC, stage by stage: what the configuration can be blamed for is checked
//! (`checks`), what others may hold is taken, the shared memory is made and retained values
//! restored, every module is initialised before any runs, then threads and programs are
//! started. A start that fails at any stage undoes what the earlier ones made.

use std::path::{Path, PathBuf};
use std::process::Child;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

use petriplc_config::{ConfigError, PlcConfig};
use petriplc_runtime::image::{GlobalMap, Layout, ModuleMap, PointId};
use petriplc_runtime::module::InitContext;
use petriplc_runtime::period;
use petriplc_runtime::report::Receiver;
use petriplc_runtime::retained::{self, Adopt};
use petriplc_runtime::synch::{SharedSynch, SynchNet};
use petriplc_runtime::watchdog::ScanClocks;

use crate::checks::{self, base_dir_of, make_modules, Made};
use crate::run::{end_process, run_thread, spawn, watch_process, Ready};
use crate::{retain, ModuleStatus, Plc, Registry, RunError, RunOptions, Shared};

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
        checks::plc_id(&config, &opts.plc_id)?;
        let layout = Layout::new(&config)?;
        let net = SynchNet::from_config(&config)?;
        let (kinds, safe) =
            checks::before_making(&config, &layout, &net, &base_dir, registry, opts)?;
        let owner = checks::take_what_others_hold(&config, &kinds, &opts.plc_id)?;
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

        let modules = Modules {
            config: &config,
            layout: &layout,
            global: &global,
            retain: &retain,
            base_dir: &base_dir,
            plc_id: &opts.plc_id,
            restored_points: &restored_points,
        };
        let (ready, programs) = modules.init(kinds)?;

        retain.start(&global, &layout, config.retain.write)?;

        let status = initial_status(&config, registry);
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
        let (shared, threads) = launch(shared, ready, programs)?;
        Ok(Plc {
            shared,
            threads,
            duration: opts.duration,
            owner: Some(owner),
        })
    }
}

/// The modules that run a program: their index and the program.
type Programs = Vec<(usize, PathBuf)>;

/// What initialising the modules needs of the PLC being started.
struct Modules<'a> {
    config: &'a PlcConfig,
    layout: &'a Layout,
    global: &'a GlobalMap,
    retain: &'a retain::Retain,
    base_dir: &'a Path,
    plc_id: &'a str,
    restored_points: &'a [PointId],
}

impl Modules<'_> {
    /// Every module is initialised before any runs: a bad setting stops everything, with
    /// nothing half started. Returns the thread modules, ready, and the programs to start.
    fn init(&self, kinds: Vec<Made>) -> Result<(Vec<Ready>, Programs), RunError> {
        let config = self.config;
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
            let mut map = ModuleMap::new(self.layout, &decl.name, decl.location)?;
            retained::adopt(&mut map, self.global, Adopt::Retentive);
            self.retain.registry.new_instance(&decl.name);
            let init = module.init(&mut InitContext {
                decl,
                config,
                map: &mut map,
                base_dir: self.base_dir,
                plc_id: self.plc_id,
                restored_points: self.restored_points,
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
        Ok((ready, programs))
    }
}

/// Every module's status before it runs. A program's path would not fit the kind column: it
/// goes to the detail line.
fn initial_status(config: &PlcConfig, registry: Registry) -> Vec<ModuleStatus> {
    config
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
        .collect()
}

/// Starts a thread per ready module and a process per program (each with a thread watching
/// it); if one cannot be started, those already running are stopped.
fn launch(
    shared: Arc<Shared>,
    ready: Vec<Ready>,
    programs: Programs,
) -> Result<(Arc<Shared>, Vec<JoinHandle<()>>), RunError> {
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
    Ok(starting.done())
}
