//! A source saved in a single-byte code page (CODESYS, TwinCAT and PCWorx write Windows-1252,
//! OSCAT's files hold `ä` and `°` so) is read byte for byte: a character of a string literal
//! is one byte of STRING, as on those PLCs, not the three bytes of a replacement character.

use petriplc_iec::{build, Natives, Select, Sources};
use petriplc_iec_vm::Machine;

#[test]
fn a_latin1_file_keeps_one_byte_per_character() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("umlauts.st");
    let mut text = b"PROGRAM main\nVAR s : STRING[3] := '".to_vec();
    text.extend_from_slice(&[0xe4, 0xf6, 0xfc]); // äöü in Latin-1
    text.extend_from_slice(b"'; n : INT; b : BYTE; END_VAR\nn := LEN(s);\nEND_PROGRAM\n");
    std::fs::write(&path, &text).unwrap();
    let mut sources = Sources::new();
    sources.add_file(&path).unwrap();
    let b = match build(&sources, &Select::Auto, Natives::default()) {
        Ok(b) => b,
        Err(e) => panic!("{e}"),
    };
    let mut m = Machine::new(b.engine.clone());
    m.scan(0, &mut || true).unwrap();
    let n = b.engine.lookup("main.n").unwrap();
    let v = m.get(n).unwrap();
    assert_eq!(petriplc_iec_vm::display(&b.engine.project, n.ty, &v), "3");
}
