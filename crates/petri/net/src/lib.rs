//! The Petri-net model every part of petriplc shares: places, transitions, arcs and signals,
//! guards over input signals, and the two semantics (interleaving firing for analysis, PLC
//! scans for simulation and code generation).
//!
//! This crate does no I/O: files are read by `petriplc-pnml`, time is passed in by the caller.

pub mod guard;
pub mod ids;
pub mod model;
pub mod scan;
pub mod time;

pub use guard::{FlatGuard, Guard, GuardError};
pub use ids::{ArcId, PlaceId, SignalId, TransitionId};
pub use model::{
    is_signal_name, Arc, ArcDirection, ArcKind, ArcSpec, Evolution, Marking, ModelError, Net,
    NetBuilder, Place, PlaceSpec, Signal, SignalDirection, SignalType, StepRule, TimedArc,
    TokenOverflow, Transition, TransitionArcs, TransitionSpec,
};
pub use scan::{Blocker, ScanError, ScanOptions, Scanner};
