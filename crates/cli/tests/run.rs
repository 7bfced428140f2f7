//! `petriplc run`, `status` and `stop` through the real binary: the README's main job (the
//! mixer controller against the simulated tank) goes through full cycles; status and stop
//! reach a running PLC; bad configurations start nothing; failing modules follow
//! `on_failure`.

mod common;

use std::fs;
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use assert_cmd::Command;
use predicates::prelude::*;
use tempfile::TempDir;

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");

/// The mixer's Modbus server and HMI on ports the system picks, so that runs side by side
/// do not collide on 5020 and 8080.
const FREE_PORTS: [&str; 4] = [
    "--set",
    "modbus:listen=127.0.0.1:0",
    "--set",
    "hmi:listen=127.0.0.1:0",
];

fn plc_id(name: &str) -> String {
    format!("test-{name}-{}", std::process::id())
}

/// `petriplc run` of the README's main job (examples/mixer/plc.conf) as PLC `id`.
fn mixer(id: &str) -> Process {
    let mut run = Process::cargo_bin("petriplc").unwrap();
    run.args(["run", &format!("{EXAMPLES}/mixer/plc.conf"), "--plc-id", id]);
    run
}

/// `petriplc status` of PLC `id` once it runs (20 s at most).
fn wait_for_status(id: &str) -> String {
    let started = Instant::now();
    loop {
        let out = Command::cargo_bin("petriplc")
            .unwrap()
            .args(["status", "--plc-id", id])
            .output()
            .unwrap();
        // Exit 0 also while it starts (its lock is held: `PLC ID (process N) is starting or
        // stopping`); the table, with its module header, comes once it runs.
        let text = String::from_utf8_lossy(&out.stdout);
        if out.status.success()
            && text.starts_with(&format!("PLC {id} (process "))
            && text.contains("\nmodule ")
        {
            return text.into_owned();
        }
        assert!(
            started.elapsed() < Duration::from_secs(20),
            "PLC {id} never came up"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
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

#[test]
fn the_mixer_goes_through_full_cycles() {
    let dir = TempDir::new().unwrap();
    let log = dir.path().join("plc.log");
    let id = plc_id("mixer");
    // A cycle is B1 (fill), N2, N3 (drain), N1 (back to ready): about 1.6 s with the tank at
    // speed 5, plus at most 1.4 s until the operator presses B1 again. Not a fixed `--for`
    // (a loaded machine scans late, and would fit fewer cycles in it): the PLC runs until
    // its status shows two whole cycles, then is stopped.
    let run = mixer(&id)
        .args(["--for", "120s"])
        .args(FREE_PORTS)
        .arg("--log")
        .arg(&log)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let cycles = |status: &str| {
        let line = status.lines().find(|l| l.contains("fired "))?;
        line.split_whitespace()
            .find_map(|w| w.strip_prefix("N1:"))
            .and_then(|n| n.parse::<u64>().ok())
    };
    while cycles(&wait_for_status(&id)).unwrap_or(0) < 2 {
        assert!(
            started.elapsed() < Duration::from_secs(60),
            "{}",
            wait_for_status(&id)
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", &id])
        .assert()
        .success();
    let out = run.wait_with_output().unwrap();
    let report = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{report}");
    assert!(fired(&report, "N1") >= 2, "{report}");
    for t in ["B1", "N2", "N3"] {
        assert!(fired(&report, t) >= fired(&report, "N1"), "{report}");
    }
    assert!(
        report.contains("controller   petrinet      stopped"),
        "{report}"
    );
}

#[test]
fn status_and_stop_reach_a_running_plc() {
    let id = plc_id("status");
    // `--for` only so that a failing test leaves no PLC behind: `stop` ends it long before.
    let mut run = mixer(&id)
        .args(["--for", "60s"])
        .args(FREE_PORTS)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status = wait_for_status(&id);
    assert!(status.contains(&format!("PLC {id}")), "{status}");
    for m in ["operator", "tank", "controller"] {
        assert!(status.contains(m), "{status}");
    }
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", &id])
        .assert()
        .success();
    let exit = run.wait().unwrap();
    assert!(exit.success());
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["status", "--plc-id", &id])
        .assert()
        .code(4)
        .stderr(predicate::str::contains(format!("no PLC with id `{id}`")));
}

fn run_config(dir: &TempDir, text: &str, id: &str, extra: &[&str]) -> std::process::Output {
    let conf = dir.path().join("plc.conf");
    fs::write(&conf, text).unwrap();
    Command::cargo_bin("petriplc")
        .unwrap()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", id])
        .args(extra)
        .output()
        .unwrap()
}

/// `petriplc stop` may reach a PLC the moment it holds its id, still starting: the PLC then
/// stops cleanly once started (exit 0), never killed half-way by the signal.
#[test]
fn a_stop_while_starting_stops_the_plc_cleanly() {
    let dir = TempDir::new().unwrap();
    let conf = dir.path().join("plc.conf");
    fs::write(
        &conf,
        "[PLC]\nmodule q shutdown\npoint s \"\" q\n[q]\npoint = s\nscan_period = 0.01\n",
    )
    .unwrap();
    for round in 0..5 {
        let id = plc_id(&format!("early{round}"));
        let run = Process::cargo_bin("petriplc")
            .unwrap()
            .arg("run")
            .arg(&conf)
            .args(["--plc-id", &id, "--for", "30s"])
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let started = Instant::now();
        // 4 until the PLC holds its id; then `stop` waits for it to be proven and signals it.
        loop {
            let stop = Command::cargo_bin("petriplc")
                .unwrap()
                .args(["stop", "--plc-id", &id])
                .output()
                .unwrap();
            match stop.status.code() {
                Some(0) => break,
                Some(4) if started.elapsed() < Duration::from_secs(20) => {}
                _ => panic!("round {round}: {stop:?}"),
            }
        }
        let out = run.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "round {round}: {:?}\n{err}",
            out.status
        );
        assert!(err.contains(&format!("PLC {id} stopped")), "{err}");
    }
}

#[test]
fn bad_configurations_start_nothing() {
    let dir = TempDir::new().unwrap();
    let cases: &[(&str, &str)] = &[
        (
            "[PLC]\nmodule a nosuchkind\n",
            "`nosuchkind` is neither a built-in module (petrinet, iec, plant, timeline, logger, shutdown, dsp, modbus_server, modbus_client, vitrine, hmi, mqtt, opcua_server)",
        ),
        (
            "[PLC]\nmodule a shutdown\npoint q \"quit\" b\n[a]\npoint = q\n",
            "plc.conf:3",
        ),
        ("[PLC]\nmodule a shutdown\n", "module a: "),
        (
            "[PLC]\nmodule a shutdown\npoint q \"quit\" a\n[a]\npoint = q\nlocation = isolate\n",
            "`location = isolate` is for modules that run as their own process",
        ),
    ];
    for (i, (text, message)) in cases.iter().enumerate() {
        let out = run_config(&dir, text, &plc_id(&format!("bad{i}")), &[]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{text}\n{err}");
        assert!(
            err.contains(message),
            "{text}\nexpected `{message}` in:\n{err}"
        );
    }
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["run", "no/such.conf"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("no/such.conf"));

    // `--set` overrides are checked like the file's settings, and name themselves.
    let text = "[PLC]\nmodule a shutdown\npoint q \"quit\" a\n[a]\npoint = q\n";
    let sets: &[(&str, &str)] = &[
        ("a:point=nosuch", "nosuch"),
        (
            "a:scan_period=soon",
            "--set: error[C034]: `scan_period = soon`",
        ),
        (
            "b:point=q",
            "--set: error[C033]: `point` is set for `b`, but no module b is declared",
        ),
        ("a-point", "is neither SECTION:NAME=VALUE"),
    ];
    for (i, (set, message)) in sets.iter().enumerate() {
        let out = run_config(&dir, text, &plc_id(&format!("set{i}")), &["--set", set]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "--set {set}\n{err}");
        assert!(
            err.contains(message),
            "--set {set}: expected `{message}` in:\n{err}"
        );
    }
}

#[test]
fn a_bad_configuration_is_reported_once_compiler_style() {
    let dir = TempDir::new().unwrap();
    let out = run_config(&dir, "x = 1\n\n[PLC\n", &plc_id("badconf"), &[]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let conf = dir.path().join("plc.conf");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 3, "{err}");
    assert!(lines[0].starts_with(&format!("{}:1: error[C005]", conf.display())));
    assert!(lines[1].starts_with(&format!("{}:3: error[", conf.display())));
    assert_eq!(
        lines[2],
        format!(
            "error: {} is not a valid configuration (2 problems); nothing was started",
            conf.display()
        )
    );
}

/// Ports another program holds: every one is reported in one attempt, each with a free
/// address, and the command line printed with them starts the PLC as written.
#[test]
fn taken_ports_are_all_reported_with_a_command_that_avoids_them() {
    let holders = [
        std::net::TcpListener::bind("127.0.0.1:0").unwrap(),
        std::net::TcpListener::bind("127.0.0.1:0").unwrap(),
    ];
    let [modbus, hmi] = holders.each_ref().map(|l| l.local_addr().unwrap());
    let id = plc_id("ports");
    let out = mixer(&id)
        .args(["--for", "1s"])
        .args(["--set", &format!("modbus:listen={modbus}")])
        .args(["--set", &format!("hmi:listen={hmi}")])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.starts_with("error: nothing was started: 2 things this PLC needs are taken:\n"),
        "{err}"
    );
    for (module, addr) in [("modbus", modbus), ("hmi", hmi)] {
        assert!(
            err.contains(&format!(
                "\n  module {module}: listen = {addr}: another program (another PLC?) listens \
                 there; use --set {module}:listen=127.0.0.1:"
            )),
            "{err}"
        );
    }
    let command = err
        .lines()
        .skip_while(|l| *l != "a command line that avoids them:")
        .nth(1)
        .unwrap_or_else(|| panic!("no command line in:\n{err}"));
    let words: Vec<&str> = command.split_whitespace().collect();
    assert_eq!(words[..2], ["petriplc", "run"], "{command}");
    // Each fix replaced the option it overrides.
    assert_eq!(
        words
            .iter()
            .filter(|w| w.starts_with("modbus:listen="))
            .count(),
        1,
        "{command}"
    );
    let out = Process::cargo_bin("petriplc")
        .unwrap()
        .args(&words[1..])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{command}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_failing_process_module_follows_on_failure() {
    let dir = TempDir::new().unwrap();
    let script = dir.path().join("crash.sh");
    fs::write(&script, "#!/bin/sh\nsleep 0.2\nexit 3\n").unwrap();
    let mut perms = fs::metadata(&script).unwrap().permissions();
    std::os::unix::fs::PermissionsExt::set_mode(&mut perms, 0o755);
    fs::set_permissions(&script, perms).unwrap();
    let conf = |on_failure: &str| {
        format!(
            "[PLC]\nmodule crasher crash.sh\nmodule quit shutdown\npoint stop \"stop\" crasher\n\
             point valve \"valve\" crasher init 1\n\
             [crasher]\non_failure = {on_failure}\nsafe valve 0\n[quit]\npoint = stop\nscan_period = 0.01\n"
        )
    };
    // restart: the PLC keeps running and counts the restarts. It runs until the log says so
    // (not for a fixed time, which a loaded machine may not start the program in), then is
    // stopped.
    let id = plc_id("restart");
    let conf_file = dir.path().join("restart.conf");
    fs::write(&conf_file, conf("restart")).unwrap();
    let mut run = Process::cargo_bin("petriplc")
        .unwrap()
        .arg("run")
        .arg(&conf_file)
        .args(["--plc-id", &id, "--for", "120s"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = common::Lines::of(&mut run);
    lines.until("restarting it", Duration::from_secs(60));
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", &id])
        .assert()
        .success();
    let err = lines.rest();
    assert!(run.wait().unwrap().success(), "{err}");
    // stop: safe values written, the PLC stops, exit code 1 (`--for` only bounds a broken
    // run: the failure ends it first).
    let out = run_config(&dir, &conf("stop"), &plc_id("stop"), &["--for", "120s"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("safe value valve = 0"), "{err}");
    assert!(err.contains("crasher      program       failed"), "{err}");
    assert!(err.contains("             crash.sh"), "{err}");
}

#[test]
fn two_plcs_cannot_share_an_id() {
    let id = plc_id("twice");
    // Stopped by the test: `--for` only bounds a broken run (a short one could end the
    // first PLC before the second is tried, on a loaded machine).
    let mut first = mixer(&id)
        .args(["--for", "120s"])
        .args(FREE_PORTS)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    wait_for_status(&id);
    Command::from_std(mixer(&id))
        .args(FREE_PORTS)
        .assert()
        .code(3)
        .stderr(predicate::str::contains(format!(
            "error: nothing was started: something this PLC needs is taken:\n  PLC id `{id}`: a \
             PLC with this id is running (process "
        )))
        .stderr(predicate::str::contains(format!(
            "`petriplc stop --plc-id {id}` stops it); use --plc-id {id}-2\n"
        )));
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", &id])
        .assert()
        .success();
    assert!(first.wait().unwrap().success());
}

/// The id and the ports clash together: all are reported in one attempt (exit 3). An id is
/// taken only while a live PLC holds it: one a PLC killed with SIGKILL left is suggested as
/// free, and the printed command line takes it, removing the remains with one log line.
#[test]
fn a_live_id_and_ports_clash_together_and_a_dead_id_is_free() {
    let ports: Vec<String> = (0..2)
        .map(|_| {
            let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
            l.local_addr().unwrap().to_string()
        })
        .collect();
    let listen = [
        "--set".to_string(),
        format!("modbus:listen={}", ports[0]),
        "--set".to_string(),
        format!("hmi:listen={}", ports[1]),
    ];
    let id = plc_id("clash");
    let dead = format!("{id}-2");
    // `--for` only bounds a broken run: both must still run when the third one is tried.
    let mut first = mixer(&id)
        .args(["--for", "120s"])
        .args(&listen)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut killed = mixer(&dead)
        .args(["--for", "120s"])
        .args(FREE_PORTS)
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    wait_for_status(&id);
    wait_for_status(&dead);
    killed.kill().unwrap();
    killed.wait().unwrap();
    let out = mixer(&id)
        .args(["--for", "1s"])
        .args(&listen)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.starts_with(&format!(
            "error: nothing was started: 3 things this PLC needs are taken:\n  PLC id `{id}`: a \
             PLC with this id is running (process {}; `petriplc stop --plc-id {id}` stops it); \
             use --plc-id {dead}\n",
            first.id()
        )),
        "{err}"
    );
    for (module, addr) in [("modbus", &ports[0]), ("hmi", &ports[1])] {
        assert!(
            err.contains(&format!("\n  module {module}: listen = {addr}: ")),
            "{err}"
        );
    }
    let command = err
        .lines()
        .skip_while(|l| *l != "a command line that avoids them:")
        .nth(1)
        .unwrap_or_else(|| panic!("no command line in:\n{err}"));
    let words: Vec<&str> = command.split_whitespace().collect();
    let out = Process::cargo_bin("petriplc")
        .unwrap()
        .args(&words[1..])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{command}\n{err}");
    assert_eq!(
        err.matches(&format!(
            "PLC {dead}: the PLC (pid {}) exited without stopping",
            killed.id()
        ))
        .count(),
        1,
        "{err}"
    );
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", &id])
        .assert()
        .success();
    assert!(first.wait().unwrap().success());
}

/// One Modbus TCP request (unit 1) and its response's PDU.
fn modbus(stream: &mut std::net::TcpStream, tid: u16, pdu: &[u8]) -> Vec<u8> {
    use std::io::{Read, Write};
    let mut adu = tid.to_be_bytes().to_vec();
    adu.extend([0, 0]);
    adu.extend(((pdu.len() + 1) as u16).to_be_bytes());
    adu.push(1);
    adu.extend(pdu);
    stream.write_all(&adu).unwrap();
    let mut header = [0u8; 7];
    stream.read_exact(&mut header).unwrap();
    assert_eq!(header[..2], tid.to_be_bytes(), "transaction id echoed");
    let len = u16::from_be_bytes([header[4], header[5]]) as usize;
    let mut body = vec![0u8; len - 1];
    stream.read_exact(&mut body).unwrap();
    body
}

#[test]
fn the_main_job_serves_modbus_and_a_modbus_write_stops_it() {
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let mut run = mixer(&plc_id("modbus"))
        .args(["--for", "120s"])
        .args(["--set", &format!("modbus:listen=127.0.0.1:{port}")])
        .args(["--set", "hmi:listen=127.0.0.1:0"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let started = Instant::now();
    let mut stream = loop {
        match std::net::TcpStream::connect(("127.0.0.1", port)) {
            Ok(s) => break s,
            Err(_) if started.elapsed() < Duration::from_secs(20) => {
                std::thread::sleep(Duration::from_millis(50))
            }
            Err(e) => {
                let _ = run.kill();
                panic!("no Modbus server on port {port}: {e}");
            }
        }
    };
    stream
        .set_read_timeout(Some(Duration::from_secs(5)))
        .unwrap();
    // The lamps and valves as coils 0-7 (owned by the controller) and the sensors and B1 as
    // discrete inputs: watch the valves open and close as the mixer cycles.
    let mut seen = std::collections::BTreeSet::new();
    let mut tid = 0;
    while seen.len() < 3 && started.elapsed() < Duration::from_secs(30) {
        tid += 1;
        let coils = modbus(&mut stream, tid, &[1, 0, 0, 0, 8]);
        assert_eq!(coils[..2], [1, 1], "FC 1 reply with one byte of coils");
        seen.insert(coils[2] & 0b11_1000); // V1 V2 V3
        tid += 1;
        let inputs = modbus(&mut stream, tid, &[2, 0, 0, 0, 4]);
        assert_eq!(inputs[..2], [2, 1]);
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(
        seen.len() >= 3,
        "valve states seen over Modbus: {seen:?} (expected closed, filling, draining)"
    );
    // The controller's points are read-only over Modbus; the server's own `stop` is not.
    let refused = modbus(&mut stream, 100, &[5, 0, 3, 0xFF, 0]);
    assert_eq!(
        refused,
        [0x85, 2],
        "writing V1 (owned by the controller) is refused"
    );
    let accepted = modbus(&mut stream, 101, &[5, 0, 100, 0xFF, 0]);
    assert_eq!(accepted, [5, 0, 100, 0xFF, 0]);
    let exit = loop {
        if let Some(status) = run.try_wait().unwrap() {
            break status;
        }
        if started.elapsed() > Duration::from_secs(40) {
            let _ = run.kill();
            panic!("coil 100 did not stop the PLC");
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    let mut log = String::new();
    std::io::Read::read_to_string(&mut run.stderr.take().unwrap(), &mut log).unwrap();
    assert!(exit.success(), "{log}");
    assert!(log.contains("module remote_stop stops the PLC"), "{log}");
    // The refused write is logged with its reason, not only counted.
    assert!(
        log.contains(
            "modbus_server modbus: refused write coil 3: exception 02, coil 3 shows point `V1`"
        ),
        "{log}"
    );
}
