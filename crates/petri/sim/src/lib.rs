//! Closed-loop simulation of a controller net: input timelines, plant models (a second net or a
//! built-in device), the scan-by-scan driver, the recorded trace and its CSV and SVG renderings.
//!
//! Time is exact ([`std::time::Duration`]) throughout, so a run is deterministic: the same net,
//! options, timeline and plant give byte-identical CSV and SVG output.

pub mod error;
pub mod plant;
pub mod plants;
pub mod plot;
pub mod sim;
pub mod timeline;
pub mod trace;
pub mod trend;
pub mod wiring;

pub use error::SimError;
pub use plant::{builtin, builtin_settings, builtin_with, Plant, PlantError, BUILTINS};
pub use plants::{
    Keyboard, NetPlant, Tank, Tape, Thermal, ThermalParams, Turntable, TurntableSettings,
    THERMAL_SETTINGS, TURNTABLE_SETTINGS,
};
pub use plot::{render_svg, render_svg_with, write_svg, PlotError, PlotOptions};
pub use sim::{SimOptions, Simulation};
pub use timeline::{NonFinite, Timeline, TimelineCursor, TimelineError, TimelineProblem};
pub use trace::{Trace, TraceRow};
pub use trend::{render_trend_svg, write_trend_svg, Series};
pub use wiring::{wire, Controller, Port, Wiring};
