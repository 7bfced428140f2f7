//! The function blocks, each a plain struct with a `step` that takes its inputs (and, for
//! the blocks that integrate or differentiate, the time since the previous step) and returns
//! its outputs. They know nothing of plc points: [`crate::chain`] binds them to values, and
//! an IEC 61131-3 engine can wrap each as a native function block.

pub mod alarm;
pub mod arith;
pub mod delay;
pub mod filter;
pub mod pid;
pub mod ramp;
pub mod select;
pub mod source;

/// `x` limited to `[lo, hi]`: like `f64::clamp`, but never panics (bounds that are NaN or
/// crossed, which a block built by hand might hold, limit nothing and take `lo` first), and
/// a NaN `x` stays NaN.
pub fn limit(x: f64, lo: f64, hi: f64) -> f64 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

pub use alarm::{Alarm, Compare, Hysteresis, Limit, MAX_LIMITS};
pub use arith::{convert, Add, Mult, NumType, Pow};
pub use delay::Delay;
pub use filter::{Fir, Iir};
pub use pid::{AntiWindup, Pid, PidConfig, PidForm, PidInput};
pub use ramp::{Ramp, RampConfig};
pub use select::{Multiplexor, Nonlinear};
pub use source::{Source, Wave};
