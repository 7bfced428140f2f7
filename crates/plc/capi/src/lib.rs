//! The C ABI of the petriplc soft PLC (`include/petriplc.h`, `libpetriplc.so`,
//! `libpetriplc.a`), in the spirit of MatPLC's library (seed 000): a module written in C
//! runs as its own process, attaches to a running PLC with `plc_init`, looks points up by
//! name, gets and sets them in its private map, and frames each scan with `plc_scan_beg` /
//! `plc_scan_end` (period wait, synchronisation net, `update()`), until the PLC stops.
//!
//! The state is per process, as in MatPLC: one module per process, behind one lock, so a
//! multi-threaded C module may call the functions from any thread. [`ffi`] is the only code
//! that touches C pointers; `session` does the work in safe Rust and `args` resolves which
//! PLC and module the process belongs to.

mod args;
pub mod ffi;
mod session;

use std::os::raw::c_int;

pub use ffi::*;
pub use session::PlcPt;

/// Success.
pub const PLC_OK: c_int = 0;
/// Not an error: the PLC is shutting down, the module should leave its scan loop.
pub const PLC_STOPPING: c_int = 1;
/// `plc_init` has not been called (or `plc_close` has).
pub const PLC_ERR_NOT_INIT: c_int = -1;
/// `plc_init` was already called in this process.
pub const PLC_ERR_ALREADY_INIT: c_int = -2;
/// A bad argument: a NULL pointer, an unknown `--PLC` option, a missing module name or
/// configuration, a name that is not UTF-8.
pub const PLC_ERR_ARGS: c_int = -3;
/// The configuration cannot be read or is invalid.
pub const PLC_ERR_CONFIG: c_int = -4;
/// The module is not declared in the configuration.
pub const PLC_ERR_MODULE: c_int = -5;
/// No PLC with this id is running.
pub const PLC_ERR_NOT_RUNNING: c_int = -6;
/// The running PLC was started with another configuration (points or synchronisation net).
pub const PLC_ERR_MISMATCH: c_int = -7;
/// An invalid point handle, or no such point or transition.
pub const PLC_ERR_POINT: c_int = -8;
/// The point belongs to another module: only its owner may set it.
pub const PLC_ERR_NOT_OWNER: c_int = -9;
/// The value does not fit the point, or the point is of another kind.
pub const PLC_ERR_VALUE: c_int = -10;
/// The operating system refused (shared memory).
pub const PLC_ERR_OS: c_int = -11;
/// A bug in the library (a caught panic); the message says where.
pub const PLC_ERR_INTERNAL: c_int = -12;

/// A failed call: the code returned to C and the message `plc_last_error` gives.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Error {
    pub code: c_int,
    pub message: String,
}

impl Error {
    pub fn new(code: c_int, message: impl Into<String>) -> Self {
        Error {
            code,
            message: message.into(),
        }
    }
}
