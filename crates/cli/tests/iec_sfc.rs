//! Textual SFC through the real binary: `petriplc sim` traces a chart's step flags, and
//! `petriplc check` tells a chart's structural errors at their lines.

use assert_cmd::Command;
use predicates::prelude::*;

mod common;
use common::file;

fn petriplc() -> Command {
    Command::cargo_bin("petriplc").unwrap()
}

#[test]
fn sim_traces_a_text_chart_and_check_tells_its_errors() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "chart.st",
        "PROGRAM chart\nVAR_INPUT go : BOOL; END_VAR\nVAR_OUTPUT lamp : BOOL; END_VAR\nINITIAL_STEP idle : END_STEP\nTRANSITION FROM idle TO lit := go; END_TRANSITION\nSTEP lit : lamp(N); END_STEP\nTRANSITION FROM lit TO idle := NOT go; END_TRANSITION\nEND_PROGRAM\n",
    );
    let tl = file(&dir, "tl.csv", "time,GO\n0,0\n0.02,1\n0.04,0\n");
    petriplc()
        .args(["sim", &prog, "--inputs", &tl, "--until", "0.06s", "--vars"])
        .assert()
        .success()
        .stdout(TRACE);
    let bad = file(
        &dir,
        "bad.st",
        "PROGRAM p\nVAR go : BOOL; END_VAR\nINITIAL_STEP a : END_STEP\nTRANSITION FROM a TO b := go; END_TRANSITION\ngo := TRUE;\nEND_PROGRAM\n",
    );
    petriplc().args(["check", &bad]).assert().code(2).stderr(
        predicate::str::contains("bad.st:4:22: error[E030]: the transition goes to step b").and(
            predicate::str::contains("bad.st:5:1: error[E031]: this body is a chart"),
        ),
    );
}

/// A step flag is traced as `S.X`; the chart moves in the scan its condition becomes TRUE.
const TRACE: &str = "time,in:go,lamp,idle.X,lit.X\n0,0,0,1,0\n0.02,1,1,0,1\n0.04,0,0,1,0\n";
