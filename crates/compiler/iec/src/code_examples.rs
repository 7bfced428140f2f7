//! Every example of docs/diagnostics.md's IEC sections, built as a user's file would be,
//! gets the code it illustrates (the tables are petriplc-iec-syntax's `codes.rs`).

use petriplc_iec_syntax::codes::{CODES, PLCOPEN_CODES, TWINCAT_CODES};

use crate::{build_text, Select};

/// What building `text` as `name` prints: the errors, or the warnings.
fn diagnostics(name: &str, text: &str) -> String {
    match build_text(name, text, &Select::Auto) {
        Ok(b) => b.warnings.join("\n"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn every_example_gets_its_code() {
    let mut missing = Vec::new();
    let tables = [
        (CODES, "t.st"),
        (PLCOPEN_CODES, "t.xml"),
        (TWINCAT_CODES, "t.TcPOU"),
    ];
    for (table, name) in tables {
        for entry in table.iter().filter(|e| !e.example.is_empty()) {
            let got = diagnostics(name, entry.example);
            if !got.contains(&format!("[{}]", entry.code)) {
                missing.push(format!("{}: the example gets\n{got}", entry.code));
            }
        }
    }
    assert!(missing.is_empty(), "{}", missing.join("\n\n"));
}
