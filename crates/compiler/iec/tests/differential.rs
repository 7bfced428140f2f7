//! The ST and IL that `petriplc compile` writes (bare text and PLCopen XML projects) run on
//! the engine exactly as `petriplc sim` runs the net: for every example net and 500 random
//! nets, under every step rule, evolution and marking representation, 2 s of 10 ms scans on
//! a timeline, outputs and markings compared scan by scan (the harness: `common/mod.rs`).
//! Half the runs build with `overflow = fault`, half with the default `wrap` (alternating
//! by mode and net), so machine code and VM are held to each other under both rules.

mod common;

use common::random::{arb_desc, build, timeline_text, Desc};
use common::{compare, example_timeline, modes, read, Figures, NETS};
use petriplc_codegen::{Form, Language};
use petriplc_iec::sema::Overflow;
use petriplc_sim::Timeline;
use proptest::strategy::{Strategy, ValueTree};
use proptest::test_runner::{Config, TestRng, TestRunner};

const LANGUAGES: [(Language, Form); 4] = [
    (Language::St, Form::Plain),
    (Language::St, Form::Project),
    (Language::Il, Form::Plain),
    (Language::Il, Form::Project),
];

/// Every other run in fault mode.
fn overflow_of(k: usize) -> Overflow {
    if k % 2 == 0 {
        Overflow::Wrap
    } else {
        Overflow::Fault
    }
}

#[test]
fn generated_code_of_the_examples_runs_as_the_nets_simulate() {
    let mut figures = Figures::default();
    let modes = modes();
    for &(name, path, sipn, timeline, plant) in NETS {
        let net = read(path, sipn);
        let timeline = example_timeline(timeline);
        figures.nets += 1;
        for (k, &mode) in modes.iter().enumerate() {
            compare(
                name,
                &net,
                timeline.as_ref(),
                plant,
                mode,
                overflow_of(k),
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
    let config = Config::default();
    // A fixed seed: the same 500 nets on every run, so a failure reproduces.
    let rng = TestRng::deterministic_rng(config.rng_algorithm);
    let mut runner = TestRunner::new_with_rng(config, rng);
    let nets: Vec<Desc> = (0..500)
        .map(|_| arb_desc().new_tree(&mut runner).unwrap().current())
        .collect();
    let modes = modes();
    // Both cores: the suite runs one test binary at a time.
    let figures = std::thread::scope(|s| {
        let workers: Vec<_> = nets
            .chunks(nets.len().div_ceil(2))
            .enumerate()
            .map(|(half, chunk)| {
                let modes = &modes;
                s.spawn(move || {
                    let mut f = Figures::default();
                    for (i, d) in chunk.iter().enumerate() {
                        let net = build(d);
                        let timeline = Timeline::parse(&timeline_text(d), "timeline.csv").unwrap();
                        let name = format!("random net {} {d:?}", half * 250 + i);
                        f.nets += 1;
                        for (k, &mode) in modes.iter().enumerate() {
                            compare(
                                &name,
                                &net,
                                Some(&timeline),
                                None,
                                mode,
                                overflow_of(i + k),
                                &[LANGUAGES[0], LANGUAGES[2]],
                                &mut f,
                            );
                        }
                    }
                    f
                })
            })
            .collect();
        let mut all = Figures::default();
        for w in workers {
            all.merge(w.join().expect("a worker panicked (its message is above)"));
        }
        all
    });
    eprintln!("{}", figures.report("random nets", modes.len()));
    assert!(figures.nets >= 500);
}
