//! What a start checks before it makes anything: the PLC id, every module's settings or
//! program, safe values, watchdogs, a synchronisation net that lets every module scan; then
//! what others may hold (the PLC id's lock, the addresses modules listen on), every clash
//! reported at once with its fix.

use std::path::{Path, PathBuf};

use petriplc_config::{Location, ModuleDecl, PlcConfig, PointKind, PointValue};
use petriplc_runtime::image::{Handle, ImageError, Layout, ModuleMap};
use petriplc_runtime::module::{Factory, Module};
use petriplc_runtime::owner::{self, Owner, OwnerError, Probe};
use petriplc_runtime::synch::SynchNet;

use crate::{Registry, RunError, RunOptions};

/// The PLC id must name shared memory objects; one set in the configuration is blamed on
/// its line.
pub(crate) fn plc_id(config: &PlcConfig, plc_id: &str) -> Result<(), RunError> {
    if let Err(ImageError::BadPlcId { plc_id, reason }) =
        petriplc_runtime::image::shm::shm_name(plc_id)
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
    Ok(())
}

/// Everything the configuration can be blamed for, checked before anything exists and
/// reported at once: every built-in module is made (its settings checked), every program
/// found, every safe value and watchdog checked; then whether the synchronisation net lets
/// every module scan. Returns the modules made and their safe values.
pub(crate) fn before_making(
    config: &PlcConfig,
    layout: &Layout,
    net: &SynchNet,
    base_dir: &Path,
    registry: Registry,
    opts: &RunOptions,
) -> Result<(Vec<Made>, Vec<Vec<SafeValue>>), RunError> {
    let (kinds, mut problems) = make_modules(config, base_dir, registry, opts);
    let mut safe = Vec::new();
    for decl in &config.modules {
        match safe_values(config, layout, decl) {
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
    Ok((kinds, safe))
}

/// What others may hold — the id and the addresses to listen on — is checked as a whole, so
/// that one attempt reports every clash. The id is taken only while a live PLC holds its
/// lock: what a dead one left is removed here, not reported.
pub(crate) fn take_what_others_hold(
    config: &PlcConfig,
    kinds: &[Made],
    plc_id: &str,
) -> Result<Owner, RunError> {
    let listening: Vec<(usize, &dyn Module)> = kinds
        .iter()
        .enumerate()
        .filter_map(|(i, k)| k.as_ref().ok().map(|(_, m)| (i, m.as_ref())))
        .collect();
    let mut taken = listen_clashes(config, &listening);
    let owner = match Owner::acquire(plc_id) {
        Ok((owner, remains)) => {
            if let Some(r) = remains {
                log::warn!(
                    "PLC {}: {}; removed what it left ({})",
                    plc_id,
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
    match owner {
        Some(o) if taken.is_empty() => Ok(o),
        // The id just taken is given up when dropped here.
        _ => Err(RunError::Taken(taken)),
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

pub(crate) fn taken_list(taken: &[Taken]) -> String {
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

/// One `safe POINT VALUE` row, checked against the layout.
#[derive(Clone, Debug)]
pub(crate) struct SafeValue {
    pub handle: Handle,
    pub value: PointValue,
    pub text: String,
}

/// The folder relative paths of `config_path` start at. `plc.conf` has the parent "",
/// which would send a program path `prog` to a search of PATH: the folder is `.` then.
pub(crate) fn base_dir_of(config_path: &Path) -> PathBuf {
    config_path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

/// A module made from its declaration by its kind's factory, or the program it runs.
pub(crate) type Made = Result<(Factory, Box<dyn Module>), PathBuf>;

/// Every module of `config`: a built-in one made by its factory (which checks its
/// settings), a program found; with every problem, not only the first. The modules are in
/// declaration order when there is no problem.
pub(crate) fn make_modules(
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

/// The program of a module that is not built in: it must exist and be executable.
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
