//! Fuzzes the retain file reader: any bytes as a slot must decode to a snapshot or a reason,
//! never a panic, and a decoded snapshot encodes back to the same bytes.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    if let Ok((snap, len)) = petriplc_retain::file::decode(bytes) {
        assert_eq!(petriplc_retain::file::encode(&snap), &bytes[..len]);
    }
});
