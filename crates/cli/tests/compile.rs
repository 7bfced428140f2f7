//! `petriplc compile` through the real binary: files written, errors and exit codes, and the
//! generated C run against `petriplc sim` end to end.

use std::fs;
use std::path::Path;
use std::process::Command as Process;

use assert_cmd::Command;
use predicates::prelude::*;
use tempfile::TempDir;

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");

fn petriplc() -> Command {
    let mut cmd = Command::cargo_bin("petriplc").unwrap();
    cmd.env("SOURCE_DATE_EPOCH", "1767225600");
    cmd
}

fn example(path: &str) -> String {
    format!("{EXAMPLES}/{path}")
}

#[test]
fn st_project_is_written_with_the_date_from_source_date_epoch() {
    let dir = TempDir::new().unwrap();
    let out = dir.path().join("mixer.xml");
    petriplc()
        .args([
            "compile",
            &example("mixer/mixer.pnml"),
            "--names",
            "sipn",
            "--lang",
            "st",
        ])
        .arg("--out")
        .arg(&out)
        .assert()
        .success();
    let xml = fs::read_to_string(&out).unwrap();
    assert!(
        xml.contains("creationDateTime=\"2026-01-01T00:00:00\""),
        "{xml}"
    );
    assert!(xml.contains("<pou name=\"mixer\" pouType=\"program\">"));
    assert!(xml.contains("B1Fire := (* input condition *) B1"));
    assert!(xml.contains("<task name=\"task0\" priority=\"0\" interval=\"T#10ms\">"));
}

#[test]
fn plain_st_goes_to_stdout_and_conflicts_are_noted() {
    petriplc()
        .args([
            "compile",
            &example("blink/blink.pnml"),
            "--lang",
            "st",
            "--plain",
        ])
        .assert()
        .success()
        .stdout(predicate::str::starts_with("PROGRAM blink\n"))
        .stdout(predicate::str::contains("END_PROGRAM"))
        .stderr(predicate::str::contains(
            "note: conflict: t1 and t4 both take tokens from p1; t1 has priority",
        ));
}

#[test]
fn pou_name_and_period_are_options() {
    petriplc()
        .args(["compile", &example("blink/blink.pnml"), "--lang", "il"])
        .args(["--pou", "Blinker", "--period", "T#20ms"])
        .assert()
        .success()
        .stdout(predicate::str::contains(
            "<pou name=\"Blinker\" pouType=\"program\">",
        ))
        .stdout(predicate::str::contains("interval=\"T#20ms\""));
}

#[test]
fn bad_requests_are_refused_with_exit_code_2() {
    let cases: &[(&[&str], &str)] = &[
        (
            &["--lang", "ld", "--plain"],
            "--plain writes bare ST or IL text",
        ),
        (&["--lang", "st", "--pou", "IF"], "--pou IF: not a valid"),
        (&["--lang", "st", "--pou", "two words"], "--pou two words"),
        (
            &["--lang", "sfc", "--markings", "int"],
            "SFC needs a safe net with BOOL markings",
        ),
        (
            &["--lang", "ld", "--evolve", "until-stable"],
            "LD cannot express the until-stable evolution",
        ),
    ];
    for (args, message) in cases {
        petriplc()
            .args(["compile", &example("blink/blink.pnml")])
            .args(*args)
            .assert()
            .code(2)
            .stderr(predicate::str::contains(*message));
    }
    petriplc()
        .args(["compile", "no/such/net.pnml", "--lang", "st"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("no/such/net.pnml"));
    petriplc()
        .args([
            "compile",
            &example("philosophers/philosophers.pnml"),
            "--lang",
            "sfc",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cannot compile"));
}

/// The README's software-in-the-loop recipe: generate C, build it, run the timeline.
#[test]
fn generated_c_prints_the_trace_sim_prints() {
    let dir = TempDir::new().unwrap();
    let source = dir.path().join("blink.c");
    let exe = dir.path().join("blink");
    petriplc()
        .args([
            "compile",
            &example("blink/blink.pnml"),
            "--lang",
            "c",
            "--out",
        ])
        .arg(&source)
        .assert()
        .success();
    let cc = Process::new("cc")
        .args(["-std=c99", "-O2", "-DPETRIPLC_MAIN", "-o"])
        .arg(&exe)
        .arg(&source)
        .output()
        .expect("cc runs");
    assert!(
        cc.status.success(),
        "{}",
        String::from_utf8_lossy(&cc.stderr)
    );
    let timeline = example("blink/timeline.csv");
    let c = Process::new(&exe)
        .args([
            Path::new(&timeline).as_os_str(),
            "--until".as_ref(),
            "9s".as_ref(),
        ])
        .output()
        .unwrap();
    assert!(c.status.success());
    let sim = petriplc()
        .args([
            "sim",
            &example("blink/blink.pnml"),
            "--inputs",
            &timeline,
            "--until",
            "9s",
        ])
        .output()
        .unwrap();
    assert!(sim.status.success());
    assert_eq!(
        String::from_utf8_lossy(&c.stdout),
        String::from_utf8_lossy(&sim.stdout)
    );
    // A timeline naming an output is refused by the C program as by sim.
    let bad = dir.path().join("bad.csv");
    fs::write(&bad, "time,out0\n0,1\n").unwrap();
    let c = Process::new(&exe).arg(&bad).output().unwrap();
    assert_eq!(c.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&c.stderr).contains("column `out0` is an output"));
}
