//! Fuzzes the PNML reader: no input may panic, and every net it accepts must write back as
//! PNML that reads as the same net.

#![no_main]

use libfuzzer_sys::fuzz_target;
use petriplc_pnml::{read_str, write_string, Naming, ReadOptions};

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    for naming in [Naming::Plain, Naming::Sipn] {
        if let Ok(doc) = read_str(text, "fuzz.pnml", &ReadOptions { naming }) {
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
