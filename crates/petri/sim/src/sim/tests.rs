//! Tests of the driver: wiring checks, scan order, forcing, and closed loops with every plant.

use super::*;
use crate::plant::PlantError;
use crate::plants::NetPlant;
use crate::{builtin, render_svg};
use petriplc_net::time::{format_seconds, parse_duration};
use petriplc_testnet::net;

fn d(text: &str) -> Duration {
    parse_duration(text).unwrap()
}

/// Builds a simulation (period and until as duration text) or returns its error.
fn sim<'n>(
    controller: &'n Net,
    timeline: Option<&str>,
    plant: Option<Box<dyn Plant + 'n>>,
    period: &str,
    until: &str,
) -> Result<Simulation<'n>, SimError> {
    let tl = timeline.map(|t| Timeline::parse(t, "tl.csv").unwrap());
    Simulation::new(
        controller,
        SimOptions::new(controller, d(period), d(until)),
        tl,
        plant,
    )
}

/// Runs to the end and renders warnings, the CSV and the plant summary, or the error.
fn outcome(s: Result<Simulation<'_>, SimError>) -> String {
    let mut s = match s {
        Ok(s) => s,
        Err(e) => return format!("error: {e}"),
    };
    let mut out: String = s
        .warnings()
        .iter()
        .map(|w| format!("warning: {w}\n"))
        .collect();
    if let Err(e) = s.finish() {
        return format!("{out}error: {}", petriplc_testnet::error_chain(&e));
    }
    out += &s.trace().to_csv();
    if let Some(summary) = s.plant_summary() {
        out += &format!("plant: {summary}\n");
    }
    out
}

fn check(
    controller: &Net,
    timeline: Option<&str>,
    plant: Option<Box<dyn Plant + '_>>,
    period: &str,
    until: &str,
    expect: &str,
) {
    assert_eq!(
        outcome(sim(controller, timeline, plant, period, until)),
        expect
    );
}

fn lamp() -> Net {
    net("
        p off 1
        p on 0 >L1
        t t_on off -> on if B1
        t t_off on -> off if B2
    ")
}

#[test]
fn applies_the_timeline_scan_by_scan() {
    check(
        &lamp(),
        Some("time,B1,B2\n0,0,0\n0.02,1,\n0.035,0,\n0.05,,1\n"),
        None,
        "0.01",
        "0.08",
        "time,in:B1,in:B2,L1,m:off,m:on,fired\n\
         0,0,0,0,1,0,\n\
         0.02,1,0,1,0,1,t_on\n\
         0.04,0,0,1,0,1,\n\
         0.05,0,1,0,1,0,t_off\n",
    );
    // A row kept for an input change alone (0.04) tells why nothing fired.
    let n = lamp();
    let trace = sim(
        &n,
        Some("time,B1,B2\n0,0,0\n0.02,1,\n0.035,0,\n0.05,,1\n"),
        None,
        "0.01",
        "0.08",
    )
    .unwrap()
    .run()
    .unwrap();
    let rows: Vec<(String, Vec<i64>)> = trace
        .rows
        .iter()
        .map(|r| (format_seconds(r.time), r.inputs.clone()))
        .collect();
    assert_eq!(
        rows,
        [
            ("0".into(), vec![0, 0]),
            ("0.02".into(), vec![1, 0]),
            ("0.04".into(), vec![0, 0]),
            ("0.05".into(), vec![0, 1]),
        ]
    );
    assert_eq!(trace.end, d("0.08"));
    assert_eq!(trace.scans, 9);
}

#[test]
fn warns_about_inputs_nothing_drives() {
    let n = net("
        s SPEED in int
        p a 1 >Y
        t t1 a -> a if B1 AND SPEED > 2
    ");
    check(
        &n,
        None,
        None,
        "1",
        "1",
        "warning: input SPEED is driven by neither the timeline nor the plant; it stays 0\n\
         warning: input B1 is driven by neither the timeline nor the plant; it stays FALSE\n\
         time,in:SPEED,in:B1,Y,m:a,fired\n\
         0,0,0,1,1,\n",
    );
    check(
        &n,
        Some("time,SPEED,B1\n0,3,TRUE\n"),
        None,
        "1",
        "1",
        "time,in:SPEED,in:B1,Y,m:a,fired\n0,3,1,1,1,t1\n1,3,1,1,1,t1\n",
    );
}

#[test]
fn rejects_bad_wiring() {
    let n = lamp();
    let tank = || builtin("tank");
    check(
        &n,
        Some("time,B1,b2\n0,0,0\n"),
        None,
        "1",
        "1",
        "error: timeline tl.csv: column `b2` is not an input of the controller; known inputs: B1, B2; check the spelling",
    );
    check(
        &n,
        Some("time,L1\n0,0\n"),
        None,
        "1",
        "1",
        "error: timeline tl.csv: column `L1` is an output of the controller; a timeline drives inputs only (the controller computes its outputs)",
    );
    check(
        &net("p a 1"),
        Some("time,X\n0,0\n"),
        None,
        "1",
        "1",
        "error: timeline tl.csv: column `X` is not an input of the controller; it has no inputs at all",
    );
    check(
        &n,
        Some("time,B1\n0,0\n1,2\n"),
        None,
        "1",
        "1",
        "error: timeline column `B1` sets boolean input `B1` to 2 at t=1s; write 0/1 or TRUE/FALSE, or declare the input as int",
    );
    check(
        &n,
        None,
        None,
        "0",
        "1",
        "error: the scan period is 0; give a period greater than zero (e.g. 0.01 or T#10ms)",
    );

    let mixer = net("
        p fill 1 >V1
        p mix 0 >V2
        p drain 0 >V3
        t t1 fill -> mix if N2
        t t2 mix -> drain if N3
        t t3 drain -> fill if N1
    ");
    check(
        &mixer,
        Some("time,N1,N4\n0,0,0\n"),
        tank(),
        "1",
        "1",
        "error: timeline tl.csv: column `N4` is not an input of the controller nor of plant `tank`; known inputs: N2, N3, N1; check the spelling",
    );
    check(
        &mixer,
        Some("time,N1\n0,0\n"),
        tank(),
        "1",
        "1",
        "error: `N1` is driven by both the timeline and plant `tank`; drop it from one of them",
    );
    check(
        &mixer,
        Some("time,V1\n0,0\n"),
        tank(),
        "1",
        "1",
        "error: `V1` is driven by both the controller and the timeline; drop it from one of them",
    );
    check(
        &net("p fill 1 >V1"),
        None,
        tank(),
        "1",
        "1",
        "warning: plant `tank` reads V2, V3, which neither the controller nor the timeline drives; they stay 0 (add timeline columns to drive them)\n\
         time,V1,m:fill,fired\n\
         0,1,1,\n\
         plant: tank level 20 %, 0 fill/drain cycles completed\n",
    );
    check(
        &net("
            p fill 1 >V1
            p mix 0 >V2
            p drain 0 >V3
            p lamp 0 >N3
        "),
        None,
        tank(),
        "1",
        "1",
        "error: `N3` is driven by both the controller and plant `tank`; drop it from one of them",
    );
}

#[test]
fn scans_at_exact_multiples_of_the_period_up_to_until() {
    let n = lamp();
    let mut s = sim(&n, None, None, "0.3", "1").unwrap();
    assert_eq!(s.now(), Duration::ZERO);
    let mut times = Vec::new();
    while let Some(row) = s.step().unwrap() {
        times.push(format_seconds(row.time));
    }
    assert_eq!(times, ["0", "0.3", "0.6", "0.9"]);
    assert_eq!(s.now(), d("0.9"));
    assert_eq!(s.scans(), 4);
    assert!(s.is_over());
    assert_eq!(s.next_time(), d("1.2"));
    assert!(s.step().unwrap().is_none());
    // 0.1 is not exact in binary floating point, but scan times are: the 10th scan is at 1s.
    let mut s = sim(&n, None, None, "0.1", "1").unwrap();
    s.finish().unwrap();
    assert_eq!(s.now(), Duration::from_secs(1));
    assert_eq!(s.scans(), 11);
}

#[test]
fn set_input_overrides_the_timeline_from_then_on() {
    let n = lamp();
    let mut s = sim(&n, Some("time,B1,B2\n0,0,0\n1,,1\n"), None, "1", "10").unwrap();
    // Before a scan: what the first scan will see.
    assert_eq!(s.pending_input("B2"), Some(0));
    s.step().unwrap();
    assert_eq!(s.pending_input("B1"), Some(0));
    assert_eq!(
        s.pending_input("B2"),
        Some(1),
        "the timeline sets it at the next scan"
    );
    assert_eq!(s.pending_input("L1"), None);
    assert_eq!(s.pending_input("B9"), None);
    s.set_input("B2", 0).unwrap();
    assert_eq!(s.preview_signals(), [0, 0, 0], "L1, B1, B2");
    assert_eq!(s.signal("L1"), Some(0));
    s.set_input("B1", 1).unwrap();
    assert_eq!(
        s.signal("B1"),
        Some(1),
        "visible at once, e.g. for blockers()"
    );
    let row = s.step().unwrap().unwrap();
    assert_eq!(row.fired, ["t_on"]);
    assert_eq!(s.tokens("on"), Some(1));
    s.set_input("B1", 0).unwrap();
    s.set_input("B2", 1).unwrap();
    assert_eq!(s.step().unwrap().unwrap().fired, ["t_off"]);
    assert_eq!(s.tokens("off"), Some(1));
    assert_eq!(s.tokens("nowhere"), None);

    assert_eq!(
        s.set_input("B3", 1).unwrap_err().to_string(),
        "`B3` is not an input of this simulation; inputs: B1, B2; check the spelling"
    );
    assert_eq!(
        s.set_input("L1", 1).unwrap_err().to_string(),
        "`L1` is an output of the controller; only inputs can be set"
    );
    assert_eq!(
        s.set_input("B1", 7).unwrap_err().to_string(),
        "boolean input `B1` cannot be set to 7; use 0 or 1"
    );
}

#[test]
fn run_errors_carry_their_time() {
    let n = net("
        evolve until-stable
        p a 1
        p b 0
        t ab a -> b if GO
        t ba b -> a
    ");
    let out = outcome(sim(&n, Some("time,GO\n0,0\n0.2,1\n"), None, "0.1", "1"));
    assert!(
        out.starts_with(
            "error: controller: the net is unstable at t=0.2s: still firing after 1000 passes"
        ),
        "{out}"
    );
    let mut s = sim(&n, Some("time,GO\n0,0\n0.2,1\n"), None, "0.1", "1").unwrap();
    let e = s.finish().unwrap_err();
    assert_eq!(e.time(), Some(d("0.2")));
    assert!(
        s.step().unwrap().is_none(),
        "the run is over after an error"
    );

    struct Failing;
    impl Plant for Failing {
        fn name(&self) -> &str {
            "failing"
        }
        fn inputs(&self) -> Vec<String> {
            vec![]
        }
        fn outputs(&self) -> Vec<String> {
            vec!["B1".into()]
        }
        fn step(&mut self, now: Duration, _: &[i64], out: &mut [i64]) -> Result<(), PlantError> {
            out[0] = 1;
            if now >= Duration::from_millis(20) {
                return Err(PlantError::Failed {
                    plant: "failing".into(),
                    message: "jammed".into(),
                });
            }
            Ok(())
        }
        fn summary(&self) -> String {
            "jammed".into()
        }
    }
    check(
        &lamp(),
        None,
        Some(Box::new(Failing)),
        "0.01",
        "1",
        "warning: input B2 is driven by neither the timeline nor the plant; it stays FALSE\n\
         error: at t=0.02s: plant `failing`: jammed",
    );
}

/// Seed 003 Example 3: the 3-state busy beaver as a net whose places drive the tape. Each
/// FSM arc is a place (its action) and two transitions; `wr` rides along with every action
/// place because a place drives a single output.
fn busy_beaver() -> Net {
    net("
        p A 1
        p B 0
        p C 0
        p H 0
        p A0 0 >right
        p A1 0 >left
        p B0 0 >left
        p B1 0 >right
        p C0 0 >left
        p C1 0
        p wr 0 >write
        t a0 A -> A0 wr if NOT read
        t a1 A -> A1 wr if read
        t b0 B -> B0 wr if NOT read
        t b1 B -> B1 wr if read
        t c0 C -> C0 wr if NOT read
        t c1 C -> C1 wr if read
        t a0x A0 wr -> B
        t a1x A1 wr -> C
        t b0x B0 wr -> A
        t b1x B1 wr -> B
        t c0x C0 wr -> B
        t c1x C1 wr -> H
    ")
}

#[test]
fn busy_beaver_fills_six_ones_on_the_tape() {
    let n = busy_beaver();
    let mut s = sim(&n, None, builtin("tape"), "1", "100").unwrap();
    assert!(s.warnings().is_empty(), "{:?}", s.warnings());
    s.finish().unwrap();
    assert_eq!(s.tokens("H"), Some(1));
    assert_eq!(
        s.plant_summary().unwrap(),
        "tape 111111 (6 ones) on cells -3..2, head at 0"
    );
    // 13 FSM steps, two scans each (read and choose, then act): the last acts at scan 25.
    let trace = s.into_trace();
    let last_fired = trace
        .rows
        .iter()
        .rev()
        .find(|r| !r.fired.is_empty())
        .unwrap();
    assert_eq!(last_fired.fired, ["c1x"]);
    assert_eq!(format_seconds(last_fired.time), "25");
}

#[test]
fn keyboard_lines_follow_powered_columns_and_timeline_keys() {
    // The controller powers column 1 only and latches keys 1 and 4 (rows 1 and 2 of it).
    let n = net("
        p power 1 >col1
        p c2 0 >col2
        p c3 0 >col3
        p k1 0 >got1
        p k4 0 >got4
        t d1 !k1 -> k1 if line1
        t d4 !k4 -> k4 if line2
    ");
    let keys = |pressed: &[usize]| -> String {
        (1..=12)
            .map(|k| if pressed.contains(&k) { ",1" } else { ",0" })
            .collect()
    };
    let header: String = (1..=12).map(|k| format!(",key{k}")).collect();
    let tl = format!(
        "time{header}\n0{}\n0.02{}\n0.04{}\n0.06{}\n",
        keys(&[]),
        keys(&[2]),
        keys(&[2, 4]),
        keys(&[])
    );
    check(
        &n,
        Some(&tl),
        builtin("keyboard"),
        "0.01",
        "0.08",
        "time,in:line1,in:line2,col1,col2,col3,got1,got4,m:power,m:c2,m:c3,m:k1,m:k4,fired\n\
         0,0,0,1,0,0,0,0,1,0,0,0,0,\n\
         0.04,0,1,1,0,0,0,1,1,0,0,0,1,d4\n\
         0.06,0,0,1,0,0,0,1,1,0,0,0,1,\n\
         plant: no key pressed\n",
    );
    // Keys the timeline leaves out stay released, with one warning naming them.
    check(
        &n,
        Some("time,key1\n0,1\n"),
        builtin("keyboard"),
        "1",
        "1",
        "warning: plant `keyboard` reads key2, key3, key4, key5, key6, key7, key8, key9, key10, key11, key12, which neither the controller nor the timeline drives; they stay 0 (add timeline columns to drive them)\n\
         time,in:line1,in:line2,col1,col2,col3,got1,got4,m:power,m:c2,m:c3,m:k1,m:k4,fired\n\
         0,0,0,1,0,0,0,0,1,0,0,0,0,\n\
         1,1,0,1,0,0,1,0,1,0,0,1,0,d1\n\
         plant: keys pressed: 1\n",
    );
    // Keys fed by the timeline can be forced by hand too.
    let mut s = sim(&n, Some(&tl), builtin("keyboard"), "0.01", "0.08").unwrap();
    s.set_input("key1", 1).unwrap();
    s.step().unwrap();
    assert_eq!(s.step().unwrap().unwrap().fired, ["d1"]);
    assert_eq!(s.plant_summary().unwrap(), "keys pressed: 1");
    assert_eq!(s.pending_input("key1"), Some(1));
    assert_eq!(
        s.pending_input("key2"),
        Some(1),
        "the timeline presses it at the next scan"
    );
    assert_eq!(s.pending_input("key3"), Some(0));
    assert_eq!(s.pending_input("col1"), None, "driven by the controller");
    assert_eq!(s.settable_inputs().len(), 2 + 12);
}

/// Seed 002 Fig. 2, reduced to its valves: solvent to N2, solute to N3, drain to N1.
fn mixer() -> Net {
    net("
        p idle 1
        p fill1 0 >V1
        p fill2 0 >V2
        p drain 0 >V3
        t go idle -> fill1 if START
        t half fill1 -> fill2 if N2
        t full fill2 -> drain if N3
        t empty drain -> idle if N1
    ")
}

#[test]
fn mixer_controls_the_tank_in_a_closed_loop() {
    let n = mixer();
    let out = outcome(sim(
        &n,
        Some("time,START\n0,1\n"),
        builtin("tank"),
        "0.1",
        "20",
    ));
    // 2 %/step to 50 % (t=2.5), to 90 % (4.5), then -2.5 %/step to 5 % (7.9). Later cycles
    // start from what the drain left (5 %, then 3.5 %), so they run a little shorter.
    // Inputs: the timeline's START first, then the tank's sensors in the plant's order.
    assert_eq!(
        out,
        "time,in:START,in:N1,in:N2,in:N3,V1,V2,V3,m:idle,m:fill1,m:fill2,m:drain,fired\n\
         0,1,1,0,0,1,0,0,0,1,0,0,go\n\
         0.3,1,0,0,0,1,0,0,0,1,0,0,\n\
         2.5,1,0,1,0,0,1,0,0,0,1,0,half\n\
         4.5,1,0,1,1,0,0,1,0,0,0,1,full\n\
         4.6,1,0,1,0,0,0,1,0,0,0,1,\n\
         6.2,1,0,0,0,0,0,1,0,0,0,1,\n\
         7.9,1,1,0,0,0,0,0,1,0,0,0,empty\n\
         8,1,1,0,0,1,0,0,0,1,0,0,go\n\
         8.1,1,0,0,0,1,0,0,0,1,0,0,\n\
         10.3,1,0,1,0,0,1,0,0,0,1,0,half\n\
         12.3,1,0,1,1,0,0,1,0,0,0,1,full\n\
         12.4,1,0,1,0,0,0,1,0,0,0,1,\n\
         14,1,0,0,0,0,0,1,0,0,0,1,\n\
         15.8,1,1,0,0,0,0,0,1,0,0,0,empty\n\
         15.9,1,1,0,0,1,0,0,0,1,0,0,go\n\
         16,1,0,0,0,1,0,0,0,1,0,0,\n\
         18.3,1,0,1,0,0,1,0,0,0,1,0,half\n\
         plant: tank level 85.5 %, 2 fill/drain cycles completed\n"
    );
}

#[test]
fn a_second_net_models_the_process() {
    // Seed 004: the controller pushes a cylinder out until it reports `extended`, then pulls
    // it back until `home`; the cylinder is itself a net.
    let controller = net("
        p pushing 1 >push
        p pulling 0
        t a pushing -> pulling if extended
        t b pulling -> pushing if home
    ");
    let model = net("
        p retracted 1 >home
        p extended 0 >extended
        t out retracted -> extended if push
        t back extended -> retracted if NOT push
    ");
    let plant = NetPlant::new(&model, ScanOptions::of(&model));
    check(
        &controller,
        None,
        Some(Box::new(plant)),
        "1",
        "4",
        "time,in:home,in:extended,push,m:pushing,m:pulling,fired\n\
         0,1,0,1,1,0,\n\
         1,0,1,0,0,1,a\n\
         2,1,0,1,1,0,b\n\
         3,0,1,0,0,1,a\n\
         4,1,0,1,1,0,b\n\
         plant: test, marking retracted\n",
    );
}

#[test]
fn runs_are_deterministic() {
    let n = mixer();
    let run = || {
        let trace = sim(
            &n,
            Some("time,START\n0,1\n13,0\n"),
            builtin("tank"),
            "T#30ms",
            "30",
        )
        .unwrap()
        .run()
        .unwrap();
        (trace.to_csv(), render_svg(&trace).unwrap())
    };
    let (csv1, svg1) = run();
    let (csv2, svg2) = run();
    assert_eq!(csv1, csv2);
    assert_eq!(svg1, svg2);
    assert!(csv1.lines().count() > 5);
}
