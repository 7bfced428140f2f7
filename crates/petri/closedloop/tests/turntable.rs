//! Seed 004's turntable (examples/turntable): the plant net is an abstraction of the continuous
//! `turntable` plant — checked scan by scan on the example's timeline, timing included — and
//! the closed-loop proof that no error place is ever marked means something: controllers
//! with a seeded mistake reach the error in the analysis and in the continuous plant alike.

use std::collections::{HashMap, HashSet, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use petriplc_closedloop::{closed_loop, never, never_all, NeverResult, PlcOptions};
use petriplc_net::{Marking, Net, PlaceId, TransitionId};
use petriplc_pnml::ReadOptions;
use petriplc_sim::{Plant, PlantError, SimOptions, Simulation, Timeline, Turntable};

const PERIOD: Duration = Duration::from_millis(10);

fn example(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../examples/turntable")
        .join(file)
}

fn read_net(text: &str, name: &str) -> Net {
    petriplc_pnml::read_str(text, name, &ReadOptions::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .net
}

fn controller_text() -> String {
    std::fs::read_to_string(example("controller.pnml")).unwrap()
}

fn plant_net() -> Net {
    read_net(
        &std::fs::read_to_string(example("plant.pnml")).unwrap(),
        "plant.pnml",
    )
}

/// The controller with MR and ML swapped: it turns right where it should turn left.
fn swapped_motors(text: &str) -> String {
    text.replace("<output>MR</output>", "<output>@</output>")
        .replace("<output>ML</output>", "<output>MR</output>")
        .replace("<output>@</output>", "<output>ML</output>")
}

/// The controller without Fig. 6's inhibitor arc from BF to T1: the table may start turning
/// while the belt still runs forward.
fn without_belt_interlock(text: &str) -> String {
    let start = text
        .find(r#"source="BF" target="T1_turn_left_loaded""#)
        .expect("the arc BF -o T1");
    let open = text[..start].rfind("<arc ").unwrap();
    let close = start + text[start..].find("</arc>").unwrap() + "</arc>".len();
    assert!(text[open..close].contains("<arctype>inhibitor</arctype>"));
    format!(
        "{}{}",
        &text[..open],
        text[close..].trim_start_matches('\n')
    )
}

/// Everything the continuous plant was after one step.
#[derive(Clone, Debug)]
struct Snap {
    time: Duration,
    /// MR, ML, BF, BB as the step saw them (the controller's outputs of its previous scan).
    inputs: [i64; 4],
    alpha: i128,
    x: Option<i128>,
    waiting: (bool, bool),
    /// E_sector, E_belt_turning, E_MR_ML, E_BF_BB, E_fall.
    errors: [i64; 5],
}

/// The built-in turntable, recording its state after every step.
struct Recorder {
    inner: Turntable,
    log: Arc<Mutex<Vec<Snap>>>,
}

impl Plant for Recorder {
    fn name(&self) -> &str {
        self.inner.name()
    }
    fn inputs(&self) -> Vec<String> {
        self.inner.inputs()
    }
    fn outputs(&self) -> Vec<String> {
        self.inner.outputs()
    }
    fn step(
        &mut self,
        now: Duration,
        inputs: &[i64],
        outputs: &mut [i64],
    ) -> Result<(), PlantError> {
        self.inner.step(now, inputs, outputs)?;
        let at = |name: &str| outputs[Turntable::OUTPUTS.iter().position(|o| *o == name).unwrap()];
        self.log.lock().unwrap().push(Snap {
            time: now,
            inputs: [inputs[0], inputs[1], inputs[2], inputs[3]],
            alpha: self.inner.alpha_picodegrees(),
            x: self.inner.x_femtometres(),
            waiting: self.inner.waiting(),
            errors: ["E_sector", "E_belt_turning", "E_MR_ML", "E_BF_BB", "E_fall"].map(at),
        });
        Ok(())
    }
    fn summary(&self) -> String {
        self.inner.summary()
    }
}

/// Runs `controller` against the continuous turntable on the example's timeline for 13 s;
/// returns every step's state and the plant's summary.
fn simulate(controller: &Net) -> (Vec<Snap>, String) {
    let log = Arc::new(Mutex::new(Vec::new()));
    let plant = Recorder {
        inner: Turntable::default(),
        log: log.clone(),
    };
    let timeline = Timeline::read_file(example("timeline.csv")).unwrap();
    let opts = SimOptions::new(controller, PERIOD, Duration::from_secs(13));
    let mut sim = Simulation::new(controller, opts, Some(timeline), Some(Box::new(plant))).unwrap();
    sim.finish().unwrap();
    let summary = sim.plant_summary().unwrap();
    drop(sim);
    let snaps = log.lock().unwrap().clone();
    (snaps, summary)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    Minus,
    Plus,
}

/// The plant net's marking for a state of the continuous plant: the regions of α and x
/// (`side`: where the workpiece last came into the SWP band from), the stations, the errors.
/// `None` once α has left the sector (the net's angle token is then in `E_sector`).
fn abstraction(net: &Net, s: &Snap, side: &mut Option<Side>) -> Option<Marking> {
    let settings = Turntable::default().settings().to_owned();
    let milli = 1_000_000_000i128;
    let half_alpha = i128::from(settings.b_alpha) * milli / 2;
    let half_bx = i128::from(settings.b_x) * milli / 2;
    let left_alpha = 90_000 * milli;
    let mut m = Marking(vec![0; net.places().len()]);
    let mut mark = |name: &str| {
        let p = net
            .place_ids()
            .find(|&p| net.place_label(p) == name)
            .unwrap_or_else(|| panic!("no place {name}"));
        m[p] = 1;
    };
    if s.alpha.abs() <= half_alpha {
        mark("right");
    } else if (s.alpha - left_alpha).abs() <= half_alpha {
        mark("left");
    } else if s.alpha > half_alpha && s.alpha < left_alpha - half_alpha {
        mark("between");
    } else {
        return None;
    }
    match s.x {
        None => {
            *side = None;
            mark("free");
        }
        Some(x) if x < -half_bx => {
            *side = Some(Side::Minus);
            mark("M_minus");
        }
        Some(x) if x > half_bx => {
            *side = Some(Side::Plus);
            mark("M_plus");
        }
        Some(_) => match side.expect("a workpiece appears in the SWP band") {
            Side::Minus => mark("M_centre_from_minus"),
            Side::Plus => mark("M_centre_from_plus"),
        },
    }
    if s.waiting.0 {
        mark("Msouth");
    }
    if s.waiting.1 {
        mark("Meast");
    }
    for (e, on) in ["E_sector", "E_belt_turning", "E_MR_ML", "E_BF_BB", "E_fall"]
        .iter()
        .zip(s.errors)
    {
        if on != 0 {
            mark(e);
        }
    }
    Some(m)
}

/// `m` with the input places showing `inputs` (MR, ML, BF, BB), as S1 sets them.
fn with_inputs(net: &Net, m: &Marking, inputs: &[i64; 4]) -> Marking {
    let mut m = m.clone();
    for p in net.place_ids() {
        if let Some(s) = net.place(p).input {
            let k = ["MR", "ML", "BF", "BB"]
                .iter()
                .position(|n| *n == net.signal(s).name)
                .unwrap();
            m[p] = inputs[k] as u32;
        }
    }
    m
}

fn enabled(net: &Net, m: &Marking, t: TransitionId) -> bool {
    net.arcs_of(t).allow(
        |q| m[q],
        |q| u64::from(m[q]),
        |q| net.bound(q).map_or(u64::MAX, u64::from),
        |_| false,
    )
}

/// A shortest firing sequence of `net` from `from` to `to` under the inputs, if any
/// (interleaving, inputs held: what the plant net allows during one step).
fn path(net: &Net, from: &Marking, to: &Marking, inputs: &[i64; 4]) -> Option<Vec<TransitionId>> {
    let start = with_inputs(net, from, inputs);
    let goal = with_inputs(net, to, inputs);
    let mut seen: HashMap<Marking, Option<(Marking, TransitionId)>> = HashMap::new();
    seen.insert(start.clone(), None);
    let mut queue = VecDeque::from([start]);
    while let Some(m) = queue.pop_front() {
        if m == goal {
            let mut out = Vec::new();
            let mut cur = m;
            while let Some(Some((prev, t))) = seen.get(&cur).cloned() {
                out.push(t);
                cur = prev;
            }
            out.reverse();
            return Some(out);
        }
        for t in net.transition_ids() {
            if enabled(net, &m, t) {
                let mut n = m.clone();
                net.fire(&mut n, t).unwrap();
                if !seen.contains_key(&n) {
                    seen.insert(n.clone(), Some((m.clone(), t)));
                    queue.push_back(n);
                }
            }
        }
    }
    None
}

/// Checks every step of `snaps` against the plant net: the change of the abstract marking is
/// a firing sequence the net allows under the step's inputs, each delayed arc has held its
/// tokens as long as the scans show it could have, each deadline is kept. Returns the labels
/// of the transitions fired, in order, up to the step where α leaves the sector.
fn agree(net: &Net, snaps: &[Snap]) -> Vec<String> {
    let period = PERIOD.as_nanos();
    let mut side = None;
    let mut prev = abstraction(net, &snaps[0], &mut side).expect("starts in the sector");
    assert_eq!(prev, {
        let mut m = net.initial_marking();
        for p in net.place_ids() {
            if net.place(p).input.is_some() {
                m[p] = 0;
            }
        }
        m
    });
    // Step index since which each place has been marked, and each deadline transition enabled.
    let mut marked_since: Vec<Option<usize>> = net
        .place_ids()
        .map(|p| (prev[p] > 0).then_some(0))
        .collect();
    let mut enabled_since: HashMap<TransitionId, usize> = HashMap::new();
    let mut fired = Vec::new();
    for (k, s) in snaps.iter().enumerate().skip(1) {
        let next = abstraction(net, s, &mut side);
        let inputs = s.inputs;
        let held = with_inputs(net, &prev, &inputs);
        for t in net.transition_ids() {
            if net.transition(t).deadline.is_some() && enabled(net, &held, t) {
                enabled_since.entry(t).or_insert(k - 1);
            } else {
                enabled_since.remove(&t);
            }
        }
        let Some(next) = next else {
            // α left the sector: the net must be able to overturn from here.
            let over = net
                .transition_ids()
                .filter(|&t| net.transition_label(t).starts_with("overturn"))
                .any(|t| enabled(net, &held, t));
            assert!(
                over,
                "at {:?}: α left the sector but the net cannot overturn",
                s.time
            );
            fired.push("overturn".to_string());
            return fired;
        };
        let Some(steps) = path(net, &prev, &next, &inputs) else {
            panic!(
                "at {:?} with MR ML BF BB = {:?} the continuous plant went from {} to {}, which \
                 no firing sequence of the plant net does",
                s.time,
                inputs,
                marked(net, &prev),
                marked(net, &next)
            );
        };
        let mut m = held;
        for t in steps {
            let name = net.transition_label(t).to_string();
            for &i in &net.arcs_of(t).timed {
                let ta = net.timed_arcs()[i];
                let since =
                    marked_since[ta.place.index()].expect("a delayed arc's place is marked");
                // Marked during step `since` at the latest, fired during step k: at most
                // (k - since + 1) periods apart.
                let most = (k - since + 1) as u128 * period;
                assert!(
                    most >= ta.delay.as_nanos(),
                    "at {:?}: {name} fired after at most {most} ns, its delay is {:?}",
                    s.time,
                    ta.delay
                );
            }
            if let Some(d) = net.transition(t).deadline {
                if let Some(&since) = enabled_since.get(&t) {
                    // Enabled by the end of step `since`, fired after the start of step k.
                    let least = (k - 1 - since) as u128 * period;
                    assert!(
                        least <= d.as_nanos(),
                        "at {:?}: {name} fired at least {least} ns after it was enabled, its deadline is {d:?}",
                        s.time
                    );
                }
                enabled_since.remove(&t);
            }
            let before = m.clone();
            net.fire(&mut m, t).unwrap();
            for p in net.place_ids() {
                if before[p] == 0 && m[p] > 0 {
                    marked_since[p.index()] = Some(k);
                } else if m[p] == 0 {
                    marked_since[p.index()] = None;
                }
            }
            fired.push(name);
        }
        prev = next;
    }
    fired
}

fn marked(net: &Net, m: &Marking) -> String {
    net.place_ids()
        .filter(|&p| m[p] > 0 && net.place(p).input.is_none())
        .map(|p| net.place_label(p).to_string())
        .collect::<Vec<_>>()
        .join(" ")
}

/// The fired transitions of the plant net, without the rest of the cell's moves.
fn turntable_moves(fired: &[String]) -> Vec<&str> {
    fired
        .iter()
        .map(String::as_str)
        .filter(|f| {
            ![
                "TS_brings",
                "TS_takes",
                "machine_brings",
                "machine_takes",
                "chute_clears",
            ]
            .contains(f)
        })
        .collect()
}

#[test]
fn the_plant_net_allows_every_change_of_the_continuous_plant() {
    let plant = plant_net();
    let controller = read_net(&controller_text(), "controller.pnml");
    let (snaps, summary) = simulate(&controller);
    assert_eq!(snaps.len(), 1301);
    assert_eq!(
        summary,
        "turntable at 4.5°, 1 delivered south, 1 east, 1 rejected"
    );
    let fired = agree(&plant, &snaps);
    assert_eq!(
        turntable_moves(&fired),
        [
            // GoEast: from the south, left, to machine 1, back right.
            "t5_enter_from_south",
            "belt_fwd_to_centre",
            "turn_left_from_right",
            "reach_left",
            "belt_back_out_of_centre",
            "t2_leave_to_east",
            "turn_right_from_left",
            "reach_right",
            // GoSouth: left empty, from machine 1, right, to the transport system.
            "turn_left_from_right",
            "reach_left",
            "t3_enter_from_east",
            "belt_fwd_to_centre",
            "turn_right_from_left",
            "reach_right",
            "belt_back_out_of_centre",
            "t4_leave_to_south",
            // Reject: from the south through the centre to the chute.
            "t5_enter_from_south",
            "belt_fwd_to_centre",
            "belt_fwd_past_centre",
            "t1_reject_north",
        ]
    );
}

/// The mutated controllers drive the continuous plant into the error their analysis finds,
/// and the plant net still allows every step up to it.
#[test]
fn seeded_mistakes_reach_the_errors_in_the_continuous_plant() {
    let plant = plant_net();
    let swapped = read_net(&swapped_motors(&controller_text()), "swapped.pnml");
    let (snaps, summary) = simulate(&swapped);
    assert!(summary.ends_with("ERRORS: E_sector"), "{summary}");
    let fired = agree(&plant, &snaps);
    assert_eq!(
        turntable_moves(&fired),
        ["t5_enter_from_south", "belt_fwd_to_centre", "overturn"]
    );

    let loose = read_net(&without_belt_interlock(&controller_text()), "loose.pnml");
    let (snaps, summary) = simulate(&loose);
    assert!(summary.contains("ERRORS: E_belt_turning"), "{summary}");
    let fired = agree(&plant, &snaps);
    let moves = turntable_moves(&fired);
    let at = moves
        .iter()
        .position(|f| f.starts_with("belt_turning_"))
        .unwrap();
    // During the reject, the table starts turning left while the belt still runs forward.
    assert_eq!(moves[at], "belt_turning_ML_BF");
    assert_eq!(
        &moves[at - 3..at],
        [
            "t5_enter_from_south",
            "belt_fwd_to_centre",
            "turn_left_from_right"
        ]
    );
}

fn opts(controller: &Net) -> PlcOptions {
    PlcOptions {
        timed: true,
        ..PlcOptions::of(controller)
    }
}

const ERRORS: [&str; 5] = ["E_sector", "E_belt_turning", "E_MR_ML", "E_BF_BB", "E_fall"];

#[test]
fn the_closed_loop_never_marks_an_error_place_at_10_ms() {
    let plant = plant_net();
    let controller = read_net(&controller_text(), "controller.pnml");
    let cl = closed_loop(&controller, &plant, &opts(&controller)).unwrap();
    let report = never_all(&cl, &ERRORS).unwrap();
    assert!(report.complete);
    assert_eq!(
        (report.states, report.edges, report.time_locks),
        (34_372, 138_382, 0)
    );
    for (label, verdict) in &report.verdicts {
        assert!(
            matches!(verdict, NeverResult::Proved { .. }),
            "{label}: {verdict:?}"
        );
    }
    // Every timing: the plant may turn past a sensor before the next scan.
    let cl = closed_loop(&controller, &plant, &PlcOptions::of(&controller)).unwrap();
    let report = never_all(&cl, &ERRORS).unwrap();
    let reached: Vec<&str> = report
        .verdicts
        .iter()
        .filter(|(_, v)| matches!(v, NeverResult::Reached { .. }))
        .map(|(l, _)| l.as_str())
        .collect();
    assert_eq!(reached, ["plant:E_sector", "plant:E_fall"]);
}

/// Each seeded mistake makes the analysis find its error place, with a run the simulator's
/// controller side replays.
#[test]
fn the_analysis_finds_each_seeded_mistake() {
    let plant = plant_net();
    let check = |text: String, place: &str, expect_last: &str| {
        let controller = read_net(&text, "mutant.pnml");
        let cl = closed_loop(&controller, &plant, &opts(&controller)).unwrap();
        let NeverResult::Reached { moves, replays, .. } = never(&cl, place).unwrap() else {
            panic!("{place} not reached");
        };
        assert!(replays);
        let last = moves.last().unwrap().describe(&controller, &plant, 0);
        assert_eq!(last, expect_last, "{place}");
    };
    check(
        swapped_motors(&controller_text()),
        "E_sector",
        "plant fires overturn_right",
    );
    check(
        without_belt_interlock(&controller_text()),
        "E_belt_turning",
        "plant fires belt_turning_ML_BF",
    );
    // A run-out shorter than the 0.54 s a workpiece needs to the end of the belt: a rejected
    // workpiece can stay at the north end and be pushed off the west end later.
    check(
        controller_text().replace("<delay>T#1s</delay>", "<delay>T#300ms</delay>"),
        "E_fall",
        "plant fires fall_west",
    );
}

/// The labels in the net are the ones the README and the seed use.
#[test]
fn names_a_reader_of_the_seed_recognises() {
    let plant = plant_net();
    let labels: HashSet<&str> = plant.place_ids().map(|p| plant.place_label(p)).collect();
    for p in [
        "Msouth",
        "Meast",
        "Rejections",
        "right",
        "left",
        "M_minus",
        "M_plus",
    ] {
        assert!(labels.contains(p), "{p}");
    }
    for e in ERRORS {
        let p: PlaceId = plant
            .place_ids()
            .find(|&p| plant.place_label(p) == e)
            .unwrap();
        assert_eq!(plant.capacity(p), 1, "{e}");
    }
    let controller = read_net(&controller_text(), "controller.pnml");
    let t2 = controller
        .transition_ids()
        .find(|&t| controller.transition_label(t) == "T2_turn_right_empty")
        .unwrap();
    // The seed's generated TRANSITION_2: inhibitor arcs from SWP, BB and BF.
    let inhibit: Vec<&str> = controller
        .arcs_of(t2)
        .inhibit
        .iter()
        .map(|&(p, _)| controller.place_label(p))
        .collect();
    for p in ["SWP", "BB", "BF"] {
        assert!(inhibit.contains(&p), "{inhibit:?}");
    }
}
