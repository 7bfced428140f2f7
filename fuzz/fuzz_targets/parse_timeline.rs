//! Fuzzes the timeline CSV parser: no input may panic, and every timeline it accepts must
//! write back as CSV that parses to the same values at every row time.

#![no_main]

use libfuzzer_sys::fuzz_target;
use petriplc_sim::Timeline;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(tl) = Timeline::parse(text, "fuzz.csv") {
        let written = tl.to_string();
        let back = Timeline::parse(&written, "written.csv")
            .unwrap_or_else(|e| panic!("written timeline does not parse back: {e}\n{written}"));
        assert_eq!(back.columns(), tl.columns());
        for c in 0..tl.columns().len() {
            for &(t, _) in tl.changes(c) {
                assert_eq!(back.value_at(c, t), tl.value_at(c, t), "{written}");
            }
        }
    }
});
