//! Bad input and faults through the real binary, as a careful user would try them: nets
//! without places, a bounded net past the 32-bit token counter, a panicking worker thread,
//! a closed standard output, a simulation that fails or is interrupted (its partial trace
//! is written, marked incomplete), a timeline far in the future or not UTF-8.

use std::fs;
use std::io::Read;
use std::path::Path;
use std::process::{Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use assert_cmd::Command;
use predicates::prelude::*;
use tempfile::TempDir;

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");
/// Only keeps a broken build from hanging the suite.
const SAFETY_NET: Duration = Duration::from_secs(60);

fn pnml(id: &str, body: &str) -> String {
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">
  <net id="{id}" type="http://www.pnml.org/version-2009/grammar/ptnet"><page id="page">
{body}
  </page></net>
</pnml>
"#
    )
}

fn petriplc(dir: &Path) -> Command {
    let mut cmd = Command::cargo_bin("petriplc").unwrap();
    cmd.current_dir(dir).timeout(SAFETY_NET);
    cmd
}

#[test]
fn nets_without_places_are_analysed_not_a_panic_and_a_hang() {
    let dir = TempDir::new().unwrap();
    fs::write(dir.path().join("none.pnml"), pnml("none", "")).unwrap();
    fs::write(
        dir.path().join("only-t.pnml"),
        pnml("only", r#"<transition id="t1"/><transition id="t2"/>"#),
    )
    .unwrap();
    for net in ["none.pnml", "only-t.pnml"] {
        for extra in [
            &[][..],
            &["--json"],
            &["--max-states", "3"],
            &["--plant", "only-t.pnml"],
        ] {
            let out = petriplc(dir.path())
                .args(["analyze", net])
                .args(extra)
                .output()
                .unwrap();
            let (so, se) = (
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr),
            );
            assert_eq!(out.status.code(), Some(0), "{net} {extra:?}\n{so}{se}");
            assert!(!se.contains("panicked"), "{net} {extra:?}: {se}");
        }
    }
    petriplc(dir.path())
        .args(["analyze", "only-t.pnml"])
        .assert()
        .success()
        .stdout(predicate::str::contains("states:             1"))
        .stdout(predicate::str::contains("deadlock:           no"));
    petriplc(dir.path())
        .args(["analyze", "none.pnml"])
        .assert()
        .success()
        .stdout(predicate::str::contains("deadlock:           yes"));
}

#[test]
fn a_bounded_net_past_the_32_bit_counter_is_not_called_unbounded() {
    let dir = TempDir::new().unwrap();
    // b reaches 6·10⁹ tokens and no more; a transition that could add more never fires, so
    // the net is bounded without being structurally bounded.
    fs::write(
        dir.path().join("big.pnml"),
        pnml(
            "big",
            r#"<place id="a"><initialMarking><text>1</text></initialMarking></place>
<place id="c"><initialMarking><text>1</text></initialMarking></place>
<place id="b"/><place id="never"/>
<transition id="t1"/><transition id="t2"/><transition id="t3"/>
<arc id="x1" source="a" target="t1"/>
<arc id="x2" source="t1" target="b"><inscription><text>3000000000</text></inscription></arc>
<arc id="x3" source="c" target="t2"/>
<arc id="x4" source="t2" target="b"><inscription><text>3000000000</text></inscription></arc>
<arc id="x5" source="never" target="t3"/><arc id="x6" source="t3" target="never"/>
<arc id="x7" source="t3" target="b"/>"#,
        ),
    )
    .unwrap();
    petriplc(dir.path())
        .args(["analyze", "big.pnml"])
        .assert()
        .success()
        .stdout(predicate::str::contains("bounded:            yes"))
        .stdout(predicate::str::contains(
            "reachability graph not built: place b: a reachable marking has more than \
             4294967295 tokens, the limit of petriplc's 32-bit token counters",
        ))
        .stdout(predicate::str::contains("unbounded").not());
}

#[test]
fn a_panic_in_a_worker_thread_ends_the_command() {
    let dir = TempDir::new().unwrap();
    for args in [
        &["analyze", "x.pnml"][..],
        &["sim", "x.pnml"],
        &["compile", "x.pnml", "--lang", "st"],
        &["status"],
    ] {
        petriplc(dir.path())
            .args(args)
            .env("PETRIPLC_TEST_PANIC", "worker")
            .assert()
            .code(1)
            .stderr(predicate::str::contains("a worker thread panicked"))
            .stderr(predicate::str::contains(
                "error: petriplc stopped on an internal error",
            ));
    }
}

/// Runs `petriplc args` with its standard output closed before it writes: it must end
/// quietly and as it would have otherwise (exit code `code`).
fn closed_stdout(dir: &Path, args: &[&str], code: i32) {
    let mut child = Process::cargo_bin("petriplc")
        .unwrap()
        .current_dir(dir)
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    let exit = child.wait().unwrap();
    assert_eq!(exit.code(), Some(code), "{args:?}: {err}");
    assert!(
        !err.contains("panicked") && !err.contains("Broken pipe") && !err.contains("error"),
        "{args:?}: {err}"
    );
}

#[test]
fn every_command_is_quiet_on_a_closed_stdout() {
    let dir = TempDir::new().unwrap();
    let mixer = format!("{EXAMPLES}/mixer/mixer.pnml");
    let timeline = format!("{EXAMPLES}/mixer/timeline.csv");
    closed_stdout(dir.path(), &["--help"], 0);
    closed_stdout(dir.path(), &["analyze", &mixer, "--names", "sipn"], 0);
    closed_stdout(
        dir.path(),
        &["analyze", &mixer, "--names", "sipn", "--json"],
        0,
    );
    closed_stdout(
        dir.path(),
        &["compile", &mixer, "--names", "sipn", "--lang", "st"],
        0,
    );
    closed_stdout(
        dir.path(),
        &["sim", &mixer, "--names", "sipn", "--inputs", &timeline],
        0,
    );
    // `status` of a running PLC (`petriplc status | head -c1`).
    let id = format!("faults-closed-{}", std::process::id());
    let conf = dir.path().join("plc.conf");
    fs::write(
        &conf,
        "[PLC]\nmodule q shutdown\npoint s \"\" q\n[q]\npoint = s\nscan_period = 0.01\n",
    )
    .unwrap();
    let mut plc = Process::cargo_bin("petriplc")
        .unwrap()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &id, "--for", "60s"])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let started = Instant::now();
    while !Process::cargo_bin("petriplc")
        .unwrap()
        .args(["status", "--plc-id", &id])
        .output()
        .unwrap()
        .stdout
        .starts_with(format!("PLC {id} (").as_bytes())
    {
        assert!(started.elapsed() < SAFETY_NET, "the PLC never ran");
        std::thread::sleep(Duration::from_millis(20));
    }
    closed_stdout(dir.path(), &["status", "--plc-id", &id], 0);
    petriplc(dir.path())
        .args(["stop", "--plc-id", &id])
        .assert()
        .success();
    assert!(plc.wait().unwrap().success());
}

/// A source transition that adds 2³¹ tokens a scan: the counter overflows in the 2nd scan.
fn overflowing() -> String {
    pnml(
        "grow",
        r#"<place id="p"><name><text>p</text></name></place>
<transition id="add"><name><text>add</text></name></transition>
<arc id="a" source="add" target="p"><inscription><text>2147483648</text></inscription></arc>"#,
    )
}

#[test]
fn a_failing_simulation_writes_what_it_simulated_marked_incomplete() {
    let dir = TempDir::new().unwrap();
    fs::write(dir.path().join("grow.pnml"), overflowing()).unwrap();
    petriplc(dir.path())
        .args([
            "sim",
            "grow.pnml",
            "--out",
            "out/trace.csv",
            "--plot",
            "out/plot.svg",
        ])
        .assert()
        .code(1)
        .stderr(predicate::str::contains("the simulation failed"))
        .stderr(predicate::str::contains(
            "wrote out/trace.csv (trace, 1 row, incomplete)",
        ));
    let trace = fs::read_to_string(dir.path().join("out/trace.csv")).unwrap();
    assert!(
        trace.starts_with("time,m:p,fired\n0,2147483648,add\n"),
        "{trace}"
    );
    let last = trace.lines().last().unwrap();
    assert!(
        last.starts_with("# incomplete: the simulation failed at t=0.01 s: "),
        "{trace}"
    );
    let svg = fs::read_to_string(dir.path().join("out/plot.svg")).unwrap();
    assert!(
        svg.contains("incomplete: the simulation failed at t=0.01 s"),
        "{svg}"
    );
    // To standard output too.
    petriplc(dir.path())
        .args(["sim", "grow.pnml"])
        .assert()
        .code(1)
        .stdout(predicate::str::starts_with(
            "time,m:p,fired\n0,2147483648,add\n",
        ))
        .stdout(predicate::str::contains(
            "# incomplete: the simulation failed",
        ));
}

/// Whether process `pid` has a handler for SIGINT (its `SigCgt` mask in /proc).
fn catches_sigint(pid: u32) -> bool {
    let status = fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status
        .lines()
        .find_map(|l| l.strip_prefix("SigCgt:"))
        .and_then(|mask| u64::from_str_radix(mask.trim(), 16).ok())
        .is_some_and(|mask| mask & (1 << (nix::sys::signal::Signal::SIGINT as u32 - 1)) != 0)
}

#[test]
fn an_interrupted_simulation_writes_what_it_simulated() {
    let dir = TempDir::new().unwrap();
    let mixer = format!("{EXAMPLES}/mixer/mixer.pnml");
    let mut child = Process::cargo_bin("petriplc")
        .unwrap()
        .current_dir(dir.path())
        .args(["sim", &mixer, "--names", "sipn", "--plant", "tank"])
        .args(["--until", "1000000s", "--out", "trace.csv"])
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Not a fixed pause (a loaded machine may not have started it by then, and SIGINT before
    // its handler kills it): wait until the process catches SIGINT.
    let started = Instant::now();
    while !catches_sigint(child.id()) {
        assert!(
            started.elapsed() < SAFETY_NET,
            "the simulation never caught SIGINT"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(child.id() as i32),
        nix::sys::signal::Signal::SIGINT,
    )
    .unwrap();
    let started = Instant::now();
    let exit = loop {
        if let Some(e) = child.try_wait().unwrap() {
            break e;
        }
        assert!(started.elapsed() < SAFETY_NET, "Ctrl-C did not end the run");
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert_eq!(exit.code(), Some(130), "{err}");
    assert!(err.contains("interrupted at t="), "{err}");
    let trace = fs::read_to_string(dir.path().join("trace.csv")).unwrap();
    assert!(trace.starts_with("time,"), "{trace}");
    assert!(
        trace
            .lines()
            .last()
            .unwrap()
            .starts_with("# incomplete: interrupted (Ctrl-C) after t="),
        "{trace}"
    );
}

#[test]
fn a_timeline_far_in_the_future_needs_until() {
    let dir = TempDir::new().unwrap();
    let mixer = format!("{EXAMPLES}/mixer/mixer.pnml");
    fs::write(dir.path().join("far.csv"), "time,B1\n0,1\n1000000,0\n").unwrap();
    petriplc(dir.path())
        .args(["sim", &mixer, "--names", "sipn", "--inputs", "far.csv"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "the timeline's last row is at 1000000 s, so the simulation would run",
        ))
        .stderr(predicate::str::contains("pass --until"));
    petriplc(dir.path())
        .args(["sim", &mixer, "--names", "sipn", "--inputs", "far.csv"])
        .args(["--until", "1s"])
        .assert()
        .success();
}

#[test]
fn a_timeline_that_is_not_utf8_is_refused_at_its_line() {
    let dir = TempDir::new().unwrap();
    let mixer = format!("{EXAMPLES}/mixer/mixer.pnml");
    fs::write(dir.path().join("latin1.csv"), b"time,B1\n0,1\n1,\xe9\n").unwrap();
    petriplc(dir.path())
        .args(["sim", &mixer, "--names", "sipn", "--inputs", "latin1.csv"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "latin1.csv:3:3: byte 0xe9 is not UTF-8 text",
        ));
}
