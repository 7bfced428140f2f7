//! Integration tests of the shared synchronisation net: modules in threads and in another
//! process lock-stepped through the marking in POSIX shared memory, weights, `stop()`,
//! timeouts and the shared memory's life cycle.
//!
//! There are no timing assertions: timeouts only keep a broken build from hanging.

use std::io::Write as _;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Mutex};
use std::time::{Duration, Instant};

use petriplc_config::{ArcDecl, ModuleDecl, Origin, PlaceDecl, PlcConfig, SynchRule};
use petriplc_runtime::synch::{SharedSynch, Stopped, SynchError, SynchNet, TransitionRef};

/// Long enough never to be hit by a working build.
const SAFETY_NET: Duration = Duration::from_secs(60);
/// Set in the environment of the child process of `a_child_process_lock_steps_with_us`.
const CHILD_PLC_ID: &str = "PETRIPLC_SYNCH_TEST_CHILD_PLC_ID";
const CHILD_LOG: &str = "PETRIPLC_SYNCH_TEST_CHILD_LOG";
const PROCESS_SCANS: usize = 200;

fn at(line: usize) -> Origin {
    Origin {
        file: "test.conf".into(),
        line,
    }
}

fn module(name: &str, beg: Option<&str>, end: Option<&str>) -> ModuleDecl {
    ModuleDecl {
        scan_beg: beg.map(str::to_string),
        scan_end: end.map(str::to_string),
        origin: at(1),
        ..ModuleDecl::new(name, "test")
    }
}

/// `synch` rules `(from, weight, to)` and `synch_start` over modules without scan_beg/end.
fn simple(modules: &[&str], rules: &[(&str, u32, &str)], starts: &[&str]) -> SynchNet {
    let mut cfg = PlcConfig {
        modules: modules.iter().map(|m| module(m, None, None)).collect(),
        ..PlcConfig::default()
    };
    for (i, (from, weight, to)) in rules.iter().enumerate() {
        cfg.synch.rules.push(SynchRule {
            from: (*from).into(),
            to: (*to).into(),
            weight: *weight,
            origin: at(10 + i),
        });
    }
    for s in starts {
        cfg.synch.starts.push(((*s).into(), at(20)));
    }
    SynchNet::from_config(&cfg).expect("valid synch configuration")
}

/// A unique plc id per test and process, so tests can run in parallel.
fn plc_id(test: &str) -> String {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    format!(
        "test-{}-{}-{test}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    )
}

fn synch(shared: &SharedSynch, t: TransitionRef) {
    let fired = shared.synch_timeout(t, SAFETY_NET).expect("not stopping");
    assert!(
        fired.is_some(),
        "{} never fired: marking {:?}",
        shared.net().transition_name(t),
        shared.marking()
    );
}

/// Runs `scans` scans of `module` (scan_beg, record, scan_end).
fn run_module(shared: &SharedSynch, module: &str, scans: usize, log: &Mutex<Vec<String>>) {
    let (beg, end) = (shared.net().scan_beg(module), shared.net().scan_end(module));
    for _ in 0..scans {
        synch(shared, beg);
        log.lock().unwrap().push(module.to_string());
        synch(shared, end);
    }
}

#[test]
fn two_threads_strictly_alternate_for_1000_scans() {
    let net = simple(&["a", "b"], &[("a", 1, "b"), ("b", 1, "a")], &["a"]);
    let id = plc_id("alternate");
    let creator = SharedSynch::create(&id, &net).unwrap();
    // b goes through its own mapping of the object, as another process would.
    let opened = SharedSynch::open(&id, &net).unwrap();
    let log = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        s.spawn(|| run_module(&opened, "b", 1000, &log));
        s.spawn(|| run_module(&creator, "a", 1000, &log));
    });
    let log = log.into_inner().unwrap();
    assert_eq!(log.len(), 2000);
    for (i, module) in log.iter().enumerate() {
        assert_eq!(module, if i % 2 == 0 { "a" } else { "b" }, "scan {i}");
    }
    // a->b empty, b->a holding b's last token for a scan of a that never came.
    assert_eq!(creator.marking(), vec![0, 1]);
    assert_eq!(opened.marking(), vec![0, 1]);
}

#[test]
fn a_weight_two_rule_lets_b_scan_twice_per_scan_of_a() {
    let net = simple(&["a", "b"], &[("a", 2, "b"), ("a", 1, "a")], &["a"]);
    let shared = SharedSynch::create(&plc_id("weight2"), &net).unwrap();
    let log = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        s.spawn(|| run_module(&shared, "b", 200, &log));
        s.spawn(|| run_module(&shared, "a", 100, &log));
    });
    let log = log.into_inner().unwrap();
    let (mut a, mut b) = (0, 0);
    for module in &log {
        if module == "a" {
            a += 1;
        } else {
            b += 1;
        }
        assert!(b <= 2 * a, "b made scan {b} after only {a} scans of a");
    }
    assert_eq!((a, b), (100, 200));
    assert_eq!(shared.marking(), vec![0, 1]);
}

/// Seed 000's complex example: `P_chaser --2--> T_chaser_beg`, `T_chaser_end --2-->
/// P_vitrine`, `P_vitrine -> T_vitrine_beg`, `T_vitrine_end -> P_chaser`, `place P_chaser 2`.
fn chaser_net() -> SynchNet {
    let mut cfg = PlcConfig {
        modules: vec![
            module("chaser", Some("Tc_beg"), Some("Tc_end")),
            module("vitrine", Some("Tv_beg"), Some("Tv_end")),
        ],
        ..PlcConfig::default()
    };
    for (name, tokens) in [("Pc", 2), ("Pv", 0)] {
        cfg.synch.places.push(PlaceDecl {
            name: name.into(),
            tokens,
            origin: at(1),
        });
    }
    for name in ["Tc_beg", "Tc_end", "Tv_beg", "Tv_end"] {
        cfg.synch.transitions.push((name.into(), at(2)));
    }
    for (from, weight, to) in [
        ("Pc", 2, "Tc_beg"),
        ("Tc_end", 2, "Pv"),
        ("Pv", 1, "Tv_beg"),
        ("Tv_end", 1, "Pc"),
    ] {
        cfg.synch.arcs.push(ArcDecl {
            from: from.into(),
            to: to.into(),
            weight,
            origin: at(3),
        });
    }
    SynchNet::from_config(&cfg).unwrap()
}

#[test]
fn the_advanced_form_runs_the_chaser_once_and_the_vitrine_twice() {
    let net = chaser_net();
    let shared = SharedSynch::create(&plc_id("chaser"), &net).unwrap();
    let log = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        s.spawn(|| run_module(&shared, "vitrine", 400, &log));
        s.spawn(|| run_module(&shared, "chaser", 200, &log));
    });
    let log = log.into_inner().unwrap();
    let expected: Vec<&str> = ["chaser", "vitrine", "vitrine"].repeat(200);
    assert_eq!(log, expected);
    assert_eq!(shared.marking(), vec![2, 0]);
}

#[test]
fn an_input_arc_of_weight_two_runs_b_once_per_two_scans_of_a() {
    // a runs freely (Pa gives its token back); every two ends of a enable one b.
    let mut cfg = PlcConfig {
        modules: vec![
            module("a", Some("Ta_beg"), Some("Ta_end")),
            module("b", Some("Tb_beg"), None),
        ],
        ..PlcConfig::default()
    };
    for (name, tokens) in [("Pa", 1), ("Pb", 0)] {
        cfg.synch.places.push(PlaceDecl {
            name: name.into(),
            tokens,
            origin: at(1),
        });
    }
    for name in ["Ta_beg", "Ta_end", "Tb_beg"] {
        cfg.synch.transitions.push((name.into(), at(2)));
    }
    for (from, weight, to) in [
        ("Pa", 1, "Ta_beg"),
        ("Ta_end", 1, "Pa"),
        ("Ta_end", 1, "Pb"),
        ("Pb", 2, "Tb_beg"),
    ] {
        cfg.synch.arcs.push(ArcDecl {
            from: from.into(),
            to: to.into(),
            weight,
            origin: at(3),
        });
    }
    let net = SynchNet::from_config(&cfg).unwrap();
    assert_eq!(net.scan_end("b"), TransitionRef::Null);
    let shared = SharedSynch::create(&plc_id("half"), &net).unwrap();
    let log = Mutex::new(Vec::new());
    std::thread::scope(|s| {
        s.spawn(|| run_module(&shared, "b", 50, &log));
        s.spawn(|| run_module(&shared, "a", 100, &log));
    });
    let log = log.into_inner().unwrap();
    let (mut a, mut b) = (0, 0);
    for module in &log {
        if module == "a" {
            a += 1;
        } else {
            b += 1;
        }
        assert!(2 * b <= a, "b made scan {b} after only {a} scans of a");
    }
    assert_eq!((a, b), (100, 50));
    assert_eq!(shared.marking(), vec![1, 0]);
}

#[test]
fn contending_threads_never_lose_or_invent_tokens() {
    // Tokens shuttle between P and Q through `there` and `back`; eight threads fire them
    // as fast as they can, so the lock and the wake-ups are contended all the time.
    let mut cfg = PlcConfig::default();
    for (name, tokens) in [("P", 3), ("Q", 0)] {
        cfg.synch.places.push(PlaceDecl {
            name: name.into(),
            tokens,
            origin: at(1),
        });
    }
    for name in ["there", "back"] {
        cfg.synch.transitions.push((name.into(), at(2)));
    }
    for (from, to) in [("P", "there"), ("there", "Q"), ("Q", "back"), ("back", "P")] {
        cfg.synch.arcs.push(ArcDecl {
            from: from.into(),
            to: to.into(),
            weight: 1,
            origin: at(3),
        });
    }
    let net = SynchNet::from_config(&cfg).unwrap();
    let shared = SharedSynch::create(&plc_id("contend"), &net).unwrap();
    let (there, back) = (
        net.transition("there").unwrap(),
        net.transition("back").unwrap(),
    );
    std::thread::scope(|s| {
        for i in 0..8 {
            let t = if i % 2 == 0 { there } else { back };
            let shared = &shared;
            s.spawn(move || {
                for _ in 0..500 {
                    synch(shared, t);
                    let m = shared.marking();
                    assert_eq!(m[0] + m[1], 3, "tokens lost or invented: {m:?}");
                }
            });
        }
    });
    assert_eq!(shared.marking(), vec![3, 0]);
}

#[test]
fn stop_releases_a_blocked_waiter_and_every_later_synch() {
    let net = simple(&["a", "b"], &[("a", 1, "b")], &[]);
    let shared = SharedSynch::create(&plc_id("stop"), &net).unwrap();
    let b_beg = net.scan_beg("b");
    let (ready, waiting) = mpsc::channel();
    std::thread::scope(|s| {
        let waiter = s.spawn(|| {
            ready.send(()).unwrap();
            // b:beg has no token and nobody will give it one: only stop() ends this.
            shared.synch(b_beg)
        });
        waiting.recv().unwrap();
        shared.stop();
        assert_eq!(waiter.join().unwrap(), Err(Stopped));
    });
    assert!(shared.is_stopping());
    assert_eq!(shared.synch(net.scan_beg("a")), Err(Stopped));
    assert_eq!(shared.synch(TransitionRef::Null), Err(Stopped));
    assert_eq!(shared.try_synch(b_beg), Err(Stopped));
}

#[test]
fn timeouts_and_non_blocking_synch_leave_the_marking_alone() {
    let net = simple(&["a", "b"], &[("a", 1, "b")], &[]);
    let shared = SharedSynch::create(&plc_id("timeout"), &net).unwrap();
    let (a_end, b_beg) = (net.scan_end("a"), net.scan_beg("b"));
    assert_eq!(shared.try_synch(b_beg), Ok(None));
    assert_eq!(
        shared.synch_timeout(b_beg, Duration::from_millis(20)),
        Ok(None)
    );
    assert_eq!(shared.marking(), vec![0]);
    assert!(shared.synch(TransitionRef::Null).is_ok());
    let before = shared.generation();
    let fired = shared.synch(a_end).unwrap();
    assert_eq!(fired.generation, before.wrapping_add(1));
    assert_eq!(shared.marking(), vec![1]);
    assert!(shared.try_synch(b_beg).unwrap().is_some());
    assert_eq!(shared.marking(), vec![0]);
}

#[test]
fn shared_memory_life_cycle() {
    let net = simple(&["a", "b"], &[("a", 1, "b")], &["b"]);
    let id = plc_id("life");
    assert!(matches!(
        SharedSynch::open(&id, &net),
        Err(SynchError::NotRunning { .. })
    ));
    let shared = SharedSynch::create(&id, &net).unwrap();
    assert_eq!(shared.shm(), format!("/petriplc-{id}-synch"));
    let again = SharedSynch::create(&id, &net).unwrap_err();
    assert!(matches!(again, SynchError::Exists { .. }));
    assert!(again.to_string().contains("already exists"), "{again}");
    // Same size, other arcs: refused by the fingerprint.
    let other = simple(&["a", "b"], &[("b", 1, "a")], &["a"]);
    let mismatch = SharedSynch::open(&id, &other).unwrap_err();
    assert!(
        matches!(mismatch, SynchError::Mismatch { .. }),
        "{mismatch}"
    );
    let bigger = simple(&["a", "b"], &[("a", 1, "b"), ("b", 1, "a")], &[]);
    assert!(matches!(
        SharedSynch::open(&id, &bigger),
        Err(SynchError::Mismatch { .. })
    ));
    let opened = SharedSynch::open(&id, &net).unwrap();
    assert_eq!(opened.marking(), vec![1]);
    // Dropping an opener leaves the object; dropping the creator removes it.
    drop(opened);
    SharedSynch::open(&id, &net).unwrap();
    drop(shared);
    assert!(matches!(
        SharedSynch::open(&id, &net),
        Err(SynchError::NotRunning { .. })
    ));
    assert!(!SharedSynch::unlink(&id).unwrap());
    for bad in ["", "a/b", "with space"] {
        assert!(matches!(
            SharedSynch::create(bad, &net),
            Err(SynchError::BadPlcId { .. })
        ));
    }
}

/// Modules `p` (the parent) and `c` (the child) in a ring, `p` first.
fn process_net() -> SynchNet {
    simple(&["p", "c"], &[("p", 1, "c"), ("c", 1, "p")], &["p"])
}

/// One scan step in the child or the parent: wait on `t`, giving up if the other side
/// died (`alive` says whether it still runs) or after the safety net.
fn synch_while(shared: &SharedSynch, t: TransitionRef, mut alive: impl FnMut() -> bool) {
    let started = Instant::now();
    loop {
        if shared
            .synch_timeout(t, Duration::from_millis(200))
            .expect("not stopping")
            .is_some()
        {
            return;
        }
        assert!(alive(), "the other process died");
        assert!(started.elapsed() < SAFETY_NET, "lock-step hung");
    }
}

fn append(path: &str, line: &str) {
    // O_APPEND: each line is one write at the end of the file, whichever process writes.
    let mut f = std::fs::OpenOptions::new()
        .append(true)
        .create(true)
        .open(path)
        .unwrap();
    f.write_all(line.as_bytes()).unwrap();
}

/// The child's side of `a_child_process_lock_steps_with_us`; a no-op in a normal test run.
#[test]
fn child_process_role() {
    let (Ok(id), Ok(log)) = (std::env::var(CHILD_PLC_ID), std::env::var(CHILD_LOG)) else {
        return;
    };
    let net = process_net();
    let shared = SharedSynch::open(&id, &net).unwrap();
    let (beg, end) = (net.scan_beg("c"), net.scan_end("c"));
    for _ in 0..PROCESS_SCANS {
        synch_while(&shared, beg, || true);
        append(&log, "c\n");
        synch_while(&shared, end, || true);
    }
}

#[test]
fn a_child_process_lock_steps_with_us() {
    let net = process_net();
    let id = plc_id("process");
    let shared = SharedSynch::create(&id, &net).unwrap();
    let log = std::env::temp_dir().join(format!("petriplc-{id}.log"));
    let log = log.to_str().unwrap().to_string();
    let _ = std::fs::remove_file(&log);
    let mut child = Command::new(std::env::current_exe().unwrap())
        .args([
            "--exact",
            "child_process_role",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD_PLC_ID, &id)
        .env(CHILD_LOG, &log)
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let (beg, end) = (net.scan_beg("p"), net.scan_end("p"));
    let mut child_alive = || matches!(child.try_wait(), Ok(None));
    for _ in 0..PROCESS_SCANS {
        synch_while(&shared, beg, &mut child_alive);
        append(&log, "p\n");
        synch_while(&shared, end, &mut child_alive);
    }
    let status = child.wait().unwrap();
    assert!(status.success(), "child failed: {status}");
    let text = std::fs::read_to_string(&log).unwrap();
    let _ = std::fs::remove_file(&log);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 2 * PROCESS_SCANS);
    for (i, line) in lines.iter().enumerate() {
        assert_eq!(*line, if i % 2 == 0 { "p" } else { "c" }, "scan {i}");
    }
    assert_eq!(shared.marking(), vec![0, 1]);
}
