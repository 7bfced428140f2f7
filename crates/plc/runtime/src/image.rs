//! The process image (MatPLC's global memory manager): a layout of plc points in 32-bit
//! words, the global map in POSIX shared memory, and per-module maps synchronised with it by
//! `update()`.
//!
//! MatPLC keeps the state of every plc point in one global map shared by all module
//! processes. Each module works on a private copy and a write mask (the bits of the points it
//! owns); `update()` copies the owned bits out and every other bit in, as one bit-for-bit
//! logical function, under a lock, so a module's logic sees a state no other module changes
//! while it runs. `Location::Shared` modules skip the private copy and reach the global map
//! directly, for modules the synchronisation net runs alone.
//!
//! [`layout`] places the points, [`shm`] owns the shared memory (locked with `crate::futex`)
//! (with `module/isolate.rs`, the proxy process of an isolated module, the only code here
//! that needs `unsafe`), [`module`] is the per-module view with typed
//! access through [`Handle`]s.

// Mapping shared memory and waiting on futexes need `unsafe`; it is confined to `shm`, and
// every use carries a SAFETY comment.
#![allow(unsafe_code)]

pub mod layout;
pub mod module;
pub mod shm;

pub use layout::{Layout, PointId, Slot};
pub use module::{Handle, ModuleMap};
pub use petriplc_config::{Location, PointKind, PointValue};
pub use shm::GlobalMap;

/// Everything that can go wrong laying out, mapping or accessing the process image.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{place}point `{point}`: {reason}")]
    InvalidPoint {
        point: String,
        place: String,
        reason: String,
    },
    #[error("{place}point `{point}` is declared twice (first at {first})")]
    DuplicatePoint {
        point: String,
        place: String,
        first: String,
    },
    #[error("{place}point `{second}` overlaps point `{first}` ({detail})")]
    Overlap {
        first: String,
        second: String,
        place: String,
        /// Where each of the two lies.
        detail: String,
    },
    #[error("{place}point `{point}`: its owner `{owner}` is not a declared module{}", known_modules(.modules))]
    UnknownOwner {
        point: String,
        owner: String,
        place: String,
        modules: Vec<String>,
    },
    #[error("module `{module}` is not declared in the configuration{}", known_modules(.modules))]
    UnknownModule {
        module: String,
        modules: Vec<String>,
    },
    #[error("the process image would need {words} words (at most {max} are allowed)")]
    TooLarge { words: u64, max: u64 },
    #[error("no point named `{name}`{}", close_matches(.close))]
    UnknownPoint { name: String, close: Vec<String> },
    #[error("module `{module}` may not write point `{point}`: it is owned by `{owner}`")]
    NotOwner {
        point: String,
        owner: String,
        module: String,
    },
    #[error("point `{point}` ({kind}, {bits} bits) cannot hold {value}")]
    OutOfRange {
        point: String,
        kind: &'static str,
        bits: u8,
        value: String,
    },
    #[error("point `{point}` is {kind}: it cannot be accessed as {requested}")]
    WrongKind {
        point: String,
        kind: &'static str,
        requested: &'static str,
    },
    #[error("invalid plc id `{plc_id}`: {reason}")]
    BadPlcId { plc_id: String, reason: String },
    #[error(
        "shared memory `{shm}` of PLC `{plc_id}` already exists although this process owns \
         the id: something other than `petriplc run` made it"
    )]
    AlreadyRunning { plc_id: String, shm: String },
    #[error(
        "no PLC with id `{plc_id}` is running (no shared memory `{shm}`); start the PLC first, \
         or pass the id it was started with (--plc-id)"
    )]
    NotRunning { plc_id: String, shm: String },
    #[error("shared memory `{shm}` is not a usable petriplc process image: {reason}")]
    BadImage { shm: String, reason: String },
    #[error(
        "the PLC `{plc_id}` was started with a different point layout than this configuration \
         (were the points edited since it started?)"
    )]
    LayoutMismatch { plc_id: String },
    #[error("{what} is not supported yet")]
    Unsupported { what: String },
    #[error("{what} `{shm}`: {source}")]
    Os {
        what: &'static str,
        shm: String,
        #[source]
        source: std::io::Error,
    },
}

fn known_modules(modules: &[String]) -> String {
    if modules.is_empty() {
        " (no modules are declared)".to_string()
    } else {
        format!(" (declared: {})", modules.join(", "))
    }
}

fn close_matches(close: &[String]) -> String {
    if close.is_empty() {
        String::new()
    } else {
        let quoted: Vec<String> = close.iter().map(|c| format!("`{c}`")).collect();
        format!("; did you mean {}?", quoted.join(", "))
    }
}

/// The name used in messages for a point kind.
pub(crate) fn kind_name(kind: PointKind) -> &'static str {
    match kind {
        PointKind::Unsigned => "unsigned",
        PointKind::Signed => "signed",
        PointKind::Float => "float",
    }
}
