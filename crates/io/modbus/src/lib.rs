//! Modbus TCP and RTU for the soft PLC: `modbus_server` exposes points as coils, discrete
//! inputs, holding and input registers; `modbus_client` polls remote devices into points.

pub mod client;
pub mod serial;
pub mod server;
pub mod value;

use petriplc_runtime::module::Factory;

/// The module kinds of this crate.
pub const KINDS: &[&str] = &["modbus_server", "modbus_client"];

/// The factory of a module kind of this crate (see [`KINDS`]).
pub fn builtin(kind: &str) -> Option<Factory> {
    let factory: Factory = match kind {
        "modbus_server" => server::factory,
        "modbus_client" => client::factory,
        _ => return None,
    };
    Some(factory)
}
