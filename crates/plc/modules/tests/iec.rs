//! The `iec` module driven in-process: bindings (located globals, map rows, a program's
//! inputs and outputs), types against point sizes, faults, and the chaser example.

mod harness;

use harness::{examples, ms, start, start_err};

const COUNTER: &str = "PROGRAM counter
VAR_INPUT go : BOOL; END_VAR
VAR_OUTPUT n : INT; odd : BOOL; END_VAR
VAR edge : R_TRIG; END_VAR
edge(CLK := go);
IF edge.Q THEN n := n + 1; END_IF;
odd := n MOD 2 = 1;
END_PROGRAM
";

fn dir_with(files: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    for (name, text) in files {
        std::fs::write(dir.path().join(name), text).unwrap();
    }
    dir
}

#[test]
fn a_program_binds_its_inputs_and_outputs_by_name() {
    let dir = dir_with(&[
        ("counter.st", COUNTER),
        ("drive.csv", "time,go\n0,0\n0.02,1\n0.04,0\n0.06,1\n"),
    ]);
    let mut plc = start(
        "[PLC]\nmodule drive timeline\nmodule ctl iec\n\
         point go \"\" drive\npoint n \"\" ctl i16\npoint odd \"\" ctl\n\
         [drive]\nfile = drive.csv\n[ctl]\nprogram = counter.st\n",
        dir.path(),
    )
    .unwrap();
    let mut seen = Vec::new();
    for k in 0..8 {
        plc.tick(ms(10 * k)).unwrap();
        seen.push(format!("{}{}", plc.value("n"), plc.value("odd")));
    }
    assert_eq!(seen.join(" "), "00 00 11 11 11 11 20 20");
    assert!(
        plc.status("ctl").contains("8 scans, 1 inputs, 2 outputs"),
        "{}",
        plc.status("ctl")
    );
}

#[test]
fn map_rows_and_located_globals() {
    let src = "PROGRAM p
VAR_EXTERNAL level : INT; alarm : BOOL; END_VAR
alarm := level > 100;
END_PROGRAM
CONFIGURATION c
VAR_GLOBAL level AT %IW0 : INT; alarm AT %horn : BOOL; END_VAR
RESOURCE r ON PLC TASK t (INTERVAL := T#20ms); PROGRAM main WITH t : p; END_RESOURCE
END_CONFIGURATION
";
    let dir = dir_with(&[
        ("p.st", src),
        ("lv.csv", "time,tank_level\n0,50\n0.03,150\n"),
    ]);
    let mut plc = start(
        "[PLC]\nmodule lv timeline\nmodule ctl iec\n\
         point tank_level \"\" lv i16\npoint horn \"\" ctl\n\
         [lv]\nfile = lv.csv\n[ctl]\nprogram = p.st\nmap level tank_level\n",
        dir.path(),
    )
    .unwrap();
    let mut seen = Vec::new();
    for k in 0..6 {
        plc.tick(ms(10 * k)).unwrap();
        seen.push(plc.value("horn").to_string());
    }
    // The task runs every 20 ms: at 0, 20, 40 ms.
    assert_eq!(seen.join(""), "000011");
}

#[test]
fn wrong_bindings_are_all_reported_before_anything_runs() {
    let src = "PROGRAM p
VAR_INPUT a : BOOL; b : INT; END_VAR
VAR_OUTPUT c : REAL; d : LINT; END_VAR
c := 1.0;
END_PROGRAM
";
    let dir = dir_with(&[("p.st", src)]);
    let err = start_err(
        "[PLC]\nmodule ctl iec\nmodule other timeline\n\
         point a \"\" other u16\npoint b \"\" other u16\npoint c \"\" ctl\npoint d \"\" ctl u32\n\
         [other]\nfile = x.csv\n[ctl]\nprogram = p.st\n",
        dir.path(),
    );
    for expect in [
        "variable `a` is BOOL but it is bound to point `a` (unsigned 16 bits); declare `a` with 1 bit (`u1`), or make `a` an integer of 16 bits",
        "variable `b` is INT but it is bound to point `b` (unsigned 16 bits); declare `b` as `i16`",
        "variable `c` is REAL but it is bound to point `c` (unsigned 1 bit); declare `c` as `f32`",
        "variable `d` is LINT, which no point can hold",
    ] {
        assert!(err.contains(expect), "missing `{expect}` in:\n{err}");
    }
}

#[test]
fn a_program_that_does_not_compile_is_refused_with_every_error() {
    let dir = dir_with(&[(
        "bad.st",
        "PROGRAM p\nVAR x : INT; END_VAR\nx := y;\nx := 1.5;\nEND_PROGRAM\n",
    )]);
    let err = start_err(
        "[PLC]\nmodule ctl iec\n[ctl]\nprogram = bad.st\n",
        dir.path(),
    );
    assert!(
        err.contains("bad.st:3:6: error[E100]: `y` is not declared"),
        "{err}"
    );
    assert!(err.contains("bad.st:4:6: error[E110]"), "{err}");
}

#[test]
fn a_global_the_program_needs_but_nobody_declares_is_an_error_to_run() {
    // `petriplc check` of the same file only warns (W021): a library checked alone.
    let dir = dir_with(&[(
        "lib.st",
        "PROGRAM p\nVAR_EXTERNAL PLC_TICKS_PER_SEC : INT; END_VAR\nVAR x : INT; END_VAR\nx := PLC_TICKS_PER_SEC;\nEND_PROGRAM\n",
    )]);
    let err = start_err(
        "[PLC]\nmodule ctl iec\n[ctl]\nprogram = lib.st\n",
        dir.path(),
    );
    assert!(
        err.contains("lib.st:2:14: error[E106]: VAR_EXTERNAL PLC_TICKS_PER_SEC has no VAR_GLOBAL"),
        "{err}"
    );
}

#[test]
fn a_run_time_fault_fails_the_module_with_pou_line_and_values() {
    let src = "PROGRAM p
VAR_INPUT d : INT; END_VAR
VAR_OUTPUT q : INT; END_VAR
q := 100 / d;
END_PROGRAM
";
    let dir = dir_with(&[("p.st", src), ("d.csv", "time,d\n0,5\n0.02,0\n")]);
    let mut plc = start(
        "[PLC]\nmodule drive timeline\nmodule ctl iec\n\
         point d \"\" drive i16\npoint q \"\" ctl i16\n\
         [drive]\nfile = d.csv\n[ctl]\nprogram = p.st\n",
        dir.path(),
    )
    .unwrap();
    plc.tick(ms(0)).unwrap();
    plc.tick(ms(10)).unwrap();
    assert_eq!(plc.value("q"), 20);
    let e = plc.tick(ms(20)).unwrap_err().to_string();
    assert!(
        e.contains("p.st:4: in PROGRAM p: division by zero: 100 / 0"),
        "{e}"
    );
}

#[test]
fn an_endless_loop_is_stopped_by_the_iteration_budget() {
    let src = "PROGRAM p VAR i : INT; END_VAR WHILE TRUE DO i := 1; END_WHILE; END_PROGRAM";
    let dir = dir_with(&[("p.st", src)]);
    let mut plc = start(
        "[PLC]\nmodule ctl iec\n[ctl]\nprogram = p.st\nmax_iterations = 1000\n",
        dir.path(),
    )
    .unwrap();
    let e = plc.tick(ms(0)).unwrap_err().to_string();
    assert!(
        e.contains("watchdog: a loop ran out of the scan's iteration budget"),
        "{e}"
    );
}

/// Overflow wraps by default (the point reads -32768); `overflow = fault` fails the module at
/// the line, and a value other than `wrap` or `fault` is refused with both named.
#[test]
fn overflow_wraps_unless_the_module_says_fault() {
    let src = "PROGRAM p
VAR_OUTPUT q : INT := 32766; END_VAR
q := q + 1;
END_PROGRAM
";
    let dir = dir_with(&[("p.st", src)]);
    let conf = |setting: &str| {
        format!("[PLC]\nmodule ctl iec\npoint q \"\" ctl i16\n[ctl]\nprogram = p.st\n{setting}")
    };
    let mut plc = start(&conf(""), dir.path()).unwrap();
    plc.tick(ms(0)).unwrap();
    plc.tick(ms(10)).unwrap();
    assert_eq!(plc.value("q"), -32768);
    let mut plc = start(&conf("overflow = fault\n"), dir.path()).unwrap();
    plc.tick(ms(0)).unwrap();
    let e = plc.tick(ms(10)).unwrap_err().to_string();
    assert!(
        e.contains("p.st:3: in PROGRAM p: overflow: 32767 + 1 = 32768 leaves -32768..32767"),
        "{e}"
    );
    let err = start_err(&conf("overflow = saturate\n"), dir.path());
    assert!(
        err.contains("`overflow = saturate`: give `wrap`") && err.contains("or `fault`"),
        "{err}"
    );
}

#[test]
fn libs_loads_vendor_libraries() {
    // CODESYS's TIME() is the PLC's clock, as TON's: 0, 10, 20 ms at the first three ticks.
    let src =
        "PROGRAM p\nVAR_OUTPUT ms : DINT; END_VAR\nms := TIME_TO_DINT(TIME());\nEND_PROGRAM\n";
    let dir = dir_with(&[("p.st", src)]);
    let conf = "[PLC]\nmodule ctl iec\npoint ms \"\" ctl i32\n[ctl]\nprogram = p.st\n";
    let mut plc = start(&format!("{conf}libs = codesys\n"), dir.path()).unwrap();
    let mut seen = Vec::new();
    for k in 0..3 {
        plc.tick(ms(10 * k)).unwrap();
        seen.push(plc.value("ms").to_string());
    }
    assert_eq!(seen.join(" "), "0 10 20");
    // A vendor function block runs on the PLC as in `sim`.
    let fb = "PROGRAM q\nVAR_OUTPUT lit : BOOL; END_VAR\nVAR h : HYSTERESIS; END_VAR\nh(IN := 1, HIGH := 9, LOW := 5); lit := h.OUT;\nEND_PROGRAM\n";
    std::fs::write(dir.path().join("q.st"), fb).unwrap();
    let mut plc = start(
        "[PLC]\nmodule ctl iec\npoint lit \"\" ctl\n[ctl]\nprogram = q.st\nlibs = codesys\n",
        dir.path(),
    )
    .unwrap();
    plc.tick(ms(0)).unwrap();
    assert_eq!(plc.value("lit"), 1);
    let e = start_err(conf, dir.path());
    assert!(e.contains("TIME is a CODESYS/TwinCAT function: add --lib codesys (`libs = codesys` on `module NAME iec`)"), "{e}");
    let e = start_err(&format!("{conf}libs = codesys, step7\n"), dir.path());
    assert!(
        e.contains(
            "`libs`: unknown vendor library `step7`; the libraries are codesys, twincat, pcworx, beremiz"
        ),
        "{e}"
    );
}

#[test]
fn the_chaser_runs_on_the_plc() {
    // The example's configuration, with a timeline standing in for the vitrine's keys.
    let example = examples("chaser");
    let text = std::fs::read_to_string(example.join("plc.conf")).unwrap();
    let text = text[..text.find("[vitrine]").unwrap()]
        .replace("module vitrine     vitrine", "module vitrine     timeline")
        + "[vitrine]\nfile = keys.csv\n";
    let dir = dir_with(&[
        (
            "chaser.st",
            &std::fs::read_to_string(example.join("chaser.st")).unwrap(),
        ),
        ("keys.csv", "time,left,right\n0,0,0\n"),
    ]);
    let mut plc = start(&text, dir.path()).unwrap();
    let mut lamps = Vec::new();
    for k in 0..5 {
        plc.tick(ms(300 * k)).unwrap();
        let lit: Vec<&str> = ["L1", "L2", "L3", "L4"]
            .into_iter()
            .filter(|l| plc.value(l) != 0)
            .collect();
        lamps.push(lit.join(""));
    }
    assert_eq!(lamps.join(" "), "L2 L3 L4 L1 L2");
    assert_eq!(plc.value("laps"), 1);
}

#[test]
fn a_ladder_project_runs_as_a_module() {
    // The LD corpus project: a contact on `a` drives a coil on `q`.
    let ld = include_str!("../../../compiler/iec/tests/corpus-graphical/ld01_contact_coil.xml");
    let dir = dir_with(&[
        ("ld.xml", ld),
        ("drive.csv", "time,a\n0,0\n0.02,1\n0.04,0\n"),
    ]);
    let mut plc = start(
        "[PLC]\nmodule drive timeline\nmodule ctl iec\n\
         point a \"\" drive\npoint q \"\" ctl\n\
         [drive]\nfile = drive.csv\n[ctl]\nproject = ld.xml\n",
        dir.path(),
    )
    .unwrap();
    let mut seen = Vec::new();
    for k in 0..6 {
        plc.tick(ms(10 * k)).unwrap();
        seen.push(plc.value("q").to_string());
    }
    assert_eq!(seen.join(""), "001100");
}

#[test]
fn a_folder_of_sources_runs_as_one_program() {
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path().join("plc");
    std::fs::create_dir_all(src.join("POUs")).unwrap();
    // The function block in TwinCAT's file format, the program in Structured Text.
    std::fs::write(
        src.join("POUs/Edges.TcPOU"),
        "<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<TcPlcObject Version=\"1.1.0.1\">\n  <POU Name=\"Edges\">\n    <Declaration><![CDATA[FUNCTION_BLOCK Edges\nVAR_INPUT\n\tgo : BOOL;\nEND_VAR\nVAR_OUTPUT\n\tn : INT;\nEND_VAR\nVAR\n\tedge : R_TRIG;\nEND_VAR]]></Declaration>\n    <Implementation>\n      <ST><![CDATA[edge(CLK := go);\nIF edge.Q THEN\n\tn := n + 1;\nEND_IF;]]></ST>\n    </Implementation>\n  </POU>\n</TcPlcObject>\n",
    )
    .unwrap();
    std::fs::write(
        src.join("main.st"),
        "PROGRAM counter\nVAR_INPUT go : BOOL; END_VAR\nVAR_OUTPUT n : INT; END_VAR\nVAR e : Edges; END_VAR\ne(go := go);\nn := e.n;\nEND_PROGRAM\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("drive.csv"),
        "time,go\n0,0\n0.02,1\n0.04,0\n0.06,1\n",
    )
    .unwrap();
    let mut plc = start(
        "[PLC]\nmodule drive timeline\nmodule ctl iec\n\
         point go \"\" drive\npoint n \"\" ctl i16\n\
         [drive]\nfile = drive.csv\n[ctl]\nprogram = plc\n",
        dir.path(),
    )
    .unwrap();
    let mut seen = Vec::new();
    for k in 0..8 {
        plc.tick(ms(10 * k)).unwrap();
        seen.push(plc.value("n").to_string());
    }
    assert_eq!(seen.join(" "), "0 0 1 1 1 1 2 2");

    // An empty folder is refused with what it lacks.
    std::fs::create_dir_all(dir.path().join("empty")).unwrap();
    let e = start_err(
        "[PLC]\nmodule ctl iec\n[ctl]\nprogram = empty\n",
        dir.path(),
    );
    assert!(e.contains("holds no IEC 61131-3 source"), "{e}");
}
