//! The plants petriplc ships: a second net as process model (seed 004) and the devices of
//! seeds 002 and 003.

mod keyboard;
mod net;
mod tank;
mod tape;

pub use keyboard::Keyboard;
pub use net::NetPlant;
pub use tank::Tank;
pub use tape::Tape;
