//! Faults, tested by killing: a process killed (SIGKILL, by the test hook) while it holds the
//! shared-memory lock half-way through an `update()` or a firing never blocks the others,
//! and its half-done change is undone; the ownership of a PLC id follows the kernel's lock,
//! so a PLC that died is told from a running one and what it left is removed.
//!
//! The victims are this test binary run again as a child (`victim_entry`), so that each
//! starts single-threaded and dies alone.

use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use petriplc_config::{Location, ModuleDecl, Origin, PlcConfig, PointDecl, PointKind, PointValue};
use petriplc_runtime::image::{GlobalMap, Layout, ModuleMap};
use petriplc_runtime::owner::{self, Owner, OwnerError, Probe};
use petriplc_runtime::synch::{Abandoned, SharedSynch, SynchNet};
use petriplc_runtime::testhook;

const VICTIM: &str = "PETRIPLC_ROBUST_TEST_VICTIM";

fn plc_id(test: &str) -> String {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    format!(
        "robust-{}-{}-{test}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    )
}

fn point(name: &str, owner: &str, at: u32) -> PointDecl {
    PointDecl {
        name: name.into(),
        description: String::new(),
        owner: owner.into(),
        at: Some((at, 0)),
        kind: PointKind::Unsigned,
        bits: 32,
        init: PointValue::Unsigned(0),
        retain: false,
        origin: Origin::default(),
    }
}

/// The victim owns `a` and `b` (words 0 and 4) and always writes them equal; `other` owns
/// the words between, so the victim's update writes two runs.
fn config() -> PlcConfig {
    let mut c = PlcConfig {
        modules: ["victim", "other", "a", "b"]
            .iter()
            .map(|m| ModuleDecl::new(*m, "test"))
            .collect(),
        points: vec![
            point("a", "victim", 0),
            point("o1", "other", 1),
            point("o2", "other", 2),
            point("o3", "other", 3),
            point("b", "victim", 4),
        ],
        ..PlcConfig::default()
    };
    for (from, to) in [("a", "b"), ("b", "a")] {
        c.synch.rules.push(petriplc_config::SynchRule {
            from: from.into(),
            to: to.into(),
            weight: 1,
            origin: Origin::default(),
        });
    }
    c.synch.starts.push(("a".into(), Origin::default()));
    c
}

/// Words `bulk` owns, and the word among them that `other` owns.
const BULK: u32 = 5000;
const BULK_OTHER: u32 = 3000;

/// `bulk` owns 5000 words and `other` one word among them: `bulk`'s update writes them over
/// several journal chunks (2048 words each).
fn bulk_layout() -> Layout {
    let mut points: Vec<PointDecl> = (0..BULK)
        .map(|i| {
            let at = if i < BULK_OTHER { i } else { i + 1 };
            point(&format!("w{i}"), "bulk", at)
        })
        .collect();
    points.push(point("o", "other", BULK_OTHER));
    two_modules(["bulk", "other"], points)
}

/// The layout of `points` owned by two modules.
fn two_modules(modules: [&str; 2], points: Vec<PointDecl>) -> Layout {
    Layout::new(&PlcConfig {
        modules: modules
            .iter()
            .map(|m| ModuleDecl::new(*m, "test"))
            .collect(),
        points,
        ..PlcConfig::default()
    })
    .unwrap()
}

/// Runs only as a victim: `update VALUE` writes a = b = VALUE and updates (dying half-way
/// if the hook is armed); `bulk VALUE` writes VALUE to its 5000 words and updates; `loop`
/// writes 1, 2, 3... to all of its points of the mixed layout, updating after each, until
/// killed (saying `victim ready` after the first update); `fire` fires `a:beg` (dying half-way if
/// armed).
#[test]
fn victim_entry() {
    let Ok(spec) = std::env::var(VICTIM) else {
        return;
    };
    let mut words = spec.split_whitespace();
    let (what, id) = (words.next().unwrap(), words.next().unwrap());
    if let Ok(hook) = std::env::var(testhook::ENV) {
        testhook::arm_from(&hook).unwrap();
    }
    let config = config();
    match what {
        "update" => {
            let value: u32 = words.next().unwrap().parse().unwrap();
            let layout = Layout::new(&config).unwrap();
            let global = GlobalMap::open(id).unwrap();
            let mut m = ModuleMap::new(&layout, "victim", Location::Local).unwrap();
            m.set_u32(&m.handle("a").unwrap(), value).unwrap();
            m.set_u32(&m.handle("b").unwrap(), value).unwrap();
            m.update(&global);
        }
        "bulk" => {
            let value: u32 = words.next().unwrap().parse().unwrap();
            let layout = bulk_layout();
            let global = GlobalMap::open(id).unwrap();
            let mut m = ModuleMap::new(&layout, "bulk", Location::Local).unwrap();
            for i in 0..BULK {
                m.set_u32(&m.handle(&format!("w{i}")).unwrap(), value)
                    .unwrap();
            }
            m.update(&global);
        }
        "loop" => {
            let layout = mixed_layout();
            let global = GlobalMap::open(id).unwrap();
            let mut m = ModuleMap::new(&layout, "victim", Location::Local).unwrap();
            let mine: Vec<_> = layout
                .points()
                .filter(|(_, s)| s.owner == "victim")
                .map(|(_, s)| m.handle(&s.name).unwrap())
                .collect();
            for value in 1u32.. {
                for h in &mine {
                    m.set_u32(h, value & 0xFFFF).unwrap();
                }
                m.update(&global);
                if value == 1 {
                    // After the harness's "test victim_entry ... ", on the same line.
                    println!("victim ready");
                }
            }
        }
        "fire" => {
            let net = SynchNet::from_config(&config).unwrap();
            let synch = SharedSynch::open(id, &net).unwrap();
            let a = net.scan_ref("a").unwrap();
            synch.begin_scan(&a).unwrap();
        }
        other => panic!("unknown victim job {other}"),
    }
}

/// Runs a victim; returns whether it was killed by SIGKILL (else it must have succeeded).
fn victim(job: &str, hook: Option<&str>) -> bool {
    let mut cmd = Command::new(std::env::current_exe().unwrap());
    cmd.args(["victim_entry", "--exact", "--nocapture", "--test-threads=1"])
        .env(VICTIM, job)
        .env_remove(testhook::ENV);
    if let Some(h) = hook {
        cmd.env(testhook::ENV, h);
    }
    let out = cmd.output().unwrap();
    use std::os::unix::process::ExitStatusExt;
    if out.status.signal() == Some(9) {
        return true;
    }
    assert!(
        out.status.success(),
        "victim {job} failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    false
}

fn ab(global: &GlobalMap) -> (u32, u32) {
    let g = global.lock();
    (g.words()[0], g.words()[4])
}

#[test]
fn a_process_killed_inside_update_never_blocks_the_others_and_is_undone() {
    let id = plc_id("update");
    let layout = Layout::new(&config()).unwrap();
    let global = GlobalMap::create(&id, &layout).unwrap();
    let mut other = ModuleMap::new(&layout, "other", Location::Local).unwrap();
    let o2 = other.handle("o2").unwrap();
    for round in 1..=10u32 {
        assert!(!victim(&format!("update {id} {}", 2 * round), None));
        assert_eq!(ab(&global), (2 * round, 2 * round));
        // Killed after the journal and half of its words: a is written, b not yet.
        assert!(victim(
            &format!("update {id} {}", 2 * round + 1),
            Some("update:1")
        ));
        // The lock is free again, and the image holds the victim's previous scan whole.
        other.set_u32(&o2, round).unwrap();
        other.update(&global);
        assert_eq!(ab(&global), (2 * round, 2 * round), "round {round}");
        assert_eq!(global.recoveries(), round);
        assert_eq!(other.get_u32(&other.handle("a").unwrap()), 2 * round);
        assert_eq!(
            global.lock().words()[2],
            round,
            "other's own write went through"
        );
    }
    eprintln!(
        "priority inheritance on this system: {}",
        global.priority_inheritance()
    );
}

#[test]
fn a_death_after_several_journal_chunks_is_undone_whole() {
    let id = plc_id("bulk");
    let layout = bulk_layout();
    let global = GlobalMap::create(&id, &layout).unwrap();
    assert!(!victim(&format!("bulk {id} 7"), None));
    // Dies after 2500 of its 5000 words: one journal chunk (2048 words) saved and written,
    // the next saved and written in part.
    assert!(victim(&format!("bulk {id} 8"), Some("update:1")));
    let mut other = ModuleMap::new(&layout, "other", Location::Local).unwrap();
    other.update(&global);
    let words = global.lock().words().to_vec();
    assert_eq!(words.len(), BULK as usize + 1);
    for (w, &v) in words.iter().enumerate() {
        assert_eq!(v, if w == BULK_OTHER as usize { 0 } else { 7 }, "word {w}");
    }
}

/// Every shape of ownership `update()` has a way of writing: `victim` owns every fourth word
/// of the first 4096 (merged word by word), the next 1024 whole (copied out), 12 words of
/// every 16 of the next 1024 (merged block by block), and the low halves of the next 256
/// words (16-bit points sharing words with `other`'s); `other` owns the rest.
fn mixed_layout() -> Layout {
    let half = |name: String, owner: &str, word: u32, bit: u8| PointDecl {
        bits: 16,
        at: Some((word, bit)),
        ..point(&name, owner, word)
    };
    let mut points = Vec::new();
    for w in 0..6400u32 {
        let victim = match w {
            0..4096 => w % 4 == 1,
            4096..5120 => true,
            5120..6144 => w % 16 >= 4,
            _ => false,
        };
        if w >= 6144 {
            points.push(half(format!("v{w}"), "victim", w, 0));
            points.push(half(format!("o{w}"), "other", w, 16));
        } else {
            let owner = if victim { "victim" } else { "other" };
            points.push(point(&format!("w{w}"), owner, w));
        }
    }
    two_modules(["victim", "other"], points)
}

/// The values of `victim`'s points and of `other`'s in the global map, read under the lock
/// (which undoes a half-done update first).
fn values(global: &GlobalMap, layout: &Layout) -> (Vec<u32>, Vec<u32>) {
    let mut words = Vec::new();
    global.snapshot(&mut words);
    let (mut victim, mut other) = (Vec::new(), Vec::new());
    for (id, s) in layout.points() {
        let PointValue::Unsigned(v) = layout.decode(id, &words) else {
            panic!("unsigned points only");
        };
        if s.owner == "victim" {
            &mut victim
        } else {
            &mut other
        }
        .push(v);
    }
    (victim, other)
}

#[test]
fn kills_at_random_moments_never_leave_a_half_done_update() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    const KILLS: u32 = 200;
    let id = plc_id("kills");
    let layout = mixed_layout();
    let global = GlobalMap::create(&id, &layout).unwrap();
    // `other` writes distinct values once; no victim may ever change them.
    let mut other = ModuleMap::new(&layout, "other", Location::Local).unwrap();
    for (_, s) in layout.points().filter(|(_, s)| s.owner == "other") {
        let h = other.handle(&s.name).unwrap();
        other.set_u32(&h, 0xA000 + s.word % 0x1000).unwrap();
    }
    other.update(&global);
    let (_, others) = values(&global, &layout);
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut last = 0;
    for kill in 0..KILLS {
        let mut child = Command::new(std::env::current_exe().unwrap())
            .args(["victim_entry", "--exact", "--nocapture", "--test-threads=1"])
            .env(VICTIM, format!("loop {id}"))
            .env_remove(testhook::ENV)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut ready = String::new();
        let mut out = BufReader::new(child.stdout.take().unwrap());
        while !ready.contains("victim ready") {
            ready.clear();
            assert!(out.read_line(&mut ready).unwrap() > 0, "the victim exited");
        }
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        std::thread::sleep(Duration::from_micros(seed % 3000));
        child.kill().unwrap();
        child.wait().unwrap();
        let (victim, now) = values(&global, &layout);
        assert_eq!(now, others, "kill {kill}: other's points changed");
        let v = victim[0];
        assert!(v >= 1, "kill {kill}: the victim's first update is lost");
        assert!(
            victim.iter().all(|&x| x == v),
            "kill {kill}: the victim's points hold values of different scans: {:?}",
            victim
                .iter()
                .filter(|&&x| x != v)
                .take(5)
                .collect::<Vec<_>>()
        );
        last = v;
    }
    eprintln!(
        "{KILLS} kills, {} of them inside the lock (undone); last value {last}",
        global.recoveries()
    );
    assert!(global.recoveries() > 0, "no kill landed inside update()");
}

#[test]
fn a_process_killed_inside_a_firing_never_blocks_the_others_and_is_undone() {
    let id = plc_id("firing");
    let net = SynchNet::from_config(&config()).unwrap();
    let synch = SharedSynch::create(&id, &net).unwrap();
    let (a, b) = (net.scan_ref("a").unwrap(), net.scan_ref("b").unwrap());
    let before = synch.marking();
    // `a:beg` takes the start token from `b->a`; killed before anything else.
    assert!(victim(&format!("fire {id}"), Some("firing:1")));
    assert_eq!(synch.marking(), before, "the token is back");
    assert!(!synch.in_scan(&a));
    assert_eq!(synch.recoveries(), 1);
    // The net goes on: a's scan, then b's.
    synch.begin_scan(&a).unwrap();
    synch.end_scan(&a).unwrap();
    synch.begin_scan(&b).unwrap();
    synch.end_scan(&b).unwrap();
    // A victim that completes its firing is inside its scan when it exits.
    assert!(!victim(&format!("fire {id}"), None));
    assert!(synch.in_scan(&a));
}

#[test]
fn the_scan_of_a_module_that_died_inside_it_is_ended_on_its_behalf() {
    let id = plc_id("abandon");
    let net = SynchNet::from_config(&config()).unwrap();
    let synch = SharedSynch::create(&id, &net).unwrap();
    let (a, b) = (net.scan_ref("a").unwrap(), net.scan_ref("b").unwrap());
    assert_eq!(synch.abandon_scan(&a), Abandoned::NotInScan);
    synch.begin_scan(&a).unwrap();
    assert!(synch.in_scan(&a));
    // `a` dies inside its scan: its `a:end` is fired for it, so `b` can scan.
    assert_eq!(synch.abandon_scan(&a), Abandoned::Ended);
    assert!(!synch.in_scan(&a));
    let fired = synch.synch_timeout(b.beg, Duration::from_secs(10)).unwrap();
    assert!(fired.is_some(), "b's scan starts");
}

#[test]
fn an_id_is_owned_while_its_lock_is_held() {
    let id = plc_id("owner");
    assert_eq!(owner::probe(&id).unwrap(), Probe::Absent);
    let (me, remains) = Owner::acquire(&id).unwrap();
    assert_eq!(remains, None);
    assert_eq!(
        owner::probe(&id).unwrap(),
        Probe::Running {
            pid: Some(std::process::id())
        }
    );
    match Owner::acquire(&id) {
        Err(OwnerError::Running { pid, .. }) => assert_eq!(pid, Some(std::process::id())),
        other => panic!("a second owner: {other:?}"),
    }
    let proven = owner::running_plc(&id).unwrap().expect("we hold it");
    assert_eq!(proven.pid(), std::process::id());
    me.release();
    assert_eq!(owner::probe(&id).unwrap(), Probe::Absent);
    assert!(owner::running_plc(&id).unwrap().is_none());
    assert!(!owner::lock_path(&id).exists());
}

/// Runs only as the child of `what_a_dead_plc_left_is_found_and_removed`: owns the id,
/// creates its objects, then dies without stopping.
#[test]
fn dead_plc_entry() {
    let Ok(id) = std::env::var("PETRIPLC_ROBUST_TEST_DEAD_PLC") else {
        return;
    };
    let layout = Layout::new(&config()).unwrap();
    let (_owner, _) = Owner::acquire(&id).unwrap();
    let _global = GlobalMap::create(&id, &layout).unwrap();
    let _synch = SharedSynch::create(&id, &SynchNet::from_config(&config()).unwrap()).unwrap();
    std::fs::write(petriplc_runtime::status::path(&id), "{}").unwrap();
    let _ = nix::sys::signal::raise(nix::sys::signal::Signal::SIGKILL);
}

#[test]
fn what_a_dead_plc_left_is_found_and_removed() {
    let id = plc_id("dead");
    let child = Command::new(std::env::current_exe().unwrap())
        .args([
            "dead_plc_entry",
            "--exact",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("PETRIPLC_ROBUST_TEST_DEAD_PLC", &id)
        .spawn()
        .unwrap();
    let pid = child.id();
    let out = child.wait_with_output().unwrap();
    assert!(!out.status.success());
    let Probe::Dead(remains) = owner::probe(&id).unwrap() else {
        panic!("not dead: {:?}", owner::probe(&id));
    };
    assert_eq!(remains.pid, Some(pid));
    assert!(remains.last_seen.is_some());
    assert_eq!(remains.objects.len(), 4, "{remains:?}");
    assert!(
        remains
            .describe()
            .starts_with(&format!("the PLC (pid {pid}) exited without stopping at 2")),
        "{}",
        remains.describe()
    );
    assert!(
        owner::running_plc(&id).unwrap().is_none(),
        "never a dead pid"
    );
    let (me, removed) = Owner::acquire(&id).unwrap();
    assert_eq!(removed.as_ref().map(|r| r.objects.len()), Some(4));
    assert!(GlobalMap::open(&id).is_err(), "the image is gone");
    assert!(!petriplc_runtime::status::path(&id).exists());
    me.release();
    assert_eq!(owner::probe(&id).unwrap(), Probe::Absent);
}
