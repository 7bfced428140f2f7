//! The state and statistics of a running PLC's modules, published as a small JSON file in
//! /dev/shm (replaced atomically several times a second) that `petriplc status` reads.
//! Whether the PLC runs at all is for its lock (`crate::owner`) to say, not this file.

use std::fmt::{self, Write as _};
use std::path::{Path, PathBuf};
use std::time::Duration;

use crate::period::ScanStats;
use serde_json::{json, Value};

/// Where a module is in its life.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModuleState {
    Starting,
    Running,
    Stopped,
    Failed,
}

impl ModuleState {
    pub fn as_str(self) -> &'static str {
        match self {
            ModuleState::Starting => "starting",
            ModuleState::Running => "running",
            ModuleState::Stopped => "stopped",
            ModuleState::Failed => "failed",
        }
    }

    fn parse(s: &str) -> ModuleState {
        match s {
            "running" => ModuleState::Running,
            "stopped" => ModuleState::Stopped,
            "failed" => ModuleState::Failed,
            _ => ModuleState::Starting,
        }
    }
}

/// One module's state and statistics.
#[derive(Clone, Debug, PartialEq)]
pub struct ModuleStatus {
    pub name: String,
    pub kind: String,
    pub state: ModuleState,
    pub pid: u32,
    pub scans: u64,
    /// Cycle time (scan begin to scan end, synchronisation included), µs.
    pub cycle_us: [f64; 3],
    /// Lateness of the period's wake-ups, p50 / p99 / max, µs.
    pub late_us: [f64; 3],
    pub overruns: u64,
    pub restarts: u64,
    /// The module's own one-line status.
    pub detail: String,
    /// A `petrinet` module's marking: every place (by label) with its tokens, in place order.
    pub marking: Vec<(String, u64)>,
}

impl ModuleStatus {
    pub fn new(name: &str, kind: &str) -> Self {
        ModuleStatus {
            name: name.into(),
            kind: kind.into(),
            state: ModuleState::Starting,
            pid: 0,
            scans: 0,
            cycle_us: [0.0; 3],
            late_us: [0.0; 3],
            overruns: 0,
            restarts: 0,
            detail: String::new(),
            marking: Vec::new(),
        }
    }

    /// The module's state and figures as JSON (the status file's form; the HMI sends it too).
    pub fn to_json(&self) -> Value {
        json!({
            "name": self.name,
            "kind": self.kind,
            "state": self.state.as_str(),
            "pid": self.pid,
            "scans": self.scans,
            "cycle_us": self.cycle_us,
            "late_us": self.late_us,
            "overruns": self.overruns,
            "restarts": self.restarts,
            "detail": self.detail,
            "marking": self.marking.iter().map(|(p, n)| json!([p, n])).collect::<Vec<_>>(),
        })
    }

    /// Takes the figures of `stats`, the module's status line and its marking.
    pub fn record(&mut self, stats: &ScanStats, detail: String, marking: Vec<(String, u64)>) {
        self.marking = marking;
        let us = |d: Option<Duration>| d.map_or(0.0, |d| d.as_secs_f64() * 1e6);
        self.scans = stats.scans();
        self.overruns = stats.overruns();
        self.cycle_us = [
            us(stats.cycle_min()),
            us(stats.cycle_mean()),
            us(stats.cycle_max()),
        ];
        self.late_us = match stats.lateness() {
            Some(l) => [us(Some(l.p50)), us(Some(l.p99)), us(Some(l.max))],
            None => [0.0; 3],
        };
        self.detail = detail;
    }
}

/// A PLC's status.
#[derive(Clone, Debug, PartialEq)]
pub struct PlcStatus {
    pub plc_id: String,
    /// The process of `petriplc run`.
    pub pid: u32,
    pub config: String,
    pub uptime: Duration,
    /// The synchronisation net's marking, as text.
    pub marking: String,
    pub modules: Vec<ModuleStatus>,
    /// What the retain file holds, when the PLC keeps retentive values.
    pub retain: Option<RetainStatus>,
}

/// The last snapshot of the retentive values known to be in the retain file (written and
/// synced: "acknowledged").
#[derive(Clone, Debug, PartialEq, Default)]
pub struct RetainStatus {
    pub file: String,
    /// The snapshot's sequence number (0: nothing written yet).
    pub sequence: u64,
    /// When it was taken, RFC 3339.
    pub written: String,
    /// Every retained value, by name, as text.
    pub values: Vec<(String, String)>,
}

impl RetainStatus {
    fn to_json(&self) -> Value {
        let values: serde_json::Map<String, Value> = self
            .values
            .iter()
            .map(|(k, v)| (k.clone(), Value::String(v.clone())))
            .collect();
        json!({
            "file": self.file,
            "sequence": self.sequence,
            "written": self.written,
            "values": values,
        })
    }

    fn from_json(v: &Value) -> Option<RetainStatus> {
        let o = v.as_object()?;
        Some(RetainStatus {
            file: o.get("file")?.as_str()?.to_string(),
            sequence: o.get("sequence")?.as_u64()?,
            written: o.get("written")?.as_str()?.to_string(),
            values: o
                .get("values")?
                .as_object()?
                .iter()
                .map(|(k, v)| (k.clone(), v.as_str().unwrap_or_default().to_string()))
                .collect(),
        })
    }
}

/// The status file of PLC `plc_id`.
pub fn path(plc_id: &str) -> PathBuf {
    crate::shm_name::state_dir().join(format!("petriplc-{plc_id}.status.json"))
}

/// The temporary file a status file is written to before it replaces the old one. One fixed
/// name per PLC (only its runner writes it), so that a crash leaves a name its successor
/// knows to remove.
pub fn tmp_path(file: &Path) -> PathBuf {
    let mut name = file.as_os_str().to_owned();
    name.push(".tmp");
    PathBuf::from(name)
}

impl PlcStatus {
    pub fn to_json(&self) -> Value {
        json!({
            "plc_id": self.plc_id,
            "pid": self.pid,
            "config": self.config,
            "uptime_s": self.uptime.as_secs_f64(),
            "marking": self.marking,
            "modules": self.modules.iter().map(ModuleStatus::to_json).collect::<Vec<_>>(),
            "retain": self.retain.as_ref().map(RetainStatus::to_json),
        })
    }

    /// Writes the file atomically (a reader never sees half of it).
    pub fn write(&self, file: &Path) -> std::io::Result<()> {
        let tmp = tmp_path(file);
        std::fs::write(&tmp, self.to_json().to_string())?;
        std::fs::rename(&tmp, file)
    }

    /// Reads the status file of PLC `plc_id`; `None` when no such PLC runs.
    pub fn read(plc_id: &str) -> Option<PlcStatus> {
        let text = std::fs::read_to_string(path(plc_id)).ok()?;
        let v: Value = serde_json::from_str(&text).ok()?;
        let f3 = |v: &Value| -> [f64; 3] {
            let a = v.as_array().cloned().unwrap_or_default();
            let g = |i: usize| a.get(i).and_then(Value::as_f64).unwrap_or(0.0);
            [g(0), g(1), g(2)]
        };
        let s = |v: &Value| v.as_str().unwrap_or_default().to_string();
        let n = |v: &Value| v.as_u64().unwrap_or(0);
        Some(PlcStatus {
            plc_id: s(&v["plc_id"]),
            pid: n(&v["pid"]) as u32,
            config: s(&v["config"]),
            uptime: Duration::from_secs_f64(v["uptime_s"].as_f64().unwrap_or(0.0).max(0.0)),
            marking: s(&v["marking"]),
            modules: v["modules"]
                .as_array()
                .map(|ms| {
                    ms.iter()
                        .map(|m| ModuleStatus {
                            name: s(&m["name"]),
                            kind: s(&m["kind"]),
                            state: ModuleState::parse(m["state"].as_str().unwrap_or("")),
                            pid: n(&m["pid"]) as u32,
                            scans: n(&m["scans"]),
                            cycle_us: f3(&m["cycle_us"]),
                            late_us: f3(&m["late_us"]),
                            overruns: n(&m["overruns"]),
                            restarts: n(&m["restarts"]),
                            detail: s(&m["detail"]),
                            marking: m["marking"]
                                .as_array()
                                .map(|ps| ps.iter().map(|p| (s(&p[0]), n(&p[1]))).collect())
                                .unwrap_or_default(),
                        })
                        .collect()
                })
                .unwrap_or_default(),
            retain: RetainStatus::from_json(&v["retain"]),
        })
    }
}

impl fmt::Display for PlcStatus {
    /// A table for people: one line per module.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "PLC {} (process {}, {}), up {:.1} s",
            self.plc_id,
            self.pid,
            self.config,
            self.uptime.as_secs_f64()
        )?;
        writeln!(
            f,
            "{:<12} {:<13} {:<8} {:>7} {:>9}  {:>26}  {:>22} {:>8} {:>8}",
            "module",
            "kind",
            "state",
            "pid",
            "scans",
            "cycle min/mean/max µs",
            "late p50/p99/max µs",
            "overruns",
            "restarts"
        )?;
        for m in &self.modules {
            let mut line = String::new();
            let _ = write!(
                line,
                "{:<12} {:<13} {:<8} {:>7} {:>9}  {:>26}  {:>22} {:>8} {:>8}",
                m.name,
                m.kind,
                m.state.as_str(),
                m.pid,
                m.scans,
                format!(
                    "{:.0}/{:.0}/{:.0}",
                    m.cycle_us[0], m.cycle_us[1], m.cycle_us[2]
                ),
                format!(
                    "{:.0}/{:.0}/{:.0}",
                    m.late_us[0], m.late_us[1], m.late_us[2]
                ),
                m.overruns,
                m.restarts
            );
            writeln!(f, "{}", line.trim_end())?;
            // A detail of several lines (a dsp module's filter coefficients) stays indented.
            for line in m.detail.lines() {
                writeln!(f, "{:<12} {}", "", line)?;
            }
        }
        if !self.marking.is_empty() {
            writeln!(f, "synchronisation net marking: {}", self.marking)?;
        }
        if let Some(r) = &self.retain {
            if r.sequence == 0 {
                writeln!(f, "retain: {}: nothing written yet", r.file)?;
            } else {
                writeln!(
                    f,
                    "retain: {}: snapshot {} of {} ({} value{})",
                    r.file,
                    r.sequence,
                    r.written,
                    r.values.len(),
                    if r.values.len() == 1 { "" } else { "s" }
                )?;
            }
        }
        Ok(())
    }
}
