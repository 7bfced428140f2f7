//! Conformance over third-party files: every configuration file of MatPLC's reference
//! (`../shared/reference/matplc`, MatPLC's own, not copied into the repository) read at
//! layer 1, as shipped and in the directory layout the demos were written for, plus the
//! typed outcome of a few of them. Without `../shared` each test says it was skipped.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use petriplc_config::{read_file, read_raw};

/// MatPLC's reference folder, if `../shared` is there.
fn reference(test: &str) -> Option<PathBuf> {
    petriplc_testnet::data::conformance(test, "reference/matplc")
}

fn reference_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("MatPLC's reference folder")
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.is_file()
                && p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.contains(".conf"))
        })
        .collect();
    files.sort();
    files
}

/// The demos that `*include vitrine.conf`, a file shipped here as `demo-X-vitrine.conf`, and
/// the line of the include.
fn missing_vitrine() -> BTreeMap<&'static str, usize> {
    BTreeMap::from([
        ("demo-basic-matplc.conf", 66),
        ("demo-basic_cif-matplc.conf", 31),
        ("demo-basic_dsp-matplc.conf", 39),
        ("demo-basic_iec-matplc.conf", 86),
        ("demo-basic_il-matplc.conf", 82),
        ("demo-basic_logger-matplc.conf", 86),
        ("demo-basic_modbus-matplc.conf", 35),
        ("demo-basic_modbus_slave-matplc.conf", 36),
        ("demo-basic_parport-matplc.conf", 31),
        ("demo-basic_plc5-matplc.conf", 33),
        ("demo-basic_synch-matplc.conf", 64),
        ("demo-basic_synch-matplc.conf.complex", 64),
        ("demo-basic_synch-matplc.conf.simple", 64),
        ("demo-oven-matplc.conf", 206),
    ])
}

#[test]
fn every_reference_file_reads_at_layer_one_or_misses_its_include() {
    let Some(dir) = reference("every_reference_file_reads_at_layer_one_or_misses_its_include")
    else {
        return;
    };
    let files = reference_files(&dir);
    let r = dir.display();
    assert_eq!(files.len(), 37, "{files:?}");
    let missing = missing_vitrine();
    for path in &files {
        let name = path.file_name().unwrap().to_str().unwrap();
        match (read_raw(path), missing.get(name)) {
            (Ok(raw), None) => {
                assert!(!raw.sections.is_empty(), "{name} has no sections");
            }
            (Err(e), Some(line)) => assert_eq!(
                e.to_string(),
                format!(
                    "{r}/{name}:{line}: error[C001]: cannot read included file \
                     `{r}/vitrine.conf`: no such file; check \
                     the name (it is relative to the directory of `{r}/{name}`)"
                ),
            ),
            (Ok(_), Some(_)) => panic!("{name} was expected to miss vitrine.conf"),
            (Err(e), None) => panic!("{name} does not read:\n{e}"),
        }
    }
}

/// Puts `demo-X-matplc.conf*` and `demo-X-vitrine.conf` back as `X/matplc.conf*` and
/// `X/vitrine.conf`, as in MatPLC's source tree.
fn demo_tree(reference: &Path, root: &Path) -> Vec<PathBuf> {
    let mut mains = Vec::new();
    for path in reference_files(reference) {
        let name = path.file_name().unwrap().to_str().unwrap();
        let Some(rest) = name.strip_prefix("demo-") else {
            continue;
        };
        let (demo, file) = rest.split_once('-').unwrap();
        let dir = root.join(demo);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::copy(&path, dir.join(file)).unwrap();
        if file.starts_with("matplc.conf") {
            mains.push(dir.join(file));
        }
    }
    mains.sort();
    mains
}

#[test]
fn every_demo_reads_at_layer_one_in_its_own_directory() {
    let Some(dir) = reference("every_demo_reads_at_layer_one_in_its_own_directory") else {
        return;
    };
    let root = tempfile::tempdir().unwrap();
    let mains = demo_tree(&dir, root.path());
    assert_eq!(mains.len(), 24);
    for main in &mains {
        let raw = read_raw(main).unwrap_or_else(|e| panic!("{}:\n{e}", main.display()));
        assert!(raw.sections.contains_key("PLC"), "{}", main.display());
    }
    // The included file's rows land in its own section, with its own file and lines.
    let basic = read_raw(&root.path().join("basic/matplc.conf")).unwrap();
    let vitrine = &basic.sections["vitrine"];
    let shows: Vec<String> = vitrine
        .rows
        .iter()
        .map(|r| format!("{}:{} {}", r.origin.line, r.table, r.cells.join("|")))
        .collect();
    assert_eq!(
        shows,
        [
            "8:show L1|6|31|(*)| -",
            "9:show L2|6|34|(*)| -",
            "10:show L3|6|37|(*)| -",
            "11:show L4|6|40|(*)| -",
            "12:show left|10|35|<*| <",
            "13:show right|10|38|*>|>",
            "14:show quit|10|37|Q|-",
        ]
    );
    assert!(vitrine.rows[0].origin.file.ends_with("basic/vitrine.conf"));
    let pairs: Vec<String> = vitrine
        .pairs
        .iter()
        .map(|(k, v)| format!("{k}={} ({})", v.value, v.origin.line))
        .collect();
    assert_eq!(
        pairs,
        ["background=vitrine.txt (4)", "scan_period=0.01 (84)"]
    );
    // `Chaser: delay = 0.3` before any header goes to [Chaser].
    assert_eq!(basic.sections["Chaser"].pairs[0].1.value, "0.3");
    assert_eq!(basic.sections["Chaser"].pairs[0].1.origin.line, 8);
}

#[test]
fn typed_outcome_of_some_reference_files() {
    let Some(dir) = reference("typed_outcome_of_some_reference_files") else {
        return;
    };
    let file = |n: &str| dir.join(n);
    // MatPLC's configuration memory key means nothing to petriplc, and nothing would read
    // it: an error, as every setting nobody reads.
    let tank = read_file(&file("demo-tank_hmiViewer-matplc.conf")).unwrap_err();
    assert_eq!(tank.codes(), ["C012", "C012"]);
    assert_eq!(tank.diagnostics[0].span.line, 11);
    assert!(tank.diagnostics[0]
        .message
        .starts_with("`confmap_key = 20` in [PLC]: nothing reads this setting"));

    // The Tcl demo's keyboard module is commented out, but its points are still owned by it.
    // Its [Kbd] section then configures a module nobody declares.
    let tcl = read_file(&file("demo-basic_tcl-matplc.conf")).unwrap_err();
    assert_eq!(
        tcl.codes(),
        ["C022", "C022", "C022", "C033", "C033", "C033", "C033"]
    );
    assert!(tcl.diagnostics[0].message.contains("`Kbd`"));

    // gtk2 renamed its module hmi_gtk2 but still sets hmi_gtk's period.
    let gtk2 = read_file(&file("demo-basic_dsp_gtk2-matplc.conf")).unwrap_err();
    assert_eq!(gtk2.codes(), ["C011", "C033", "C033"]);
    assert_eq!(gtk2.diagnostics[1].span.line, 35);
    assert!(gtk2.diagnostics[1]
        .message
        .starts_with("`scan_period` is set for `hmi_gtk`"));

    // The appendix holds its three sample configurations in one file.
    let appendix = read_file(&file("appendix-matplc.conf")).unwrap_err();
    assert_eq!(
        appendix.codes(),
        ["C021", "C021", "C021", "C021", "C021", "C021", "C031", "C031", "C031"]
    );
}

#[test]
fn the_complex_synch_demo_types_once_its_keyboard_is_declared() {
    let Some(dir) = reference("the_complex_synch_demo_types_once_its_keyboard_is_declared") else {
        return;
    };
    let root = tempfile::tempdir().unwrap();
    demo_tree(&dir, root.path());
    let main = root.path().join("basic_synch/matplc.conf.complex");
    let text = std::fs::read_to_string(&main).unwrap() + "\n[PLC]\nmodule Kbd ./kbd\n";
    std::fs::write(&main, text).unwrap();
    let c = read_file(&main).unwrap_or_else(|e| panic!("{e}"));
    let net = &c.synch;
    assert_eq!(net.places.len(), 2);
    assert_eq!(net.transitions.len(), 4);
    assert_eq!(net.arcs.len(), 4);
    let chaser = c.modules.iter().find(|m| m.name == "Chaser").unwrap();
    assert_eq!(chaser.scan_beg.as_deref(), Some("T_chaser_beg"));
    assert_eq!(chaser.scan_end.as_deref(), Some("T_chaser_end"));
    assert_eq!(
        chaser.scan_period,
        Some(std::time::Duration::from_millis(20))
    );
    assert_eq!(chaser.settings["delay"].value, "0.3");
    let l1 = c.points.iter().find(|p| p.name == "L1").unwrap();
    assert_eq!((l1.at, l1.bits), (Some((0, 0)), 1));
}
