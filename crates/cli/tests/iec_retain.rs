//! `VAR RETAIN` through the real binary: an ST program counts in a RETAIN variable and a
//! RETAIN CTU instance; the PLC is killed with SIGKILL and started again, and the program
//! resumes from exactly what the retain file held while its other variables start from their
//! initial values; a changed declaration is refused with the documented message. A plain
//! output variable that drives a retentive point goes on from the point's stored value.
//!
//! No timing assertions: waits poll for a state with a generous safety limit.

use std::fs;
use std::path::Path;
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use petriplc_retain::Value;

const SAFETY_NET: Duration = Duration::from_secs(60);

fn petriplc() -> Process {
    Process::cargo_bin("petriplc").unwrap()
}

/// `total` counts scans across restarts; `ctr` counts every second one; `scans` (not
/// retained) counts the scans of this start only, so `resumed`/`cv_resumed` record, in the
/// first scan after a restart, what was given back.
fn program(total_type: &str) -> String {
    format!(
        "PROGRAM main\n\
         VAR RETAIN total : {total_type}; resumed : DINT; cv_resumed : INT; ctr : CTU; END_VAR\n\
         VAR scans : DINT := 0; END_VAR\n\
         VAR_OUTPUT count : DINT; END_VAR\n\
         IF scans = 0 AND total > 0 THEN resumed := total; cv_resumed := ctr.CV; END_IF;\n\
         scans := scans + 1;\n\
         total := total + 1;\n\
         ctr(CU := total MOD 2 = 0, PV := 32000);\n\
         count := total;\n\
         END_PROGRAM\n"
    )
}

const CONF: &str = "[PLC]\nmodule logic iec\n\
    point count \"scans counted\" logic i32\n\
    retain_file = state/plc.retain\nretain_write = change\n\
    [logic]\nprogram = main.st\nscan_period = T#1ms\n";

/// The program's retained values in the file, by variable path (lower case), as integers.
fn stored(path: &Path) -> Vec<(String, i64)> {
    let Ok(loaded) = petriplc_retain::file::peek(path) else {
        return Vec::new();
    };
    assert_eq!(
        loaded.warnings,
        Vec::<String>::new(),
        "the retain file is damaged"
    );
    let Some(snap) = loaded.snapshot else {
        return Vec::new();
    };
    snap.entries
        .iter()
        .filter_map(|e| match &e.value {
            Value::Data { bytes, .. } => Some((
                e.name.to_ascii_lowercase(),
                i64::from_le_bytes(bytes[..8].try_into().unwrap()),
            )),
            Value::Point { .. } => None,
        })
        .collect()
}

/// Runs the PLC of `conf` until `done` holds, then kills it with SIGKILL.
fn kill_9_once(conf: &Path, id: &str, done: impl Fn() -> bool) {
    let mut plc = petriplc()
        .arg("run")
        .arg(conf)
        .args(["--plc-id", id, "--log-level", "warn"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !done() {
        if let Some(exit) = plc.try_wait().unwrap() {
            let out = plc.wait_with_output().unwrap();
            panic!(
                "the PLC exited ({exit}):\n{}",
                String::from_utf8_lossy(&out.stderr)
            );
        }
        assert!(started.elapsed() < SAFETY_NET, "nothing retained in time");
        std::thread::sleep(Duration::from_millis(5));
    }
    plc.kill().unwrap();
    plc.wait().unwrap();
}

fn value(entries: &[(String, i64)], name: &str) -> Option<i64> {
    entries.iter().find(|(n, _)| n == name).map(|(_, v)| *v)
}

#[test]
fn var_retain_survives_kill_9_and_a_changed_declaration_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(dir.path().join("main.st"), program("DINT")).unwrap();
    let conf = dir.path().join("plc.conf");
    fs::write(&conf, CONF).unwrap();
    let retain = dir.path().join("state/plc.retain");
    let id = format!("iecret-{}", std::process::id());

    // Run until the file holds a count of at least 50, then kill -9.
    kill_9_once(&conf, &id, || {
        value(&stored(&retain), "logic/main.total").is_some_and(|t| t >= 50)
    });
    let at_kill = stored(&retain);
    let total = value(&at_kill, "logic/main.total").unwrap();
    // The CTU instance is stored whole; its count follows the total.
    assert!(
        at_kill.iter().any(|(n, _)| n == "logic/main.ctr"),
        "{at_kill:?}"
    );
    assert!(value(&at_kill, "logic/main.scans").is_none(), "{at_kill:?}");

    // A clean restart goes on from exactly the stored values. It runs until the file shows
    // the restart's first scans (a fixed `--for` may hold none on a loaded machine), then is
    // stopped.
    let plc = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &id, "--for", "120s", "--log-level", "warn"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while value(&stored(&retain), "logic/main.total").is_none_or(|t| t <= total) {
        assert!(started.elapsed() < SAFETY_NET, "no scan after the restart");
        std::thread::sleep(Duration::from_millis(5));
    }
    let stop = petriplc().args(["stop", "--plc-id", &id]).output().unwrap();
    assert!(
        stop.status.success(),
        "{}",
        String::from_utf8_lossy(&stop.stderr)
    );
    let out = plc.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    let after = stored(&retain);
    assert_eq!(
        value(&after, "logic/main.resumed"),
        Some(total),
        "{after:?}"
    );
    assert_eq!(
        value(&after, "logic/main.cv_resumed"),
        Some(total / 2),
        "the RETAIN CTU instance came back with its count: {after:?}"
    );
    assert!(value(&after, "logic/main.total").unwrap() > total);

    // The declaration changes: refused, naming the value and both types, exit 2.
    fs::write(dir.path().join("main.st"), program("INT")).unwrap();
    let out = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &id, "--for", "200ms"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains(
            "`main.total` of module logic was stored as `DINT` and the module now keeps it as \
             `INT`: its stored value is not reinterpreted"
        ),
        "{err}"
    );
    // Nothing was overwritten by the refused start.
    assert_eq!(stored(&retain), after);
}

/// The stored bits of retentive point `name`.
fn stored_point(path: &Path, name: &str) -> Option<u32> {
    let loaded = petriplc_retain::file::peek(path).ok()?;
    loaded.snapshot?.entries.iter().find_map(|e| match e.value {
        Value::Point { raw, .. } if e.name == name => Some(raw),
        _ => None,
    })
}

/// Issue 27: `point batches … retain` driven by a VAR_OUTPUT that is not RETAIN was given
/// back ("restored 1 of 1 retentive points") and then overwritten by the variable's initial
/// value at the first scan (197 → 63). The variable now starts from the restored value.
#[test]
fn a_plain_output_driving_a_retentive_point_goes_on_from_its_stored_value() {
    let dir = tempfile::tempdir().unwrap();
    fs::write(
        dir.path().join("main.st"),
        "PROGRAM main\n\
         VAR_OUTPUT batches : UDINT := 63; END_VAR\n\
         VAR scans : DINT; END_VAR\n\
         VAR RETAIN resumed : UDINT; END_VAR\n\
         IF scans = 0 THEN resumed := batches; END_IF;\n\
         scans := scans + 1;\n\
         batches := batches + 1;\n\
         END_PROGRAM\n",
    )
    .unwrap();
    let conf = dir.path().join("plc.conf");
    fs::write(
        &conf,
        "[PLC]\nmodule logic iec\n\
         point batches \"batches made\" logic u32 retain\n\
         retain_file = state/plc.retain\nretain_write = change\n\
         [logic]\nprogram = main.st\nscan_period = T#1ms\n",
    )
    .unwrap();
    let retain = dir.path().join("state/plc.retain");
    let id = format!("iecpt-{}", std::process::id());
    kill_9_once(&conf, &id, || {
        stored_point(&retain, "batches").is_some_and(|b| b >= 197)
    });
    let at_kill = stored_point(&retain, "batches").unwrap();

    let out = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &id, "--for", "200ms"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(err.contains("restored 1 of 1 retentive point"), "{err}");
    // In its first scan the variable held exactly what the file gave back, and the count
    // went on from there.
    assert_eq!(
        value(&stored(&retain), "logic/main.resumed"),
        Some(i64::from(at_kill)),
        "{err}"
    );
    assert!(stored_point(&retain, "batches").unwrap() > at_kill);
}
