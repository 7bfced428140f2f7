//! The generated C means what `petriplc sim` does: for every example and for random nets,
//! under every step rule, evolution and marking representation, the C program built with `cc`
//! and run on a timeline prints exactly the trace the simulator writes.

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use common::random::{arb_desc, build, timeline_text};
use petriplc_codegen::{generate, Form, Language, Markings, Options, Request};
use petriplc_net::{Evolution, Net, ScanOptions, StepRule};
use petriplc_sim::{SimOptions, Simulation, Timeline};
use proptest::prelude::*;

/// How one run goes: the semantics, the markings, and the scans.
#[derive(Clone, Copy, Debug)]
struct Run {
    step: StepRule,
    evolve: Evolution,
    markings: Markings,
    period: Duration,
    until: Duration,
}

/// The simulator's trace CSV, or the error when the run failed.
fn simulate(net: &Net, timeline: Option<&str>, run: Run) -> Result<String, String> {
    let timeline = timeline.map(|t| Timeline::parse(t, "timeline.csv").expect("valid timeline"));
    let opts = SimOptions {
        period: run.period,
        until: run.until,
        scan: ScanOptions {
            step: run.step,
            evolve: run.evolve,
            max_passes: 1000,
        },
    };
    let sim = Simulation::new(net, opts, timeline, None).map_err(|e| e.to_string())?;
    sim.run().map(|t| t.to_csv()).map_err(|e| e.to_string())
}

/// Builds the generated C with `cc` and runs it; the trace CSV, or stderr when it failed.
fn run_c(net: &Net, timeline: Option<&str>, run: Run, dir: &Path) -> Result<String, String> {
    let mut options = Options::of(net);
    options.step = run.step;
    options.evolve = run.evolve;
    options.markings = run.markings;
    options.period = run.period;
    let request = Request {
        language: Language::C,
        form: Form::Project,
        options,
        created: common::CREATED.into(),
    };
    let code = generate(net, &request).expect("C is generated").text;
    let source = dir.join("net.c");
    let exe = dir.join("net");
    std::fs::write(&source, &code).unwrap();
    let cc = Command::new("cc")
        .args(["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror"])
        .args(["-Wno-unused-function", "-DPETRIPLC_MAIN", "-o"])
        .arg(&exe)
        .arg(&source)
        .output()
        .expect("cc runs (install a C compiler)");
    assert!(
        cc.status.success(),
        "cc failed:\n{}\n--- source ---\n{code}",
        String::from_utf8_lossy(&cc.stderr)
    );
    let mut cmd = Command::new(&exe);
    if let Some(t) = timeline {
        let path = dir.join("timeline.csv");
        std::fs::write(&path, t).unwrap();
        cmd.arg(path);
    }
    cmd.args(["--until", &format!("{}ms", run.until.as_millis())]);
    let out = cmd.output().unwrap();
    if out.status.success() {
        Ok(String::from_utf8(out.stdout).unwrap())
    } else {
        Err(String::from_utf8_lossy(&out.stderr).into_owned())
    }
}

/// Requires the C program and the simulator to agree (both fail, or identical traces).
fn check(net: &Net, timeline: Option<&str>, run: Run, dir: &Path) {
    let sim = simulate(net, timeline, run);
    let c = run_c(net, timeline, run, dir);
    match (&sim, &c) {
        (Ok(a), Ok(b)) => assert_eq!(a, b, "C trace differs from sim's ({run:?})"),
        (Err(_), Err(_)) => {}
        _ => panic!("sim and C disagree ({run:?}):\nsim: {sim:?}\nC:   {c:?}"),
    }
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("petriplc-codegen-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const RULES: [(StepRule, Evolution); 4] = [
    (StepRule::MaximalStep, Evolution::OnePass),
    (StepRule::MaximalStep, Evolution::UntilStable),
    (StepRule::Sequential, Evolution::OnePass),
    (StepRule::Sequential, Evolution::UntilStable),
];

#[test]
fn every_example_runs_in_c_as_in_sim() {
    let examples: &[(&str, Option<&str>, u64)] = &[
        ("mixer", Some("mixer/timeline.csv"), 0),
        ("blink", Some("blink/timeline.csv"), 9_000),
        ("philosophers", Some("philosophers/timeline.csv"), 0),
        ("keyboard", Some("keyboard/timeline.csv"), 0),
        ("busy-beaver", None, 1_000),
        ("tank", None, 2_000),
    ];
    let dir = scratch("examples");
    for &(name, timeline, until_ms) in examples {
        let net = common::example(name);
        let text =
            timeline.map(|t| std::fs::read_to_string(format!("{}/{t}", common::EXAMPLES)).unwrap());
        let until = if until_ms > 0 {
            Duration::from_millis(until_ms)
        } else {
            let tl = Timeline::parse(text.as_deref().unwrap(), "t").unwrap();
            tl.end() + Duration::from_secs(1)
        };
        for (step, evolve) in RULES {
            for markings in [Markings::Auto, Markings::Int] {
                let run = Run {
                    step,
                    evolve,
                    markings,
                    period: Duration::from_millis(10),
                    until,
                };
                check(&net, text.as_deref(), run, &dir);
            }
        }
    }
}

#[test]
fn degenerate_nets_run_in_c_as_in_sim() {
    let dir = scratch("degenerate");
    let timeline = "time,B\n0,0\n0.05,1\n0.12,0\n";
    for (name, net) in common::degenerate_nets() {
        let driven = net.signals().iter().any(|s| s.name == "B");
        for (step, evolve) in RULES {
            for markings in [Markings::Auto, Markings::Int] {
                let run = Run {
                    step,
                    evolve,
                    markings,
                    period: Duration::from_millis(10),
                    until: Duration::from_millis(200),
                };
                eprintln!("{name}: {run:?}");
                check(&net, driven.then_some(timeline), run, &dir);
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 40, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn random_nets_run_in_c_as_in_sim(
        d in arb_desc(),
        rule in 0..4usize,
        int in any::<bool>(),
    ) {
        let net = build(&d);
        let (step, evolve) = RULES[rule];
        let run = Run {
            step,
            evolve,
            markings: if int { Markings::Int } else { Markings::Auto },
            period: Duration::from_millis(10),
            until: Duration::from_millis(700),
        };
        let text = timeline_text(&d);
        check(&net, Some(&text), run, &scratch("random"));
    }
}
