//! IEC 61131-3 programs through the real binary: `petriplc check`, `petriplc sim` on a
//! program and on the chaser's configuration, run-time faults, and the chaser on the soft
//! PLC.

use assert_cmd::Command;
use predicates::prelude::*;

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");

mod common;
use common::file;

fn petriplc() -> Command {
    Command::cargo_bin("petriplc").unwrap()
}

#[test]
fn check_accepts_a_good_program_and_reports_every_error_of_a_bad_one() {
    petriplc()
        .args(["check", &format!("{EXAMPLES}/chaser/chaser.st")])
        .assert()
        .success()
        .stderr(
            predicate::str::contains("ok: ").and(predicate::str::contains("CONFIGURATION chaser")),
        );
    let dir = tempfile::tempdir().unwrap();
    let bad = file(
        &dir,
        "bad.st",
        "PROGRAM p\nVAR x : INT; r : REAL; k : INT; END_VAR\nVAR CONSTANT c : INT := 1; END_VAR\nx := r;\nc := 2;\nCASE k OF 1: x := 1; 1: x := 2; END_CASE;\nx := f(1);\nEND_PROGRAM\n",
    );
    let out = petriplc()
        .args(["check", &bad])
        .assert()
        .code(2)
        .get_output()
        .stderr
        .clone();
    let err = String::from_utf8_lossy(&out);
    for expect in [
        "bad.st:4:6: error[E110]: the value assigned to `x` is REAL but INT is needed; convert explicitly: REAL_TO_INT(…) rounds, TRUNC(…) truncates",
        "bad.st:5:1: error[E121]: `c` is a CONSTANT",
        "bad.st:6:22: error[E140]: this label is unreachable",
        "bad.st:7:6: error[E102]: unknown function `f`",
        "error: 4 problems found; nothing was run",
    ] {
        assert!(err.contains(expect), "missing `{expect}` in:\n{err}");
    }
    let syntax = file(&dir, "syntax.st", "PROGRAM p\nx := ;\nEND_PROGRAM\n");
    petriplc()
        .args(["check", &syntax])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "syntax.st:2:6: error[E010]: expected an expression, found `;`",
        ));
    petriplc()
        .args([
            "check",
            &dir.path().join("missing.st").display().to_string(),
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("cannot read"));
}

#[test]
fn a_library_checks_with_a_warning_for_a_global_it_names_but_does_not_run_without_it() {
    let dir = tempfile::tempdir().unwrap();
    let lib = file(
        &dir,
        "lib.st",
        "PROGRAM ticks\nVAR_EXTERNAL PLC_TICKS_PER_SEC : INT; END_VAR\nVAR_OUTPUT n : INT; END_VAR\nn := PLC_TICKS_PER_SEC;\nEND_PROGRAM\n",
    );
    petriplc().args(["check", &lib]).assert().success().stderr(
        predicate::str::contains(
            "lib.st:2:14: warning[W021]: VAR_EXTERNAL PLC_TICKS_PER_SEC has no VAR_GLOBAL",
        )
        .and(predicate::str::contains("1 warning(s)")),
    );
    petriplc()
        .args(["sim", &lib, "--until", "0.1s"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "lib.st:2:14: error[E106]: VAR_EXTERNAL PLC_TICKS_PER_SEC has no VAR_GLOBAL",
        ));
}

#[test]
fn lib_loads_a_vendor_library_on_check_and_sim() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "clock.st",
        "PROGRAM p\nVAR_OUTPUT ms : DINT; hex : STRING[4]; END_VAR\nms := TIME_TO_DINT(TIME());\nhex := BYTE_TO_STRING(DINT_TO_BYTE(ms), '%02X');\nEND_PROGRAM\n",
    );
    petriplc()
        .args(["check", &prog])
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("clock.st:3:20: error[E180]: TIME is a CODESYS/TwinCAT function: add --lib codesys")
                .and(predicate::str::contains("clock.st:4:8: error[E180]: BYTE_TO_STRING(value, format) is a PCWorx function: add --lib pcworx")),
        );
    petriplc()
        .args(["check", &prog, "--lib", "codesys,pcworx"])
        .assert()
        .success();
    petriplc()
        .args(["check", &prog, "--lib", "siemens"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "unknown vendor library `siemens`; the libraries are codesys, twincat, pcworx, beremiz",
        ));
    // In simulation TIME() is the simulated clock: 0, 10 ms, 20 ms…
    petriplc()
        .args([
            "sim", &prog, "--lib", "twincat", "--lib", "pcworx", "--until", "0.02s",
        ])
        .assert()
        .success()
        .stdout("time,ms,hex\n0,0,'00'\n0.01,10,'0A'\n0.02,20,'14'\n");
}

#[test]
fn sim_traces_a_program_against_a_timeline() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "count.st",
        "PROGRAM counter\nVAR_INPUT go : BOOL; END_VAR\nVAR_OUTPUT n : INT; odd : BOOL; END_VAR\nVAR e : R_TRIG; last : BOOL; END_VAR\ne(CLK := go);\nIF e.Q THEN n := n + 1; END_IF;\nodd := n MOD 2 = 1;\nlast := go;\nEND_PROGRAM\n",
    );
    let tl = file(&dir, "tl.csv", "time,GO\n0,0\n0.02,1\n0.04,0\n0.06,1\n");
    petriplc()
        .args(["sim", &prog, "--inputs", &tl, "--until", "0.1s"])
        .assert()
        .success()
        .stdout("time,in:go,n,odd\n0,0,0,0\n0.02,1,1,1\n0.04,0,1,1\n0.06,1,2,0\n");
    petriplc()
        .args(["sim", &prog, "--inputs", &tl, "--until", "0.03s", "--vars"])
        .assert()
        .success()
        .stdout("time,in:go,n,odd,last\n0,0,0,0,0\n0.02,1,1,1,1\n");
    let bad_tl = file(&dir, "bad.csv", "time,stop\n0,1\n");
    petriplc()
        .args(["sim", &prog, "--inputs", &bad_tl])
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("column `stop` is not an input of the controller")
                .and(predicate::str::contains("known inputs: go")),
        );
}

#[test]
fn sim_runs_the_chaser_configuration_on_its_task() {
    let out = petriplc()
        .args([
            "sim",
            &format!("{EXAMPLES}/chaser/chaser.st"),
            "--inputs",
            &format!("{EXAMPLES}/chaser/timeline.csv"),
            "--until",
            "2.1s",
        ])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let csv = String::from_utf8_lossy(&out);
    let lines: Vec<&str> = csv.lines().collect();
    // Inputs first (in:NAME, in the timeline's column order), as for nets.
    assert_eq!(lines[0], "time,in:right,in:left,L1,L2,L3,L4,laps");
    // The task runs every 300 ms; right turns the light at 1.5 s.
    assert_eq!(
        &lines[1..8],
        &[
            "0,0,0,0,1,0,0,0",
            "0.3,0,0,0,0,1,0,0",
            "0.6,0,0,0,0,0,1,0",
            "0.9,0,0,1,0,0,0,1",
            "1.2,0,0,0,1,0,0,1",
            "1.5,1,0,1,0,0,0,1",
            "1.8,0,0,0,0,0,1,2",
        ]
    );
}

#[test]
fn a_run_time_fault_fails_the_simulation_with_pou_line_and_values() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "div.st",
        "PROGRAM p\nVAR_INPUT d : INT; END_VAR\nVAR_OUTPUT q : INT; END_VAR\nq := 100 / d;\nEND_PROGRAM\n",
    );
    let tl = file(&dir, "d.csv", "time,d\n0,4\n0.05,0\n");
    petriplc()
        .args(["sim", &prog, "--inputs", &tl])
        .assert()
        .code(1)
        .stderr(
            predicate::str::contains("at t=0.05s: ").and(predicate::str::contains(
                "div.st:4: in PROGRAM p: division by zero: 100 / 0",
            )),
        )
        // What was simulated is written, marked incomplete, as for nets.
        .stdout(
            predicate::str::starts_with(
                "time,in:d,q\n0,4,25\n# incomplete: the simulation failed: at t=0.05s: ",
            )
            .and(predicate::str::contains("div.st:4: in PROGRAM p")),
        );
}

/// Integer overflow wraps by default, as other PLCs; `--overflow fault` makes it the fault it
/// was; `check --overflow fault` folds constants by the same rule; nets refuse the flag.
#[test]
fn overflow_wraps_unless_sim_is_told_to_fault() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "ovf.st",
        "PROGRAM p\nVAR_OUTPUT q : SINT := 126; END_VAR\nq := q + 1;\nEND_PROGRAM\n",
    );
    petriplc()
        .args(["sim", &prog, "--until", "30ms"])
        .assert()
        .success()
        .stdout("time,q\n0,127\n0.01,-128\n0.02,-127\n0.03,-126\n");
    petriplc()
        .args(["sim", &prog, "--until", "30ms", "--overflow", "fault"])
        .assert()
        .code(1)
        .stderr(predicate::str::contains(
            "ovf.st:3: in PROGRAM p: overflow: 127 + 1 = 128 leaves -128..127",
        ));
    let conv = file(
        &dir,
        "conv.st",
        "PROGRAM p\nVAR q : UDINT := REAL_TO_UDINT(-1.75); END_VAR\nEND_PROGRAM\n",
    );
    petriplc().args(["check", &conv]).assert().success();
    petriplc()
        .args(["check", &conv, "--overflow", "fault"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "error[E113]: this constant does not convert to UDINT",
        ));
    petriplc()
        .args([
            "sim",
            &format!("{EXAMPLES}/blink/blink.pnml"),
            "--overflow",
            "fault",
        ])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "--overflow and --lib apply to IEC 61131-3 programs",
        ));
}

#[test]
fn the_chaser_runs_on_the_soft_plc() {
    let id = format!("test-chaser-{}", std::process::id());
    let out = petriplc()
        .args([
            "run",
            &format!("{EXAMPLES}/chaser/plc.conf"),
            "--plc-id",
            &id,
            "--for",
            "1s",
        ])
        .assert()
        .success()
        .get_output()
        .stderr
        .clone();
    let report = String::from_utf8_lossy(&out);
    assert!(report.contains("chaser_iec   iec"), "{report}");
    assert!(report.contains("chaser.st (chaser):"), "{report}");
}

#[test]
fn the_il_chaser_simulates_exactly_as_the_st_chaser() {
    let sim = |file: &str| {
        petriplc()
            .args([
                "sim",
                &format!("{EXAMPLES}/chaser/{file}"),
                "--inputs",
                &format!("{EXAMPLES}/chaser/timeline.csv"),
                "--until",
                "6s",
                "--vars",
            ])
            .assert()
            .success()
            .get_output()
            .stdout
            .clone()
    };
    let (st, il) = (sim("chaser.st"), sim("chaser_il.il"));
    assert_eq!(String::from_utf8_lossy(&il), String::from_utf8_lossy(&st));
    assert!(String::from_utf8_lossy(&il).lines().count() > 20);
}

#[test]
fn the_il_chaser_runs_on_the_soft_plc() {
    let id = format!("test-chaser-il-{}", std::process::id());
    let out = petriplc()
        .args([
            "run",
            &format!("{EXAMPLES}/chaser/plc_il.conf"),
            "--plc-id",
            &id,
            "--for",
            "1s",
        ])
        .assert()
        .success()
        .get_output()
        .stderr
        .clone();
    let report = String::from_utf8_lossy(&out);
    assert!(report.contains("chaser_il    iec"), "{report}");
    assert!(report.contains("chaser_il.il (chaser):"), "{report}");
}

/// Issue 27: a stuck IEC scan was failed by the runner's watchdog with "its scan has run
/// 100.1 ms" and no place; the engine's own check now fails it first, naming the file and
/// line of the loop, with the fault time in milliseconds.
#[test]
fn a_stuck_scan_on_the_soft_plc_names_its_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    file(
        &dir,
        "stuck.st",
        "PROGRAM main\nVAR i : DINT; go : BOOL := TRUE; END_VAR\n\
         WHILE go DO\n  i := i + 1;\n  IF i > 1000000 THEN i := 0; END_IF;\nEND_WHILE;\n\
         END_PROGRAM\n",
    );
    let conf = file(
        &dir,
        "plc.conf",
        "[PLC]\nmodule logic iec\n[logic]\nprogram = stuck.st\nwatchdog = T#100ms\n\
         max_iterations = 4000000000\n",
    );
    let out = petriplc()
        .args(["run", &conf, "--for", "5s"])
        .args(["--plc-id", &format!("test-stuck-{}", std::process::id())])
        .assert()
        .code(1)
        .get_output()
        .stderr
        .clone();
    let log = String::from_utf8_lossy(&out);
    assert!(
        log.contains("stuck.st:3: in PROGRAM main: watchdog: a loop ran past the watchdog time (watchdog = T#100ms)"),
        "{log}"
    );
    // Milliseconds: `at t=0.01s`, never nine decimals.
    let at = log
        .split("at t=")
        .nth(1)
        .unwrap()
        .split('s')
        .next()
        .unwrap();
    assert!(at.split('.').nth(1).is_none_or(|f| f.len() <= 3), "{log}");
}

/// Issue 28: `petriplc sim PROGRAM --plant turntable --plant-set K_alpha=45` silently ignored
/// the setting (the CLI read --plant-set only for nets). Programs and nets now build their
/// plant the same way: a setting is taken, a wrong one refused.
#[test]
fn plant_settings_apply_to_a_program_as_to_a_net() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "p.st",
        "PROGRAM main\nVAR_OUTPUT ML, MR : BOOL; END_VAR\nML := FALSE;\nEND_PROGRAM\n",
    );
    let run = |sets: &[&str]| {
        let mut args = vec![
            "sim",
            prog.as_str(),
            "--plant",
            "turntable",
            "--until",
            "0.1",
        ];
        for s in sets {
            args.extend(["--plant-set", s]);
        }
        petriplc().args(&args).assert()
    };
    run(&["K_alpha=45"]).success();
    run(&["speed=3"]).code(2).stderr(predicate::str::contains(
        "the turntable has no setting `speed`",
    ));
    run(&["K_alpha=fast"])
        .code(2)
        .stderr(predicate::str::contains(
            "turntable setting `K_alpha = fast`",
        ));
    // Without a plant, a setting has nothing to apply to: the usage error names --plant.
    petriplc()
        .args(["sim", &prog, "--until", "0.1", "--plant-set", "L=3"])
        .assert()
        .code(2)
        .stderr(
            predicate::str::contains("required arguments were not provided")
                .and(predicate::str::contains("--plant <NAME|PNML>")),
        );
}

/// Issue 28: a program's simulation had its own copy of the wiring, which let a plant output
/// drive a variable the program writes too (a net's refused it). One wiring now refuses both.
#[test]
fn a_plant_output_the_program_also_writes_is_driven_twice() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "p.st",
        "PROGRAM main\nVAR_OUTPUT V1, N3 : BOOL; END_VAR\nN3 := TRUE;\nEND_PROGRAM\n",
    );
    petriplc()
        .args(["sim", &prog, "--plant", "tank", "--until", "0.1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "`N3` is driven by both the controller and plant `tank`; drop it from one of them",
        ));
}

/// Issue 28: a timeline giving 2 to a BOOL input of a program is refused before the run, as
/// for a net (it failed in the middle of the run, naming no column).
#[test]
fn a_timeline_gives_a_bool_input_of_a_program_0_or_1() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "p.st",
        "PROGRAM main\nVAR_INPUT b : BOOL; END_VAR\nVAR_OUTPUT q : BOOL; END_VAR\nq := b;\nEND_PROGRAM\n",
    );
    let tl = file(&dir, "b.csv", "time,B\n0,1\n0.05,2\n");
    petriplc()
        .args(["sim", &prog, "--inputs", &tl, "--until", "0.1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "timeline column `B` sets boolean input `B` to 2 at t=0.05s; write 0/1 or TRUE/FALSE",
        ));
}

/// Issue 28: the wiring's warnings are the same words for a net and for a program with the
/// same signals (a program's said "it keeps its initial value").
#[test]
fn wiring_warnings_are_worded_the_same_for_a_net_and_a_program() {
    let dir = tempfile::tempdir().unwrap();
    let prog = file(
        &dir,
        "mixer.st",
        "PROGRAM mixer\nVAR_INPUT B1, N1, N2, N3 : BOOL; END_VAR\n\
         VAR_OUTPUT V1, V2, V3 : BOOL; END_VAR\nV1 := B1;\nEND_PROGRAM\n",
    );
    let warnings = |args: &[&str]| {
        let out = petriplc()
            .args(args)
            .args(["--plant", "tank", "--until", "0"])
            .assert()
            .success()
            .get_output()
            .stderr
            .clone();
        String::from_utf8_lossy(&out)
            .lines()
            .filter(|l| l.starts_with("warning: "))
            .map(str::to_string)
            .collect::<Vec<_>>()
    };
    let net = format!("{EXAMPLES}/mixer/mixer.pnml");
    let expect =
        ["warning: input B1 is driven by neither the timeline nor the plant; it stays FALSE"];
    assert_eq!(warnings(&["sim", &net, "--names", "sipn"]), expect);
    assert_eq!(warnings(&["sim", &prog]), expect);
}

#[test]
fn check_and_sim_take_a_folder_and_a_twincat_project() {
    for target in ["twincat-blink/Blink.plcproj", "twincat-blink", "st-folder"] {
        petriplc()
            .args(["check", &format!("{EXAMPLES}/{target}")])
            .assert()
            .success()
            .stderr(predicate::str::contains("ok: ").and(predicate::str::contains("1 PROGRAM")));
    }
    // The task object's 10 ms cycle is the scan period; the lamp turns every 70 ms once on.
    let trace = |target: &str| {
        let out = petriplc()
            .args([
                "sim",
                &format!("{EXAMPLES}/{target}"),
                "--inputs",
                &format!("{EXAMPLES}/twincat-blink/timeline.csv"),
                "--until",
                "0.3s",
            ])
            .assert()
            .success()
            .get_output()
            .stdout
            .clone();
        String::from_utf8(out).unwrap()
    };
    assert_eq!(
        trace("twincat-blink/Blink.plcproj"),
        "time,in:run,lamp,mode\n0,0,0,Off\n0.1,1,0,Blinking\n0.15,1,1,Blinking\n0.22,1,0,Blinking\n0.29,1,1,Blinking\n"
    );
    assert_eq!(
        trace("st-folder"),
        "time,in:run,lamp\n0,0,0\n0.1,1,0\n0.15,1,1\n0.22,1,0\n0.29,1,1\n"
    );

    // A project naming a missing file: the error is at its <Compile> item.
    let dir = tempfile::tempdir().unwrap();
    let proj = file(
        &dir,
        "p.plcproj",
        "<Project>\n  <ItemGroup>\n    <Compile Include=\"POUs\\MAIN.TcPOU\" />\n  </ItemGroup>\n</Project>\n",
    );
    petriplc()
        .args(["check", &proj])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "p.plcproj:3:5: error[E056]: the project compiles POUs/MAIN.TcPOU, which does not exist beside it",
        ));
    // An empty folder says what it lacks.
    let empty = tempfile::tempdir().unwrap();
    petriplc()
        .args(["check", &empty.path().display().to_string()])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("holds no IEC 61131-3 source"));
}
