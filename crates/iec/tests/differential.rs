//! The ST and IL that `petriplc compile` writes (bare text and PLCopen XML projects) run on
//! the engine exactly as `petriplc sim` runs the net: for every example net and 500 random
//! nets, under every step rule, evolution and marking representation, 2 s of 10 ms scans on
//! a timeline, outputs and markings compared scan by scan (the harness: `common/mod.rs`).

mod common;

use common::random::{arb_desc, build, timeline_text};
use common::{compare, example_timeline, modes, read, Figures, NETS};
use petriplc_codegen::{Form, Language};
use petriplc_sim::Timeline;
use proptest::test_runner::{Config, TestRng, TestRunner};

const LANGUAGES: [(Language, Form); 4] = [
    (Language::St, Form::Plain),
    (Language::St, Form::Project),
    (Language::Il, Form::Plain),
    (Language::Il, Form::Project),
];

#[test]
fn generated_code_of_the_examples_runs_as_the_nets_simulate() {
    let mut figures = Figures::default();
    let modes = modes();
    for &(name, path, sipn, timeline, plant) in NETS {
        let net = read(path, sipn);
        let timeline = example_timeline(timeline);
        figures.nets += 1;
        for &mode in &modes {
            compare(
                name,
                &net,
                timeline.as_ref(),
                plant,
                mode,
                &LANGUAGES,
                &mut figures,
            );
        }
    }
    eprintln!("{}", figures.report("examples", modes.len()));
    assert!(figures.scans() > 0);
}

#[test]
fn generated_code_of_random_nets_runs_as_the_nets_simulate() {
    let config = Config {
        cases: 500,
        failure_persistence: None,
        ..Config::default()
    };
    // A fixed seed: a failure reproduces on every run.
    let rng = TestRng::deterministic_rng(config.rng_algorithm);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let modes = modes();
    let figures = std::cell::RefCell::new(Figures::default());
    runner
        .run(&arb_desc(), |d| {
            let net = build(&d);
            let timeline = Timeline::parse(&timeline_text(&d), "timeline.csv").unwrap();
            let mut f = figures.borrow_mut();
            f.nets += 1;
            for &mode in &modes {
                compare(
                    "random",
                    &net,
                    Some(&timeline),
                    None,
                    mode,
                    &[LANGUAGES[0], LANGUAGES[2]],
                    &mut f,
                );
            }
            Ok(())
        })
        .unwrap();
    let figures = figures.into_inner();
    eprintln!("{}", figures.report("random nets", modes.len()));
    assert!(figures.nets >= 500);
}
