//! Drives the real `petriplc` binary: options, exit codes and error messages.

use assert_cmd::Command;
use predicates::prelude::*;
use std::fs;
use tempfile::TempDir;

/// A two-place net: `go` moves the token from `idle` (output Ready) to `busy` (output Busy),
/// `stop` moves it back.
const TOGGLE: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">
  <net id="toggle" type="http://www.pnml.org/version-2009/grammar/ptnet">
    <page id="page0">
      <place id="idle"><name><text>idle</text></name><initialMarking><text>1</text></initialMarking>
        <toolspecific tool="petriplc" version="1"><output>Ready</output></toolspecific></place>
      <place id="busy"><name><text>busy</text></name>
        <toolspecific tool="petriplc" version="1"><output>Busy</output></toolspecific></place>
      <transition id="go"><name><text>go</text></name>
        <toolspecific tool="petriplc" version="1"><guard>Start AND NOT Stop</guard></toolspecific></transition>
      <transition id="stop"><name><text>stop</text></name>
        <toolspecific tool="petriplc" version="1"><guard>Stop</guard></toolspecific></transition>
      <arc id="a1" source="idle" target="go"/>
      <arc id="a2" source="go" target="busy"/>
      <arc id="a3" source="busy" target="stop"/>
      <arc id="a4" source="stop" target="idle"/>
    </page>
  </net>
</pnml>
"#;

/// Two transitions passing a token back and forth forever: unstable under until-stable.
const PINGPONG: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">
  <net id="pp" type="http://www.pnml.org/version-2009/grammar/ptnet">
    <page id="page0">
      <place id="a"><name><text>a</text></name><initialMarking><text>1</text></initialMarking></place>
      <place id="b"><name><text>b</text></name></place>
      <transition id="ping"><name><text>ping</text></name></transition>
      <transition id="pong"><name><text>pong</text></name></transition>
      <arc id="x1" source="a" target="ping"/><arc id="x2" source="ping" target="b"/>
      <arc id="x3" source="b" target="pong"/><arc id="x4" source="pong" target="a"/>
    </page>
  </net>
</pnml>
"#;

struct Fixture {
    dir: TempDir,
}

impl Fixture {
    fn new(files: &[(&str, &str)]) -> Self {
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in files {
            fs::write(dir.path().join(name), text).unwrap();
        }
        Fixture { dir }
    }

    fn command(&self, args: &[&str]) -> Command {
        let mut cmd = Command::cargo_bin("petriplc").unwrap();
        cmd.current_dir(self.dir.path()).args(args);
        cmd
    }

    fn petriplc(&self, args: &[&str]) -> assert_cmd::assert::Assert {
        self.command(args).assert()
    }
}

/// Runs `petriplc` in a folder holding `files` and checks exit code and output fragments.
fn check(files: &[(&str, &str)], args: &[&str], code: i32, stdout: &str, stderr: &str) {
    Fixture::new(files)
        .petriplc(args)
        .code(code)
        .stdout(predicate::str::contains(stdout))
        .stderr(predicate::str::contains(stderr));
}

#[test]
fn trace_goes_to_stdout_without_out_or_plot() {
    let timeline = "time,Start,Stop\n0,0,0\n0.05,1,0\n0.1,0,1\n";
    check(
        &[("toggle.pnml", TOGGLE), ("in.csv", timeline)],
        &["sim", "toggle.pnml", "--inputs", "in.csv", "--until", "0.2"],
        0,
        "time,in:Start,in:Stop,Ready,Busy,m:idle,m:busy,fired\n\
         0,0,0,1,0,1,0,\n\
         0.05,1,0,0,1,0,1,go\n\
         0.1,0,1,1,0,1,0,stop\n",
        "",
    );
}

#[test]
fn writes_trace_and_plot_files_creating_folders() {
    let fx = Fixture::new(&[
        ("toggle.pnml", TOGGLE),
        ("in.csv", "time,Start,Stop\n0,1,0\n"),
    ]);
    fx.petriplc(&[
        "sim",
        "toggle.pnml",
        "--inputs",
        "in.csv",
        "--out",
        "out/t.csv",
        "--plot",
        "out/t.svg",
    ])
    .success()
    .stderr(predicate::str::contains("out/t.csv"));
    let csv = fs::read_to_string(fx.dir.path().join("out/t.csv")).unwrap();
    assert!(
        csv.starts_with("time,in:Start,in:Stop,Ready,Busy,m:idle,m:busy,fired\n0,1,0,0,1,0,1,go\n"),
        "{csv}"
    );
    let svg = fs::read_to_string(fx.dir.path().join("out/t.svg")).unwrap();
    assert!(
        svg.contains("<svg") && svg.contains("Ready"),
        "plot lacks the output lane"
    );
}

#[test]
fn the_plot_shows_the_signals_and_window_asked_for() {
    let fx = Fixture::new(&[
        ("toggle.pnml", TOGGLE),
        ("in.csv", "time,Stop,Start\n0,0,1\n0.5,1,0\n"),
    ]);
    let svg_of = |args: &[&str]| {
        let mut all = vec![
            "sim",
            "toggle.pnml",
            "--inputs",
            "in.csv",
            "--plot",
            "p.svg",
        ];
        all.extend_from_slice(args);
        fx.petriplc(&all).success();
        fs::read_to_string(fx.dir.path().join("p.svg")).unwrap()
    };
    // The lanes in the order given, and nothing else; the title names net and period.
    let svg = svg_of(&[
        "--signals",
        "Busy,m:idle,Start",
        "--from",
        "0.2s",
        "--to",
        "0.8",
    ]);
    let at = |label: &str| svg.find(&format!(">\n{label}\n<")).unwrap_or(usize::MAX);
    assert!(
        at("Busy") < at("m:idle") && at("m:idle") < at("Start"),
        "{svg}"
    );
    assert_eq!(at("Ready"), usize::MAX, "Ready was not asked for");
    assert_eq!(at("Stop"), usize::MAX, "Stop was not asked for");
    assert!(
        svg.contains("toggle · scan every 10 ms · 0.2 to 0.8 s"),
        "{svg}"
    );
    // By default inputs follow the timeline's columns: Stop before Start.
    let svg = svg_of(&[]);
    let at = |label: &str| svg.find(&format!(">\n{label}\n<")).unwrap_or(usize::MAX);
    assert!(at("Stop") < at("Start"), "{svg}");
}

#[test]
fn bad_plot_options_are_bad_input() {
    let files = [("toggle.pnml", TOGGLE), ("in.csv", "time,Start\n0,1\n")];
    let base = [
        "sim",
        "toggle.pnml",
        "--inputs",
        "in.csv",
        "--plot",
        "p.svg",
    ];
    fn with<'a>(base: &[&'a str], extra: &[&'a str]) -> Vec<&'a str> {
        [base, extra].concat()
    }
    check(
        &files,
        &with(&base, &["--signals", "Ready,Lamp"]),
        2,
        "",
        "`Lamp` is neither a signal nor a place of this run",
    );
    check(
        &files,
        &with(&base, &["--from", "2s", "--to", "1s"]),
        2,
        "",
        "--from 2 s is not before --to 1 s",
    );
    check(
        &files,
        &with(&base, &["--from", "5s"]),
        2,
        "",
        "--from 5 s is not before the end of the run (1 s)",
    );
    check(
        &files,
        &["sim", "toggle.pnml", "--signals", "Ready"],
        2,
        "",
        "--plot",
    );
}

#[test]
fn missing_net_file_is_bad_input() {
    check(&[], &["sim", "nope.pnml"], 2, "", "nope.pnml");
}

#[test]
fn malformed_net_names_file_and_line() {
    let broken = "<pnml xmlns=\"http://www.pnml.org/version-2009/grammar/pnml\">\n<net id=\"n\" type=\"http://www.pnml.org/version-2009/grammar/ptnet\"><page id=\"p\">\n<arc id=\"a\" source=\"x\" target=\"y\"/>\n</page></net></pnml>\n";
    check(
        &[("bad.pnml", broken)],
        &["sim", "bad.pnml"],
        2,
        "",
        "bad.pnml:3:",
    );
}

#[test]
fn bad_options_are_bad_input() {
    let files = [("toggle.pnml", TOGGLE)];
    check(
        &files,
        &["sim", "toggle.pnml", "--period", "0"],
        2,
        "",
        "longer than 0",
    );
    check(
        &files,
        &["sim", "toggle.pnml", "--period", "fast"],
        2,
        "",
        "is not a duration",
    );
    check(
        &files,
        &["sim", "toggle.pnml", "--step", "greedy"],
        2,
        "",
        "maximal-step",
    );
    check(
        &files,
        &["sim", "toggle.pnml", "--plant", "boiler"],
        2,
        "",
        "unknown plant `boiler`",
    );
}

/// `--plant-set` reaches every built-in plant with settings, through the registry the `plant`
/// module uses too: the thermal plant's constants, not only the turntable's.
#[test]
fn thermal_plant_takes_its_settings_as_in_a_plant_module() {
    let files = [("toggle.pnml", TOGGLE)];
    let args = |set: &'static str| {
        [
            "sim",
            "toggle.pnml",
            "--plant",
            "thermal",
            "--plant-set",
            set,
            "--until",
            "0",
        ]
    };
    check(
        &files,
        &args("initial=55.5"),
        0,
        "",
        "plant at the end: thermal 55.50 °C",
    );
    check(
        &files,
        &args("dead_time=-1"),
        2,
        "",
        "`dead_time = -1` must be from 0 to 3600 s",
    );
}

#[test]
fn timeline_errors_name_the_line() {
    let files = [
        ("toggle.pnml", TOGGLE),
        ("in.csv", "time,Start\n0,1\nsoon,0\n"),
    ];
    check(
        &files,
        &["sim", "toggle.pnml", "--inputs", "in.csv"],
        2,
        "",
        "in.csv:3",
    );
}

#[test]
fn timeline_column_must_be_an_input() {
    let files = [("toggle.pnml", TOGGLE), ("in.csv", "time,Strat\n0,1\n")];
    check(
        &files,
        &["sim", "toggle.pnml", "--inputs", "in.csv"],
        2,
        "",
        "Strat",
    );
}

#[test]
fn unstable_net_fails_with_the_cycling_transitions() {
    let files = [("pp.pnml", PINGPONG)];
    check(
        &files,
        &["sim", "pp.pnml", "--evolve", "until-stable", "--until", "0"],
        1,
        "",
        "ping, pong",
    );
    // One pass per scan is fine: the token just alternates.
    check(
        &files,
        &["sim", "pp.pnml", "--until", "0.02"],
        0,
        "0,0,1,ping\n0.01,1,0,pong\n",
        "",
    );
}

/// A chain p1 → t1 → p2 → t2 → p3 whose net asks for the sequential rule.
const CHAIN: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">
  <net id="chain" type="http://www.pnml.org/version-2009/grammar/ptnet">
    <toolspecific tool="petriplc" version="1"><step>sequential</step></toolspecific>
    <page id="page0">
      <place id="p1"><name><text>p1</text></name><initialMarking><text>1</text></initialMarking></place>
      <place id="p2"><name><text>p2</text></name></place>
      <place id="p3"><name><text>p3</text></name></place>
      <transition id="t1"><name><text>t1</text></name></transition>
      <transition id="t2"><name><text>t2</text></name></transition>
      <arc id="a1" source="p1" target="t1"/><arc id="a2" source="t1" target="p2"/>
      <arc id="a3" source="p2" target="t2"/><arc id="a4" source="t2" target="p3"/>
    </page>
  </net>
</pnml>
"#;

#[test]
fn the_net_chooses_its_step_rule_and_the_command_line_overrides_it() {
    let files = [("chain.pnml", CHAIN)];
    // The net's own rule, sequential: t2 sees t1's token in the same pass.
    check(
        &files,
        &["sim", "chain.pnml", "--until", "0.02"],
        0,
        "time,m:p1,m:p2,m:p3,fired\n0,0,0,1,t1 t2\n",
        "",
    );
    // Overridden: maximal-step needs a pass per transition.
    check(
        &files,
        &[
            "sim",
            "chain.pnml",
            "--until",
            "0.02",
            "--step",
            "maximal-step",
        ],
        0,
        "time,m:p1,m:p2,m:p3,fired\n0,0,1,0,t1\n0.01,0,0,1,t2\n",
        "",
    );
    // until-stable runs both passes within the first scan.
    check(
        &files,
        &[
            "sim",
            "chain.pnml",
            "--until",
            "0.02",
            "--step",
            "maximal-step",
            "--evolve",
            "until-stable",
        ],
        0,
        "time,m:p1,m:p2,m:p3,fired\n0,0,0,1,t1 t2\n",
        "",
    );
}

#[test]
fn traces_are_byte_identical_across_runs() {
    let fx = Fixture::new(&[
        ("toggle.pnml", TOGGLE),
        ("in.csv", "time,Start,Stop\n0,1,0\n0.03,0,1\n0.05,1,0\n"),
    ]);
    let run = || {
        fx.petriplc(&["sim", "toggle.pnml", "--inputs", "in.csv"])
            .success()
            .get_output()
            .stdout
            .clone()
    };
    assert_eq!(run(), run());
}

#[test]
fn step_through_scans_on_enter_and_toggles_inputs() {
    Fixture::new(&[("toggle.pnml", TOGGLE)])
        .command(&["sim", "toggle.pnml", "--step-through"])
        .write_stdin("\nStart\n\nq\n")
        .assert()
        .success()
        .stdout(predicate::str::contains("enabled: -"))
        .stdout(predicate::str::contains(
            "go: guard `Start AND NOT Stop` is false",
        ))
        .stdout(predicate::str::contains("Start := 1"))
        .stdout(predicate::str::contains("fired last scan: go"));
}

/// One rule for every file a command writes: the folders are created and a line says what
/// was written.
#[test]
fn every_output_option_creates_its_folder_and_says_what_it_wrote() {
    let fx = Fixture::new(&[
        ("toggle.pnml", TOGGLE),
        ("in.csv", "time,Start,Stop\n0,1,0\n"),
    ]);
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "sim",
                "toggle.pnml",
                "--inputs",
                "in.csv",
                "--out",
                "a/b/t.csv",
            ],
            "wrote a/b/t.csv (trace, 1 row)\n",
        ),
        (
            &[
                "sim",
                "toggle.pnml",
                "--inputs",
                "in.csv",
                "--plot",
                "c/t.svg",
            ],
            "wrote c/t.svg (plot)\n",
        ),
        (
            &[
                "compile",
                "toggle.pnml",
                "--lang",
                "st",
                "--out",
                "d/e/t.xml",
            ],
            "wrote d/e/t.xml (ST in a PLCopen XML project, 1 POU, ",
        ),
        (
            &[
                "compile",
                "toggle.pnml",
                "--lang",
                "il",
                "--plain",
                "--out",
                "f/t.il",
            ],
            "wrote f/t.il (bare IL, ",
        ),
        (
            &["compile", "toggle.pnml", "--lang", "c", "--out", "g/t.c"],
            "wrote g/t.c (C99, ",
        ),
        (
            &["analyze", "toggle.pnml", "--dot", "h/rg.dot"],
            "wrote h/rg.dot (the reachability graph in Graphviz DOT, 2 states)\n",
        ),
        (
            &["analyze", "toggle.pnml", "--svg", "i/rg.svg"],
            "wrote i/rg.svg (the reachability graph as SVG, 2 states)\n",
        ),
    ];
    for (args, says) in cases {
        fx.petriplc(args)
            .success()
            .stderr(predicate::str::contains(*says));
        let written = fx.dir.path().join(args.last().unwrap());
        assert!(
            fs::metadata(&written).is_ok_and(|m| m.len() > 0),
            "{args:?}"
        );
    }
}

/// A SIPN net read with plain names has no inputs: the timeline or plant that names them
/// gets the hint instead of a bare "not an input".
#[test]
fn a_sipn_net_without_names_sipn_gets_the_hint() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
    let mut sim = Command::cargo_bin("petriplc").unwrap();
    sim.current_dir(root).args([
        "sim",
        "examples/mixer/mixer.pnml",
        "--inputs",
        "examples/mixer/timeline.csv",
    ]);
    sim.assert().code(2).stderr(predicate::str::contains(
        "column `B1` is not an input of the controller; it has no inputs at all\n\
         did you mean --names sipn? Read with plain names, examples/mixer/mixer.pnml has no \
         inputs; read with --names sipn",
    ));
    let mut analyze = Command::cargo_bin("petriplc").unwrap();
    analyze.current_dir(root).args([
        "analyze",
        "examples/mixer/mixer.pnml",
        "--plant",
        "examples/mixer/tank.pnml",
    ]);
    analyze.assert().success().stderr(predicate::str::contains(
        "warning: did you mean --names sipn?",
    ));
    // A net without signals that no timeline or plant names: no hint.
    check(
        &[("toggle.pnml", PINGPONG)],
        &["analyze", "toggle.pnml"],
        0,
        "",
        "",
    );
}

/// Issue 27: `petriplc status ID` was refused ("unexpected argument"): status and stop take
/// the id as users type it, or as `--plc-id`, but not both.
#[test]
fn status_and_stop_take_the_id_as_an_argument() {
    let id = format!("no-such-plc-{}", std::process::id());
    for command in ["status", "stop"] {
        for args in [
            vec![command, id.as_str()],
            vec![command, "--plc-id", id.as_str()],
        ] {
            Command::cargo_bin("petriplc")
                .unwrap()
                .args(&args)
                .assert()
                .code(4)
                .stderr(predicate::str::contains(format!("no PLC with id `{id}`")));
        }
        Command::cargo_bin("petriplc")
            .unwrap()
            .args([command, "a", "--plc-id", "b"])
            .assert()
            .code(2)
            .stderr(predicate::str::contains("cannot be used with"));
    }
}

/// Issue 27: a configuration's problems came in two passes (C022 first, the modules' own
/// errors only once that was fixed). One attempt now tells them all.
#[test]
fn every_problem_of_a_configuration_is_reported_at_once() {
    let dir = TempDir::new().unwrap();
    fs::write(
        dir.path().join("plc.conf"),
        "[PLC]\nmodule logic iec\nmodule hmi hmi\nmodule io ./no-such-program\n\
         point V1 \"valve\" controller\n[logic]\nprogram = nope.st\n\
         [hmi]\nlisten = not-an-address\n",
    )
    .unwrap();
    Command::cargo_bin("petriplc")
        .unwrap()
        .current_dir(dir.path())
        .args(["run", "plc.conf", "--for", "1s"])
        .args(["--set", "nosuch:x=1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "error[C022]: the owner of point V1",
        ))
        .stderr(predicate::str::contains(
            "error: module hmi: plc.conf:9: `listen = not-an-address` is not an address",
        ))
        .stderr(predicate::str::contains(
            "error: module io: `./no-such-program`",
        ))
        .stderr(predicate::str::contains(
            "--set: error[C033]: `x` is set for `nosuch`, but no module nosuch is declared",
        ))
        .stderr(predicate::str::contains(
            "plc.conf is not a valid configuration (4 problems); nothing was started",
        ));
}
