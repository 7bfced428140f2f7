//! Fuzzes the Modbus TCP server's framing and request handling: any bytes a client may send
//! on one connection, answered against a register map with every table and value type.
#![no_main]

use std::path::Path;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use petriplc_config::PlcConfig;

const CONFIG: &str = r#"
[PLC]
module mb modbus_server
module other shutdown
point b0 "coil" mb
point b1 "read-only coil" other
point d0 "input" other
point h0 "u16" mb u16
point h1 "i16" mb i16
point h2 "u32" mb u32
point h3 "f32" mb f32
point h4 "u8" mb u8
point r0 "input register" other i32
[mb]
coil 0 b0
coil 1 b1
discrete_input 0 d0
holding 0 h0
holding 1 h1
holding 2 h2
holding 4 h3 f32 low_first
holding 6 h4
input 0 r0
[other]
point = b1
"#;

fn config() -> &'static PlcConfig {
    static C: OnceLock<PlcConfig> = OnceLock::new();
    C.get_or_init(|| petriplc_config::parse_str(CONFIG, "fuzz.conf", Path::new(".")).unwrap())
}

fuzz_target!(|bytes: &[u8]| {
    let out = petriplc_modbus::server::answer_tcp_bytes(config(), "mb", bytes).unwrap();
    // Every answer is a whole ADU: at least a header and a function code.
    assert!(out.is_empty() || out.len() >= 9, "{out:?}");
});
