//! The examples of examples/*, run through the real `petriplc` binary. Each test states the
//! trace the seeds' semantics predict (derived by hand in the comments) and checks it.
//!
//! Rules used throughout (docs/semantics.md): a scan every 10 ms at t = k·10 ms applies the
//! timeline, steps the plant on the controller's outputs of the previous scan, then scans the
//! controller; maximal step, one pass per scan, the lowest transition index wins a conflict;
//! tokens produced by a scan can fire only in the next scan; a delayed arc's timer looks at the
//! marking at the start of each pass, so a place marked by the scan at t is first seen at
//! t + 10 ms and a delay d on its arc holds from t + 10 ms + d.

use std::collections::BTreeMap;
use std::fs;
use std::path::{Path, PathBuf};

use assert_cmd::Command;

/// The workspace root, where the examples' commands are run from.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// A parsed trace CSV (`time,in:<input>…,<outputs…>,m:<place>…,fired`) and the run's
/// standard error.
struct Trace {
    header: Vec<String>,
    rows: Vec<Row>,
    stderr: String,
}

struct Row {
    /// Milliseconds.
    t: u64,
    cells: Vec<String>,
}

/// Runs `petriplc sim <args> --out <tmp>/trace.csv` from the workspace root, checks it
/// succeeds, and parses the trace it wrote.
fn sim(args: &[&str]) -> Trace {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("trace.csv");
    let output = Command::cargo_bin("petriplc")
        .unwrap()
        .current_dir(root())
        .arg("sim")
        .args(args)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(
        output.status.success(),
        "petriplc sim {args:?} failed ({}):\n{stderr}",
        output.status
    );
    let csv = fs::read_to_string(&out).unwrap();
    let mut lines = csv.lines();
    let header: Vec<String> = lines
        .next()
        .expect("a header")
        .split(',')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|line| {
            let cells: Vec<String> = line.split(',').map(str::to_string).collect();
            assert_eq!(cells.len(), header.len(), "row `{line}`");
            Row {
                t: millis(&cells[0]),
                cells,
            }
        })
        .collect();
    Trace {
        header,
        rows,
        stderr,
    }
}

/// "8.96" → 8960.
fn millis(time: &str) -> u64 {
    let (s, frac) = time.split_once('.').unwrap_or((time, ""));
    assert!(frac.len() <= 3, "time {time} is finer than a millisecond");
    s.parse::<u64>().unwrap() * 1000 + format!("{frac:0<3}").parse::<u64>().unwrap()
}

/// "1.5" for 1500, for readable expectations.
fn secs(ms: u64) -> String {
    let s = format!("{}.{:03}", ms / 1000, ms % 1000);
    s.trim_end_matches('0').trim_end_matches('.').to_string()
}

impl Trace {
    fn col(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name} in {:?}", self.header))
    }
    fn value(&self, row: &Row, name: &str) -> i64 {
        row.cells[self.col(name)].parse().unwrap()
    }
    fn fired<'r>(&self, row: &'r Row) -> Vec<&'r str> {
        row.cells.last().unwrap().split_whitespace().collect()
    }
    /// Output columns (neither `time`, `in:…`, `m:…` nor `fired`).
    fn outputs(&self) -> Vec<&str> {
        self.header[1..self.header.len() - 1]
            .iter()
            .map(String::as_str)
            .filter(|h| !h.starts_with("m:") && !h.starts_with("in:"))
            .collect()
    }
    /// Per row where an output changed or something fired (and the first): time, the outputs
    /// that are on (sorted), the transitions fired — one string each. Rows for an input
    /// change alone are left out.
    fn story(&self) -> Vec<String> {
        let mut outputs = self.outputs();
        outputs.sort_unstable();
        let mut last_on = None;
        let mut story = Vec::new();
        for r in &self.rows {
            let on: Vec<&str> = outputs
                .iter()
                .copied()
                .filter(|o| self.value(r, o) != 0)
                .collect();
            let fired = self.fired(r);
            if last_on.as_ref() == Some(&on) && fired.is_empty() {
                continue;
            }
            story.push(
                format!("{} [{}] {}", secs(r.t), on.join(" "), fired.join(" "))
                    .trim_end()
                    .to_string(),
            );
            last_on = Some(on);
        }
        story
    }
    /// Every firing as "time label".
    fn firings(&self) -> Vec<String> {
        self.rows
            .iter()
            .flat_map(|r| {
                self.fired(r)
                    .into_iter()
                    .map(move |f| format!("{} {f}", secs(r.t)))
            })
            .collect()
    }
    /// The intervals [on, off) in which `output` is 1, as "on-off" ("on-" when still on at the end).
    fn on_intervals(&self, output: &str) -> Vec<String> {
        let mut out = Vec::new();
        let mut since = None;
        for r in &self.rows {
            match (since, self.value(r, output) != 0) {
                (None, true) => since = Some(r.t),
                (Some(s), false) => {
                    out.push(format!("{}-{}", secs(s), secs(r.t)));
                    since = None;
                }
                _ => {}
            }
        }
        if let Some(s) = since {
            out.push(format!("{}-", secs(s)));
        }
        out
    }
}

// ---------------------------------------------------------------------------------------------
// 1. Mixer tank (seed 002, section 5)

/// The README's command: one cycle with the sensors from examples/mixer/timeline.csv. Each
/// transition fires in the scan its sensor comes on, so every change happens exactly at a
/// timeline time, in the order the paper describes.
#[test]
fn mixer_runs_one_cycle_from_the_timeline() {
    let dir = tempfile::tempdir().unwrap();
    let svg = dir.path().join("mixer-trace.svg");
    let t = sim(&[
        "examples/mixer/mixer.pnml",
        "--names",
        "sipn",
        "--inputs",
        "examples/mixer/timeline.csv",
        "--plot",
        svg.to_str().unwrap(),
    ]);
    assert_eq!(
        t.story(),
        [
            "0 [L1]",               // ready, waiting for the start button
            "1 [A1 L2 V1] B1",      // filling with solvent, heater on, lamp "filling"
            "3.5 [A1 L2 M1 V2] N2", // 50 %: V1 closed, solute and mixer on
            "5.5 [L3 V3] N3",       // 90 %: V2, M1, A1, L2 off; draining, lamp "draining"
            "8.9 [L1] N1",          // empty: ready again
        ]
    );
    assert_eq!(t.header.iter().filter(|h| h.starts_with("m:")).count(), 8);
    // The CSV alone tells why each transition fired: its input is 1 in the same row, and
    // the inputs come in the timeline's order.
    assert_eq!(t.header[1..5], ["in:B1", "in:N1", "in:N2", "in:N3"]);
    for r in &t.rows {
        for f in t.fired(r) {
            assert_eq!(t.value(r, &format!("in:{f}")), 1, "{f} at {}", secs(r.t));
        }
    }
    let plot = fs::read_to_string(&svg).unwrap();
    // Every marking repeats its output: none gets a lane of its own.
    assert!(plot.contains("L1 = m:L1"), "{plot:.400}");
    assert!(!plot.contains(">\nm:L1\n<"), "a lane for m:L1");
    assert!(plot.contains("<svg"), "not an SVG: {:.80}", plot);
}

/// The controller's four firings per cycle with a tank plant: (time in ms, transition).
fn mixer_events(t: &Trace) -> Vec<(u64, String)> {
    t.rows
        .iter()
        .flat_map(|r| t.fired(r).into_iter().map(move |f| (r.t, f.to_string())))
        .collect()
}

/// Closed loop with the tank as a Petri net (examples/mixer/tank.pnml); only B1 comes from the
/// timeline. First cycle, B1 pressed at 1 s, the tank dry:
///   1.00   B1 fires, V1 on (the plant sees it at 1.01)
///   1.26   fill_dry_V1: V1's read arc held 250 ms from 1.01 → N1 off
///   3.52   fill_mid_V1: low marked at 1.26, seen at 1.27, + 2.25 s → N2 on → N2 fires
///   5.53   fill_high_V2: mid marked at 3.52, seen at 3.53, + 2 s → N3 on → N3 fires, V3 on
///   5.54   drain_high (V3 seen) → N3 off;  7.15 drain_mid (mid seen at 5.55, + 1.6 s)
///   8.96   drain_low (low seen at 7.16, + 1.8 s) → bottom, N1 on → N1 fires, L1 on
/// Draining stops at N1 (5 %), so the next cycles start from `bottom`: with B1 at s,
/// fill_bottom at s+10ms, then N2 at s+2270, N3 at s+4280, N1 at s+7710.
/// The press at 5 s falls inside the first cycle and is ignored (L1 is empty).
#[test]
fn mixer_cycles_against_the_tank_net() {
    let t = sim(&[
        "examples/mixer/mixer.pnml",
        "--names",
        "sipn",
        "--plant",
        "examples/mixer/tank.pnml",
        "--inputs",
        "examples/mixer/press-b1.csv",
        "--until",
        "28s",
    ]);
    let mut expect = Vec::new();
    for (s, from_dry) in [(1000, true), (10_000, false), (19_000, false)] {
        let offsets = if from_dry {
            [0, 2520, 4530, 7960]
        } else {
            [0, 2270, 4280, 7710]
        };
        for (dt, tr) in offsets.into_iter().zip(["B1", "N2", "N3", "N1"]) {
            expect.push((s + dt, tr.to_string()));
        }
    }
    assert_eq!(mixer_events(&t), expect);
    let story = t.story();
    assert_eq!(
        story[..5],
        [
            "0 [L1]",
            "1 [A1 L2 V1] B1",
            "3.52 [A1 L2 M1 V2] N2",
            "5.53 [L3 V3] N3",
            "8.96 [L1] N1"
        ]
    );
    assert_eq!(story.len(), 1 + 3 * 4, "{story:#?}");
    // The tank net ends drained to N1 (its summary lists the marked places).
    assert!(
        t.stderr.contains("plant at the end: tank, marking bottom"),
        "{}",
        t.stderr
    );
}

/// The same loop against the built-in continuous `tank` plant, whose sensors switch exactly
/// at 1.25 s, 3.5 s, 5.5 s and 8.9 s of the first cycle (the times of timeline.csv) and which
/// keeps 5 % after each drain, as the net's `bottom` place does. The net model follows it
/// within three scans: each level place costs one scan before its timer starts.
#[test]
fn mixer_tank_net_agrees_with_the_builtin_tank() {
    let builtin = sim(&[
        "examples/mixer/mixer.pnml",
        "--names",
        "sipn",
        "--plant",
        "tank",
        "--inputs",
        "examples/mixer/press-b1.csv",
        "--until",
        "28s",
    ]);
    let net = sim(&[
        "examples/mixer/mixer.pnml",
        "--names",
        "sipn",
        "--plant",
        "examples/mixer/tank.pnml",
        "--inputs",
        "examples/mixer/press-b1.csv",
        "--until",
        "28s",
    ]);
    let (b, n) = (mixer_events(&builtin), mixer_events(&net));
    assert_eq!(
        b[..4],
        [
            (1000, "B1".into()),
            (3500, "N2".into()),
            (5500, "N3".into()),
            (8900, "N1".into())
        ]
    );
    assert_eq!(b.len(), n.len(), "built-in {b:?}\nnet {n:?}");
    for ((tb, fb), (tn, f_n)) in b.iter().zip(&n) {
        assert_eq!(fb, f_n);
        assert!(
            (*tb..=tb + 60).contains(tn),
            "{fb}: built-in tank at {tb} ms, tank net at {tn} ms"
        );
    }
    assert!(
        builtin.stderr.contains("3 fill/drain cycles"),
        "{}",
        builtin.stderr
    );
}

// ---------------------------------------------------------------------------------------------
// 2. Blink (seed 003, Example 4)

/// p1 is marked at t=0 and seen by the first scan, so t1 fires at 0.5 s. After that each place
/// is marked by the scan at t, first seen at t+10 ms, and its 0.5 s delay holds at t+510 ms:
/// lamps change every 510 ms. input0 (3.3 s) takes the token from p1 into p4 at once; its
/// release (5.0 s) puts it back and p1's timer restarts. Held again at 6.2 s while p3 is lit,
/// the token finishes its round: t3 marks p1 at 6.53 and t4 parks it at 6.54, so out0 shows
/// for one scan.
#[test]
fn blink_period_and_input0_parking() {
    let t = sim(&[
        "examples/blink/blink.pnml",
        "--inputs",
        "examples/blink/timeline.csv",
        "--until",
        "9s",
    ]);
    assert_eq!(
        t.firings(),
        [
            "0.5 t1", "1.01 t2", "1.52 t3", "2.03 t1", "2.54 t2", "3.05 t3", // blinking
            "3.3 t4",  // input0: parked in p4
            "5 t5", "5.51 t1", "6.02 t2", "6.53 t3", // released: p1's timer starts again
            "6.54 t4", // input0 again: parked after the round ends in p1
            "7 t5", "7.51 t1", "8.02 t2", "8.53 t3",
        ]
    );
    assert_eq!(
        t.on_intervals("out0"),
        [
            "0-0.5",
            "1.52-2.03",
            "3.05-3.3",
            "5-5.51",
            "6.53-6.54",
            "7-7.51",
            "8.53-"
        ]
    );
    assert_eq!(
        t.on_intervals("out1"),
        ["0.5-1.01", "2.03-2.54", "5.51-6.02", "7.51-8.02"]
    );
    assert_eq!(
        t.on_intervals("out2"),
        ["1.01-1.52", "2.54-3.05", "6.02-6.53", "8.02-8.53"]
    );
    // While parked every lamp is off and the token sits in p4.
    for r in t
        .rows
        .iter()
        .filter(|r| (3300..5000).contains(&r.t) || (6540..7000).contains(&r.t))
    {
        assert_eq!(t.value(r, "m:p4"), 1, "at {}", secs(r.t));
        assert_eq!(
            ["out0", "out1", "out2"].map(|o| t.value(r, o)),
            [0, 0, 0],
            "at {}",
            secs(r.t)
        );
    }
}

// ---------------------------------------------------------------------------------------------
// 3. Dining philosophers (seed 003, Example 1)

/// The seed's `tu` timeline. A philosopher who stops wanting releases in the scan the input
/// changes; forks released by a scan can be taken only in the next one, so a neighbour who
/// starts wanting at the same moment eats 10 ms later. At 9 s philosopher 1 wants to eat but
/// neighbour 2 keeps eating (still wanting): 1 waits, holding no fork.
#[test]
fn philosophers_eat_in_turn_and_never_beside_a_neighbour() {
    let t = sim(&[
        "examples/philosophers/philosophers.pnml",
        "--inputs",
        "examples/philosophers/timeline.csv",
    ]);
    let eats: BTreeMap<u32, Vec<String>> = (1..=5)
        .map(|i| (i, t.on_intervals(&format!("eating{i}"))))
        .collect();
    let expect: BTreeMap<u32, Vec<String>> = [
        (1, vec!["1-2", "4-5", "7.01-8"]),
        (2, vec!["2.01-3", "5.01-6", "8.01-"]),
        (3, vec!["4-5", "6.01-7"]),
        (4, vec!["5.01-6", "7.01-8"]),
        (5, vec!["6.01-7", "8.01-9"]),
    ]
    .into_iter()
    .map(|(i, v)| (i, v.into_iter().map(String::from).collect()))
    .collect();
    assert_eq!(eats, expect);
    for r in &t.rows {
        for i in 1..=5u32 {
            let j = i % 5 + 1;
            let both = t.value(r, &format!("eating{i}")) + t.value(r, &format!("eating{j}"));
            assert!(both < 2, "neighbours {i} and {j} both eat at {}", secs(r.t));
        }
        let forks: i64 = (1..=5).map(|f| t.value(r, &format!("m:fork{f}"))).sum();
        let eating: i64 = (1..=5).map(|i| t.value(r, &format!("eating{i}"))).sum();
        assert_eq!(
            forks + 2 * eating,
            5,
            "forks are conserved at {}",
            secs(r.t)
        );
    }
    // Philosopher 1 waits from 9 s on without taking anything.
    let last = t.rows.last().unwrap();
    assert_eq!(
        (t.value(last, "m:think1"), t.value(last, "m:fork1")),
        (1, 1)
    );
}

// ---------------------------------------------------------------------------------------------
// 4. Keyboard scanning (seed 003, Example 2)

/// A sweep is four scans: 4n evaluates and powers col1, 4n+1 reads col1 and powers col2,
/// 4n+2 reads col2 and powers col3, 4n+3 reads col3. Every key change in the seed's table
/// falls on a whole second (a scan 4n), so the first sweep to see a new key state is read
/// during 4n+1..4n+3 and evaluated at 4n+4: acceptance switches 40 ms after the change.
#[test]
fn keyboard_accepts_only_single_keys() {
    let t = sim(&[
        "examples/keyboard/keyboard.pnml",
        "--plant",
        "keyboard",
        "--inputs",
        "examples/keyboard/timeline.csv",
    ]);
    let mut accepted = BTreeMap::new();
    for k in 1..=12 {
        let on = t.on_intervals(&format!("accepted{k}"));
        if !on.is_empty() {
            accepted.insert(k, on.join(" "));
        }
    }
    assert_eq!(
        accepted,
        BTreeMap::from([
            (1, "1.04-2.04".into()),
            (5, "3.04-4.04".into()),
            (9, "5.04-6.04".into()),
            (12, "8.04-9.04".into())
        ])
    );
    // 7–8 s: keys 1 and 12 together are seen every sweep and rejected every sweep.
    let firings = t.firings();
    let rejected = |key: &str| {
        firings
            .iter()
            .filter(|f| f.ends_with(&format!(" reject_{key}")))
            .map(|f| millis(f.split(' ').next().unwrap()))
            .collect::<Vec<_>>()
    };
    let expect: Vec<u64> = (7040..=8000).step_by(40).collect();
    assert_eq!(rejected("k1"), expect);
    assert_eq!(rejected("k12"), expect);
    // One column powered at a time, always in turn.
    for r in &t.rows {
        let powered: i64 = ["col1", "col2", "col3"].iter().map(|c| t.value(r, c)).sum();
        assert!(powered <= 1, "{powered} columns powered at {}", secs(r.t));
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Busy beaver (seed 003, Example 3)

/// (state, symbol read) → (symbol written, head move, next state).
type Rule = ((char, u8), (u8, i64, char));

/// Seed 003's table.
const BUSY_BEAVER: [Rule; 6] = [
    (('A', 0), (1, 1, 'B')),
    (('A', 1), (1, -1, 'C')),
    (('B', 0), (1, -1, 'A')),
    (('B', 1), (1, 1, 'B')),
    (('C', 0), (1, -1, 'B')),
    (('C', 1), (1, 0, 'H')),
];

/// A direct Turing-machine run of the table: each (state, symbol) decided, ones left, head.
fn reference_machine() -> (Vec<(char, u8)>, usize, i64) {
    let mut tape = std::collections::BTreeSet::new();
    let (mut head, mut state, mut steps) = (0i64, 'A', Vec::new());
    while state != 'H' {
        let read = u8::from(tape.contains(&head));
        let &(_, (write, step, next)) = BUSY_BEAVER
            .iter()
            .find(|(k, _)| *k == (state, read))
            .unwrap();
        if write == 1 {
            tape.insert(head);
        } else {
            tape.remove(&head);
        }
        steps.push((state, read));
        head += step;
        state = next;
    }
    (steps, tape.len(), head)
}

/// Each machine step takes two scans: X_read0/X_read1 decides on the symbol and sets the
/// outputs, the tape plant acts on them in the next scan while Xs_to_Y moves on.
#[test]
fn busy_beaver_halts_with_the_reference_machine() {
    let (steps, ones, head) = reference_machine();
    assert_eq!(
        (steps.len(), ones),
        (13, 6),
        "the seed's table, run directly"
    );
    let t = sim(&[
        "examples/busy-beaver/busy-beaver.pnml",
        "--plant",
        "tape",
        "--until",
        "1s",
    ]);
    let decisions: Vec<String> = t
        .rows
        .iter()
        .flat_map(|r| t.fired(r))
        .filter(|f| f.contains("_read"))
        .map(String::from)
        .collect();
    let expect: Vec<String> = steps.iter().map(|(s, r)| format!("{s}_read{r}")).collect();
    assert_eq!(
        decisions, expect,
        "one decision per machine step, in the machine's order"
    );
    let last = t.rows.last().unwrap();
    assert_eq!(t.value(last, "m:H"), 1, "halted");
    assert_eq!(
        secs(last.t),
        secs(2 * 10 * steps.len() as u64 - 10),
        "C1_to_H fires in the last step's second scan"
    );
    assert!(t.stderr.contains(&format!("({ones} ones)")), "{}", t.stderr);
    assert!(
        t.stderr.contains(&format!("head at {head}")),
        "{}",
        t.stderr
    );
}
