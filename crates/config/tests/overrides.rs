//! `--set SECTION:NAME=VALUE` overrides: parsed, applied before the configuration is given
//! meaning, and named in messages.

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
    for bad in ["hmi", "hmi:listen", ":a=1", "a:=1", "a b:c=1", "a:b c=1"] {
        let e = bad.parse::<Override>().unwrap_err();
        assert!(e.contains("SECTION:NAME=VALUE"), "{bad}: {e}");
    }
}
