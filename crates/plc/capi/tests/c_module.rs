//! The C example module (`examples/c-module/blinker.c`) compiled with `cc` against
//! `petriplc.h` and `libpetriplc.so`, run as a child process attached to a PLC the test
//! creates, lock-stepped or free-running, and stopped cleanly.
//!
//! Finding the library: the rustc invocation that builds this package's rlib (which this
//! test binary links) also writes its cdylib, `libpetriplc.so`, into the same `deps`
//! directory as the test binary, so the library is always the one built from the code
//! under test, for whatever profile and target directory `cargo test` uses. Running a
//! nested `cargo build` instead would wait on the lock the outer cargo holds. The library is
//! copied to a temporary directory so that a concurrent cargo rewriting `deps` cannot change
//! it under the linker or the running child.

mod common;

use std::os::fd::{AsRawFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use common::TestPlc;
use petriplc_runtime::report;
use petriplc_runtime::synch::{SharedSynch, TransitionRef};

/// Long enough never to be reached by a working build; only keeps a broken one from hanging.
const SAFETY_NET: Duration = Duration::from_secs(60);

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

/// The library and the compiled blinker, built once per test process.
struct Built {
    dir: tempfile::TempDir,
    blinker: PathBuf,
}

fn built() -> &'static Built {
    static BUILT: OnceLock<Built> = OnceLock::new();
    BUILT.get_or_init(|| {
        let exe = std::env::current_exe().unwrap();
        let deps = exe.parent().unwrap();
        let lib = deps.join("libpetriplc.so");
        assert!(
            lib.exists(),
            "{} is missing: it is built with this package's rlib (crate-type cdylib)",
            lib.display()
        );
        let dir = tempfile::tempdir().unwrap();
        std::fs::copy(&lib, dir.path().join("libpetriplc.so")).unwrap();
        let blinker = dir.path().join("blinker");
        let source = workspace_root().join("examples/c-module/blinker.c");
        let include = Path::new(env!("CARGO_MANIFEST_DIR")).join("include");
        // The README's command, plus the warnings that keep the header and example clean C99.
        let out = Command::new("cc")
            .args(["-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-I"])
            .arg(&include)
            .arg(&source)
            .arg("-L")
            .arg(dir.path())
            .args(["-lpetriplc", "-o"])
            .arg(&blinker)
            .output()
            .expect("a C compiler `cc` is needed to build the C example module");
        assert!(
            out.status.success(),
            "cc failed:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        Built { dir, blinker }
    })
}

/// The blinker as `petriplc run` would start it (configuration and module in the
/// environment), with `args` on its command line.
fn spawn_blinker(plc: &TestPlc, args: &[&str]) -> Child {
    spawn_blinker_reporting(plc, args, None)
}

/// As [`spawn_blinker`], with the pipe `petriplc run` passes for scan statistics.
fn spawn_blinker_reporting(plc: &TestPlc, args: &[&str], stats: Option<&OwnedFd>) -> Child {
    let b = built();
    let out = |name: &str| std::fs::File::create(plc.dir.path().join(name)).unwrap();
    let mut command = Command::new(&b.blinker);
    if let Some(fd) = stats {
        command.env(report::STATS_FD, fd.as_raw_fd().to_string());
    }
    command
        .args(args)
        .env("PETRIPLC_CONFIG", &plc.config_path)
        .env("PETRIPLC_MODULE", "blinker")
        .env_remove("PETRIPLC_PLC_ID")
        .env("LD_LIBRARY_PATH", b.dir.path())
        .stdin(Stdio::null())
        .stdout(out("stdout"))
        .stderr(out("stderr"))
        .spawn()
        .unwrap()
}

fn output(plc: &TestPlc, name: &str) -> String {
    std::fs::read_to_string(plc.dir.path().join(name)).unwrap_or_default()
}

fn wait_exit(plc: &TestPlc, child: &mut Child) -> ExitStatus {
    let deadline = Instant::now() + SAFETY_NET;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the blinker did not exit:\n{}", output(plc, "stderr"));
        }
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// Fires `t` for the test's module, failing (with the child's messages) if the child dies
/// instead of letting the net move on.
fn synch(plc: &TestPlc, shared: &SharedSynch, t: TransitionRef, child: &mut Child) {
    let deadline = Instant::now() + SAFETY_NET;
    loop {
        match shared.synch_timeout(t, Duration::from_millis(50)) {
            Ok(Some(_)) => return,
            Ok(None) => {}
            Err(stopped) => panic!("{stopped}"),
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!(
                "the blinker exited ({status}) mid-run:\n{}",
                output(plc, "stderr")
            );
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the blinker is stuck:\n{}", output(plc, "stderr"));
        }
    }
}

const LOCK_STEP: &str = "\
[PLC]
module tester test
module blinker blinker
point enable \"blink while true\" tester
point lamp \"the blinking output\" blinker
point scans \"scans the blinker has done\" blinker u32
synch tester -> blinker
synch blinker -> tester
synch_start tester
";

/// What the tester sees at the start of each of its scans: (lamp, scans), given the enable
/// it writes in each scan. Blinker scan k runs between tester scans k and k + 1 and sees the
/// enable of tester scan k.
fn expected(enables: &[bool], every: u32) -> Vec<(u32, u32)> {
    let (mut lamp, mut ticks, mut scans) = (0, 0, 0);
    let mut seen = Vec::new();
    for &enable in enables {
        seen.push((lamp, scans));
        if enable {
            ticks += 1;
            if ticks >= every {
                ticks = 0;
                lamp ^= 1;
            }
        } else {
            ticks = 0;
        }
        scans += 1;
    }
    seen.push((lamp, scans));
    seen
}

#[test]
fn c_module_lock_steps_with_the_plc_and_stops_cleanly() {
    let plc = TestPlc::start("lockstep", LOCK_STEP);
    let mut tester = plc.module_map("tester");
    let (enable, lamp, scans) = (
        tester.handle("enable").unwrap(),
        tester.handle("lamp").unwrap(),
        tester.handle("scans").unwrap(),
    );
    let (beg, end) = (plc.net.scan_beg("tester"), plc.net.scan_end("tester"));
    // --PLCplc_id on the command line and the rest from the environment: both ways in, and
    // the blinker would refuse its arguments if plc_init left the option in argv.
    let plc_id = format!("--PLCplc_id={}", plc.id);
    let (mut stats, stats_fd) = report::Receiver::pipe().unwrap();
    let mut child = spawn_blinker_reporting(
        &plc,
        &[plc_id.as_str(), "2", "enable", "lamp", "scans"],
        Some(&stats_fd),
    );
    drop(stats_fd);

    let enables: Vec<bool> = (0..30)
        .map(|k| (4..15).contains(&k) || (20..27).contains(&k))
        .collect();
    let mut seen = Vec::new();
    for &on in &enables {
        synch(&plc, &plc.synch, beg, &mut child);
        tester.update(&plc.global);
        seen.push((tester.get_u32(&lamp), tester.get_u32(&scans)));
        tester.set_bool(&enable, on).unwrap();
        tester.update(&plc.global);
        synch(&plc, &plc.synch, end, &mut child);
    }
    // Once more, to see the blinker's last scan; it then waits for a token it never gets.
    synch(&plc, &plc.synch, beg, &mut child);
    tester.update(&plc.global);
    seen.push((tester.get_u32(&lamp), tester.get_u32(&scans)));

    assert_eq!(seen, expected(&enables, 2));
    let toggles = seen.windows(2).filter(|w| w[0].0 != w[1].0).count();
    assert!(
        toggles >= 6,
        "the lamp toggled only {toggles} times: {seen:?}"
    );

    plc.synch.stop();
    let status = wait_exit(&plc, &mut child);
    let stdout = output(&plc, "stdout");
    assert!(
        status.success(),
        "{status}\n{stdout}\n{}",
        output(&plc, "stderr")
    );
    assert!(
        stdout.contains("the PLC is stopping after 30 scans"),
        "{stdout}"
    );
    // What `petriplc status` shows of it: every scan, timed.
    let r = stats.latest().expect("the blinker reported its scans");
    assert_eq!(r.scans, 30, "{r:?}");
    assert!(
        r.cycle_us[0] > 0.0 && r.cycle_us[0] <= r.cycle_us[2],
        "{r:?}"
    );
}

#[test]
fn c_module_runs_free_on_its_scan_period() {
    let plc = TestPlc::start(
        "period",
        "[PLC]\nmodule tester test\nmodule blinker blinker\npoint enable \"\" tester init 1\n\
         point lamp \"\" blinker\npoint scans \"\" blinker u32\n[blinker]\nscan_period = 0.005\n",
    );
    let started = Instant::now();
    let plc_id = format!("--PLCplc_id={}", plc.id);
    let mut child = spawn_blinker(&plc, &[plc_id.as_str(), "1", "enable", "lamp", "scans"]);
    let (lamp, scans) = (
        plc.layout.point("lamp").unwrap(),
        plc.layout.point("scans").unwrap(),
    );
    let mut lamps_seen = [false; 2];
    let deadline = Instant::now() + SAFETY_NET;
    loop {
        let n = plc.global.read_point(&plc.layout, scans);
        let l = plc.global.read_point(&plc.layout, lamp);
        lamps_seen[usize::from(l == petriplc_config::PointValue::Unsigned(1))] = true;
        // At least 21: a poller descheduled for longer than a period misses single values.
        if matches!(n, petriplc_config::PointValue::Unsigned(k) if k >= 21) {
            break;
        }
        if let Some(status) = child.try_wait().unwrap() {
            panic!("the blinker exited ({status}):\n{}", output(&plc, "stderr"));
        }
        assert!(Instant::now() < deadline, "the blinker is stuck at {n:?}");
        std::thread::sleep(Duration::from_micros(500));
    }
    // Scan 20 cannot start before t0 + 20 periods, and t0 is after the spawn.
    assert!(started.elapsed() >= Duration::from_millis(100));
    assert_eq!(lamps_seen, [true, true], "the lamp never toggled");
    plc.synch.stop();
    let status = wait_exit(&plc, &mut child);
    assert!(status.success(), "{status}\n{}", output(&plc, "stderr"));
}

#[test]
fn c_module_reports_library_errors() {
    // No PLC with that id: the message says how to start one or which id to pass.
    let plc = TestPlc::start("errors", LOCK_STEP);
    let mut child = spawn_blinker(&plc, &["--PLCplc_id=capi-no-such-plc"]);
    let status = wait_exit(&plc, &mut child);
    let stderr = output(&plc, "stderr");
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(
        stderr.contains("no PLC with id `capi-no-such-plc`"),
        "{stderr}"
    );
    assert!(stderr.contains("petriplc run"), "{stderr}");
    assert!(stderr.contains("--PLCplc_id=ID"), "{stderr}");

    // A misspelt point: plc_last_error names it and suggests the right one.
    let plc_id = format!("--PLCplc_id={}", plc.id);
    let mut child = spawn_blinker(&plc, &[plc_id.as_str(), "2", "enable", "lamb"]);
    let status = wait_exit(&plc, &mut child);
    let stderr = output(&plc, "stderr");
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("no point named `lamb`"), "{stderr}");
    assert!(stderr.contains("`lamp`"), "{stderr}");

    // An unknown --PLC option is refused, not handed to the module.
    let mut child = spawn_blinker(&plc, &[plc_id.as_str(), "--PLCshared"]);
    let status = wait_exit(&plc, &mut child);
    let stderr = output(&plc, "stderr");
    assert_eq!(status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("unknown option `--PLCshared`"), "{stderr}");
}

/// The header is also valid C++ (the `extern "C"` block), when a C++ compiler is present.
#[test]
fn header_compiles_as_cxx() {
    let dir = tempfile::tempdir().unwrap();
    let source = dir.path().join("check.cpp");
    std::fs::write(
        &source,
        "#include \"petriplc.h\"\nint main() { plc_pt_t p = plc_pt_by_name(\"x\"); \
         return plc_pt_valid(p) + plc_set_f32(p, 1.0f); }\n",
    )
    .unwrap();
    let include = Path::new(env!("CARGO_MANIFEST_DIR")).join("include");
    match Command::new("c++")
        .args([
            "-Wall",
            "-Wextra",
            "-pedantic",
            "-Werror",
            "-fsyntax-only",
            "-I",
        ])
        .arg(&include)
        .arg(&source)
        .output()
    {
        Ok(out) => assert!(
            out.status.success(),
            "c++ rejects petriplc.h:\n{}",
            String::from_utf8_lossy(&out.stderr)
        ),
        Err(e) => eprintln!("no C++ compiler (`c++`: {e}): header not checked as C++"),
    }
}
