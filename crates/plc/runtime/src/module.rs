//! The API modules are written against: `init` once, then `scan` once per scan between the
//! scan-begin and scan-end synchronisations, then `close`. The runner (or a module's own
//! process) does the framing: period wait, `scan_beg` synch, `update()`, the scan,
//! `update()`, `scan_end` synch (seed 000: `plc_scan_beg` / `plc_scan_end`).

use std::path::Path;
use std::time::Duration;

use petriplc_config::{ModuleDecl, PlcConfig};

use crate::image::{Handle, ModuleMap, PointId};

/// Why a module could not start or could not go on; the message says what to fix.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct ModuleError(pub String);

impl ModuleError {
    pub fn new(message: impl Into<String>) -> Self {
        ModuleError(message.into())
    }
}

/// What a module sees while it starts.
pub struct InitContext<'a> {
    /// The module's declaration and its section's settings.
    pub decl: &'a ModuleDecl,
    /// The whole configuration (other sections, points).
    pub config: &'a PlcConfig,
    /// The module's view of the points: look handles up here.
    pub map: &'a mut ModuleMap,
    /// The directory of the configuration file: relative paths in settings start here.
    pub base_dir: &'a Path,
    /// The PLC's id (`petriplc run --plc-id`): names its shared memory and status file.
    pub plc_id: &'a str,
    /// The module's retentive points whose values it must go on from: given back from the
    /// retain file at this start, or, when the module restarts, as its last committed scan
    /// left them. [`InitContext::restored`] asks for one.
    pub restored_points: &'a [PointId],
}

impl InitContext<'_> {
    /// A setting of the module's section.
    pub fn setting(&self, name: &str) -> Option<&str> {
        self.decl.settings.get(name).map(|s| s.value.as_str())
    }

    /// A required setting, or an error naming the section and the setting to add.
    pub fn require(&self, name: &str) -> Result<&str, ModuleError> {
        self.setting(name).ok_or_else(|| {
            ModuleError::new(format!(
                "module {}: no `{name}` setting; add `{name} = ...` to section [{}]",
                self.decl.name, self.decl.name
            ))
        })
    }

    /// Whether point `h` holds a value the module must go on from (see
    /// [`InitContext::restored_points`]): its map already holds it, and a module that drives
    /// the point from a variable of its own loads the variable from it before its first
    /// scan, which would otherwise write the variable's initial value over it.
    pub fn restored(&self, h: &Handle) -> bool {
        self.restored_points.contains(&h.id())
    }

    /// A path setting resolved against the configuration file's directory.
    pub fn path(&self, value: &str) -> std::path::PathBuf {
        self.base_dir.join(value)
    }

    /// Registers a value the module keeps for itself across restarts (module-private
    /// retained data, e.g. an IEC program's `VAR RETAIN` variables): `name` is unique within
    /// the module, `signature` its type as the module describes it (`INT`, `ARRAY[1..4] OF
    /// REAL`). The handle holds the stored bytes (`get`; `None`: nothing stored, start from
    /// the module's initial value); set the new bytes in each scan (`set`): they are
    /// committed with the scan's outputs and written to the PLC's retain file with its
    /// retentive points. A stored value of another signature is refused (the module does not
    /// start). Register in `init` only. Without a running PLC (a test harness) the value is
    /// kept in memory only.
    pub fn retain(
        &self,
        name: &str,
        signature: &str,
    ) -> Result<petriplc_retain::Retained, ModuleError> {
        match petriplc_retain::data::installed(self.plc_id) {
            Some(r) => r
                .register(&self.decl.name, name, signature)
                .map_err(|e| ModuleError::new(format!("module {}: {e}", self.decl.name))),
            None => Ok(petriplc_retain::Retained::volatile(name, signature)),
        }
    }
}

/// What a module sees during one scan.
pub struct ScanContext<'a> {
    /// Time since the PLC started (monotonic), the same clock for every module.
    pub now: Duration,
    /// The number of this scan of this module, from 0.
    pub scan: u64,
    pub map: &'a mut ModuleMap,
}

/// What the runner does after a scan.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Control {
    /// Scan again.
    Continue,
    /// Stop the whole PLC cleanly (the `shutdown` module).
    StopPlc,
}

/// A module of the soft PLC.
pub trait Module: Send {
    /// Once, before the first scan: look up point handles, open files, check settings.
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError>;
    /// One scan: read points from and write the module's own points to `ctx.map`.
    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError>;
    /// Once, after the last scan: flush and release what it holds.
    fn close(&mut self) {}
    /// A short line for status displays.
    fn status(&self) -> String {
        String::new()
    }
    /// A net's marking for displays (vitrine, HMI): every place by label with its tokens.
    fn marking(&self) -> Vec<(String, u64)> {
        Vec::new()
    }
    /// The addresses the module will listen on once initialised, each with the setting that
    /// chooses it (`("listen", 127.0.0.1:8080)`), known from its settings alone: the runner
    /// checks them all before initialising any module, so that every clash is reported at
    /// once. Port 0 (any free port) need not be listed.
    fn listens(&self) -> Vec<(&'static str, std::net::SocketAddr)> {
        Vec::new()
    }
    /// The scan period when the section sets none and the module is not in the
    /// synchronisation net (which paces it otherwise), so that displays, network modules and
    /// watchers do not scan as fast as the CPU allows.
    fn default_scan_period(&self) -> Option<Duration> {
        None
    }
    /// How much longer than its `watchdog` the runner waits before it gives up on a scan
    /// that does not end. A module that checks the limit itself (the `iec` engine does, in
    /// its loops) then fails its own scan with a message that says where it was stuck, which
    /// the runner cannot say; the runner's watchdog stays the backstop. Default: none.
    fn watchdog_grace(&self) -> Duration {
        Duration::ZERO
    }
    /// Whether the module will register retained data in `init` ([`InitContext::retain`]),
    /// known from its settings alone: the runner then opens the PLC's retain file before
    /// initialising any module (a module that registers without saying so is refused).
    fn retains_data(&self) -> bool {
        false
    }
}

/// Makes a module of a built-in kind from its declaration.
pub type Factory = fn(&ModuleDecl) -> Result<Box<dyn Module>, ModuleError>;
