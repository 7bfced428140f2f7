//! Every example of `examples/`, with the inputs and plants its README runs it with, gives
//! byte-identical traces (and the same error, where a mode makes the net fail) whether the
//! controller is scanned by the incremental evaluator (the default) or by the reference one,
//! under both step rules and both evolution modes.

use std::path::Path;
use std::time::Duration;

use petriplc_net::{Evolution, Net, ScanOptions, StepRule};
use petriplc_pnml::{Naming, ReadOptions};
use petriplc_sim::{NetPlant, Plant, SimOptions, Simulation, Timeline};

fn root() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../.."))
}

fn read(path: &str, naming: Naming) -> Net {
    petriplc_pnml::read_file(&root().join(path), &ReadOptions { naming })
        .unwrap_or_else(|e| panic!("{path}: {e}"))
        .net
}

/// The trace CSV of a run, or its error after the partial trace.
fn run(
    net: &Net,
    scan: ScanOptions,
    until: Duration,
    timeline: Option<&str>,
    plant: Option<Box<dyn Plant + '_>>,
    reference: bool,
) -> String {
    let timeline = timeline.map(|t| Timeline::read_file(root().join(t)).unwrap());
    let opts = SimOptions {
        period: Duration::from_millis(10),
        until,
        scan,
    };
    let mut sim = Simulation::new(net, opts, timeline, plant).unwrap();
    if reference {
        sim.use_reference_evaluator();
    }
    let result = sim.finish();
    let mut out = Vec::new();
    sim.trace().write_csv(&mut out).unwrap();
    let mut text = String::from_utf8(out).unwrap();
    if let Err(e) = result {
        text += &format!(
            "error: {e} ({:?})",
            std::error::Error::source(&e).map(|s| s.to_string())
        );
    }
    text
}

/// Runs an example in every mode with both evaluators and compares the traces.
fn check(net: &str, naming: Naming, timeline: Option<&str>, plant: Option<&str>, until: f64) {
    let net = read(net, naming);
    let plant_net = plant
        .filter(|p| p.ends_with(".pnml"))
        .map(|p| read(p, Naming::Plain));
    let make_plant = || -> Option<Box<dyn Plant + '_>> {
        match (plant, &plant_net) {
            (None, _) => None,
            (Some(_), Some(n)) => Some(Box::new(NetPlant::new(n, ScanOptions::of(n)))),
            (Some(name), None) => Some(petriplc_sim::builtin(name).expect("a built-in plant")),
        }
    };
    for step in [StepRule::MaximalStep, StepRule::Sequential] {
        for evolve in [Evolution::OnePass, Evolution::UntilStable] {
            let scan = ScanOptions {
                step,
                evolve,
                max_passes: ScanOptions::DEFAULT_MAX_PASSES,
            };
            let until = Duration::from_secs_f64(until);
            let incremental = run(&net, scan, until, timeline, make_plant(), false);
            let reference = run(&net, scan, until, timeline, make_plant(), true);
            assert!(
                incremental == reference,
                "{} {step} {evolve}: the incremental trace differs from the reference\n\
                 incremental:\n{incremental}\nreference:\n{reference}",
                net.id
            );
            assert!(
                incremental.lines().count() > 1,
                "{}: an empty trace",
                net.id
            );
        }
    }
}

#[test]
fn blink() {
    check(
        "examples/blink/blink.pnml",
        Naming::Plain,
        Some("examples/blink/timeline.csv"),
        None,
        9.0,
    );
}

#[test]
fn busy_beaver_on_its_tape() {
    check(
        "examples/busy-beaver/busy-beaver.pnml",
        Naming::Plain,
        None,
        Some("tape"),
        1.0,
    );
}

#[test]
fn keyboard_with_its_plant() {
    check(
        "examples/keyboard/keyboard.pnml",
        Naming::Plain,
        Some("examples/keyboard/timeline.csv"),
        Some("keyboard"),
        10.0,
    );
}

#[test]
fn mixer_with_its_timeline_and_with_the_tank_net() {
    check(
        "examples/mixer/mixer.pnml",
        Naming::Sipn,
        Some("examples/mixer/timeline.csv"),
        None,
        9.9,
    );
    check(
        "examples/mixer/mixer.pnml",
        Naming::Sipn,
        Some("examples/mixer/press-b1.csv"),
        Some("examples/mixer/tank.pnml"),
        28.0,
    );
}

#[test]
fn philosophers() {
    check(
        "examples/philosophers/philosophers.pnml",
        Naming::Plain,
        Some("examples/philosophers/timeline.csv"),
        None,
        10.0,
    );
}

/// The examples checked above with their own inputs and plants, by net file.
const CHECKED: &[&str] = &[
    "examples/blink/blink.pnml",
    "examples/busy-beaver/busy-beaver.pnml",
    "examples/keyboard/keyboard.pnml",
    "examples/mixer/mixer.pnml",
    "examples/philosophers/philosophers.pnml",
];

/// Every other net under `examples/` (plant nets, examples added later) is checked too, as a
/// controller driven by the `timeline.csv` beside it when that fits its inputs, else alone.
#[test]
fn every_other_example_net() {
    let mut nets = Vec::new();
    for dir in std::fs::read_dir(root().join("examples")).unwrap() {
        let dir = dir.unwrap().path();
        if !dir.is_dir() {
            continue;
        }
        for f in std::fs::read_dir(&dir).unwrap() {
            let f = f.unwrap().path();
            if f.extension().is_some_and(|e| e == "pnml") {
                let rel = f
                    .strip_prefix(root())
                    .unwrap()
                    .to_string_lossy()
                    .into_owned();
                if !CHECKED.contains(&rel.as_str()) {
                    nets.push(rel);
                }
            }
        }
    }
    nets.sort();
    assert!(!nets.is_empty(), "no other example nets found");
    for rel in &nets {
        let dir = Path::new(rel).parent().unwrap();
        let timeline = dir.join("timeline.csv");
        let net = read(rel, Naming::Plain);
        let fits = root().join(&timeline).exists() && {
            let t = Timeline::read_file(root().join(&timeline)).unwrap();
            let opts = SimOptions {
                period: Duration::from_millis(10),
                until: Duration::from_secs(1),
                scan: ScanOptions::of(&net),
            };
            Simulation::new(&net, opts, Some(t), None).is_ok()
        };
        let timeline = fits.then(|| timeline.to_string_lossy().into_owned());
        check(rel, Naming::Plain, timeline.as_deref(), None, 10.0);
    }
}
