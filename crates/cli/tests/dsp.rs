//! The oven example (a dsp module's PID, alarms and filter around the thermal plant) through
//! the real binary: `petriplc status` shows the designed filter's order and coefficients while
//! it runs, the log and the trend are written, and bad fblock rows stop the start with
//! file:line.

use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use assert_cmd::Command;
use tempfile::TempDir;

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");

/// `petriplc status` of PLC `id` once it shows the dsp module's filter (20 s at most).
fn status_with_filter(id: &str) -> String {
    let started = Instant::now();
    loop {
        let out = Command::cargo_bin("petriplc")
            .unwrap()
            .args(["status", "--plc-id", id])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        if out.status.success() && text.contains("section 2:") {
            return text;
        }
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "no status: {text}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The `t=` of the `ctl` module's status line, seconds.
fn controller_time(status: &str) -> f64 {
    status
        .lines()
        .find_map(|l| l.split_once(" sections, t=").map(|(_, t)| t))
        .and_then(|t| t.trim_end_matches(" s").parse().ok())
        .unwrap_or(0.0)
}

#[test]
fn oven_status_shows_the_filter_and_the_run_writes_the_trend() {
    let dir = TempDir::new().unwrap();
    let id = format!("test-oven-{}", std::process::id());
    let log = dir.path().join("oven.csv");
    let plot = dir.path().join("oven.svg");
    let mut run = Process::cargo_bin("petriplc").unwrap();
    run.args([
        "run",
        &format!("{EXAMPLES}/oven/plc.conf"),
        "--plc-id",
        &id,
        "--for",
        "120s",
    ])
    .args(["--set", "hmi:listen=127.0.0.1:0"])
    .arg("--set")
    .arg(format!("log:file={}", log.display()))
    .arg("--set")
    .arg(format!("log:plot={}", plot.display()))
    .stdout(Stdio::null())
    .stderr(Stdio::piped());
    // Until the status shows the filter and a second of the controller's time (a fixed
    // `--for` could end before a loaded machine shows either), then stopped.
    let child = run.spawn().unwrap();
    let status = status_with_filter(&id);
    let started = Instant::now();
    while controller_time(&status_with_filter(&id)) < 1.0 {
        assert!(started.elapsed() < Duration::from_secs(60), "no progress");
        std::thread::sleep(Duration::from_millis(100));
    }
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", &id])
        .assert()
        .success();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let ctl: Vec<&str> = status
        .lines()
        .skip_while(|l| !l.starts_with("ctl "))
        .take(5)
        .collect();
    assert!(ctl[0].contains(" dsp "), "{status}");
    assert!(
        ctl[1]
            .trim_start()
            .starts_with("8 blocks, 2 second-order sections, t="),
        "{status}"
    );
    assert!(
        ctl[2].trim_start().starts_with(
            "filter butterworth lowpass: order 3 for 1/30 dB at 0.5 2 Hz (critical 0.6233961214492021 Hz)"
        ),
        "{status}"
    );
    assert!(
        ctl[3]
            .trim_start()
            .starts_with("section 1: b = 0.005264059293562908 "),
        "{status}"
    );
    let csv = std::fs::read_to_string(&log).unwrap();
    assert!(
        csv.starts_with("time,point,value\n") && csv.contains(",heater,"),
        "{csv}"
    );
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(
        svg.contains(">\ntemp\n<") && svg.contains(">\nheater\n<"),
        "no trend"
    );
}

#[test]
fn bad_fblock_rows_stop_the_start_with_file_and_line() {
    let dir = TempDir::new().unwrap();
    let conf = dir.path().join("plc.conf");
    std::fs::write(
        &conf,
        "[PLC]\nmodule ctl dsp\npoint y \"\" ctl f32\npoint x \"\" ctl f32\n[ctl]\nscan_period = 0.01\n\
         fblock filter x y elliptic lowpass 1 1 40 30 60\n",
    )
    .unwrap();
    let out = Command::cargo_bin("petriplc")
        .unwrap()
        .args(["run"])
        .arg(&conf)
        .args(["--plc-id", &format!("test-badrow-{}", std::process::id())])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!(
            "module ctl: {}:7: fblock filter: F2 = 60 Hz (stopband edge) is not below the Nyquist frequency 50 Hz",
            conf.display()
        )),
        "{err}"
    );
}
