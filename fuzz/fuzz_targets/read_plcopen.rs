//! Fuzzes the PLCopen XML reader and the checker behind it: no input may panic.

#![no_main]

use libfuzzer_sys::fuzz_target;
use petriplc_iec::{check, Natives, Sources};

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    let mut s = Sources::new();
    s.add_text("fuzz.xml", &text);
    let _ = check(&s, &Natives::default());
});
