//! The Model Checking Contest models in testdata/mcc and their known answers, shared by
//! the debug suite (tests/mcc.rs) and the release-only suite (tests/mcc_big.rs).

use std::path::{Path, PathBuf};

use petriplc_reach::{coverability, explore, properties, ExploreOptions};

pub const MCC: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../testdata/mcc");

/// Models up to this many states run in the debug suite.
pub const SMALL: u64 = 100_000;

/// Unbounded models whose coverability analysis takes seconds in release and minutes in a
/// debug build: they run in the release suite.
const SLOW_UNBOUNDED: [&str; 2] = ["DoubleLock-PT-p1s1", "Planning-PT-none"];

/// Whether a model belongs in the release-only suite (tests/mcc_big.rs).
pub fn big(name: &str) -> bool {
    Expect::of(name).states.is_some_and(|s| s > SMALL) || SLOW_UNBOUNDED.contains(&name)
}

/// A model's answers; `None` where the contest's answer is unknown (`?` or no file).
#[derive(Debug, Default)]
pub struct Expect {
    /// `None` for `+inf` (unbounded).
    pub states: Option<u64>,
    pub edges: Option<u64>,
    pub max_place: Option<u64>,
    pub max_marking: Option<u64>,
    pub deadlock: Option<bool>,
    pub quasi_live: Option<bool>,
    pub live: Option<bool>,
    pub one_safe: Option<bool>,
}

fn read(dir: &Path, name: &str, suffix: &str) -> String {
    std::fs::read_to_string(dir.join(format!("{name}-{suffix}.out"))).unwrap_or_default()
}

fn verdict(text: &str) -> Option<bool> {
    let line = text.lines().find(|l| l.starts_with("FORMULA "))?;
    match line.split_whitespace().nth(2)? {
        "TRUE" => Some(true),
        "FALSE" => Some(false),
        _ => None,
    }
}

impl Expect {
    pub fn of(name: &str) -> Expect {
        let dir = Path::new(MCC).join(name);
        let ss = read(&dir, name, "SS");
        let figure = |key: &str| {
            ss.lines()
                .find(|l| l.starts_with(&format!("STATE_SPACE {key} ")))
                .and_then(|l| l.split_whitespace().nth(2))
                .and_then(|v| v.parse::<u64>().ok())
        };
        Expect {
            states: figure("STATES"),
            edges: figure("TRANSITIONS"),
            max_place: figure("MAX_TOKEN_IN_PLACE"),
            max_marking: figure("MAX_TOKEN_PER_MARKING"),
            deadlock: verdict(&read(&dir, name, "RD")),
            quasi_live: verdict(&read(&dir, name, "QL")),
            live: verdict(&read(&dir, name, "L")),
            one_safe: verdict(&read(&dir, name, "OS")),
        }
    }
}

/// Every model folder, by name.
pub fn models() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(MCC)
        .expect("testdata/mcc, part of the repository")
        .filter_map(|e| e.ok())
        .filter(|e| e.path().join("model.pnml").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

pub fn net(name: &str) -> petriplc_net::Net {
    let path: PathBuf = Path::new(MCC).join(name).join("model.pnml");
    petriplc_pnml::read_file(&path, &Default::default())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
        .net
}

fn show(b: Option<bool>) -> &'static str {
    match b {
        Some(true) => "TRUE",
        Some(false) => "FALSE",
        None => "?",
    }
}

/// Checks one model against its answers and returns its row for the results table; panics
/// with every mismatch.
pub fn check(name: &str, threads: usize) -> String {
    let net = net(name);
    let want = Expect::of(name);
    let started = std::time::Instant::now();
    let mut wrong = Vec::new();
    let row = if want.states.is_none() {
        let c = coverability(&net, 1_000_000, None);
        if !(c.complete && !c.bounded && !c.unbounded_places.is_empty()) {
            wrong.push(format!("coverability: {c:?}"));
        }
        format!(
            "| {name} | +inf | +inf | +inf | +inf | {} | {} | {} | {} | unbounded ({} of {} places, {} nodes) | {:.2} s |",
            show(want.deadlock),
            show(want.quasi_live),
            show(want.live),
            show(want.one_safe),
            c.unbounded_places.len(),
            net.places().len(),
            c.nodes,
            started.elapsed().as_secs_f64()
        )
    } else {
        // Liveness needs no kept graph: its components are found from the states.
        let opts = ExploreOptions {
            threads,
            ..Default::default()
        };
        let space = explore(&net, &opts).unwrap_or_else(|e| panic!("{name}: {e}"));
        let p = properties(&net, &space);
        let mut eq = |what: &str, got: u64, want: Option<u64>| {
            if want.is_some_and(|w| w != got) {
                wrong.push(format!("{what}: got {got}, want {want:?}"));
            }
        };
        eq("states", p.states, want.states);
        eq("edges", p.edges, want.edges);
        eq("max tokens in a place", p.max_tokens_place, want.max_place);
        eq(
            "max tokens in a marking",
            p.max_tokens_marking,
            want.max_marking,
        );
        let mut same = |what: &str, got: Option<bool>, want: Option<bool>| {
            if want.is_some() && got != want {
                wrong.push(format!("{what}: got {got:?}, want {want:?}"));
            }
        };
        same("deadlock", Some(p.deadlock), want.deadlock);
        same("quasi-live", Some(p.quasi_live), want.quasi_live);
        same("live", p.live, want.live);
        same("1-safe", Some(p.safe), want.one_safe);
        if !p.complete {
            wrong.push("incomplete".into());
        }
        if let Some(trace) = &p.deadlock_trace {
            // The trace must lead from M0 to a marking that enables nothing.
            let mut m = net.initial_marking();
            for &t in trace {
                assert!(
                    net.is_enabled(&m, t),
                    "{name}: trace fires a disabled transition"
                );
                net.fire(&mut m, t).unwrap();
            }
            if net.transition_ids().any(|t| net.is_enabled(&m, t)) {
                wrong.push("deadlock trace ends in a live marking".into());
            }
        }
        format!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} | {} levels, trace {} | {:.2} s |",
            p.states,
            p.edges,
            p.max_tokens_place,
            p.max_tokens_marking,
            show(Some(p.deadlock)),
            show(Some(p.quasi_live)),
            show(p.live),
            show(Some(p.safe)),
            space.levels(),
            p.deadlock_trace
                .map_or("-".to_string(), |t| t.len().to_string()),
            started.elapsed().as_secs_f64()
        )
    };
    assert!(wrong.is_empty(), "{name}: {}", wrong.join("; "));
    row
}
