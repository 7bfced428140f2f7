//! `petriplc run` as a service, through the real binary: the example unit file passes
//! `systemd-analyze verify`; SIGTERM stops the PLC cleanly with every module's safe values
//! written and the retentive values saved; log lines reach the systemd journal (a datagram
//! socket standing in for journald, at its path in a mount namespace of the PLC's own) when
//! `JOURNAL_STREAM` says standard error is the journal, and syslog with `--log-to`; a C
//! module that sleeps through ten periods is killed by its watchdog and its safe value is
//! what the other modules read.
//!
//! No timing assertions: waits poll for a state with a generous safety limit.

mod common;

use std::fs;
use std::os::unix::fs::MetadataExt;
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use tempfile::TempDir;

const SAFETY_NET: Duration = Duration::from_secs(60);
const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");

fn petriplc() -> Process {
    Process::cargo_bin("petriplc").unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn binary() -> PathBuf {
    PathBuf::from(petriplc().get_program())
}

#[test]
fn the_example_unit_file_verifies() {
    let dir = TempDir::new().unwrap();
    let unit =
        fs::read_to_string(Path::new(ROOT).join("examples/systemd/petriplc.service")).unwrap();
    // The unit names the installed binary and configuration; verify checks that they exist.
    let conf = dir.path().join("plc.conf");
    fs::copy(Path::new(ROOT).join("examples/systemd/plc.conf"), &conf).unwrap();
    let unit = unit
        .replace("/usr/local/bin/petriplc", &binary().display().to_string())
        .replace("/etc/petriplc/plc.conf", &conf.display().to_string());
    assert!(unit.contains(&binary().display().to_string()), "{unit}");
    let path = dir.path().join("petriplc.service");
    fs::write(&path, unit).unwrap();
    let out = Process::new("systemd-analyze")
        .arg("verify")
        .arg(&path)
        .output()
        .expect("systemd-analyze (Debian's systemd package) is needed");
    assert!(
        out.status.success() && out.stderr.is_empty(),
        "{}{}",
        text(&out.stdout),
        text(&out.stderr)
    );
}

/// Starts the example configuration (a timeline writes a retentive setpoint and a lamp
/// with a safe value) with `args`.
fn example(dir: &Path, id: &str, args: &[&str]) -> std::process::Child {
    let conf = dir.join("plc.conf");
    for f in ["plc.conf", "setpoint.csv"] {
        fs::copy(
            Path::new(ROOT).join("examples/systemd").join(f),
            dir.join(f),
        )
        .unwrap();
    }
    petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", id])
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn wait_running(id: &str) {
    let started = Instant::now();
    loop {
        let status = fs::read_to_string(format!("/dev/shm/petriplc-{id}.status.json"));
        if status.is_ok_and(|s| s.contains("\"scans\":") && !s.contains("\"scans\":0")) {
            return;
        }
        assert!(started.elapsed() < SAFETY_NET, "PLC {id} never ran");
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn sigterm_stops_cleanly_with_safe_values_and_retained_values_written() {
    let dir = TempDir::new().unwrap();
    let id = format!("service-term-{}", std::process::id());
    let plc = example(dir.path(), &id, &[]);
    wait_running(&id);
    std::thread::sleep(Duration::from_millis(300));
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(plc.id() as i32),
        nix::sys::signal::Signal::SIGTERM,
    )
    .unwrap();
    let out = plc.wait_with_output().unwrap();
    let log = text(&out.stderr);
    assert!(out.status.success(), "{log}");
    assert!(log.contains("module lamps: safe value lamp = 0"), "{log}");
    assert!(log.contains("retain file "), "{log}");
    let retain = dir.path().join("plc.retain");
    let snap = petriplc_retain::file::peek(&retain)
        .unwrap()
        .snapshot
        .expect("the setpoint is retained");
    assert_eq!(snap.entries[0].name, "setpoint");
    // The next start gives it back.
    let out = example(dir.path(), &id, &["--for", "0.2s"])
        .wait_with_output()
        .unwrap();
    let log = text(&out.stderr);
    assert!(
        log.contains(&format!(
            "restored 1 of 1 retentive point from snapshot {}",
            snap.seq
        )),
        "{log}"
    );
}

#[test]
fn log_lines_reach_syslog_and_the_journal() {
    let dir = TempDir::new().unwrap();
    let id = format!("service-log-{}", std::process::id());
    // syslog: RFC 3164 datagrams, facility daemon.
    let socket = dir.path().join("syslog.sock");
    let syslog = UnixDatagram::bind(&socket).unwrap();
    syslog
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    let log_to = format!("syslog:{}", socket.display());
    let out = example(dir.path(), &id, &["--for", "0.2s", "--log-to", &log_to])
        .wait_with_output()
        .unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    let mut lines = Vec::new();
    let mut buf = [0u8; 4096];
    while let Ok(n) = syslog.recv(&mut buf) {
        lines.push(text(&buf[..n]));
        if lines.last().unwrap().contains(&format!("PLC {id} stopped")) {
            break;
        }
    }
    let started = lines
        .iter()
        .find(|l| l.contains(&format!("PLC {id} started")))
        .unwrap_or_else(|| panic!("{lines:?}"));
    // <30>: daemon.info; then the time, the program and its pid.
    assert!(
        started.starts_with("<30>")
            && started.contains(&format!(" petriplc[{}]: ", out_pid(&lines))),
        "{started}"
    );

    // The journal: in a mount namespace of its own the PLC finds our socket at journald's
    // path; its standard error is a file whose device and inode JOURNAL_STREAM names.
    let jdir = dir.path().join("journal");
    fs::create_dir(&jdir).unwrap();
    let journal = UnixDatagram::bind(jdir.join("socket")).unwrap();
    journal
        .set_read_timeout(Some(Duration::from_secs(10)))
        .unwrap();
    let stderr = fs::File::create(dir.path().join("stderr")).unwrap();
    let meta = stderr.metadata().unwrap();
    let conf = dir.path().join("plc.conf");
    let status = Process::new("unshare")
        .args(["-m", "--propagation", "private", "sh", "-c"])
        .arg(
            "mount -t tmpfs tmpfs /run && mkdir -p /run/systemd/journal && \
             mount --bind \"$1\" /run/systemd/journal && shift && exec \"$@\"",
        )
        .arg("sh")
        .arg(&jdir)
        .arg(binary())
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &id, "--for", "0.2s"])
        .env("JOURNAL_STREAM", format!("{}:{}", meta.dev(), meta.ino()))
        .stderr(stderr)
        .status()
        .expect("unshare (util-linux) is needed");
    let printed = fs::read_to_string(dir.path().join("stderr")).unwrap();
    assert!(status.success(), "{printed}");
    let mut entries: Vec<Vec<(String, String)>> = Vec::new();
    while let Ok(n) = journal.recv(&mut buf) {
        let e = fields(&buf[..n]);
        let done = e.contains(&("MESSAGE".into(), format!("PLC {id} stopped")));
        entries.push(e);
        if done {
            break;
        }
    }
    let started = entries
        .iter()
        .find(|e| {
            e.contains(&(
                "MESSAGE".into(),
                format!("PLC {id} started: 2 points in 1 word, 1 module"),
            ))
        })
        .unwrap_or_else(|| panic!("{entries:?}"));
    let field = |k: &str| {
        started
            .iter()
            .find(|(key, _)| key == k)
            .map(|(_, v)| v.as_str())
    };
    assert_eq!(field("PRIORITY"), Some("5"), "{started:?}");
    assert_eq!(field("SYSLOG_IDENTIFIER"), Some("petriplc"), "{started:?}");
    assert_eq!(field("PETRIPLC_PLC_ID"), Some(id.as_str()), "{started:?}");
    let warning = entries
        .iter()
        .flatten()
        .any(|(k, v)| k == "PRIORITY" && v == "4");
    assert!(!warning, "{entries:?}");
    // The journal has the lines: standard error keeps only the final table.
    assert!(!printed.contains("[INFO]"), "{printed}");
}

/// The fields of a journal datagram (systemd's native protocol): `KEY=value` lines, or
/// `KEY`, a newline, the value's length as 64-bit little-endian, the value and a newline.
fn fields(mut d: &[u8]) -> Vec<(String, String)> {
    let mut out = Vec::new();
    while !d.is_empty() {
        let eol = d.iter().position(|&b| b == b'\n').unwrap_or(d.len());
        let line = &d[..eol];
        match line.iter().position(|&b| b == b'=') {
            Some(eq) => {
                out.push((text(&line[..eq]), text(&line[eq + 1..])));
                d = &d[(eol + 1).min(d.len())..];
            }
            None => {
                let len = u64::from_le_bytes(d[eol + 1..eol + 9].try_into().unwrap()) as usize;
                out.push((text(line), text(&d[eol + 9..eol + 9 + len])));
                d = &d[(eol + 10 + len).min(d.len())..];
            }
        }
    }
    out
}

/// The pid in the first syslog line.
fn out_pid(lines: &[String]) -> String {
    let l = &lines[0];
    let start = l.find("petriplc[").unwrap() + "petriplc[".len();
    l[start..start + l[start..].find(']').unwrap()].to_string()
}

#[test]
fn a_c_module_sleeping_ten_periods_is_killed_by_its_watchdog() {
    let dir = TempDir::new().unwrap();
    // Writes busy = 1 every scan; its 4th scan sleeps ten periods, then writes 2.
    common::c_module(
        dir.path(),
        "sleeper",
        r#"#include <stdio.h>
#include <time.h>
#include "petriplc.h"
int main(int argc, char **argv) {
    if (plc_init("sleeper", &argc, argv) != PLC_OK) {
        fprintf(stderr, "sleeper: %s\n", plc_last_error());
        return 1;
    }
    plc_pt_t busy = plc_pt_by_name("busy");
    struct timespec nap = {0, 500000000};
    for (int n = 0; plc_scan_beg() == PLC_OK; n++) {
        if (n == 3) {
            nanosleep(&nap, NULL);
            plc_set(busy, 2);
        } else {
            plc_set(busy, 1);
        }
        if (plc_scan_end() != PLC_OK)
            break;
    }
    plc_close();
    return 0;
}
"#,
        &["-D_POSIX_C_SOURCE=199309L"],
    );
    let conf = dir.path().join("plc.conf");
    fs::write(
        &conf,
        "[PLC]\nmodule sleeper sleeper\nmodule log logger\npoint busy \"\" sleeper u8\n\
         [sleeper]\nscan_period = T#50ms\nwatchdog = T#100ms\non_failure = ignore\nsafe busy 0\n\
         [log]\nfile = busy.csv\nlog busy\nscan_period = T#5ms\n",
    )
    .unwrap();
    let id = format!("service-wdg-{}", std::process::id());
    // Not a fixed `--for` (a loaded machine may not start the C program and reach its 4th
    // scan in it): the PLC runs until the sleeper has failed and the logger has scanned a few
    // times since, then is stopped.
    let plc = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &id, "--for", "120s"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let logged_since_failure = wait_for_module(&id, "sleeper", "failed", "log");
    wait_for_scans(&id, "log", logged_since_failure + 3);
    let stop = petriplc().args(["stop", "--plc-id", &id]).output().unwrap();
    assert!(stop.status.success(), "{}", text(&stop.stderr));
    let out = plc.wait_with_output().unwrap();
    let log = text(&out.stderr);
    // on_failure = ignore: the others went on, and `run` says a module failed.
    assert_eq!(out.status.code(), Some(1), "{log}");
    assert!(
        log.contains("module sleeper failed (its scan has run ")
            && log.contains(
                "without ending, longer than its watchdog (100.0 ms): it is stuck or too slow; \
                 its process is killed); writing its safe values, the others go on"
            ),
        "{log}"
    );
    // The logger saw 1, then the safe 0 — never the 2 the sleeper would have written.
    let logged = fs::read_to_string(dir.path().join("busy.csv")).unwrap();
    let values: Vec<&str> = logged
        .lines()
        .skip(1)
        .filter_map(|l| l.rsplit(',').next())
        .collect();
    let one = values.iter().position(|v| *v == "1").expect(&logged);
    assert!(values[one..].contains(&"0"), "{logged}");
    assert!(!values.contains(&"2"), "{logged}");
}

/// The `petriplc status` row of `module`: (state, scans), once the PLC runs.
fn module_row(id: &str, module: &str) -> Option<(String, u64)> {
    let out = petriplc()
        .args(["status", "--plc-id", id])
        .output()
        .unwrap();
    text(&out.stdout).lines().find_map(|l| {
        let cells: Vec<&str> = l.split_whitespace().collect();
        match cells.as_slice() {
            [name, _kind, state, _pid, scans, ..] if *name == module => {
                Some((state.to_string(), scans.parse().ok()?))
            }
            _ => None,
        }
    })
}

/// Waits until `module` of PLC `id` is in `state`; returns `other`'s scans at that moment.
fn wait_for_module(id: &str, module: &str, state: &str, other: &str) -> u64 {
    let started = Instant::now();
    loop {
        if module_row(id, module).is_some_and(|(s, _)| s == state) {
            return module_row(id, other).map_or(0, |(_, n)| n);
        }
        assert!(
            started.elapsed() < SAFETY_NET,
            "module {module} of PLC {id} never {state}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Waits until `module` of PLC `id` has made `scans` scans.
fn wait_for_scans(id: &str, module: &str, scans: u64) {
    let started = Instant::now();
    while module_row(id, module).map_or(0, |(_, n)| n) < scans {
        assert!(
            started.elapsed() < SAFETY_NET,
            "module {module} of PLC {id} never made {scans} scans"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}
