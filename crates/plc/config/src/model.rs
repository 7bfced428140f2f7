//! The typed PLC configuration a configuration file describes: points, modules with their
//! settings, and the synchronisation net (advanced form and simple `synch` rules).

use std::collections::BTreeMap;
use std::time::Duration;

/// Where something was written: for error messages that name file and line.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Origin {
    pub file: String,
    /// 1-based.
    pub line: usize,
}

impl std::fmt::Display for Origin {
    /// `plc.conf:12`; line 0 (a whole file, or `--set` on the command line) shows no line.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.line == 0 {
            write!(f, "{}", self.file)
        } else {
            write!(f, "{}:{}", self.file, self.line)
        }
    }
}

/// How a point's bits are read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PointKind {
    /// `u` (the default): unsigned; a 1-bit point is a boolean.
    Unsigned,
    /// `i`: two's complement signed.
    Signed,
    /// `f`: an IEEE 754 `f32` (always 32 bits).
    Float,
}

/// A point's initial value, as written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointValue {
    Unsigned(u32),
    Signed(i32),
    Float(f32),
}

/// `point NAME "description" OWNER [at W.B] [i|u|f][bits] [init V] [retain]`
#[derive(Clone, Debug, PartialEq)]
pub struct PointDecl {
    pub name: String,
    pub description: String,
    /// The one module allowed to write the point.
    pub owner: String,
    /// `at WORD.BIT`: a fixed place in the map; otherwise the runtime allocates one.
    pub at: Option<(u32, u8)>,
    pub kind: PointKind,
    /// 1 to 32; `bit + bits <= 32`.
    pub bits: u8,
    pub init: PointValue,
    /// `retain`: the value outlives a restart of the PLC (kept in the retain file and restored
    /// at start, before any module's first scan).
    pub retain: bool,
    pub origin: Origin,
}

/// How a module reaches the global map (MatPLC's `location`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Location {
    /// A private map, synchronised by `update()` (the default).
    #[default]
    Local,
    /// Direct access to the global map, for modules the synchronisation runs alone.
    Shared,
    /// The module's process never maps the global map; a proxy does `update()`.
    Isolate,
}

/// What happens when a module fails.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum OnFailure {
    /// Write the configured safe values and stop the PLC (the default).
    #[default]
    Stop,
    /// Start the module again.
    Restart,
    /// Report it and let the others run.
    Ignore,
}

/// How `on_failure = restart` restarts a module that keeps failing: after a failure the
/// module waits `delay` before it starts again, twice as long after each further failure up to
/// `delay_max`; once it has run `delay_max` without failing the delay is back to `delay` and
/// the count to 0. `limit` restarts in a row (0: no limit) and the next failure fails the
/// module for good, as `on_failure = stop` would.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Restart {
    /// `restart_delay` (default 100 ms).
    pub delay: Duration,
    /// `restart_delay_max` (default 10 s).
    pub delay_max: Duration,
    /// `restart_limit` (default 10; 0 means no limit).
    pub limit: u32,
}

impl Default for Restart {
    fn default() -> Self {
        Restart {
            delay: Duration::from_millis(100),
            delay_max: Duration::from_secs(10),
            limit: 10,
        }
    }
}

/// `module NAME KIND-or-PATH [args]` and the module's own section.
#[derive(Clone, Debug, PartialEq)]
pub struct ModuleDecl {
    pub name: String,
    /// A built-in kind (`petrinet`, `plant`, …) or the path of a program.
    pub kind: String,
    pub args: Vec<String>,
    /// `scan_period` (seconds or an IEC literal); `None`: as fast as synchronisation allows.
    pub scan_period: Option<Duration>,
    pub location: Location,
    /// `priority`: a real-time (SCHED_FIFO) priority 1–99, when permitted.
    pub priority: Option<u8>,
    pub on_failure: OnFailure,
    /// With `on_failure = restart`: how restarts are paced and limited.
    pub restart: Restart,
    /// `watchdog`: a scan (from `scan_beg` to `scan_end`) that runs longer is a failure.
    pub watchdog: Option<Duration>,
    /// `scan_beg` / `scan_end`: transitions of the synchronisation net (`NULL` when absent).
    pub scan_beg: Option<String>,
    pub scan_end: Option<String>,
    /// Every `name = value` of the module's section (including the ones above), for the
    /// module's own settings.
    pub settings: BTreeMap<String, Setting>,
    pub origin: Origin,
}

impl ModuleDecl {
    /// A module with every setting at its default: no arguments, no scan period, `local`,
    /// no real-time priority, `on_failure = stop`, the `NULL` transitions, no settings.
    pub fn new(name: impl Into<String>, kind: impl Into<String>) -> Self {
        ModuleDecl {
            name: name.into(),
            kind: kind.into(),
            args: Vec::new(),
            scan_period: None,
            location: Location::default(),
            priority: None,
            on_failure: OnFailure::default(),
            restart: Restart::default(),
            watchdog: None,
            scan_beg: None,
            scan_end: None,
            settings: BTreeMap::new(),
            origin: Origin::default(),
        }
    }
}

/// A value from a `name = value` line, with where it was written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Setting {
    pub value: String,
    pub origin: Origin,
}

/// `place NAME [TOKENS]`
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PlaceDecl {
    pub name: String,
    pub tokens: u32,
    pub origin: Origin,
}

/// `arc FROM -N-> TO`: place → transition or transition → place. Weight 0 (only from a
/// place) means "only while the place is empty".
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ArcDecl {
    pub from: String,
    pub to: String,
    pub weight: u32,
    pub origin: Origin,
}

/// `synch A -N-> B`: whenever A ends a scan, B may start one (N ≥ 1).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SynchRule {
    pub from: String,
    pub to: String,
    pub weight: u32,
    pub origin: Origin,
}

/// The synchronisation net as written: the advanced form (places, transitions, arcs) and/or
/// the simple form (`synch`, `synch_start`), which the runtime expands into the same net.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct SynchDecl {
    pub places: Vec<PlaceDecl>,
    pub transitions: Vec<(String, Origin)>,
    pub arcs: Vec<ArcDecl>,
    pub rules: Vec<SynchRule>,
    /// `synch_start A B …`: modules that may make their first scan at once.
    pub starts: Vec<(String, Origin)>,
}

/// When the retentive values are written to the retain file (`[PLC] retain_write`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RetainWrite {
    /// `change`: every change, as soon as the previous write is done.
    Change,
    /// A duration: at most one write per this long (changes are written this long after the
    /// last write at the latest).
    Every(Duration),
}

impl Default for RetainWrite {
    /// At most every 500 ms, so that a crash loses at most the last second of changes.
    fn default() -> Self {
        RetainWrite::Every(Duration::from_millis(500))
    }
}

/// `[PLC] retain_file` and `retain_write`.
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct RetainSettings {
    /// `retain_file`, as written (relative to the configuration file's folder); `None`: the
    /// default file.
    pub file: Option<Setting>,
    pub write: RetainWrite,
}

/// A whole PLC configuration.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct PlcConfig {
    /// The file it was read from.
    pub file: String,
    /// Every `name = value` of the `[PLC]` section (e.g. `plc_id`).
    pub plc: BTreeMap<String, Setting>,
    /// Where and how often retentive values are kept.
    pub retain: RetainSettings,
    pub points: Vec<PointDecl>,
    pub modules: Vec<ModuleDecl>,
    pub synch: SynchDecl,
    /// Every section by name, as read (`[PLC]` and module sections included): modules read
    /// their own tables (e.g. a logger's `log` rows) from here.
    pub sections: BTreeMap<String, Section>,
}

/// A section as written: its `name = value` pairs and table rows, in file order (sections
/// with the same name, and `Module: name = value` lines, are merged into one).
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Section {
    pub name: String,
    pub pairs: Vec<(String, Setting)>,
    pub rows: Vec<Row>,
}

/// A table row: `table cell cell …` (a quoted cell keeps its spaces, without the quotes).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Row {
    pub table: String,
    pub cells: Vec<String>,
    pub origin: Origin,
}
