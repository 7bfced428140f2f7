//! The vitrine driven in-process scan by scan (petriplc_runtime::harness, time passed in)
//! with a [`Probe`] for a terminal: keys bound to points it owns (written) and to other
//! modules' points (forced and released), pulses, toggles, set values, the stop keys, what
//! the screen shows, and the errors a wrong section gets.

use std::cell::RefCell;
use std::path::Path;

use petriplc_config::{ModuleDecl, PointValue};
use petriplc_runtime::harness::{self, ms, Plc};
use petriplc_runtime::module::{Control, Factory, Module, ModuleError};
use petriplc_vitrine::{Probe, Vitrine};

thread_local! {
    /// The probe the next vitrine made on this thread draws into (the registry is a plain
    /// function, so it cannot carry one).
    static PROBE: RefCell<Option<Probe>> = const { RefCell::new(None) };
}

fn probe_factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    let probe = PROBE
        .with(|p| p.borrow().clone())
        .expect("a probe for this test");
    Ok(Box::new(Vitrine::with_probe(decl, probe)?))
}

fn registry(kind: &str) -> Option<Factory> {
    if kind == "vitrine" {
        Some(probe_factory as Factory)
    } else {
        petriplc_modules::builtin(kind)
    }
}

fn start_in(text: &str, dir: &Path) -> (Plc, Probe) {
    let probe = Probe::new(100, 30);
    PROBE.with(|p| *p.borrow_mut() = Some(probe.clone()));
    let plc = harness::start(text, dir, registry).unwrap_or_else(|e| panic!("{e}"));
    (plc, probe)
}

fn start(text: &str) -> (Plc, Probe) {
    start_in(text, Path::new("."))
}

fn start_err(text: &str) -> String {
    PROBE.with(|p| *p.borrow_mut() = Some(Probe::new(80, 24)));
    harness::start_err(text, Path::new("."), registry)
}

/// `stop` (a shutdown module) owns points the vitrine must force; the vitrine owns others.
const PANEL: &str = "\
[PLC]
module stop shutdown
module vitrine vitrine
point B1 \"start button\" stop
point T1 \"toggled input\" stop
point SP \"set point\" stop i16
point L \"lamp (key l)\" vitrine
point R \"run (key r)\" vitrine
point GAIN \"gain\" vitrine f32
point QUIT \"quit (key Q)\" vitrine
[stop]
point = QUIT
[vitrine]
pulse = 300ms
key b B1
key t T1 toggle
key 5 SP set -5
key l L pulse
key r R toggle
key g GAIN set 2.5
key F1 SP set 7
";

/// Ticks at `t` ms, returning the vitrine's control (the second module).
fn tick(plc: &mut Plc, t: u64) -> Control {
    plc.tick(ms(t)).unwrap_or_else(|e| panic!("{e}"))[1]
}

fn line_of(screen: &str, point: &str) -> String {
    screen
        .lines()
        .find(|l| l.contains(&format!("│{point} ")))
        .unwrap_or_else(|| panic!("no row for {point} in\n{screen}"))
        .to_string()
}

#[test]
fn a_pulse_forces_another_modules_point_then_releases_it() {
    let (mut plc, probe) = start(PANEL);
    tick(&mut plc, 0);
    assert_eq!(plc.value("B1"), 0);
    probe.press("b").unwrap();
    tick(&mut plc, 50);
    assert_eq!(
        plc.value("B1"),
        1,
        "forced at the vitrine's update after the scan"
    );
    tick(&mut plc, 100);
    let screen = probe.text();
    assert!(line_of(&screen, "B1").contains("ON F"), "{screen}");
    assert!(screen.contains("B1 forced ON for 300 ms"), "{screen}");
    tick(&mut plc, 300);
    assert_eq!(plc.value("B1"), 1, "still within the pulse");
    tick(&mut plc, 350);
    // Released at 350 (50 + 300); the owner's next update brings its own value back.
    tick(&mut plc, 400);
    assert_eq!(plc.value("B1"), 0);
    tick(&mut plc, 450);
    assert!(!line_of(&probe.text(), "B1").contains(" F "));
}

#[test]
fn a_pulse_writes_a_point_the_vitrine_owns() {
    let (mut plc, probe) = start(PANEL);
    tick(&mut plc, 0);
    probe.press("L").unwrap();
    tick(&mut plc, 50);
    assert_eq!(plc.value("L"), 1);
    tick(&mut plc, 100);
    let screen = probe.text();
    assert!(screen.contains("L := ON for 300 ms"), "{screen}");
    assert!(
        !line_of(&screen, "L").contains(" F "),
        "owned points are not forced"
    );
    tick(&mut plc, 349);
    assert_eq!(plc.value("L"), 1);
    tick(&mut plc, 350);
    assert_eq!(plc.value("L"), 0);
}

#[test]
fn a_second_press_during_a_pulse_extends_it() {
    let (mut plc, probe) = start(PANEL);
    probe.press("l").unwrap();
    tick(&mut plc, 0);
    probe.press("l").unwrap();
    tick(&mut plc, 200);
    tick(&mut plc, 400);
    assert_eq!(plc.value("L"), 1, "the second press restarted the pulse");
    tick(&mut plc, 500);
    assert_eq!(plc.value("L"), 0);
}

#[test]
fn toggle_flips_owned_and_forced_points_and_delete_releases_forces() {
    let (mut plc, probe) = start(PANEL);
    tick(&mut plc, 0);
    probe.press("r").unwrap();
    probe.press("t").unwrap();
    tick(&mut plc, 50);
    assert_eq!((plc.value("R"), plc.value("T1")), (1, 1));
    tick(&mut plc, 100);
    probe.press("r").unwrap();
    probe.press("t").unwrap();
    tick(&mut plc, 150);
    assert_eq!((plc.value("R"), plc.value("T1")), (0, 0));
    tick(&mut plc, 200);
    let screen = probe.text();
    assert!(
        line_of(&screen, "T1").contains("off F"),
        "forced off:\n{screen}"
    );
    assert!(screen.contains("Del release 1 forced"), "{screen}");
    assert_eq!(plc.status("vitrine"), "display on; 1 point forced");

    probe.press("t").unwrap();
    tick(&mut plc, 250);
    assert_eq!(plc.value("T1"), 1);
    probe.press("delete").unwrap();
    tick(&mut plc, 300);
    tick(&mut plc, 350);
    assert_eq!(plc.value("T1"), 0, "released: the owner's value is back");
    tick(&mut plc, 400);
    let screen = probe.text();
    assert!(!line_of(&screen, "T1").contains(" F "), "{screen}");
    assert!(screen.contains("released 1 force"), "{screen}");
    assert_eq!(plc.status("vitrine"), "display on");
}

#[test]
fn set_writes_or_forces_a_value_of_the_points_kind() {
    let (mut plc, probe) = start(PANEL);
    tick(&mut plc, 0);
    probe.press("5").unwrap();
    probe.press("g").unwrap();
    tick(&mut plc, 50);
    assert_eq!(plc.get("SP"), PointValue::Signed(-5));
    assert_eq!(plc.get("GAIN"), PointValue::Float(2.5));
    probe.press("F1").unwrap();
    tick(&mut plc, 100);
    assert_eq!(plc.get("SP"), PointValue::Signed(7));
    tick(&mut plc, 150);
    let screen = probe.text();
    assert!(line_of(&screen, "SP").contains("7 F"), "{screen}");
    assert!(line_of(&screen, "GAIN").contains("2.500"), "{screen}");
    // Shift or Caps Lock do not matter to letters.
    probe.press("G").unwrap();
    tick(&mut plc, 200);
    assert!(probe.text().contains("GAIN := 2.5"));
}

#[test]
fn ctrl_c_and_q_stop_the_plc() {
    let (mut plc, probe) = start(PANEL);
    assert_eq!(tick(&mut plc, 0), Control::Continue);
    probe.press("x").unwrap();
    assert_eq!(
        tick(&mut plc, 50),
        Control::Continue,
        "unbound keys do nothing"
    );
    probe.press("ctrl-c").unwrap();
    assert_eq!(tick(&mut plc, 100), Control::StopPlc);
    probe.press("q").unwrap();
    assert_eq!(tick(&mut plc, 150), Control::StopPlc);
    assert!(probe.text().contains("q/Ctrl-C stop the PLC"));
}

#[test]
fn a_key_row_may_take_q_and_matplc_s_quit_point_works() {
    let text = PANEL.replace("key F1 SP set 7", "key q QUIT set 1");
    let (mut plc, probe) = start(&text);
    tick(&mut plc, 0);
    probe.press("Q").unwrap();
    // The vitrine writes QUIT; the shutdown module sees it at its next scan.
    assert_eq!(
        plc.tick(ms(50)).unwrap(),
        [Control::Continue, Control::Continue]
    );
    assert_eq!(plc.tick(ms(100)).unwrap()[0], Control::StopPlc);
    assert!(probe.text().contains("Ctrl-C stop the PLC"));
    assert!(!probe.text().contains("q/Ctrl-C"));
}

#[test]
fn show_rows_and_background_are_drawn() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("screen.txt"),
        "  light chaser\n\n  lights:\t\n",
    )
    .unwrap();
    let text = PANEL.replace(
        "pulse = 300ms\n",
        "pulse = 300ms\nbackground = screen.txt\n\
         show L 2 17 (*) \" -\"\nshow R 2 20 ON\nshow SP 3 2 i16\nshow GAIN 3 10 f32\n\
         graph SP -10 10\ngraph L\n",
    );
    let (mut plc, probe) = start_in(&text, dir.path());
    probe.press("l").unwrap();
    probe.press("5").unwrap();
    tick(&mut plc, 0);
    tick(&mut plc, 50);
    let screen = probe.text();
    assert!(screen.contains("│  lights:        (*)   "), "{screen}");
    assert!(screen.contains("│  -5      0.000"), "{screen}");
    assert!(screen.contains(" graphs "), "{screen}");
    probe.press("r").unwrap();
    tick(&mut plc, 400);
    tick(&mut plc, 450);
    let screen = probe.text();
    assert!(screen.contains("│  lights:         - ON "), "{screen}");
}

#[test]
fn every_point_is_listed_unless_points_says_which() {
    let (mut plc, probe) = start(PANEL);
    tick(&mut plc, 0);
    let screen = probe.text();
    for p in ["B1", "T1", "SP", "L", "R", "GAIN", "QUIT"] {
        line_of(&screen, p);
    }
    assert!(line_of(&screen, "SP").contains("set point"));
    assert!(line_of(&screen, "GAIN").contains("0.000"));
    // No status file in-process: the panels say so.
    assert!(screen.contains("waiting for the PLC's status"), "{screen}");

    let (mut plc, probe) = start(&PANEL.replace("pulse = 300ms", "points = SP B1"));
    tick(&mut plc, 0);
    let screen = probe.text();
    line_of(&screen, "SP");
    assert!(!screen.contains("│GAIN "), "{screen}");
    let sp = screen.find("│SP ").unwrap();
    assert!(
        sp < screen.find("│B1 ").unwrap(),
        "in the order of `points`"
    );
}

fn with_rows(rows: &str) -> String {
    PANEL.replace("pulse = 300ms\n", &format!("pulse = 300ms\n{rows}\n"))
}

#[test]
fn wrong_sections_say_where_and_how_to_fix() {
    // PANEL's `pulse` is line 14; the first added row is line 15.
    let cases: &[(&str, &str)] = &[
        ("key b NOPE", "test.conf:15: `key`: "),
        ("key b NOPE", "declare the point in [PLC] or fix the name"),
        ("key 1 SP", "test.conf:15: `SP` is a 16-bit signed point: say what the key writes with `key 1 SP set VALUE`"),
        ("key 1 SP toggle", "`toggle` is for bool (1-bit) points and `SP` is a 16-bit signed point: use `set VALUE`"),
        ("key 1 SP set 40000", "`set 40000`: 40000 does not fit a 16-bit signed point"),
        ("key 1 GAIN set fast", "`set fast`: a float point takes a number such as 2.5"),
        ("key 1 B1 set 2", "`set 2`: a bool point takes 1 or 0"),
        ("key 1 B1 hold", "`hold` is not an action (pulse, toggle or set VALUE)"),
        ("key B L", "test.conf:16: key `b` is bound twice (also at test.conf:15)"),
        ("key delete B1", "Delete is the vitrine's key for releasing its forces"),
        ("key ctrl-x B1", "`ctrl-x` is not a key: write one character"),
        ("show L 1", "a show row is `show POINT ROW COL [TYPE] [ON [OFF]]` (got `show L 1`)"),
        ("show L x 2", "ROW `x` is not a whole number from 0 to 999"),
        ("show SP 1 2 i16 on", "ON and OFF strings are for bool fields"),
        ("show L 1 2 bool on off extra", "`extra` is one cell too many"),
        ("graph SP 5 1", "MIN (5) must be below MAX (1); swap them"),
        ("graph SP 5", "a graph row is `graph POINT [MIN MAX]`"),
        ("plot SP", "test.conf:15: a vitrine module reads only show, graph, key rows, not `plot`"),
        ("background = missing.txt", "background: cannot read "),
        ("backgrnd = x.txt", "unknown setting `backgrnd` (test.conf:15) in section [vitrine]"),
        ("points = B1 NOPE", "`points`: "),
    ];
    for (rows, want) in cases {
        let err = start_err(&with_rows(rows));
        assert!(err.contains(want), "`{rows}`: want `{want}` in\n{err}");
        assert!(err.starts_with("module vitrine: "), "{err}");
    }
    let err = start_err(&PANEL.replace("pulse = 300ms", "pulse = soon"));
    assert!(
        err.contains("test.conf:14: `pulse`: `soon` is not a duration"),
        "{err}"
    );
    let err = start_err(&PANEL.replace("pulse = 300ms", "pulse = 0"));
    assert!(err.contains("a pulse must last some time"), "{err}");
}

#[test]
fn every_bad_row_is_reported_at_once() {
    let err = start_err(&with_rows("key b NOPE\ngraph NOPE\nshow L 1"));
    assert_eq!(err.lines().count(), 3, "{err}");
    assert!(err.contains("test.conf:17: a show row"), "{err}");
}
