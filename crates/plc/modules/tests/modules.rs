//! Each built-in module driven in-process: settings, behaviour scan by scan, status, and the
//! errors a wrong configuration gets.

mod harness;

use std::path::Path;

use harness::{examples, ms, start, start_err};
use petriplc_runtime::module::Control;

/// A net with integer signals: `inc` adds a token to `cnt` (output `Count`) every scan
/// while `Go`; `up` marks `hi` (output `High`) once `Level >= 3`.
const COUNT_NET: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml">
  <net id="count" type="http://www.pnml.org/version-2009/grammar/ptnet">
    <name><text>count</text></name>
    <toolspecific tool="petriplc" version="1">
      <signal name="Go" direction="input" type="bool"/>
      <signal name="Level" direction="input" type="int"/>
      <signal name="Count" direction="output" type="int"/>
      <signal name="High" direction="output" type="bool"/>
    </toolspecific>
    <page id="pg">
      <place id="src"><initialMarking><text>1</text></initialMarking></place>
      <place id="cnt"><toolspecific tool="petriplc" version="1"><output>Count</output></toolspecific></place>
      <place id="lo"><initialMarking><text>1</text></initialMarking></place>
      <place id="hi"><toolspecific tool="petriplc" version="1"><output>High</output></toolspecific></place>
      <transition id="inc"><toolspecific tool="petriplc" version="1"><guard>Go</guard></toolspecific></transition>
      <transition id="up"><toolspecific tool="petriplc" version="1"><guard>Level &gt;= 3</guard></toolspecific></transition>
      <arc id="a1" source="src" target="inc"/>
      <arc id="a2" source="inc" target="src"/>
      <arc id="a3" source="inc" target="cnt"/>
      <arc id="a4" source="lo" target="up"/>
      <arc id="a5" source="up" target="hi"/>
    </page>
  </net>
</pnml>
"#;

const DRIVE_CSV: &str = "time,Go,Level\n0,0,-1\n0.05,1,\n0.07,,3\n";

fn count_dir() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("count.pnml"), COUNT_NET).unwrap();
    std::fs::write(dir.path().join("drive.csv"), DRIVE_CSV).unwrap();
    dir
}

fn count_config(count_point: &str, ctl: &str) -> String {
    format!(
        "[PLC]\nmodule drive timeline\nmodule ctl petrinet\n\
         point Go \"\" drive\npoint Level \"\" drive i8\n{count_point}\npoint High \"\" ctl\n\
         [drive]\nfile = drive.csv\n[ctl]\nnet = count.pnml\n{ctl}\n"
    )
}

#[test]
fn petrinet_reads_and_writes_integer_signals() {
    let dir = count_dir();
    let mut plc = start(&count_config("point Count \"\" ctl u8", ""), dir.path()).unwrap();
    let mut seen = Vec::new();
    for k in 0..10 {
        plc.tick(ms(10 * k)).unwrap();
        seen.push(format!(
            "{}:{}{}{}",
            k,
            plc.value("Level"),
            plc.value("Count"),
            plc.value("High")
        ));
    }
    // Level is a signed point: -1 reaches the net as -1, not as 255.
    assert_eq!(
        seen.join(" "),
        "0:-100 1:-100 2:-100 3:-100 4:-100 5:-110 6:-120 7:331 8:341 9:351"
    );
    assert_eq!(
        plc.status("ctl"),
        "marking src=1 cnt=5 hi=1; fired inc:5 up:1"
    );
}

#[test]
fn petrinet_output_too_large_for_its_point_is_an_error() {
    let dir = count_dir();
    let mut plc = start(&count_config("point Count \"\" ctl u2", ""), dir.path()).unwrap();
    let mut k = 0;
    let e = loop {
        match plc.tick(ms(10 * k)) {
            Ok(_) => k += 1,
            Err(e) => break e.to_string(),
        }
    };
    assert_eq!(
        e,
        "module ctl: at t=0.08s: output signal `Count` = 4: point `Count` (unsigned, 2 bits) \
         cannot hold 4"
    );
}

#[test]
fn petrinet_scan_error_is_a_module_error() {
    let dir = count_dir();
    let mut plc = start(
        &count_config(
            "point Count \"\" ctl u32",
            "evolve = until-stable\nmax_passes = 10",
        ),
        dir.path(),
    )
    .unwrap();
    for k in 0..5 {
        plc.tick(ms(10 * k)).unwrap();
    }
    let e = plc.tick(ms(50)).unwrap_err().to_string();
    assert!(
        e.starts_with(
            "module ctl: net `count.pnml`: the net is unstable at t=0.05s: still firing after \
             10 passes"
        ),
        "{e}"
    );
}

#[test]
fn petrinet_map_rows_rename_bindings() {
    let dir = count_dir();
    let text = "[PLC]\nmodule drive timeline\nmodule ctl petrinet\n\
         point Go \"\" drive\npoint Level \"\" drive i8\npoint TOTAL \"\" ctl u8\n\
         point ALARM \"\" ctl\n\
         [drive]\nfile = drive.csv\n[ctl]\nnet = count.pnml\nmap Count TOTAL\nmap High ALARM\n";
    let mut plc = start(text, dir.path()).unwrap();
    for k in 0..10 {
        plc.tick(ms(10 * k)).unwrap();
    }
    assert_eq!((plc.value("TOTAL"), plc.value("ALARM")), (5, 1));

    let bad = text.replace("map High ALARM", "map Hihg ALARM");
    assert_eq!(
        start_err(&bad, dir.path()),
        "module ctl: test.conf:13: `map Hihg ALARM`: net `count.pnml` has no signal `Hihg` (its \
         signals: Go, Level, Count, High)\n\
         module ctl: output signal `High` of net `count.pnml` needs a point: no point named \
         `High`; declare `point High \"...\" ctl` in [PLC], or bind the signal to another point \
         with a row `map High POINT` in [ctl]"
    );
    let bad = text.replace("map High ALARM", "watch High ALARM");
    assert_eq!(
        start_err(&bad, dir.path()),
        "module ctl: test.conf:13: a petrinet module reads only map rows, not `watch`"
    );
}

const MIXER_POINTS: &str = "point B1 \"\" buttons\npoint N1 \"\" buttons\npoint N2 \"\" buttons\n\
     point N3 \"\" buttons\npoint L1 \"\" ctl\npoint A1 \"\" ctl\npoint V1 \"\" ctl\n\
     point L2 \"\" ctl\npoint V2 \"\" ctl\npoint M1 \"\" ctl\npoint V3 \"\" ctl\npoint L3 \"\" ctl\n";

fn mixer(points: &str, ctl: &str) -> String {
    format!(
        "[PLC]\nmodule buttons timeline\nmodule ctl petrinet\n{points}\n\
         [buttons]\nfile = timeline.csv\n[ctl]\n{ctl}\n"
    )
}

#[test]
fn petrinet_runs_the_hand_driven_mixer_cycle() {
    let dir = examples("mixer");
    let mut plc = start(&mixer(MIXER_POINTS, "net = mixer.pnml\nnames = sipn"), &dir).unwrap();
    let mut marks = Vec::new();
    for k in 0..=1000 {
        plc.tick(ms(10 * k)).unwrap();
        let m = plc.status("ctl");
        if marks.last() != Some(&m) {
            marks.push(m);
        }
    }
    assert_eq!(
        marks,
        [
            "marking L1=1; fired B1:0 N2:0 N3:0 N1:0",
            "marking A1=1 V1=1 L2=1; fired B1:1 N2:0 N3:0 N1:0",
            "marking A1=1 L2=1 V2=1 M1=1; fired B1:1 N2:1 N3:0 N1:0",
            "marking V3=1 L3=1; fired B1:1 N2:1 N3:1 N1:0",
            "marking L1=1; fired B1:1 N2:1 N3:1 N1:1"
        ]
    );
}

#[test]
fn petrinet_errors_name_the_signal_the_point_and_the_fix() {
    let dir = examples("mixer");
    let sipn = "net = mixer.pnml\nnames = sipn";
    // Missing setting: from the factory, before anything is read.
    assert_eq!(
        start_err(&mixer(MIXER_POINTS, ""), &dir),
        "module ctl: no `net` setting; add `net = ...` to section [ctl]"
    );
    // An output point owned by another module.
    let stolen = MIXER_POINTS.replace("point V1 \"\" ctl", "point V1 \"\" buttons");
    assert_eq!(
        start_err(&mixer(&stolen, sipn), &dir),
        "module ctl: output signal `V1` of net `mixer.pnml` drives point `V1`, but `V1` is owned \
         by module `buttons`; only its owner may write a point: declare `point V1 \"...\" ctl` \
         (and let `buttons` read it), or bind the signal to a point of this module with \
         `map V1 POINT` in [ctl]"
    );
    // An input signal without a point.
    let missing = MIXER_POINTS.replace("point N3 \"\" buttons\n", "point N4 \"\" buttons\n");
    let e = start_err(
        &mixer(&missing, sipn).replace("file = timeline.csv", "file = press-b1.csv"),
        &dir,
    );
    assert_eq!(
        e,
        "module ctl: input signal `N3` of net `mixer.pnml` needs a point: no point named `N3`; \
         did you mean `L3`, `N1`, `N2`, `N4`, `V3`?; declare `point N3 \"...\" OWNER` in [PLC] with the \
         module that drives it as OWNER, or bind the signal to another point with a row \
         `map N3 POINT` in [ctl]"
    );
    // A file that does not exist.
    let e = start_err(&mixer(MIXER_POINTS, "net = nope.pnml"), &dir);
    assert!(
        e.starts_with("module ctl: net `nope.pnml`: could not read `")
            && e.contains("nope.pnml`: no such file"),
        "{e}"
    );
    // A net read with the wrong naming has no signals the points could match, but its
    // places are not the issue: a bad setting value is caught first.
    assert_eq!(
        start_err(&mixer(MIXER_POINTS, "net = mixer.pnml\nnames = SIPN"), &dir),
        "module ctl: `names = SIPN` is not valid; use `plain` or `sipn`"
    );
    assert_eq!(
        start_err(&mixer(MIXER_POINTS, "net = mixer.pnml\nname = sipn"), &dir),
        "module ctl: unknown setting `name` (test.conf:21) in section [ctl]; a petrinet module \
         knows net, names, step, evolve, max_passes"
    );
    let floats = MIXER_POINTS.replace("point B1 \"\" buttons", "point B1 \"\" buttons f");
    assert_eq!(
        start_err(&mixer(&floats, sipn), &dir),
        "module ctl: input signal `B1` of net `mixer.pnml` is bound to point `B1`, a float \
         point; bool signals carry whole numbers: declare `B1` as `u` or `i`"
    );
}

#[test]
fn plant_steps_a_rust_plant_and_reports_its_summary() {
    let text = "[PLC]\nmodule valves timeline\nmodule tank plant\n\
         point V1 \"\" valves\npoint V2 \"\" valves\npoint V3 \"\" valves\n\
         point N1 \"\" tank\npoint N2 \"\" tank\npoint N3 \"\" tank\n\
         [valves]\nfile = valves.csv\n[tank]\nplant = tank\n";
    let dir = tempfile::tempdir().unwrap();
    // Fill with both inlets (40 %/s), then drain (25 %/s). A step applies the valves it
    // reads to the 10 ms since the previous step, so the drain starts at 2.49 s, at 99.6 %.
    std::fs::write(
        dir.path().join("valves.csv"),
        "time,V1,V2,V3\n0,1,1,0\n2.5,0,0,1\n",
    )
    .unwrap();
    let mut plc = start(text, dir.path()).unwrap();
    let mut changes = Vec::new();
    let mut last = String::new();
    for k in 0..=700 {
        plc.tick(ms(10 * k)).unwrap();
        let n = format!("{}{}{}", plc.value("N1"), plc.value("N2"), plc.value("N3"));
        if n != last {
            changes.push(format!("{}:{n}", k * 10));
            last = n;
        }
    }
    assert_eq!(
        changes,
        ["0:100", "130:000", "1250:010", "2250:011", "2880:010", "4480:000", "6280:100"]
    );
    assert_eq!(
        plc.status("tank"),
        "tank level 0 %, 1 fill/drain cycle completed"
    );
}

/// The turntable with its settings from the section: turning left at K_alpha = 45 °/s. The
/// timeline switches ML off at 1 s, before the plant's step then, so ML drove it for the 99
/// steps from 0.01 s to 0.99 s: 44.55°, `alpha` in hundredths of a degree.
#[test]
fn the_turntable_takes_its_settings_from_the_section() {
    let points: String = ["MR", "ML", "BF", "BB", "arrive_south", "arrive_east"]
        .iter()
        .map(|p| format!("point {p} \"\" motor\n"))
        .chain(petriplc_sim::Turntable::OUTPUTS.iter().map(|p| {
            let ty = if *p == "alpha" || *p == "x" {
                " i32"
            } else {
                " u8"
            };
            format!("point {p} \"\" table{ty}\n")
        }))
        .collect();
    let config = |settings: &str| {
        format!(
            "[PLC]\nmodule motor timeline\nmodule table plant\n{points}\
             [motor]\nfile = motor.csv\n[table]\nplant = turntable\n{settings}\n"
        )
    };
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("motor.csv"),
        "time,MR,ML,BF,BB,arrive_south,arrive_east\n0,0,1,0,0,0,0\n1,0,0,0,0,0,0\n",
    )
    .unwrap();
    let mut plc = start(&config("K_alpha = 45"), dir.path()).unwrap();
    for k in 0..=150 {
        plc.tick(ms(10 * k)).unwrap();
    }
    assert_eq!(
        (plc.value("alpha"), plc.value("SR"), plc.value("E_sector")),
        (4455, 0, 0)
    );
    assert_eq!(
        plc.status("table"),
        "turntable at 44.55°, 0 delivered south, 0 east, 0 rejected"
    );
    assert_eq!(
        start_err(&config("K_alpha = fast"), dir.path()),
        "module table: turntable setting `K_alpha = fast`: give a number greater than 0 in °/s, \
         with at most three decimals (e.g. `K_alpha = 12.5`)"
    );
    let e = start_err(&config("K_alpha = 45\nspeed = 2\nnames = sipn"), dir.path());
    assert_eq!(
        e,
        "module table: `names` applies to a plant net (`net = FILE.pnml`), not to a built-in plant"
    );
}

#[test]
fn plant_settings_and_wiring_errors() {
    let dir = examples("mixer");
    let text = |tank: &str, n1_owner: &str| {
        format!(
            "[PLC]\nmodule ctl petrinet\nmodule tank plant\n{}\n[ctl]\nnet = mixer.pnml\n\
             names = sipn\n[tank]\n{tank}\n",
            MIXER_POINTS
                .replace("buttons", "tank")
                .replace("point N1 \"\" tank", &format!("point N1 \"\" {n1_owner}"))
        )
    };
    assert!(start(&text("plant = tank", "tank"), &dir).is_ok());
    assert!(start(&text("net = tank.pnml", "tank"), &dir).is_ok());
    // The tank has no settings of its own; the turntable's and the thermal plant's are named
    // as theirs (petriplc-sim's registry says which plant takes which).
    assert_eq!(
        start_err(&text("plant = tank\nK_alpha = 45", "tank"), &dir),
        "module tank: `K_alpha` is a setting of `plant = turntable`, not of this plant"
    );
    assert_eq!(
        start_err(&text("net = tank.pnml\nL = 400", "tank"), &dir),
        "module tank: `L` is a setting of `plant = turntable`, not of this plant"
    );
    let e = start_err(&text("plant = turntable\nL = -4", "tank"), &dir);
    assert!(
        e.starts_with("module tank: turntable setting `L = -4`: give a number greater than 0"),
        "{e}"
    );
    assert_eq!(
        start_err(&text("plant = tanks", "tank"), &dir),
        "module tank: `plant = tanks` is not a built-in plant; use one of tank, tape, keyboard, \
         turntable, thermal, or `net = FILE.pnml` for a plant net"
    );
    assert_eq!(
        start_err(&text("plant = tank\nnet = tank.pnml", "tank"), &dir),
        "module tank: both `plant` and `net` are set; a plant module runs one plant: keep one"
    );
    assert_eq!(
        start_err(&text("", "tank"), &dir),
        "module tank: no plant given; add `plant = NAME` (tank, tape, keyboard, turntable, \
         thermal) or `net = FILE.pnml` to section [tank]"
    );
    assert_eq!(
        start_err(&text("plant = tank\nnames = sipn", "tank"), &dir),
        "module tank: `names` applies to a plant net (`net = FILE.pnml`), not to a built-in plant"
    );
    assert_eq!(
        start_err(&text("plant = tank", "ctl"), &dir),
        "module tank: output signal `N1` of plant `tank` drives point `N1`, but `N1` is owned by \
         module `ctl`; only its owner may write a point: declare `point N1 \"...\" tank` (and \
         let `ctl` read it), or bind the signal to a point of this module with `map N1 POINT` \
         in [tank]"
    );
    let e = start_err(&text("net = tank.pnml", "ctl"), &dir);
    assert!(
        e.starts_with("module tank: output signal `N1` of plant net `tank.pnml` drives"),
        "{e}"
    );
    let e = start_err(&text("net = missing/tank.pnml", "tank"), &dir);
    assert!(
        e.starts_with("module tank: net `missing/tank.pnml`: could not read"),
        "{e}"
    );
    // The keyboard reads key points nobody declared.
    let e = start_err(&text("plant = keyboard", "tank"), &dir);
    assert!(
        e.starts_with("module tank: input signal `col1` of plant `keyboard` needs a point"),
        "{e}"
    );
    assert_eq!(e.lines().count(), 19, "{e}");
}

#[test]
fn timeline_drives_its_points_and_repeats() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.csv"),
        "time,A,SP\n0,1,\n0.5,0,\n1,,300\n1.5,1,-2\n",
    )
    .unwrap();
    let text = |repeat: &str| {
        format!(
            "[PLC]\nmodule t timeline\npoint A \"\" t\npoint SP \"setpoint\" t i16 init 7\n\
             [t]\nfile = t.csv\n{repeat}\n"
        )
    };
    let run = |repeat: &str| {
        let mut plc = start(&text(repeat), dir.path()).unwrap();
        let mut out = Vec::new();
        for t in [0, 400, 500, 1000, 1500, 2400, 2500, 3000, 3500, 4500] {
            plc.tick(ms(t)).unwrap();
            out.push(format!("{}/{}", plc.value("A"), plc.value("SP")));
        }
        (out.join(" "), plc.status("t"))
    };
    // Before SP's first row it keeps its init value.
    assert_eq!(
        run(""),
        (
            "1/7 1/7 0/7 0/300 1/-2 1/-2 1/-2 1/-2 1/-2 1/-2".to_string(),
            "t.csv: ended at 1.5 s; its last values hold".to_string()
        )
    );
    // The timeline starts again 1 s after its last row: at 2.5 s, 5 s, ...
    assert_eq!(
        run("repeat = yes"),
        (
            "1/7 1/7 0/7 0/300 1/-2 1/-2 1/7 0/7 0/300 1/-2".to_string(),
            "t.csv: 2 s into a 2.5 s cycle".to_string()
        )
    );
    assert_eq!(
        start_err(&text("repeat = sometimes"), dir.path()),
        "module t: `repeat = sometimes`: write `repeat = yes` or `repeat = no`"
    );
}

#[test]
fn timeline_errors() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.csv"), "time,A,B\n0,1,2\n").unwrap();
    let text = |points: &str, settings: &str| {
        format!("[PLC]\nmodule t timeline\nmodule other shutdown\n{points}\n[t]\n{settings}\n[other]\npoint = A\n")
    };
    let ok = "point A \"\" t\npoint B \"\" t u2";
    assert!(start(&text(ok, "file = t.csv"), dir.path()).is_ok());
    assert_eq!(
        start_err(&text(ok, ""), dir.path()),
        "module t: no `file` setting; add `file = ...` to section [t]"
    );
    let e = start_err(&text(ok, "file = none.csv"), dir.path());
    assert!(
        e.starts_with("module t: cannot read ") && e.ends_with("none.csv: no such file"),
        "{e}"
    );
    let e = start_err(&text(ok, "file = /dev/zero"), dir.path());
    assert_eq!(
        e,
        "module t: cannot read /dev/zero: it is a device, not a regular file; name a timeline"
    );
    assert_eq!(
        start_err(
            &text("point A \"\" t\npoint B \"\" other u2", "file = t.csv"),
            dir.path()
        ),
        "module t: timeline `t.csv` column `B` drives point `B`, which is owned by module \
         `other`; a timeline drives only its own points: declare `point B \"...\" t`, or drop \
         the column"
    );
    assert_eq!(
        start_err(&text("point A \"\" t\npoint C \"\" t", "file = t.csv"), dir.path()),
        "module t: timeline `t.csv` column `B`: no point named `B`; did you mean `A`, `C`?; declare `point B \"...\" t` \
         in [PLC], or drop the column"
    );
    assert_eq!(
        start_err(
            &text("point A \"\" t\npoint B \"\" t", "file = t.csv"),
            dir.path()
        ),
        "module t: timeline `t.csv` sets `B` to 2 at t=0s, which point `B` (unsigned, 1 bits) \
         cannot hold"
    );
    // Issue 27: NaN and infinities are refused where they are written, and so is a value an
    // f32 point would hold as an infinity.
    std::fs::write(dir.path().join("nan.csv"), "time,F\n0,1.5\n1,NaN\n").unwrap();
    let float = "point A \"\" t\npoint F \"\" t f32";
    let e = start_err(&text(float, "file = nan.csv"), dir.path());
    assert!(
        e.contains("nan.csv:3:3: `NaN` for `F` is not a finite number"),
        "{e}"
    );
    std::fs::write(dir.path().join("big.csv"), "time,F\n0,1.5\n1,1e39\n").unwrap();
    assert_eq!(
        start_err(&text(float, "file = big.csv"), dir.path()),
        "module t: timeline `big.csv` sets `F` to 1e39 at t=1s, beyond the range of point `F` (f32: ±3.4e38); write a smaller number"
    );
    std::fs::write(dir.path().join("bad.csv"), "time,A\nsoon,1\n").unwrap();
    let e = start_err(&text(ok, "file = bad.csv"), dir.path());
    assert!(
        e.starts_with("module t: ") && e.contains("bad.csv:2:1: "),
        "{e}"
    );
}

#[test]
fn logger_writes_the_first_scan_and_every_change() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("t.csv"),
        "time,A,N,X\n0,0,5,1\n0.02,1,,\n0.03,1,-3,\n",
    )
    .unwrap();
    let text = |log: &str| {
        format!(
            "[PLC]\nmodule t timeline\nmodule log logger\npoint A \"\" t\npoint N \"\" t i8\n\
             point X \"\" t f\n[t]\nfile = t.csv\n[log]\nfile = out.csv\n{log}\n"
        )
    };
    let mut plc = start(&text(""), dir.path()).unwrap();
    for k in 0..5 {
        plc.tick(ms(10 * k)).unwrap();
        // Flushed at the end of each scan: the file is complete without `close`.
        let rows = std::fs::read_to_string(dir.path().join("out.csv")).unwrap();
        assert_eq!(rows.lines().count(), [4, 4, 5, 6, 6][k as usize], "{rows}");
    }
    plc.close();
    assert_eq!(
        std::fs::read_to_string(dir.path().join("out.csv")).unwrap(),
        "time,point,value\n0,A,0\n0,N,5\n0,X,1\n0.02,A,1\n0.03,N,-3\n"
    );
    assert_eq!(
        plc.status("log"),
        format!("5 rows to {}", dir.path().join("out.csv").display())
    );
    drop(plc);

    let mut plc = start(&text("points = N\nlog X N"), dir.path()).unwrap();
    for k in 0..5 {
        plc.tick(ms(10 * k)).unwrap();
    }
    assert_eq!(
        std::fs::read_to_string(dir.path().join("out.csv")).unwrap(),
        "time,point,value\n0,N,5\n0,X,1\n0.03,N,-3\n"
    );
}

#[test]
fn logger_errors() {
    let dir = tempfile::tempdir().unwrap();
    let text = |log: &str| format!("[PLC]\nmodule log logger\npoint A \"\" log\n[log]\n{log}\n");
    assert_eq!(
        start_err(&text(""), dir.path()),
        "module log: no `file` setting; add `file = ...` to section [log]"
    );
    // A missing folder is created; one that cannot be (below a file) is named with the cause.
    let plc = start(&text("file = no/such/dir/log.csv"), dir.path()).unwrap();
    drop(plc);
    assert!(dir.path().join("no/such/dir/log.csv").is_file());
    std::fs::write(dir.path().join("plain"), "").unwrap();
    let e = start_err(&text("file = plain/sub/log.csv"), dir.path());
    assert!(
        e.starts_with(&format!(
            "module log: cannot create the folder `{}` for the log file `",
            dir.path().join("plain/sub").display()
        )),
        "{e}"
    );
    assert_eq!(
        start_err(&text("file = log.csv\npoints = A B"), dir.path()),
        "module log: cannot log `B`: no point named `B`; did you mean `A`?; fix the name in \
         `points` or the `log` rows of [log]"
    );
}

#[test]
fn shutdown_stops_the_plc_when_its_point_is_true() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("t.csv"), "time,QUIT\n0,0\n0.03,1\n").unwrap();
    for setting in [
        "point = QUIT",
        "quit_pt = QUIT",
        "point = QUIT\nquit_pt = QUIT",
    ] {
        let text = format!(
            "[PLC]\nmodule t timeline\nmodule stop shutdown\npoint QUIT \"\" t\n\
             [t]\nfile = t.csv\n[stop]\n{setting}\n"
        );
        let mut plc = start(&text, dir.path()).unwrap();
        let mut controls = Vec::new();
        for k in 0..5 {
            controls.push(plc.tick(ms(10 * k)).unwrap()[1]);
        }
        use Control::{Continue as C, StopPlc as S};
        assert_eq!(controls, [C, C, C, S, S], "{setting}");
        assert_eq!(plc.status("stop"), "stops the PLC when QUIT is true");
    }
    let text = |s: &str| format!("[PLC]\nmodule stop shutdown\npoint Q \"\" stop\n[stop]\n{s}\n");
    let p = Path::new(".");
    assert_eq!(
        start_err(&text(""), p),
        "module stop: no `point` setting; add `point = NAME` (the point that stops the PLC when \
         true) to section [stop]"
    );
    assert_eq!(
        start_err(&text("point = Q\nquit_pt = R"), p),
        "module stop: `point = Q` and `quit_pt = R` name different points; keep one setting"
    );
    assert_eq!(
        start_err(&text("point = R"), p),
        "module stop: the shutdown point: no point named `R`; did you mean `Q`?; fix `point` in [stop]"
    );
    let e = start_err(
        &text("point = Q").replace("module stop shutdown", "module stop shutdown now"),
        p,
    );
    assert_eq!(
        e,
        "module stop: a shutdown module takes no arguments (got `now`); put its settings in \
         section [stop]"
    );
}

#[test]
fn kinds_are_listed_and_built_in() {
    for kind in petriplc_modules::KINDS {
        assert!(petriplc_modules::builtin(kind).is_some(), "{kind}");
    }
    assert!(petriplc_modules::builtin("plc_logic").is_none());
}
