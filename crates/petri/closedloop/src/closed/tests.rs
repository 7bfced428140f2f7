//! Wiring, place names, proofs and counterexamples, the latter replayed by the simulator.

use std::path::Path;
use std::time::Duration;

use petriplc_pnml::{Naming, ReadOptions};
use petriplc_sim::{SimOptions, Simulation, Timeline};

use super::*;
use crate::witness::ScanStep;
use petriplc_testnet::net;

/// `never(place)` in one line: `proved N states`, `incomplete`, or the moves joined by `; `
/// with `(replays)` / `(needs other timing)`.
fn check(controller: &Net, plant: &Net, place: &str, expect: &str) {
    let cl = closed_loop(controller, plant, &PlcOptions::of(controller)).unwrap();
    let got = match never(&cl, place).unwrap() {
        NeverResult::Proved { states, .. } => format!("proved {states} states"),
        NeverResult::Incomplete { .. } => "incomplete".into(),
        NeverResult::Reached { moves, replays, .. } => {
            let mut k = 0;
            let mut lines = Vec::new();
            for m in &moves {
                lines.push(m.describe(controller, plant, k));
                k += usize::from(matches!(m, Move::Scan(_)));
            }
            let how = if replays {
                "replays"
            } else {
                "needs other timing"
            };
            format!("{} ({how})", lines.join("; "))
        }
    };
    assert_eq!(got, expect);
}

fn read(rel: &str, naming: Naming) -> Net {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    petriplc_pnml::read_file(&path, &ReadOptions { naming })
        .unwrap_or_else(|e| panic!("{rel}: {e}"))
        .net
}

#[test]
fn the_mixer_never_opens_inlet_and_outlet_together() {
    let mixer = read("../../../examples/mixer/mixer.pnml", Naming::Sipn);
    let tank = read("../../../examples/mixer/tank-observed.pnml", Naming::Plain);
    check(&mixer, &tank, "both_open", "proved 25 states");
}

/// The limit of the untimed plant: right after the scan that opens V1, the plant may fill
/// from dry to high before the controller scans again, which takes 4.5 s in the tank.
#[test]
fn the_untimed_plant_can_outrun_the_controller() {
    let mixer = read("../../../examples/mixer/mixer.pnml", Naming::Sipn);
    let tank = read("../../../examples/mixer/tank-observed.pnml", Naming::Plain);
    check(
        &mixer,
        &tank,
        "overfill",
        "scan 0: B1=1 N2=0 N3=0 N1=1 → fires B1; plant fires fill_dry_V1; \
         plant fires fill_mid_V1; plant fires fill_high_V1; plant fires see_overfill (replays)",
    );
}

#[test]
fn a_wrong_mixer_does_and_the_counterexample_replays_in_the_simulator() {
    let wrong = read("tests/data/mixer-wrong.pnml", Naming::Sipn);
    let tank = read("../../../examples/mixer/tank-observed.pnml", Naming::Plain);
    check(
        &wrong,
        &tank,
        "plant:both_open",
        "scan 0: B1=1 N2=0 N3=0 N1=1 → fires B1; plant fires fill_dry_V1; \
         plant fires fill_mid_V1; scan 1: B1=0 N2=1 N3=0 N1=0 → fires N2; \
         plant fires fill_high_V1; scan 2: B1=0 N2=1 N3=1 N1=0 → fires N3; \
         plant fires see_both (replays)",
    );
    let cl = closed_loop(&wrong, &tank, &PlcOptions::of(&wrong)).unwrap();
    let NeverResult::Reached {
        moves,
        timeline_csv,
        ..
    } = never(&cl, "both_open").unwrap()
    else {
        panic!("not reached")
    };
    assert_eq!(
        timeline_csv,
        "# closed loop `mixer_wrong` + plant `tank_observed`: plant:both_open is marked after 3 controller scans and 4 plant moves\n\
         # one row per controller scan (its inputs: the plant's outputs and free inputs); plant moves are comments\n\
         # replay the controller side: petriplc sim CONTROLLER.pnml --inputs THIS.csv --period 10ms\n\
         time,B1,N2,N3,N1\n\
         0,1,0,0,1\n\
         # plant fires fill_dry_V1\n\
         # plant fires fill_mid_V1\n\
         0.01,0,1,0,0\n\
         # plant fires fill_high_V1\n\
         0.02,0,1,1,0\n\
         # plant fires see_both\n\
         # now plant:both_open is marked\n"
    );
    // The simulator, fed the timeline alone, goes through the same controller markings.
    let scans: Vec<&ScanStep> = moves
        .iter()
        .filter_map(|m| match m {
            Move::Scan(s) => Some(s),
            Move::Plant { .. } => None,
        })
        .collect();
    let timeline = Timeline::parse(&timeline_csv, "cex.csv").unwrap();
    let period = Duration::from_millis(10);
    let opts = SimOptions::new(&wrong, period, period * (scans.len() as u32 - 1));
    let mut sim = Simulation::new(&wrong, opts, Some(timeline), None).unwrap();
    for step in &scans {
        let row = sim.step().unwrap().unwrap();
        assert_eq!(row.marking, step.marking.0);
        let fired: Vec<&str> = step
            .fired
            .iter()
            .map(|&t| wrong.transition_label(t))
            .collect();
        assert_eq!(row.fired, fired);
    }
    assert!(sim.step().unwrap().is_none());
    // The controller's outputs at the end: V1 and V3 both on.
    assert_eq!((sim.signal("V1"), sim.signal("V3")), (Some(1), Some(1)));
}

#[test]
fn free_inputs_of_both_nets_take_every_value_that_matters() {
    // B is free for the controller; the plant's `go` reads its free input G.
    let c = net("s B in bool\np idle 1\np on 0 >X\nt start idle -> on if B");
    let p = net("s X in bool\ns G in bool\np x 0 <X\np armed 1\np boom 0\n\
                 t fire armed ?x -> boom if G");
    check(
        &c,
        &p,
        "boom",
        "scan 0: B=1 → fires start; plant fires fire (with G=1) (replays)",
    );
}

#[test]
fn before_its_first_scan_the_controller_outputs_nothing() {
    // X's place is marked from the start, but the plant sees X = 0 until the first scan.
    let c = net("p on 1 >X");
    let p = net("s X in bool\np x 0 <X\np seen 0\nt see ?x -> seen");
    check(
        &c,
        &p,
        "seen",
        "scan 0: → fires nothing; plant fires see (replays)",
    );
}

#[test]
fn a_counterexample_may_need_a_delay_to_elapse_sooner_than_the_period_allows() {
    let c = net("p a 1\np b 0 >X\nt t a@1s -> b");
    let p = net("s X in bool\np x 0 <X\np seen 0\nt see ?x -> seen");
    check(
        &c,
        &p,
        "seen",
        "scan 0: delays of t elapsed → fires t; plant fires see (needs other timing)",
    );
}

#[test]
fn wiring_and_names() {
    let c = net("s B in bool\np idle 1\np on 0 >X\nt start idle -> on if B");
    let both = net("p x 0 >X");
    let err = closed_loop(&c, &both, &PlcOptions::of(&c)).unwrap_err();
    assert_eq!(
        err.to_string(),
        "`X` is an output of both the controller and the plant; a signal has one driver, rename one of them"
    );
    let p = net("s X in bool\ns B in bool\np x 0 <X\np idle 0\np b 0 <B");
    let cl = closed_loop(&c, &p, &PlcOptions::of(&c)).unwrap();
    let names = |v: Vec<SignalId>, n: &Net| -> Vec<String> {
        v.iter().map(|&s| n.signal(s).name.clone()).collect()
    };
    assert_eq!(names(cl.free_controller_inputs(), &c), ["B"]);
    assert_eq!(names(cl.free_plant_inputs(), &p), ["B"]);
    let msg = |place: &str| {
        cl.resolve(place)
            .map(|_| String::new())
            .unwrap_or_else(|e| e.to_string())
    };
    assert_eq!(
        msg("idle"),
        "`idle` names a place of the controller and of the plant; write `controller:idle` or `plant:idle`"
    );
    assert_eq!(msg("controller:idle"), "");
    assert_eq!(msg("plant:idle"), "");
    assert_eq!(msg("on"), "");
    assert_eq!(
        msg("x"),
        "`x` is an input place (it mirrors signal `X`); name the place that drives `X` instead, or add an observer place"
    );
    assert_eq!(
        msg("plant:on"),
        "no place `on` in the plant; places: x, idle, b"
    );
}

/// `never(place)` untimed (`None`) or timed at a period in ms: `proved`, `incomplete` or
/// the run's moves, as in [`check`].
fn at(controller: &Net, plant: &Net, period_ms: Option<u64>, place: &str) -> String {
    let mut opts = PlcOptions::of(controller);
    if let Some(ms) = period_ms {
        opts.period = Duration::from_millis(ms);
        opts.timed = true;
    }
    let cl = closed_loop(controller, plant, &opts).unwrap();
    match never(&cl, place).unwrap() {
        NeverResult::Proved { .. } => "proved".into(),
        NeverResult::Incomplete { .. } => "incomplete".into(),
        NeverResult::Reached { moves, .. } => {
            let mut k = 0;
            let mut lines = Vec::new();
            for m in &moves {
                lines.push(m.describe(controller, plant, k));
                k += usize::from(matches!(m, Move::Scan(_)));
            }
            lines.join("; ")
        }
    }
}

/// A motor turns until the controller sees the sensor band; crossing the band takes at
/// least 100 ms (the plant's arc delay). Untimed, the plant may cross before the next
/// scan; timed, a scan falls inside the band as long as scans are less than 100 ms apart.
#[test]
fn plant_delays_are_lower_bounds_at_the_period() {
    let c = net("s S in bool\np s 0 <S\np turning 1 >M\np stopped 0\nt stop turning ?s -> stopped");
    let p = net("s M in bool\np m 0 <M\np away 1\np band 0 >S\np over 0\n\
                 t enter away ?m -> band\nt overturn band@100ms ?m -> over");
    let overturns = "scan 0: S=0 → fires nothing; plant fires enter; plant fires overturn";
    assert_eq!(at(&c, &p, None, "over"), overturns);
    assert_eq!(at(&c, &p, Some(10), "over"), "proved");
    assert_eq!(at(&c, &p, Some(60), "over"), "proved");
    // 100 ms apart, a scan need not fall strictly inside the 100 ms crossing.
    assert_eq!(at(&c, &p, Some(100), "over"), overturns);
}

/// A belt runs for exactly 1 s (the controller's timer, exact when timed) and the
/// workpiece on it leaves within the plant's deadline; `stuck` observes a belt that has
/// run and stopped under the workpiece.
#[test]
fn plant_deadlines_are_upper_bounds_and_controller_timers_exact() {
    let c = net("p run 1 >B\np done 0\nt stop run@1s -> done");
    let plant = |deadline: &str| {
        net(&format!(
            "s B in bool\np b 0 <B\np wp 1\np gone 0\np ran 0\np stuck 0\n\
             t leave wp ?b -> gone within={deadline}\nt note ?b !ran -> ran\n\
             t see_stuck ?wp ?ran !b !stuck -> stuck"
        ))
    };
    let stuck = "scan 0: → fires nothing; plant fires note";
    // Untimed, the workpiece need not leave at all, and the belt may stop at any scan.
    assert!(at(&c, &plant("600ms"), None, "stuck").starts_with(stuck));
    assert_eq!(at(&c, &plant("600ms"), Some(10), "stuck"), "proved");
    // Enabled by scan 0 at t = 0, it leaves by 0.995 s, before scan 100 stops the belt.
    assert_eq!(at(&c, &plant("995ms"), Some(10), "stuck"), "proved");
    // By 1 s only: scan 100 may stop the belt at the same instant, just before it leaves.
    let late = at(&c, &plant("1s"), Some(10), "stuck");

    assert!(
        late.contains("scan 100: delays of stop elapsed → fires stop"),
        "{late}"
    );
    assert!(late.ends_with("plant fires see_stuck"), "{late}");
    // A controller scanning every 10 ms cannot stop the belt before scan 100 (t = 1 s).
    assert_eq!(late.matches("scan ").count(), 101);
}

#[test]
fn deadlines_on_free_inputs_are_refused_when_timed() {
    let c = net("p idle 1");
    let p = net("s G in bool\np g 0 <G\np a 1\np b 0\nt go a ?g -> b within=1s");
    let mut opts = PlcOptions::of(&c);
    assert!(closed_loop(&c, &p, &opts).is_ok());
    opts.timed = true;
    assert_eq!(
        closed_loop(&c, &p, &opts).unwrap_err().to_string(),
        "plant `test`: transition `go` has a deadline but reads `G`, an input nothing drives; \
         a deadline on a move that depends on a free input cannot be kept in a timed analysis \
         — drive `G` from the controller or drop the deadline"
    );
}

/// Several places in one search: states and edges of the whole space, a verdict each.
#[test]
fn never_all_explores_once_for_every_place() {
    let mixer = read("../../../examples/mixer/mixer.pnml", Naming::Sipn);
    let tank = read("../../../examples/mixer/tank-observed.pnml", Naming::Plain);
    let cl = closed_loop(&mixer, &tank, &PlcOptions::of(&mixer)).unwrap();
    let report = never_all(&cl, &["both_open", "overfill", "plant:both_open"]).unwrap();
    let verdicts: Vec<String> = report
        .verdicts
        .iter()
        .map(|(label, v)| match v {
            NeverResult::Proved { states, .. } => format!("{label}: proved ({states})"),
            NeverResult::Reached { moves, .. } => format!("{label}: {} moves", moves.len()),
            NeverResult::Incomplete { .. } => format!("{label}: incomplete"),
        })
        .collect();
    assert_eq!(
        verdicts,
        [
            "plant:both_open: proved (25)",
            "plant:overfill: 5 moves",
            "plant:both_open: proved (25)"
        ]
    );
    assert!(report.complete);
    assert_eq!(
        (report.states, report.edges, report.time_locks),
        (25, 45, 0)
    );
}

#[test]
fn a_search_cut_short_proves_nothing() {
    let c = net("s B in bool\np n 0\nt more -> n if B");
    let p = net("p never 0");
    let mut opts = PlcOptions::of(&c);
    opts.max_states = 10;
    let cl = closed_loop(&c, &p, &opts).unwrap();
    assert_eq!(
        never(&cl, "never").unwrap(),
        NeverResult::Incomplete { states: 10 }
    );
}
