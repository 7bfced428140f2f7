//! The Modbus modules through the real binary, as a user meets them: mbpoll writing NaN to a
//! float point that an `iec` module multiplies (refused with exception 03, logged once per
//! point, the PLC scanning on), and a `modbus_client` whose device never answers (the status
//! and the final summary say so; `connect_within` makes it a failure).

use std::io::Read;
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Child, Command as Process, Output, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use assert_cmd::Command;
use tempfile::TempDir;

/// The longest any condition is waited for: only so that a broken PLC fails the test instead
/// of hanging it.
const PATIENCE: Duration = Duration::from_secs(30);

fn plc_id(name: &str) -> String {
    format!("test-mb-{name}-{}", std::process::id())
}

/// A local port nothing listens on (the system's choice, released at once).
fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// `petriplc run CONFIG --plc-id ID ARGS…`, its standard error piped.
fn run(config: &Path, id: &str, args: &[&str]) -> Child {
    Process::cargo_bin("petriplc")
        .unwrap()
        .arg("run")
        .arg(config)
        .args(["--plc-id", id])
        .args(args)
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

/// Stops PLC `id` and returns what `petriplc run` printed and whether it exited 0.
fn stop(id: &str, mut run: Child) -> (bool, String) {
    Command::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", id])
        .assert()
        .success();
    let status = run.wait().unwrap();
    let mut log = String::new();
    run.stderr.take().unwrap().read_to_string(&mut log).unwrap();
    (status.success(), log)
}

/// `petriplc status --plc-id ID` once `ok` holds for it.
fn status_until(id: &str, what: &str, ok: impl Fn(&str) -> bool) -> String {
    let start = Instant::now();
    loop {
        let out = Command::cargo_bin("petriplc")
            .unwrap()
            .args(["status", "--plc-id", id])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&out.stdout).into_owned();
        if out.status.success() && ok(&text) {
            return text;
        }
        assert!(
            start.elapsed() < PATIENCE,
            "PLC {id}: timed out waiting for {what}:\n{text}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

fn mbpoll(port: u16, args: &[&str], values: &[&str]) -> Output {
    let mut cmd = Process::new("mbpoll");
    cmd.args(["-m", "tcp", "-p", &port.to_string(), "-0", "-1", "-o", "5"])
        .args(args)
        .arg("127.0.0.1");
    if !values.is_empty() {
        cmd.arg("--").args(values);
    }
    cmd.output()
        .expect("mbpoll (the Debian package mbpoll) is needed")
}

fn text(o: &Output) -> String {
    format!(
        "{}\n{}{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Holding registers 0-3 as two big-endian floats, read with mbpoll: `[(0, "20"), (2, "40")]`.
fn floats(port: u16) -> Vec<(u32, String)> {
    let o = mbpoll(port, &["-t", "4:float", "-B", "-r", "0", "-c", "2"], &[]);
    assert!(o.status.success(), "{}", text(&o));
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| {
            let (r, v) = l.trim().strip_prefix('[')?.split_once("]:")?;
            Some((r.parse().ok()?, v.trim().to_string()))
        })
        .collect()
}

fn pair(a: &str, b: &str) -> Vec<(u32, String)> {
    vec![(0, a.to_string()), (2, b.to_string())]
}

const CALC: &str = "\
PROGRAM main
VAR_INPUT temp : REAL; END_VAR
VAR_OUTPUT dbl : REAL; END_VAR
dbl := temp * 2.0;
END_PROGRAM
";

#[test]
fn a_nan_written_over_modbus_is_refused_and_the_plc_keeps_scanning() {
    let dir = TempDir::new().unwrap();
    std::fs::write(dir.path().join("calc.st"), CALC).unwrap();
    let port = free_port();
    let config = dir.path().join("plc.conf");
    std::fs::write(
        &config,
        format!(
            "[PLC]\nmodule mb modbus_server\nmodule calc iec\n\
             point temp \"temperature, written by Modbus clients\" mb f32 init 20\n\
             point dbl \"twice the temperature\" calc f32\n\
             [mb]\nlisten = 127.0.0.1:{port}\nholding 0 temp\nholding 2 dbl\n\
             [calc]\nprogram = calc.st\nscan_period = 10ms\non_failure = stop\n"
        ),
    )
    .unwrap();
    let id = plc_id("nan");
    let plc = run(&config, &id, &["--for", "120s"]);
    let start = Instant::now();
    while TcpStream::connect(("127.0.0.1", port)).is_err() {
        assert!(start.elapsed() < PATIENCE, "no Modbus server on {port}");
        std::thread::sleep(Duration::from_millis(50));
    }
    // The quiet NaN every tool writes, twice, as FC 16: exception 03 both times.
    let nan = ["0x7FC0", "0x0000"];
    for _ in 0..2 {
        let o = mbpoll(port, &["-t", "4:hex", "-r", "0"], &nan);
        assert!(!o.status.success(), "{}", text(&o));
        assert!(text(&o).contains("Illegal data value"), "{}", text(&o));
    }
    assert_eq!(floats(port), pair("20", "40"));
    // The PLC scans on: a good value reaches the program and comes back doubled.
    let o = mbpoll(port, &["-t", "4:float", "-B", "-r", "0"], &["21.5"]);
    assert!(o.status.success(), "{}", text(&o));
    let start = Instant::now();
    while floats(port) != pair("21.5", "43") {
        assert!(start.elapsed() < PATIENCE, "{:?}", floats(port));
        std::thread::sleep(Duration::from_millis(50));
    }
    // After an accepted write, the next refusal is logged again.
    let o = mbpoll(port, &["-t", "4:hex", "-r", "0"], &nan);
    assert!(text(&o).contains("Illegal data value"), "{}", text(&o));
    let status = status_until(&id, "the refusals counted", |s| {
        s.contains("3 values refused")
    });
    assert!(!status.contains("failed"), "{status}");
    let (ok, log) = stop(&id, plc);
    assert!(ok, "{log}");
    let warning = "modbus_server mb: refused a write of 0x7FC0 0x0000 to holding 0-1 (f32 \
                   high_first), point `temp` (";
    assert_eq!(log.matches(warning).count(), 2, "{log}");
    assert!(
        log.contains("NaN is not a finite number; points take only finite values"),
        "{log}"
    );
    assert!(log.contains("3 exceptions, 3 values refused"), "{log}");
}

/// A client module polling one device at `port` (where nothing listens), with `extra`
/// settings.
fn client_config(dir: &Path, port: u16) -> std::path::PathBuf {
    let config = dir.join("plc.conf");
    std::fs::write(
        &config,
        format!(
            "[PLC]\nmodule io modbus_client\n\
             point speed \"drive speed\" io u16\npoint offline \"drive silent\" io\n\
             [io]\ndevice drive tcp:127.0.0.1:{port} 1 100ms 500ms\n\
             read drive holding 0 speed\nstale drive offline\n"
        ),
    )
    .unwrap();
    config
}

#[test]
fn a_device_that_never_answers_is_named_in_the_status_and_the_summary() {
    let dir = TempDir::new().unwrap();
    let port = free_port();
    let config = client_config(dir.path(), port);
    let id = plc_id("never");
    let plc = run(&config, &id, &["--for", "120s"]);
    let never = format!("drive never connected to tcp:127.0.0.1:{port} (0 cycles, ");
    status_until(&id, "two failed attempts", |s| {
        s.contains(&never) && s.contains(" failures, last: cannot connect to ")
    });
    let (ok, log) = stop(&id, plc);
    // Only reported by default: the run ends well.
    assert!(ok, "{log}");
    let summary = log
        .lines()
        .find(|l| l.contains(&never))
        .unwrap_or_else(|| panic!("no device line in the summary:\n{log}"));
    assert!(summary.contains("failures, last: cannot connect"), "{log}");
}

#[test]
fn connect_within_fails_the_module_naming_the_device() {
    let dir = TempDir::new().unwrap();
    let port = free_port();
    let config = client_config(dir.path(), port);
    let out = Process::cargo_bin("petriplc")
        .unwrap()
        .arg("run")
        .arg(&config)
        .args(["--plc-id", &plc_id("within"), "--for", "60s"])
        .args(["--set", "io:connect_within=1s"])
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{log}");
    assert!(
        log.contains(&format!(
            "device `drive` (tcp:127.0.0.1:{port}, unit 1) never connected within \
             connect_within = 1s ("
        )),
        "{log}"
    );
    assert!(log.contains("a module failed"), "{log}");
}
