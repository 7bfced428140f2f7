//! The `isolate` location: a module process that never maps the global map, exchanging
//! values through the proxy process `ModuleMap::isolated` forks, and the proxy's lifetime
//! tied to the module's.
//!
//! The isolated module runs in a child process (this test binary re-run with an
//! environment variable), so that the fork happens away from the parallel tests' threads.

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::{Duration, Instant};

use petriplc_config::{Location, ModuleDecl, Origin, PlcConfig, PointDecl, PointKind, PointValue};
use petriplc_runtime::image::{GlobalMap, ImageError, Layout, ModuleMap};

const CHILD_ID: &str = "PETRIPLC_ISOLATE_TEST_ID";
const CHILD_MODE: &str = "PETRIPLC_ISOLATE_TEST_MODE";
/// Only keeps a broken build from hanging; never reached by a working one.
const SAFETY_NET: Duration = Duration::from_secs(60);

fn plc_id(test: &str) -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!(
        "t{}-iso-{test}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    )
}

fn module(name: &str) -> ModuleDecl {
    ModuleDecl::new(name, "test")
}

fn point(name: &str, owner: &str, kind: PointKind, bits: u8) -> PointDecl {
    PointDecl {
        name: name.into(),
        description: String::new(),
        owner: owner.into(),
        at: None,
        kind,
        bits,
        init: PointValue::Unsigned(0),
        retain: false,
        origin: Origin::default(),
    }
}

fn layout_with(extra: usize) -> Layout {
    let mut points = vec![
        point("to_iso", "peer", PointKind::Unsigned, 16),
        point("from_iso", "iso", PointKind::Signed, 16),
        point("iso_flag", "iso", PointKind::Unsigned, 1),
    ];
    for i in 0..extra {
        points.push(point(&format!("extra{i}"), "peer", PointKind::Unsigned, 8));
    }
    Layout::new(&PlcConfig {
        modules: vec![module("iso"), module("peer")],
        points,
        ..Default::default()
    })
    .unwrap()
}

fn layout() -> Layout {
    layout_with(0)
}

fn image_path(id: &str) -> String {
    format!("/dev/shm/petriplc-{id}-image")
}

fn maps_mention(pid: &str, id: &str) -> bool {
    let maps = std::fs::read_to_string(format!("/proc/{pid}/maps")).unwrap();
    maps.contains(&image_path(id))
}

/// Whether process `pid` has exited (a zombie nobody reaped yet counts).
fn exited(pid: u32) -> bool {
    match std::fs::read_to_string(format!("/proc/{pid}/stat")) {
        Err(_) => true,
        Ok(stat) => {
            let state = stat.rsplit_once(") ").map(|(_, rest)| rest.chars().next());
            matches!(state, Some(Some('Z' | 'X')))
        }
    }
}

fn wait_exited(pid: u32) {
    let deadline = Instant::now() + SAFETY_NET;
    while !exited(pid) {
        assert!(Instant::now() < deadline, "proxy {pid} is still running");
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// The isolated module, when run as the child of one of the tests below (a plain
/// `cargo test` passes at once).
#[test]
fn isolated_module_process() {
    let (Ok(id), Ok(mode)) = (std::env::var(CHILD_ID), std::env::var(CHILD_MODE)) else {
        return;
    };
    let layout = layout();
    let mut m = ModuleMap::isolated(&layout, "iso", &id).unwrap();
    assert!(m.is_isolated());
    let proxy = m.proxy_pid().unwrap();
    println!("proxy {proxy}");
    assert!(
        !maps_mention("self", &id),
        "the module process has mapped the global map"
    );
    assert!(
        maps_mention(&proxy.to_string(), &id),
        "the proxy has not mapped the global map"
    );
    let (to_iso, from_iso, flag) = (
        m.handle("to_iso").unwrap(),
        m.handle("from_iso").unwrap(),
        m.handle("iso_flag").unwrap(),
    );
    assert_eq!(m.get_u32(&to_iso), 0, "init value before the first update");
    m.update_isolated().unwrap();
    assert_eq!(
        m.get_u32(&to_iso),
        4321,
        "the peer's value, through the proxy"
    );
    m.set_i32(&from_iso, -1234).unwrap();
    m.set_bool(&flag, true).unwrap();
    let e = m.set_u32(&to_iso, 1).unwrap_err();
    assert!(matches!(e, ImageError::NotOwner { .. }), "{e}");
    let e = m.force(&to_iso, PointValue::Unsigned(1)).unwrap_err();
    assert!(matches!(e, ImageError::Unsupported { .. }), "{e}");
    m.update_isolated().unwrap();
    assert_eq!(
        m.get_u32(&to_iso),
        4321,
        "our update did not write the peer's point"
    );
    assert_eq!(m.get_i32(&from_iso), -1234);
    assert!(
        !maps_mention("self", &id),
        "the module process has mapped the global map"
    );
    match mode.as_str() {
        "drop" => drop(m),
        // Leaves without dropping the map: the proxy must notice on its own.
        "exit" => {
            std::mem::forget(m);
            std::process::exit(0);
        }
        "hang" => {
            // Waits for the parent to kill us.
            let mut line = String::new();
            let _ = std::io::stdin().read_line(&mut line);
            panic!("not killed");
        }
        other => panic!("unknown mode {other}"),
    }
}

/// A PLC with the peer's value published, and the isolated module started in `mode`.
fn start(test: &str, mode: &str) -> (String, GlobalMap, ModuleMap, std::process::Child) {
    let id = plc_id(test);
    let layout = layout();
    let global = GlobalMap::create(&id, &layout).unwrap();
    let mut peer = ModuleMap::new(&layout, "peer", Location::Local).unwrap();
    peer.set_u32(&peer.handle("to_iso").unwrap(), 4321).unwrap();
    peer.update(&global);
    let child = Command::new(std::env::current_exe().unwrap())
        .args([
            "isolated_module_process",
            "--exact",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD_ID, &id)
        .env(CHILD_MODE, mode)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    (id, global, peer, child)
}

/// Reads the child's stdout up to the proxy's pid.
fn proxy_pid(child: &mut std::process::Child) -> u32 {
    let out = child.stdout.as_mut().unwrap();
    let mut lines = BufReader::new(out).lines();
    loop {
        match lines.next() {
            Some(Ok(l)) => {
                // libtest prints the test's name on the same line.
                if let Some((_, pid)) = l.split_once("proxy ") {
                    return pid.trim().parse().unwrap();
                }
            }
            _ => {
                let mut err = String::new();
                let _ = std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err);
                panic!("the module printed no proxy pid:\n{err}");
            }
        }
    }
}

fn finish(mut child: std::process::Child) {
    drop(child.stdin.take());
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "the isolated module failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn values_flow_both_ways_through_the_proxy() {
    let (id, global, mut peer, mut child) = start("flow", "drop");
    let pid = proxy_pid(&mut child);
    finish(child);
    wait_exited(pid);
    let (from_iso, flag) = (
        peer.handle("from_iso").unwrap(),
        peer.handle("iso_flag").unwrap(),
    );
    assert!(!peer.get_bool(&flag), "not before our update");
    peer.update(&global);
    assert!(peer.get_bool(&flag));
    assert_eq!(peer.get_i32(&from_iso), -1234);
    assert!(maps_mention("self", &id), "we created the global map");
}

#[test]
fn the_proxy_exits_when_the_module_exits_without_dropping_its_map() {
    let (_id, _global, _peer, mut child) = start("exit", "exit");
    let pid = proxy_pid(&mut child);
    finish(child);
    wait_exited(pid);
}

#[test]
fn the_proxy_exits_when_the_module_is_killed() {
    let (_id, _global, _peer, mut child) = start("kill", "hang");
    let pid = proxy_pid(&mut child);
    assert!(!exited(pid), "the proxy serves the module while it lives");
    child.kill().unwrap();
    child.wait().unwrap();
    wait_exited(pid);
}

#[test]
fn new_points_to_isolated() {
    let e = ModuleMap::new(&layout(), "iso", Location::Isolate).unwrap_err();
    assert!(
        matches!(e, ImageError::Unsupported { .. })
            && e.to_string().contains("ModuleMap::isolated"),
        "{e}"
    );
}

/// The attach errors, in a module process of their own.
#[test]
fn attach_errors_process() {
    let Ok(id) = std::env::var("PETRIPLC_ISOLATE_TEST_ERRORS") else {
        return;
    };
    let e = ModuleMap::isolated(&layout(), "iso", &format!("{id}-none")).unwrap_err();
    assert!(matches!(e, ImageError::NotRunning { .. }), "{e}");
    let e = ModuleMap::isolated(&layout_with(3), "iso", &id).unwrap_err();
    assert!(matches!(e, ImageError::LayoutMismatch { .. }), "{e}");
    let e = ModuleMap::isolated(&layout(), "nobody", &id).unwrap_err();
    assert!(matches!(e, ImageError::UnknownModule { .. }), "{e}");
    let e = ModuleMap::isolated(&layout(), "iso", "bad id").unwrap_err();
    assert!(matches!(e, ImageError::BadPlcId { .. }), "{e}");
    // Every failed proxy was reaped: no child of ours is left, not even a zombie.
    let children =
        std::fs::read_to_string(format!("/proc/self/task/{}/children", nix_tid())).unwrap();
    assert_eq!(children.trim(), "", "proxies left behind");
}

fn nix_tid() -> String {
    // The thread that forked is the proxies' parent: /proc/thread-self names it.
    std::fs::read_link("/proc/thread-self")
        .unwrap()
        .file_name()
        .unwrap()
        .to_string_lossy()
        .into_owned()
}

#[test]
fn attach_errors_name_the_cause() {
    let id = plc_id("attach");
    let _global = GlobalMap::create(&id, &layout()).unwrap();
    let out = Command::new(std::env::current_exe().unwrap())
        .args([
            "attach_errors_process",
            "--exact",
            "--nocapture",
            "--test-threads=1",
        ])
        .env("PETRIPLC_ISOLATE_TEST_ERRORS", &id)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
