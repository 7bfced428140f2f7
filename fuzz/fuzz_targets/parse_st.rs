//! Fuzzes the Structured Text lexer and parser: no input may panic, hang or exhaust the
//! stack, and every problem is a diagnostic with a code and a position inside the source.
//! Inputs are amplified (`amplify.rs`): nesting, chains and names up to 20 000 deep or long.

#![no_main]

#[path = "amplify.rs"]
mod amplify;

use libfuzzer_sys::fuzz_target;
use petriplc_iec::syntax::{parse, Diagnostics, SourceMap};

fuzz_target!(|data: &[u8]| {
    let data = amplify::amplify(data, amplify::ST);
    let text = String::from_utf8_lossy(&data);
    let mut map = SourceMap::new();
    let f = map.add("fuzz.st", text.as_ref());
    let mut d = Diagnostics::new();
    let _ = parse(f, &text, &mut d);
    for diag in &d.items {
        assert!(diag.span.start as usize <= text.len() && diag.span.end as usize <= text.len());
        assert!(
            amplify::is_coded(&diag.render(&map)),
            "{}",
            diag.render(&map)
        );
    }
});
