//! Fuzzes the whole pipeline on Instruction List: parse, check (the current result lowered to
//! the checked form), compile (labels and jumps), and a few scans on the VM. No input may
//! panic; a program that compiles runs or faults, never hits an internal error of the engine.

#![no_main]

use libfuzzer_sys::fuzz_target;
use petriplc_iec::vm::{FaultKind, Machine};
use petriplc_iec::{build, Natives, Select, Sources};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let mut s = Sources::new();
    s.add_text("fuzz.il", &text);
    let Ok(b) = build(&s, &Select::Auto, Natives::default()) else {
        return;
    };
    let mut m = Machine::new(b.engine.clone());
    m.iterations = 10_000;
    for k in 0..3 {
        if let Err(f) = m.scan(k * 10_000_000, &mut || true) {
            assert_ne!(f.kind, FaultKind::Internal, "{f}");
            break;
        }
    }
});
