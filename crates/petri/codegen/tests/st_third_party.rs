//! The ST petriplc writes parses with a third-party IEC 61131-3 parser, blark (a lark grammar
//! of IEC 61131-3 ST as TwinCAT 3 extends it; pinned in scripts/test-all.sh, installed into
//! target/py): every example and every degenerate net (no places, transitions, inputs or
//! outputs) under every step rule, evolution and marking representation, and 24 random nets.

mod common;

use std::path::PathBuf;
use std::process::Command;

use petriplc_codegen::{generate, Form, Language, Markings, Options, Request};
use petriplc_net::{Evolution, Net, StepRule};
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::TestRunner;

fn blark() -> PathBuf {
    let path = std::env::var_os("PETRIPLC_BLARK").map_or_else(
        || {
            PathBuf::from(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/../../../target/py/bin/blark"
            ))
        },
        PathBuf::from,
    );
    assert!(
        path.exists(),
        "{} not found: scripts/test-all.sh installs blark (pip install blark==0.8.3 into \
         target/py), or set PETRIPLC_BLARK",
        path.display()
    );
    path
}

fn st(net: &Net, step: StepRule, evolve: Evolution, markings: Markings) -> String {
    let mut options = Options::of(net);
    options.step = step;
    options.evolve = evolve;
    options.markings = markings;
    let request = Request {
        language: Language::St,
        form: Form::Plain,
        options,
        created: common::CREATED.into(),
    };
    generate(net, &request).unwrap().text
}

/// Parses all `programs` with one run of blark (it starts slowly) and fails with the
/// program around the first error.
fn parse_all(programs: &[(String, String)]) {
    let mut text = String::new();
    let mut starts = Vec::new();
    for (what, program) in programs {
        starts.push((text.lines().count() + 1, what.clone()));
        text.push_str(program);
    }
    // Tests run in parallel threads of one process: one file per call.
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let file = std::env::temp_dir().join(format!("petriplc-st-{}-{call}.st", std::process::id()));
    std::fs::write(&file, &text).unwrap();
    let out = Command::new(blark())
        .arg("parse")
        .arg(&file)
        .output()
        .unwrap();
    let _ = std::fs::remove_file(&file);
    let report = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let failed = !out.status.success() || report.contains("Failed to parse");
    if failed {
        panic!(
            "blark rejects generated ST (programs start at lines {starts:?}):\n{report}\n\
             --- source ---\n{text}"
        );
    }
}

#[test]
fn st_of_every_example_parses() {
    let mut programs = Vec::new();
    for (name, _, _) in common::EXAMPLE_NETS {
        let net = common::example(name);
        if *name == "keyboard" {
            // 2 500 lines of ST, 20 s of parsing: one variant is enough for its shapes.
            let text = st(
                &net,
                StepRule::MaximalStep,
                Evolution::OnePass,
                Markings::Auto,
            );
            programs.push((name.to_string(), text));
            continue;
        }
        for step in [StepRule::MaximalStep, StepRule::Sequential] {
            for evolve in [Evolution::OnePass, Evolution::UntilStable] {
                for markings in [Markings::Auto, Markings::Int] {
                    programs.push((
                        format!("{name} {step:?} {evolve:?} {markings:?}"),
                        st(&net, step, evolve, markings),
                    ));
                }
            }
        }
    }
    parse_all(&programs);
}

/// Nets that leave blocks of the program with nothing to do, under every step rule and
/// evolution (the marking representation changes no block's shape here).
#[test]
fn st_of_degenerate_nets_parses() {
    let mut programs = Vec::new();
    for (name, net) in common::degenerate_nets() {
        for step in [StepRule::MaximalStep, StepRule::Sequential] {
            for evolve in [Evolution::OnePass, Evolution::UntilStable] {
                programs.push((
                    format!("{name} {step:?} {evolve:?}"),
                    st(&net, step, evolve, Markings::Auto),
                ));
            }
        }
    }
    parse_all(&programs);
}

#[test]
fn st_of_random_nets_parses() {
    // A fixed seed: the same 24 nets on every run, all parsed by one blark process.
    let mut runner = TestRunner::deterministic();
    let strategy = (common::random::arb_desc(), any::<bool>(), any::<bool>());
    let mut programs = Vec::new();
    for _ in 0..24 {
        let (d, sequential, stable) = strategy.new_tree(&mut runner).unwrap().current();
        let net = common::random::build(&d);
        let step = if sequential {
            StepRule::Sequential
        } else {
            StepRule::MaximalStep
        };
        let evolve = if stable {
            Evolution::UntilStable
        } else {
            Evolution::OnePass
        };
        programs.push((format!("{d:?}"), st(&net, step, evolve, Markings::Auto)));
    }
    parse_all(&programs);
}
