//! Fuzzes the guard parser: no input may panic, and every guard it accepts must print in
//! canonical form and parse back to the same tree.

#![no_main]

use libfuzzer_sys::fuzz_target;
use petriplc_net::guard::parse;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(expr) = parse(text) {
        let printed = expr.to_string();
        let back = parse(&printed).unwrap_or_else(|e| panic!("`{printed}` does not parse back: {e}"));
        assert_eq!(back, expr, "`{text}` printed as `{printed}`");
    }
});
