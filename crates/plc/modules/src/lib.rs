//! The built-in modules of `petriplc run`: `petrinet` scans a PNML net every PLC scan, `iec`
//! runs an IEC 61131-3 program (Structured Text, PLCopen XML) on the engine,
//! `plant` simulates the process for software-in-the-loop, `timeline` drives points from a
//! CSV timeline, `logger` writes point changes to CSV, `shutdown` stops the PLC when a
//! point goes true and `dsp` runs MatPLC's function blocks (petriplc-dsp) on points.
//!
//! Each kind has a [`Factory`](petriplc_runtime::module::Factory) that checks the module's
//! settings from its declaration alone (so a typo is reported before the PLC creates its
//! process image); files are read and points looked up in `init`.

pub mod common;
mod dsp;
mod iec;
mod iec_retain;
mod logger;
mod petrinet;
mod plant;
mod shutdown;
mod timeline;

use petriplc_runtime::module::Factory;

pub use dsp::DspModule;
pub use iec::IecModule;
pub use logger::Logger;
pub use petrinet::{petrinet_modules, petrinet_nets, ModuleNet, ModuleNetError, Petrinet};
pub use plant::PlantModule;
pub use shutdown::Shutdown;
pub use timeline::TimelineModule;

/// Every built-in module kind, for messages that list the known kinds.
pub const KINDS: &[&str] = &[
    "petrinet", "iec", "plant", "timeline", "logger", "shutdown", "dsp",
];

/// The factory of a built-in module kind (see [`KINDS`]).
pub fn builtin(kind: &str) -> Option<Factory> {
    let factory: Factory = match kind {
        "petrinet" => petrinet::factory,
        "iec" => iec::factory,
        "plant" => plant::factory,
        "timeline" => timeline::factory,
        "logger" => logger::factory,
        "shutdown" => shutdown::factory,
        "dsp" => dsp::factory,
        _ => return None,
    };
    Some(factory)
}
