//! Seed 004's turntable (examples/turntable) through the real binary: the README's chain run
//! as written — analysis, simulation, generated C in the loop, the soft PLC, hardware in the
//! loop over Modbus — and seeded mistakes that the analysis must find (exit code 1, with a
//! counterexample) and that must drive the continuous plant into the same error.
//!
//! The documented-commands test (docs.rs) leaves examples/turntable/README.md to this file,
//! which runs every one of its ```sh blocks (checked by `every_readme_block_is_run`).

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The ```sh blocks of the example's README, in order.
fn readme_blocks() -> Vec<String> {
    let text = std::fs::read_to_string(root().join("examples/turntable/README.md")).unwrap();
    let mut blocks = Vec::new();
    let mut current: Option<String> = None;
    for line in text.lines() {
        match (&mut current, line.trim_end()) {
            (None, "```sh") => current = Some(String::new()),
            (Some(block), "```") => {
                blocks.push(std::mem::take(block));
                current = None;
            }
            (Some(block), l) => {
                block.push_str(l);
                block.push('\n');
            }
            (None, _) => {}
        }
    }
    blocks
}

/// What picks out each README block for the test that runs it: every block matches exactly one.
const BLOCKS: [&str; 7] = [
    "--never E_sector",
    "analyze examples/turntable/plant.pnml",
    "--plant turntable",
    "--lang c",
    "diff out/turntable/trace.csv",
    "plc.conf --for",
    "plc-hil-plant.conf",
];

#[test]
fn every_readme_block_is_run() {
    for b in readme_blocks() {
        let n = BLOCKS.iter().filter(|needle| b.contains(*needle)).count();
        assert_eq!(n, 1, "a README block that no test (or several) runs:\n{b}");
    }
    assert_eq!(readme_blocks().len(), BLOCKS.len());
}

/// The one README block containing `needle`.
fn block(needle: &str) -> String {
    let found: Vec<String> = readme_blocks()
        .into_iter()
        .filter(|b| b.contains(needle))
        .collect();
    assert_eq!(found.len(), 1, "one README block with {needle:?}");
    found.into_iter().next().unwrap()
}

/// Runs a README block with bash from the repository root, `petriplc` being the built
/// binary; fails the test unless it succeeds.
fn run_block(script: &str) -> Output {
    let bin = Path::new(env!("CARGO_BIN_EXE_petriplc"));
    let path = format!(
        "{}:{}",
        bin.parent().unwrap().display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let out = Command::new("bash")
        .args(["-e", "-c", script])
        .current_dir(root())
        .env("PATH", path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{script}\nexit {:?}\nstdout:\n{}\nstderr:\n{}",
        out.status.code(),
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn text(out: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    )
}

const TRANSPORTS: &str = "1 delivered south, 1 east, 1 rejected";

/// Steps 1-4: the proof, the simulation against the continuous plant, and the generated C
/// giving the simulator's trace on the inputs the controller read.
#[test]
fn the_readme_chain_proves_simulates_and_runs_the_generated_c() {
    let out = text(&run_block(&block("--never E_sector")));
    for e in ["E_sector", "E_belt_turning", "E_MR_ML", "E_BF_BB", "E_fall"] {
        assert!(
            out.contains(&format!("never plant:{e}: proved, never marked")),
            "{e}:\n{out}"
        );
    }
    assert!(out.contains("34372 states, 138382 edges"), "{out}");
    assert!(
        out.contains("M(at_right) + M(ML) + M(at_left) + M(MR) = 1"),
        "{out}"
    );
    let svg = std::fs::read_to_string(root().join("out/turntable/controller-rg.svg")).unwrap();
    assert!(svg.contains("<svg"), "the reachability graph");

    let out = text(&run_block(&block("analyze examples/turntable/plant.pnml")));
    assert!(
        out.contains("M(right) + M(between) + M(left) + M(E_sector) = 1"),
        "{out}"
    );

    let out = text(&run_block(&block("--plant turntable")));
    assert!(
        out.contains(&format!(
            "plant at the end: turntable at 4.5°, {TRANSPORTS}"
        )),
        "{out}"
    );
    let plot = std::fs::read_to_string(root().join("out/turntable/trace.svg")).unwrap();
    assert!(
        plot.contains("plant:alpha") && plot.contains("plant:x"),
        "α and x are plotted"
    );

    run_block(&block("--lang c"));
    // `diff` exits 1 on any difference, failing the block.
    run_block(&block("diff out/turntable/trace.csv"));
    let trace = std::fs::read_to_string(root().join("out/turntable/trace-c.csv")).unwrap();
    assert!(trace.lines().count() > 20, "{trace}");
}

/// Step 5: the soft PLC runs the controller against the continuous plant for 13 s and
/// completes the three transports, as in the simulation.
#[test]
fn the_soft_plc_completes_the_transports() {
    let out = text(&run_block(&block("plc.conf --for")));
    assert!(out.contains(TRANSPORTS), "{out}");
    assert!(!out.contains("ERRORS"), "{out}");
}

/// Step 6: the controller on one PLC, the plant on another, Modbus TCP between them: the
/// same three transports.
#[test]
fn hardware_in_the_loop_completes_the_same_transports() {
    let out = text(&run_block(&block("plc-hil-plant.conf")));
    assert!(out.contains("turntable at"), "{out}");
    assert!(out.contains(TRANSPORTS), "{out}");
    assert!(!out.contains("ERRORS"), "{out}");
    assert!(
        out.contains("table connected ("),
        "the Modbus client answered: {out}"
    );
}

fn petriplc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_petriplc"))
        .args(args)
        .current_dir(root())
        .output()
        .unwrap()
}

/// A mutated copy of the controller in a temporary folder.
fn mutant(dir: &Path, name: &str, edit: impl Fn(&str) -> String) -> String {
    let text = std::fs::read_to_string(root().join("examples/turntable/controller.pnml")).unwrap();
    let edited = edit(&text);
    assert_ne!(edited, text, "the mutation changed nothing");
    let path = dir.join(name);
    std::fs::write(&path, edited).unwrap();
    path.to_str().unwrap().to_string()
}

/// Analyses a controller against the plant net for one place: (exit code, stdout).
fn analyze(controller: &str, place: &str) -> (Option<i32>, String) {
    let out = petriplc(&[
        "analyze",
        controller,
        "--plant",
        "examples/turntable/plant.pnml",
        "--period",
        "10ms",
        "--never",
        place,
    ]);
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

/// Simulates a controller against the continuous plant on the example's timeline: the
/// plant's summary line.
fn simulate(controller: &str) -> String {
    let out = petriplc(&[
        "sim",
        controller,
        "--plant",
        "turntable",
        "--inputs",
        "examples/turntable/timeline.csv",
    ]);
    assert!(out.status.success(), "{}", text(&out));
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    err.lines()
        .find(|l| l.starts_with("plant at the end: "))
        .unwrap_or_else(|| panic!("no plant summary in {err}"))
        .to_string()
}

#[test]
fn swapped_motors_turn_the_table_out_of_its_sector() {
    let dir = tempfile::tempdir().unwrap();
    let swapped = mutant(dir.path(), "swapped.pnml", |t| {
        t.replace("<output>MR</output>", "<output>@</output>")
            .replace("<output>ML</output>", "<output>MR</output>")
            .replace("<output>@</output>", "<output>ML</output>")
    });
    let (code, out) = analyze(&swapped, "E_sector");
    assert_eq!(code, Some(1), "{out}");
    assert!(
        out.contains("never plant:E_sector: VIOLATED, marked after"),
        "{out}"
    );
    // The shortest counterexample: GoSouth, the table should turn left to fetch, turns right
    // and out past SR.
    assert!(out.contains("fires T6_turn_left_to_fetch"), "{out}");
    assert!(out.contains("plant fires overturn_right"), "{out}");
    assert!(
        out.contains("time,SR,SL,SWP,GoEast,GoSouth,Reject"),
        "the timeline: {out}"
    );
    let sim = simulate(&swapped);
    assert!(sim.ends_with("ERRORS: E_sector"), "{sim}");
}

#[test]
fn without_the_belt_interlock_the_table_turns_under_a_running_belt() {
    let dir = tempfile::tempdir().unwrap();
    let loose = mutant(dir.path(), "loose.pnml", |t| {
        let start = t
            .find(r#"source="BF" target="T1_turn_left_loaded""#)
            .unwrap();
        let open = t[..start].rfind("<arc ").unwrap();
        let close = start + t[start..].find("</arc>").unwrap() + "</arc>".len();
        assert!(t[open..close].contains("inhibitor"));
        format!("{}{}", &t[..open], &t[close..])
    });
    let (code, out) = analyze(&loose, "E_belt_turning");
    assert_eq!(code, Some(1), "{out}");
    assert!(
        out.contains("never plant:E_belt_turning: VIOLATED"),
        "{out}"
    );
    assert!(
        out.contains("fires N_start"),
        "it happens during a reject: {out}"
    );
    assert!(out.contains("plant fires belt_turning_ML_BF"), "{out}");
    let sim = simulate(&loose);
    assert!(sim.contains("ERRORS: E_belt_turning"), "{sim}");
    // The unmutated controller: no error in the same simulation.
    assert_eq!(
        simulate("examples/turntable/controller.pnml"),
        format!("plant at the end: turntable at 4.5°, {TRANSPORTS}")
    );
}

#[test]
fn plant_settings_are_checked() {
    let run = |args: &[&str]| {
        let mut all = vec![
            "sim",
            "examples/turntable/controller.pnml",
            "--until",
            "0.1",
        ];
        all.extend(args);
        let out = petriplc(&all);
        (
            out.status.code(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    // Accepted settings (nothing is commanded in 0.1 s; the run just succeeds).
    let (code, err) = run(&[
        "--plant",
        "turntable",
        "--plant-set",
        "K_alpha=45",
        "--plant-set",
        "L=400",
    ]);
    assert_eq!(code, Some(0), "{err}");
    let (code, err) = run(&["--plant", "turntable", "--plant-set", "K_alpha=fast"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("turntable setting `K_alpha = fast`: give a number greater than 0 in °/s"),
        "{err}"
    );
    let (code, err) = run(&["--plant", "turntable", "--plant-set", "speed=3"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains(
            "the turntable has no setting `speed`; its settings are K_alpha, B_alpha, K_x, L, B_x"
        ),
        "{err}"
    );
    let (code, err) = run(&["--plant", "tank", "--plant-set", "L=3"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("the plant `tank` has no settings (got `L`)"),
        "{err}"
    );
    let (code, err) = run(&[
        "--plant",
        "examples/turntable/plant.pnml",
        "--plant-set",
        "L=3",
    ]);
    assert_eq!(code, Some(2), "{err}");
    assert!(
        err.contains("--plant-set applies to a built-in plant"),
        "{err}"
    );
    let (code, err) = run(&["--plant", "turntable", "--plant-set", "L"]);
    assert_eq!(code, Some(2), "{err}");
    assert!(err.contains("`L` is not NAME=VALUE"), "{err}");
}

/// The nets are what the generator writes, and valid PNML for petriplc's grammar with read
/// arcs (docs/schemas/readinhibitorptnet.pntd, checked with xmllint).
#[test]
fn the_nets_are_generated_and_valid() {
    let dir = tempfile::tempdir().unwrap();
    let status = Command::new("python3")
        .arg(root().join("examples/turntable/gen_turntable.py"))
        .arg(dir.path())
        .status()
        .unwrap();
    assert!(status.success());
    for file in ["plant.pnml", "controller.pnml"] {
        let shipped = root().join("examples/turntable").join(file);
        assert_eq!(
            std::fs::read_to_string(dir.path().join(file)).unwrap(),
            std::fs::read_to_string(&shipped).unwrap(),
            "{file}: run python3 examples/turntable/gen_turntable.py"
        );
        let out = Command::new("xmllint")
            .args(["--noout", "--relaxng"])
            .arg(root().join("docs/schemas/readinhibitorptnet.pntd"))
            .arg(&shipped)
            .output()
            .unwrap();
        assert!(out.status.success(), "{file}: {}", text(&out));
    }
}
