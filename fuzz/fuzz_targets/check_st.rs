//! Fuzzes the whole pipeline on Structured Text: parse, check, compile, and a few scans on
//! the VM. No input may panic; a refused program has only coded diagnostics; a program that
//! compiles runs or faults, never hits an internal error of the engine (which the VM would
//! otherwise turn into a fault). Inputs are amplified (`amplify.rs`): nesting of statements,
//! expressions and types, chains and names up to 20 000 deep or long.

#![no_main]

#[path = "amplify.rs"]
mod amplify;

use libfuzzer_sys::fuzz_target;
use petriplc_iec::vm::{FaultKind, Machine};
use petriplc_iec::{build, IecError, Natives, Select, Sources};

fuzz_target!(|data: &[u8]| {
    let data = amplify::amplify(data, amplify::ST);
    let text = String::from_utf8_lossy(&data);
    let mut s = Sources::new();
    s.add_text("fuzz.st", &text);
    let b = match build(&s, &Select::Auto, Natives::default()) {
        Ok(b) => b,
        Err(IecError::Invalid(lines)) => {
            for l in lines.lines().filter(|l| *l != "no project") {
                assert!(amplify::is_coded(l), "{l}");
            }
            return;
        }
        Err(_) => return,
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
