//! Fuzzes the TwinCAT 3 reader and the checker behind it (a `.TcPOU` source: its XML, the
//! declaration and the ST body inside): no input may panic, and a refused project has only
//! coded diagnostics. Inputs are amplified as XML (`amplify.rs`): elements nested deep.

#![no_main]

#[path = "amplify.rs"]
mod amplify;

use libfuzzer_sys::fuzz_target;
use petriplc_iec::{check, IecError, Natives, Sources};

fuzz_target!(|data: &[u8]| {
    let data = amplify::amplify(data, amplify::XML);
    let text = String::from_utf8_lossy(&data);
    let mut s = Sources::new();
    s.add_text("fuzz.TcPOU", &text);
    if let Err(IecError::Invalid(lines)) = check(&s, &Natives::default()) {
        for l in lines.lines().filter(|l| *l != "no project") {
            assert!(amplify::is_coded(l), "{l}");
        }
    }
});
