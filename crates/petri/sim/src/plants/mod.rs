//! The plants petriplc ships: a second net as process model (seed 004), the devices of seeds
//! 002 and 003, seed 004's turntable, and a heated vessel (first order plus dead time) for
//! control loops.

mod keyboard;
mod net;
mod tank;
mod tape;
mod thermal;
mod turntable;

pub use keyboard::Keyboard;
pub use net::NetPlant;
pub use tank::Tank;
pub use tape::Tape;
pub use thermal::{Thermal, ThermalParams, THERMAL_SETTINGS};
pub use turntable::{Turntable, TurntableSettings, TURNTABLE_SETTINGS};
