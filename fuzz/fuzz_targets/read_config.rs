//! Fuzzes the configuration reader: no text may panic it, every problem it reports names a
//! line of the text, and every configuration it accepts has declared owners for its points.

#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use petriplc_config::parse_str;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    // A directory that does not exist keeps relative `*include`s from reading real files.
    match parse_str(text, "fuzz.conf", Path::new("/nonexistent-petriplc-fuzz")) {
        Ok(config) => {
            for p in &config.points {
                assert!(config.modules.iter().any(|m| m.name == p.owner));
            }
        }
        Err(e) => {
            assert!(!e.diagnostics.is_empty());
            for d in &e.diagnostics {
                // Absolute includes may name other files; the text's own lines must exist.
                if d.origin.file == "fuzz.conf" {
                    assert!(d.origin.line >= 1 && d.origin.line <= text.lines().count().max(1));
                }
            }
        }
    }
});
