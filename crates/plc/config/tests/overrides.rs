//! `--set SECTION:NAME=VALUE` and `--set 'SECTION:TABLE KEY CELL…'` overrides: parsed,
//! applied before the configuration is given meaning, and named in messages.

use std::time::Duration;

use petriplc_config::{read_file_with, Override};

const CONF: &str =
    "[PLC]\nmodule a shutdown\npoint q \"quit\" a\n[a]\npoint = q\nscan_period = 0.5\n";

fn read(sets: &[&str]) -> Result<petriplc_config::PlcConfig, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plc.conf");
    std::fs::write(&path, CONF).unwrap();
    let overrides: Vec<Override> = sets.iter().map(|s| s.parse().unwrap()).collect();
    read_file_with(&path, &overrides).map_err(|e| e.to_string())
}

#[test]
fn overrides_replace_or_add_settings_before_they_are_checked() {
    let cfg = read(&["a:scan_period=T#10ms", "a:extra = two words"]).unwrap();
    let a = &cfg.modules[0];
    assert_eq!(a.scan_period, Some(Duration::from_millis(10)));
    assert_eq!(a.settings.get("extra").unwrap().value, "two words");
    assert_eq!(
        a.settings.get("point").unwrap().value,
        "q",
        "others untouched"
    );
    assert_eq!(a.settings.get("scan_period").unwrap().origin.file, "--set");

    let err = read(&["a:scan_period=soon"]).unwrap_err();
    assert!(err.starts_with("--set: error[C034]"), "{err}");
    // Nobody would read a setting of a module that is not declared.
    let err = read(&["b:x=1"]).unwrap_err();
    assert!(err.starts_with("--set: error[C033]"), "{err}");
}

#[test]
fn only_section_name_value_parses() {
    let o: Override = "hmi:listen=127.0.0.1:8081".parse().unwrap();
    assert_eq!(
        (o.section.as_str(), o.name.as_str(), o.value.as_str()),
        ("hmi", "listen", "127.0.0.1:8081")
    );
    let o: Override = "m:v=".parse().unwrap();
    assert_eq!(o.value, "");
    for bad in ["hmi", "hmi:listen", ":a=1", "a:=1", "a b:c=1", "a:\"b"] {
        let e = bad.parse::<Override>().unwrap_err();
        assert!(e.contains("SECTION:NAME=VALUE"), "{bad}: {e}");
    }
}

/// Issue 27: `--set` could not override rows (the HiL example's `device … tcp:…:5021` needed
/// the file edited). A row override replaces the row of its table with the same first cell,
/// or adds one, and reads back as written.
#[test]
fn a_row_replaces_the_row_with_the_same_key_or_is_added() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("plc.conf");
    std::fs::write(
        &path,
        "[PLC]\nmodule io modbus_client\npoint x \"\" io\n\
         [io]\ndevice table tcp:127.0.0.1:5021 1 5ms 500ms\ndevice other tcp:10.0.0.1:502 2\n\
         read table x coil 0\n",
    )
    .unwrap();
    let sets: Vec<Override> = [
        "io:device table tcp:127.0.0.1:5022 1 5ms 500ms",
        "io: read spare x coil \"1\"",
    ]
    .iter()
    .map(|s| s.parse().unwrap())
    .collect();
    assert_eq!(
        sets[0].to_string(),
        "io:device table tcp:127.0.0.1:5022 1 5ms 500ms"
    );
    assert_eq!(sets[0].to_string().parse::<Override>().unwrap(), sets[0]);
    let odd: Override = "io:label a \"two words\" \"q\\\"x\"".parse().unwrap();
    assert_eq!(odd.cells.as_deref().unwrap(), ["a", "two words", "q\"x"]);
    assert_eq!(odd.to_string().parse::<Override>().unwrap(), odd);
    let cfg = read_file_with(&path, &sets).unwrap();
    let rows: Vec<String> = cfg.sections["io"]
        .rows
        .iter()
        .map(|r| format!("{} {}", r.table, r.cells.join(" ")))
        .collect();
    assert_eq!(
        rows,
        [
            "device table tcp:127.0.0.1:5022 1 5ms 500ms",
            "device other tcp:10.0.0.1:502 2",
            "read table x coil 0",
            "read spare x coil 1",
        ]
    );
    assert_eq!(cfg.sections["io"].rows[0].origin.file, "--set");
}
