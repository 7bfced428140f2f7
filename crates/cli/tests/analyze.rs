//! `petriplc analyze` through the real binary: text and JSON reports against known answers,
//! unbounded nets, limits, graph export, and closed-loop proofs and counterexamples.

use assert_cmd::Command;
use predicates::prelude::*;
use serde_json::Value;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../..");
const MCC: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../testdata/mcc");

fn petriplc(args: &[&str]) -> Command {
    let mut cmd = Command::cargo_bin("petriplc").unwrap();
    cmd.current_dir(ROOT).args(args);
    cmd
}

/// Runs `analyze --json` on `net` (with extra args) and returns the report.
fn json(net: &str, extra: &[&str]) -> Value {
    let mut args = vec!["analyze", net, "--json"];
    args.extend_from_slice(extra);
    let out = petriplc(&args)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    serde_json::from_slice(&out).unwrap()
}

/// Checks the JSON report of `net` against `expect`: each listed key must equal its value.
fn check(net: &str, extra: &[&str], expect: &[(&str, Value)]) -> Value {
    let report = json(net, extra);
    for (key, value) in expect {
        assert_eq!(&report[*key], value, "`{key}` of {net}");
    }
    report
}

fn mcc(model: &str) -> String {
    format!("{MCC}/{model}/model.pnml")
}

#[test]
fn json_matches_the_model_checking_contest() {
    use serde_json::json;
    // Philosophers-PT-000005: 243 states, 945 edges, a deadlock (all hold one fork).
    let r = check(
        &mcc("Philosophers-PT-000005"),
        &[],
        &[
            ("complete", json!(true)),
            ("bounded", json!(true)),
            ("states", json!(243)),
            ("edges", json!(945)),
            ("max_tokens_place", json!(1)),
            ("max_tokens_marking", json!(10)),
            ("safe", json!(true)),
            ("deadlock", json!(true)),
            ("quasi_live", json!(true)),
            ("live", json!(false)),
            ("structurally_bounded", json!(true)),
        ],
    );
    let trace = r["deadlock_trace"].as_array().expect("a deadlock trace");
    assert_eq!(trace.len(), 5, "each philosopher takes one fork: {trace:?}");
    assert_eq!(r["place_bounds"].as_object().unwrap().len(), 25);
    for inv in r["p_invariants"].as_array().unwrap() {
        assert!(inv
            .as_object()
            .unwrap()
            .values()
            .all(|w| w.as_u64().unwrap() > 0));
    }
    // A live, reversible net.
    check(
        &mcc("ERK-PT-000001"),
        &[],
        &[
            ("states", json!(13)),
            ("edges", json!(30)),
            ("deadlock", json!(false)),
            ("live", json!(true)),
            ("deadlock_trace", Value::Null),
        ],
    );
}

#[test]
fn unbounded_nets_have_no_state_count() {
    use serde_json::json;
    let r = check(
        &mcc("CryptoMiner-PT-D03N000"),
        &[],
        &[
            ("bounded", json!(false)),
            ("states", Value::Null),
            ("edges", Value::Null),
            ("complete", json!(true)),
        ],
    );
    assert!(!r["unbounded_places"].as_array().unwrap().is_empty());
    assert!(r["place_bounds"]
        .as_object()
        .unwrap()
        .values()
        .any(|b| b == "inf"));
}

#[test]
fn max_states_gives_a_partial_report() {
    use serde_json::json;
    let r = check(
        &mcc("Philosophers-PT-000010"),
        &["--max-states", "100"],
        &[("complete", json!(false))],
    );
    assert!(r["states"].as_u64().unwrap() < 59049);
    assert!(r["incomplete"]
        .as_array()
        .unwrap()
        .iter()
        .any(|s| s.as_str().unwrap().contains("max-states")));
}

#[test]
fn text_report_puts_properties_then_invariants_then_conflicts() {
    let out = petriplc(&["analyze", "examples/mixer/mixer.pnml", "--names", "sipn"])
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let text = String::from_utf8(out).unwrap();
    let at = |s: &str| {
        text.find(s)
            .unwrap_or_else(|| panic!("no `{s}` in\n{text}"))
    };
    assert!(at("states:             4") < at("P-invariants: 8"));
    assert!(at("P-invariants: 8") < at("conflicts"));
    assert!(text.contains("M(L1) + M(L2) + M(L3) = 1"), "{text}");
    assert!(text.contains("B1 + N2 + N3 + N1"), "T-invariant: {text}");
    // SIPN: with every sensor on at once the mixer cycles B1 N2 N3 N1 within one scan.
    assert!(
        text.contains("the firings B1 N2 N3 N1 repeat forever"),
        "{text}"
    );
}

#[test]
fn graph_export_and_its_limit() {
    let dir = tempfile::tempdir().unwrap();
    let dot = dir.path().join("rg.dot");
    let svg = dir.path().join("rg.svg");
    petriplc(&["analyze", "examples/mixer/mixer.pnml", "--names", "sipn"])
        .args([
            "--dot".as_ref(),
            dot.as_os_str(),
            "--svg".as_ref(),
            svg.as_os_str(),
        ])
        .assert()
        .success();
    let dot = std::fs::read_to_string(dot).unwrap();
    assert_eq!(dot.matches(" -> ").count(), 4, "{dot}");
    assert!(dot.contains("label=\"A1 V1 L2\""), "{dot}");
    let svg = std::fs::read_to_string(svg).unwrap();
    assert!(
        svg.contains("<svg") && svg.contains("A1 V1 L2"),
        "Graphviz laid the graph out"
    );
    petriplc(&[
        "analyze",
        "examples/mixer/mixer.pnml",
        "--names",
        "sipn",
        "--dot",
        "x.dot",
        "--graph-limit",
        "3",
    ])
    .assert()
    .code(2)
    .stderr(predicate::str::contains(
        "4 states, more than --graph-limit 3",
    ));
}

#[test]
fn never_needs_a_plant() {
    petriplc(&["analyze", "examples/mixer/mixer.pnml", "--never", "L1"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains("--plant"));
}

const OBSERVED_TANK: &str = "examples/mixer/tank-observed.pnml";
const WRONG_MIXER: &str = "crates/petri/closedloop/tests/data/mixer-wrong.pnml";

#[test]
fn closed_loop_proves_the_valves_exclusive() {
    petriplc(&[
        "analyze",
        "examples/mixer/mixer.pnml",
        "--names",
        "sipn",
        "--plant",
        OBSERVED_TANK,
        "--never",
        "both_open",
    ])
    .assert()
    .success()
    .stdout(predicate::str::contains(
        "never plant:both_open: proved, never marked",
    ));
}

/// Untimed, the plant may fill the tank before the controller's next scan; at a 10 ms scan
/// with the tank's delays kept, the controller closes V1 at N2 long before `high`.
#[test]
fn a_timed_closed_loop_proves_what_every_timing_cannot() {
    let run = |timed: bool| {
        let mut args = vec![
            "analyze",
            "examples/mixer/mixer.pnml",
            "--names",
            "sipn",
            "--plant",
            OBSERVED_TANK,
            "--never",
            "both_open",
            "--never",
            "overfill",
            "--json",
        ];
        if timed {
            args.extend(["--period", "10ms"]);
        }
        let out = petriplc(&args).output().unwrap();
        let report: Value = serde_json::from_slice(&out.stdout).unwrap();
        (out.status.code(), report["closed_loop"].clone())
    };
    let (code, cl) = run(false);
    assert_eq!(code, Some(1));
    assert_eq!(
        (cl["states"].as_u64(), cl["edges"].as_u64()),
        (Some(25), Some(45))
    );
    let verdicts = |cl: &Value| -> Vec<String> {
        cl["places"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| {
                format!(
                    "{} {}",
                    p["label"].as_str().unwrap(),
                    p["verdict"].as_str().unwrap()
                )
            })
            .collect()
    };
    assert_eq!(
        verdicts(&cl),
        ["plant:both_open never", "plant:overfill reached"]
    );
    assert_eq!(cl["timed"], false);
    let (code, cl) = run(true);
    assert_eq!(code, Some(0));
    assert_eq!(
        verdicts(&cl),
        ["plant:both_open never", "plant:overfill never"]
    );
    assert_eq!(
        (cl["timed"].as_bool(), cl["period"].as_f64()),
        (Some(true), Some(0.01))
    );
    assert!(cl["complete"].as_bool().unwrap());
}

#[test]
fn closed_loop_counterexample_replays_in_the_simulator() {
    let out = petriplc(&[
        "analyze",
        WRONG_MIXER,
        "--names",
        "sipn",
        "--plant",
        OBSERVED_TANK,
        "--never",
        "both_open",
        "--json",
    ])
    .assert()
    .code(1)
    .stderr(predicate::str::contains("`both_open` can be marked"))
    .get_output()
    .stdout
    .clone();
    let report: Value = serde_json::from_slice(&out).unwrap();
    assert_eq!(report["never"]["verdict"], "reached");
    let timeline = report["never"]["timeline"].as_str().unwrap();
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("cex.csv");
    std::fs::write(&csv, timeline).unwrap();
    // Replayed, the wrong controller opens V3 (N3 fires) while V1 is still open.
    let trace = petriplc(&["sim", WRONG_MIXER, "--names", "sipn", "--until", "0.02"])
        .arg("--inputs")
        .arg(&csv)
        .assert()
        .success()
        .get_output()
        .stdout
        .clone();
    let trace = String::from_utf8(trace).unwrap();
    let last = trace.lines().last().unwrap();
    assert!(
        last.starts_with("0.02,") && last.ends_with(",N3"),
        "{trace}"
    );
}

/// A place marked in the plant's initial marking is not "reached after" anything, and the
/// verdict says which abstraction it holds for.
#[test]
fn never_words_the_start_and_names_its_abstraction() {
    let never = |place: &str| {
        petriplc(&[
            "analyze",
            "examples/mixer/mixer.pnml",
            "--names",
            "sipn",
            "--plant",
            OBSERVED_TANK,
            "--never",
            place,
        ])
        .assert()
    };
    let out = never("dry")
        .code(1)
        .stderr(predicate::str::contains(
            "error: `dry` is marked from the start",
        ))
        .get_output()
        .stdout
        .clone();
    let out = String::from_utf8(out).unwrap();
    assert!(
        out.contains(
            "closed loop with plant tank_observed (every timing: any scan period, plant delays \
             ignored)\n  1 state, 0 edges (search stopped early), "
        ),
        "{out}"
    );
    assert!(
        out.contains(
            "\n  never plant:dry: VIOLATED, marked from the start, in the initial marking, \
             before\n  any scan or plant move: there is nothing to replay\n"
        ),
        "{out}"
    );
    let out = never("overfill").code(1).get_output().stdout.clone();
    let out = String::from_utf8(out).unwrap();
    assert!(
        out.contains(
            "never plant:overfill: VIOLATED, marked after 1 controller scan and 4 plant moves:"
        ),
        "{out}"
    );
    assert!(
        out.contains("The plant's moves here ignore its delays"),
        "{out}"
    );
    assert!(
        out.contains("plant:overfill is marked after 1 controller scan and 4 plant moves\n"),
        "{out}"
    );
}

#[test]
fn max_memory_gives_a_partial_report_with_the_limit() {
    use serde_json::json;
    // Philosophers-PT-000010 has 59 049 states; 256 KiB of states holds far fewer.
    let r = check(
        &mcc("Philosophers-PT-000010"),
        &["--max-memory", "256K"],
        &[
            ("complete", json!(false)),
            // Nothing found yet decides these: they are not claimed.
            ("deadlock", Value::Null),
            ("dead_transitions", Value::Null),
            ("live", Value::Null),
            ("reversible", Value::Null),
        ],
    );
    assert!(r["states"].as_u64().unwrap() < 59049);
    let why = r["incomplete"].to_string();
    assert!(why.contains("--max-memory 256K"), "{why}");
    // What the part explored shows holds: every transition fired somewhere.
    assert_eq!(r["quasi_live"], json!(true));
}

#[test]
fn max_memory_reads_sizes() {
    petriplc(&[
        "analyze",
        "examples/mixer/mixer.pnml",
        "--max-memory",
        "lots",
    ])
    .assert()
    .code(2)
    .stderr(predicate::str::contains("write a size such as 512M"));
}

/// The progress bar is for terminals: piped, an exploration long enough for the bar to show
/// on a terminal (over a second in a debug build) writes nothing to standard error.
#[test]
fn no_progress_bar_when_piped() {
    let net = format!("{MCC}/Kanban-PT-00005/model.pnml");
    let out = petriplc(&["analyze", &net, "--json", "--max-states", "200000"])
        .assert()
        .success()
        .get_output()
        .clone();
    let r: Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r["complete"], serde_json::json!(false));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !err.contains("states/s") && !err.contains('\u{1b}'),
        "progress written to a pipe: {err}"
    );
}
