//! The plants petriplc ships: a second net as process model (seed 004), the devices of seeds
//! 002 and 003, and seed 004's turntable.

mod keyboard;
mod net;
mod tank;
mod tape;
mod turntable;

pub use keyboard::Keyboard;
pub use net::NetPlant;
pub use tank::Tank;
pub use tape::Tape;
pub use turntable::{Turntable, TurntableSettings, TURNTABLE_SETTINGS};
