//! Fuzzes the PNML reader: no input may panic, a refused file has coded diagnostics
//! (`P0xx`), and every net it accepts must write back as PNML that reads as the same net.
//! Inputs are amplified (`amplify.rs`): pages, guards and numbers up to 20 000 deep or long.

#![no_main]

#[path = "amplify.rs"]
mod amplify;

use libfuzzer_sys::fuzz_target;
use petriplc_pnml::{read_str, write_string, Naming, ReadOptions};

fuzz_target!(|data: &[u8]| {
    let data = amplify::amplify(data, amplify::PNML);
    let Ok(text) = std::str::from_utf8(&data) else {
        return;
    };
    for naming in [Naming::Plain, Naming::Sipn] {
        let read = read_str(text, "fuzz.pnml", &ReadOptions { naming });
        if let Err(e) = &read {
            for d in e.diagnostics() {
                assert!(d.code.len() == 4 && d.code.starts_with('P'), "{d}");
            }
        }
        if let Ok(doc) = read {
            let written = write_string(&doc.net, Some(&doc.layout));
            match read_str(&written, "written.pnml", &ReadOptions::default()) {
                Ok(back) => assert_eq!(
                    back.net, doc.net,
                    "the net changed on the way back:\n{written}"
                ),
                Err(e) => panic!("written PNML does not read back:\n{e}\n{written}"),
            }
        }
    }
});
