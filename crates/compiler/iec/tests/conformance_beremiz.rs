//! Conformance over third-party code: Beremiz's PLCopen projects and libraries, the sample
//! projects in `../shared/schemas/plcopen/samples` (not copied into the repository). Without
//! `../shared` each test says in one line that it was skipped.

use std::path::{Path, PathBuf};

use petriplc_iec::{check, Natives, Sources};

/// The sample projects, if `../shared` is there.
fn samples(test: &str) -> Option<PathBuf> {
    petriplc_testnet::data::conformance(test, "schemas/plcopen/samples")
}

fn checked(path: &str) -> Result<Vec<String>, String> {
    let mut s = Sources::new();
    s.add_file(Path::new(path)).map_err(|e| e.to_string())?;
    check(&s, &Natives::default())
        .map(|c| c.warnings)
        .map_err(|e| e.to_string())
}

#[test]
fn beremiz_libraries_load() {
    let Some(samples) = samples("beremiz_libraries_load") else {
        return;
    };
    let samples = samples.display();
    let w = checked(&format!("{samples}/plcopen_Standard_Function_Blocks.xml")).unwrap();
    assert!(
        w.iter().any(|w| w
            .contains("warning[W001]: FUNCTION_BLOCK TON replaces the standard function block")),
        "{w:?}"
    );
    checked(&format!("{samples}/plcopen_Additional_Function_Blocks.xml")).unwrap();
}

#[test]
fn beremiz_projects_in_other_languages_check() {
    let Some(dir) = samples("beremiz_projects_in_other_languages_check") else {
        return;
    };
    // plc_prg is FBD (lowered like LD); the block it calls, Beremiz's CounterIL, is written
    // in IL: with both front ends the whole project checks, with nothing to report.
    let w = checked(&format!("{}/exemples_first_steps.xml", dir.display()))
        .unwrap_or_else(|e| panic!("the FBD program calling an IL block is refused:\n{e}"));
    assert!(!w.iter().any(|w| w.contains("CounterIL")), "{w:?}");
    // Every sample is read without a crash, whatever it holds.
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let _ = checked(&path.display().to_string());
    }
}

#[test]
fn beremiz_traffic_light_sfc_is_checked() {
    // The project's HMI types come from Beremiz's SVGHMI library, which is not in the file:
    // the file is recognised as Beremiz's, so the `beremiz` library is loaded and provides
    // them.
    let Some(dir) = samples("beremiz_traffic_light_sfc_is_checked") else {
        return;
    };
    let path = dir.join("exemples_svghmi_traffic_light.xml");
    let mut s = Sources::new();
    s.add_file(&path).unwrap();
    if let Err(e) = check(&s, &Natives::default()) {
        panic!("the Beremiz project is refused with its library loaded:\n{e}");
    }
}
