//! `--dialect` on `petriplc check` and `petriplc sim`, and `dialect = …` on `module NAME iec`:
//! CODESYS's counters name their inputs `RESET` and `LOAD` where the standard has `R` and `LD`
//! (docs/iec.md, "Dialects and vendor code").

use assert_cmd::Command;
use predicates::prelude::*;

mod common;
use common::file;

fn petriplc() -> Command {
    Command::cargo_bin("petriplc").unwrap()
}

/// A program written for CODESYS: CTU's `RESET`.
const CODESYS_COUNTER: &str = "PROGRAM main
VAR_INPUT pulse : BOOL; clear : BOOL; END_VAR
VAR_OUTPUT count : INT; done : BOOL; END_VAR
VAR c : CTU; END_VAR
c(CU := pulse, RESET := clear, PV := 2);
count := c.CV;
done := c.Q;
END_PROGRAM
";

#[test]
fn check_and_sim_read_codesys_counters_with_dialect_codesys() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(&dir, "counter.st", CODESYS_COUNTER);
    petriplc()
        .args(["check", &prog])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "counter.st:5:16: error[E130]: CTU has no parameter `RESET`; its parameters are CU, R, PV, Q, CV",
        ));
    for d in ["codesys", "twincat", "CODESYS"] {
        petriplc()
            .args(["check", "--dialect", d, &prog])
            .assert()
            .success();
    }
    petriplc()
        .args(["check", "--dialect", "step7", &prog])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "unknown dialect `step7`; write one of iec, codesys, twincat, pcworx",
        ));
    let timeline = file(
        &dir,
        "t.csv",
        "time,pulse,clear\n0,0,0\n0.01,1,0\n0.02,0,0\n0.03,1,0\n0.04,0,1\n",
    );
    let out = petriplc()
        .args(["sim", &prog, "--dialect", "codesys", "--inputs", &timeline])
        .args(["--until", "50ms"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    assert_eq!(
        String::from_utf8_lossy(&out),
        "time,in:pulse,in:clear,count,done\n0,0,0,0,0\n0.01,1,0,1,0\n0.02,0,0,1,0\n0.03,1,0,2,1\n0.04,0,1,0,0\n"
    );
    // A net has no dialect.
    let net = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../examples/blink/blink.pnml"
    );
    petriplc()
        .args(["sim", net, "--dialect", "codesys"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "--dialect applies to IEC 61131-3 programs",
        ));
}

#[test]
fn a_twincat_file_is_read_as_twincat_unless_told_otherwise() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "counter.st",
        &format!("{{attribute 'TcRpcEnable'}}\n{CODESYS_COUNTER}"),
    );
    petriplc()
        .args(["check", &prog])
        .assert()
        .success()
        .stderr(predicate::str::contains(
            "counter.st:1:1: warning[W010]: 1 pragma ignored here ({attribute 'TcRpcEnable'}): petriplc does not model them",
        ));
    petriplc()
        .args(["check", "--dialect", "iec", &prog])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "error[E130]: CTU has no parameter `RESET`",
        ));
}

#[test]
fn the_iec_module_takes_a_dialect() {
    let dir = tempfile::tempdir().unwrap();
    file(
        &dir,
        "counter.st",
        "PROGRAM main\nVAR c : CTU; n : INT; END_VAR\n\
         c(CU := n MOD 2 = 0, RESET := FALSE, PV := 3);\nn := n + 1;\nEND_PROGRAM\n",
    );
    let run = |settings: &str| {
        let conf = file(
            &dir,
            "plc.conf",
            &format!("[PLC]\nmodule logic iec\n[logic]\nprogram = counter.st\n{settings}"),
        );
        let out = petriplc()
            .args(["run", &conf, "--for", "200ms"])
            .args(["--plc-id", &format!("test-dialect-{}", std::process::id())])
            .output()
            .unwrap();
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (code, log) = run("dialect = codesys\n");
    assert_eq!(code, Some(0), "{log}");
    let (code, log) = run("");
    assert_ne!(code, Some(0), "{log}");
    assert!(log.contains("CTU has no parameter `RESET`"), "{log}");
    let (code, log) = run("dialect = step7\n");
    assert_ne!(code, Some(0), "{log}");
    assert!(
        log.contains("`dialect = step7`: unknown dialect `step7`; write one of iec, codesys, twincat, pcworx"),
        "{log}"
    );
}
