//! examples/two-cells through the real binary: the mixer's controller on one PLC and its tank
//! on another (two `--plc-id`s), exchanging valves and level sensors through Debian's
//! mosquitto started on a free loopback port; the broker is killed and started again mid-run;
//! paho-mqtt (a third-party client, pinned in scripts/test-all.sh) watches the topics.
//!
//! The documented-commands test (docs.rs) leaves examples/two-cells/README.md to this file:
//! its ```sh block starts background jobs and waits for them, so it runs here as one script.

use std::path::{Path, PathBuf};
use std::process::{Child, Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use petriplc_mqtt::testing::Broker;

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/two-cells");

fn python() -> PathBuf {
    std::env::var_os("PETRIPLC_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/py/bin/python"))
}

/// `petriplc run examples/two-cells/CELL.conf` as PLC `id`, on the test's broker, until the
/// test stops it (`--for` only bounds a broken run).
fn cell(cell: &str, id: &str, broker: &Broker, log: &Path, extra: &[&str]) -> Child {
    Process::cargo_bin("petriplc")
        .unwrap()
        .args(["run", &format!("{EXAMPLES}/{cell}.conf"), "--plc-id", id])
        .args(["--for", "120s", "--log"])
        .arg(log)
        .args(["--set", &format!("mqtt:broker={}", broker.address())])
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// `petriplc status` of PLC `id` (empty while it does not answer).
fn status(id: &str) -> String {
    let out = Process::cargo_bin("petriplc")
        .unwrap()
        .args(["status", "--plc-id", id])
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The mqtt module's line of `petriplc status`.
fn mqtt_line(id: &str) -> String {
    status(id)
        .lines()
        .find(|l| l.contains("broker "))
        .unwrap_or_default()
        .to_string()
}

fn wait_until(what: &str, done: impl Fn() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(start.elapsed() < Duration::from_secs(30), "{what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// How often transition `t` has fired so far, from `petriplc status` (0 before the first).
fn fired_so_far(id: &str, t: &str) -> u64 {
    let status = status(id);
    status
        .lines()
        .find(|l| l.contains("fired "))
        .and_then(|line| {
            line.split_whitespace()
                .find_map(|w| w.strip_prefix(&format!("{t}:")))
                .and_then(|n| n.parse().ok())
        })
        .unwrap_or(0)
}

fn stop(id: &str) {
    let out = Process::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", id])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "stop {id}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// How often transition `t` fired, from the controller's status line `fired B1:3 N2:3 ...`.
fn fired(report: &str, t: &str) -> u64 {
    let line = report
        .lines()
        .find(|l| l.contains("fired "))
        .unwrap_or_else(|| panic!("no controller status in:\n{report}"));
    line.split_whitespace()
        .find_map(|w| w.strip_prefix(&format!("{t}:")))
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no count for {t} in `{line}`"))
}

/// The topics paho must see go 1 and 0.
const TOPICS: [&str; 5] = [
    "control/V1",
    "control/V3",
    "control/B1",
    "plant/N2",
    "plant/N3",
];

#[test]
fn two_plcs_run_the_mixer_through_mosquitto_and_survive_a_broker_restart() {
    let dir = tempfile::tempdir().unwrap();
    let mut broker = Broker::start();
    let pid = std::process::id();
    let (control_id, plant_id) = (format!("control-{pid}"), format!("plant-{pid}"));
    let plant = cell(
        "plant",
        &plant_id,
        &broker,
        &dir.path().join("plant.log"),
        &[],
    );
    let state = format!("opcua:state_dir={}", dir.path().join("opcua").display());
    let control = cell(
        "control",
        &control_id,
        &broker,
        &dir.path().join("control.log"),
        &["--set", "opcua:listen=127.0.0.1:0", "--set", &state],
    );
    let watcher = Process::new(python())
        .arg(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/two_cells_paho.py"
        ))
        .args([&broker.port.to_string(), "60"])
        .args(TOPICS)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python with paho-mqtt (scripts/test-all.sh installs it into target/py)");

    wait_until("both cells connected", || {
        mqtt_line(&control_id).contains(" up;") && mqtt_line(&plant_id).contains(" up;")
    });
    std::thread::sleep(Duration::from_millis(2500));
    broker.kill();
    wait_until("both cells see the outage", || {
        mqtt_line(&control_id).contains("stale: ") && mqtt_line(&plant_id).contains("stale: ")
    });
    std::thread::sleep(Duration::from_millis(700));
    broker.restart();
    wait_until("both cells reconnected", || {
        mqtt_line(&control_id).contains(" up;") && mqtt_line(&plant_id).contains(" up;")
    });
    // Wait for what is asserted below (two whole cycles, paho seeing every value), not for
    // a fixed time, then stop both cells.
    let start = Instant::now();
    while fired_so_far(&control_id, "N1") < 2 {
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "{}",
            status(&control_id)
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let watched = watcher.wait_with_output().unwrap();
    stop(&control_id);
    stop(&plant_id);

    let control = control.wait_with_output().unwrap();
    let plant = plant.wait_with_output().unwrap();
    let report = String::from_utf8_lossy(&control.stderr);
    assert!(control.status.success(), "control cell:\n{report}");
    assert!(
        plant.status.success(),
        "plant cell:\n{}",
        String::from_utf8_lossy(&plant.stderr)
    );
    // The controller went through whole cycles against a tank on another PLC, outage or not.
    assert!(fired(&report, "N1") >= 2, "{report}");
    for t in ["B1", "N2", "N3"] {
        assert!(fired(&report, t) >= fired(&report, "N1"), "{report}");
    }
    // One warning per outage, not one per scan or per attempt.
    for (name, log) in [("control", "control.log"), ("plant", "plant.log")] {
        let text = std::fs::read_to_string(dir.path().join(log)).unwrap();
        let warnings = text.matches("unreachable").count();
        assert_eq!(warnings, 1, "{name}:\n{text}");
        assert!(text.contains("again after"), "{name}:\n{text}");
        assert!(!text.contains("panicked"), "{name}:\n{text}");
    }
    // A third-party client saw both cells' values change.
    let seen = String::from_utf8_lossy(&watched.stdout);
    assert!(
        watched.status.success(),
        "{seen}\n{}",
        String::from_utf8_lossy(&watched.stderr)
    );
    let json: serde_json::Value = serde_json::from_str(seen.trim()).unwrap();
    for topic in TOPICS {
        let values: Vec<&str> = json[topic]
            .as_array()
            .unwrap_or_else(|| panic!("paho saw no {topic}: {seen}"))
            .iter()
            .filter_map(|v| v.as_str())
            .collect();
        assert!(
            values.contains(&"1") && values.contains(&"0"),
            "{topic}: {values:?}"
        );
    }
}

/// The README's ```sh block, run as one bash script from the repository root (`petriplc`
/// being the built binary): both cells run a whole cycle through the README's broker.
#[test]
fn the_readme_runs_as_written() {
    let readme = std::fs::read_to_string(format!("{EXAMPLES}/README.md")).unwrap();
    let blocks: Vec<&str> = readme
        .split("```sh\n")
        .skip(1)
        .map(|b| b.split("```").next().unwrap())
        .collect();
    assert_eq!(blocks.len(), 1, "the README has one ```sh block, run here");
    let bin = assert_cmd::cargo::cargo_bin("petriplc");
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Process::new("bash")
        .args(["-e", "-c", blocks[0]])
        .current_dir(format!("{EXAMPLES}/../.."))
        .env("PATH", path)
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "the README's block failed:\n{stderr}");
    assert!(fired(&stderr, "B1") >= 1, "no cycle ran:\n{stderr}");
}
