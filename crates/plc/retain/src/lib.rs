//! Retentive values of the soft PLC: the values that outlive a restart (counters, totals,
//! recipes) — retentive points of the process image and data modules keep for themselves —
//! kept in a crash-safe file and given back at the next start.
//!
//! - [`file`]: the retain file. Two copies ("slots"), each a whole snapshot with a sequence
//!   number and a CRC-32C; a write overwrites the older copy in place and syncs it, so that a
//!   crash or power loss at any moment leaves at least one whole copy, and reading takes the
//!   newest good one (warning when the other is damaged). The file is locked while a PLC uses
//!   it. Its copies' byte format (header, CRC, entries) is `record`, which both the file and
//!   the search for its copies in a damaged file (`copies`) read.
//! - [`restore`]: which stored values a configuration may take back: by name, refusing a
//!   point whose type or size changed and a file that belongs to another PLC or
//!   configuration.
//! - [`persist`]: the persistence thread: takes a snapshot from a source (the runner copies
//!   the retentive points out of the process image under its lock, at a committed scan
//!   boundary) and writes it off the scan path, on change, at most as often as the write
//!   policy allows, and publishes what was last written ("acknowledged").
//! - [`data`]: module-private retained data (a module registers named values at init, sets
//!   them in its scans, and the runner commits them with the scan's outputs).

mod copies;
pub mod data;
pub mod file;
pub mod persist;
mod record;
pub mod restore;

use std::path::PathBuf;
use std::time::SystemTime;

pub use data::{Registry, Retained};
pub use file::RetainFile;
pub use persist::{Ack, Persister};
use petriplc_config::PointKind;

/// One retained value.
#[derive(Clone, Debug, PartialEq)]
pub struct Entry {
    /// A point's name, or `MODULE/NAME` for a module's own data.
    pub name: String,
    pub value: Value,
}

/// What a retained value is.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A retentive point: its kind, width and bits (as the image holds them).
    Point { kind: PointKind, bits: u8, raw: u32 },
    /// A module's data: its type as the module describes it (e.g. an IEC type, `INT` or
    /// `ARRAY[1..4] OF REAL`) and its bytes.
    Data { signature: String, bytes: Vec<u8> },
}

/// A point's type as configurations write it: `u16`, `i8`, `f32`.
pub fn type_name(kind: PointKind, bits: u8) -> String {
    let letter = match kind {
        PointKind::Unsigned => 'u',
        PointKind::Signed => 'i',
        PointKind::Float => 'f',
    };
    format!("{letter}{bits}")
}

/// The PLC a snapshot was written for: its id and configuration file, so that a file from
/// another PLC is recognised (and named in messages).
#[derive(Clone, Debug, PartialEq, Eq, Default)]
pub struct Identity {
    pub plc_id: String,
    /// The configuration file's path (as it was given; for messages only).
    pub config: String,
}

/// One snapshot: every retained value as of one committed scan.
#[derive(Clone, Debug, PartialEq)]
pub struct Snapshot {
    /// Numbers the snapshots of a file, 1, 2, 3, … across restarts.
    pub seq: u64,
    /// When it was taken.
    pub written: SystemTime,
    pub identity: Identity,
    pub entries: Vec<Entry>,
}

impl Snapshot {
    /// A fingerprint of the retentive points' names and types (not their values), order
    /// independent: equal for two configurations that retain the same points.
    pub fn layout_hash(&self) -> u64 {
        layout_hash(self.entries.iter().filter_map(|e| match &e.value {
            Value::Point { kind, bits, .. } => Some((e.name.as_str(), *kind, *bits)),
            Value::Data { .. } => None,
        }))
    }
}

/// [`Snapshot::layout_hash`] of a list of points.
pub fn layout_hash<'a>(points: impl Iterator<Item = (&'a str, PointKind, u8)>) -> u64 {
    let mut names: Vec<String> = points
        .map(|(n, k, b)| format!("{n}:{}", type_name(k, b)))
        .collect();
    names.sort();
    // FNV-1a: stable across builds and platforms, which std's hasher is not.
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for n in names {
        for b in n.bytes().chain([0]) {
            h ^= u64::from(b);
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    }
    h
}

/// Why retained values cannot be kept or given back.
#[derive(Debug, thiserror::Error)]
pub enum RetainError {
    #[error(
        "retain file {}: {why}; the retained values cannot be read back. Move it away (the \
         PLC then starts every retentive point from its init value) or point `retain_file` at \
         another file",
        .path.display()
    )]
    Unreadable { path: PathBuf, why: String },
    #[error(
        "retain file {} is used by another running PLC (it is locked); give this PLC its own \
         file with `retain_file` in [PLC] (or `--set PLC:retain_file=FILE`)",
        .path.display()
    )]
    InUse { path: PathBuf },
    #[error(
        "retain file {}: point `{point}` was stored as {stored} and is {now} in the \
         configuration: its stored value is not reinterpreted. Change the point back to \
         {stored} to keep the value, or rename the point to start it from its init value",
        .path.display()
    )]
    TypeChanged {
        path: PathBuf,
        point: String,
        stored: String,
        now: String,
    },
    #[error(
        "retain file {}: `{name}` of module {module} was stored as `{stored}` and the module \
         now keeps it as `{now}`: its stored value is not reinterpreted. Keep the old type, or \
         rename the value to start it afresh",
        .path.display()
    )]
    DataTypeChanged {
        path: PathBuf,
        module: String,
        name: String,
        stored: String,
        now: String,
    },
    #[error(
        "module {module} registers retained data (`{name}`) but its kind does not say so \
         (`Module::retains_data`), so the PLC opened no retain file for it: a bug in the module"
    )]
    Undeclared { module: String, name: String },
    #[error(
        "retain file {} belongs to PLC `{stored}` (written for {config}), not to this PLC \
         `{plc_id}`: give this PLC its own file with `retain_file` in [PLC] (or `--set \
         PLC:retain_file=FILE`), or remove that file if its values are not wanted",
        .path.display()
    )]
    OtherPlc {
        path: PathBuf,
        stored: String,
        plc_id: String,
        config: String,
    },
    #[error(
        "retain file {} was written by another configuration ({config}): none of its {count} \
         retained points ({names}) is a retentive point here. Point `retain_file` at this \
         configuration's own file, or remove that file to start from the init values",
        .path.display()
    )]
    OtherConfiguration {
        path: PathBuf,
        config: String,
        count: usize,
        names: String,
    },
    #[error(
        "retain file {} is {kind}, not a regular file: point `retain_file` in [PLC] (or \
         `--set PLC:retain_file=FILE`) at a file; it is made if missing",
        .path.display()
    )]
    NotAFile { path: PathBuf, kind: &'static str },
    #[error(
        "retain file {}: the retained values make a snapshot of {bytes} bytes, more than the \
         {limit} a retain file takes; retain fewer or smaller values",
        .path.display()
    )]
    TooLarge {
        path: PathBuf,
        bytes: usize,
        limit: usize,
    },
    #[error("retain file {}: {what}: {source}", .path.display())]
    Io {
        path: PathBuf,
        what: &'static str,
        #[source]
        source: std::io::Error,
    },
}

impl RetainError {
    /// Whether the configuration (or the file it names) is at fault — fix it and start
    /// again — rather than the machine (a file in use, a disk that refuses).
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, RetainError::InUse { .. } | RetainError::Io { .. })
    }
}
