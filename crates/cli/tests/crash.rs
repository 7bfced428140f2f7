//! The PLC survives crashes and faults, tested by killing through the real binary:
//! `petriplc run` killed with SIGKILL at random moments (start-up, running, shutting down)
//! and started again with the same id, 100 times, `status` telling the truth all along; a
//! module process killed while it holds the shared-memory lock, 200 times, the other modules
//! scanning on; `stop` never signalling a process it cannot prove is the PLC; failed starts
//! leaving nothing behind; the start-time checks (dead synchronisation net, safe values,
//! programs); restarts paced and limited; `plc_id` from the configuration.
//!
//! No timing assertions: waits poll for a state with a generous safety limit.

mod common;

use std::fs;
use std::os::unix::fs::PermissionsExt;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command as Process, Output, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use tempfile::TempDir;

const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples");
/// Long enough never to be reached by a working build; only keeps a broken one from hanging.
const SAFETY_NET: Duration = Duration::from_secs(60);

fn plc_id(name: &str) -> String {
    format!("crash-{name}-{}", std::process::id())
}

fn petriplc() -> Process {
    Process::cargo_bin("petriplc").unwrap()
}

fn run_out(args: &[&str]) -> Output {
    petriplc().args(args).output().unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Everything of PLC `id` in /dev/shm.
fn leftovers(id: &str) -> Vec<String> {
    let prefix = format!("petriplc-{id}");
    let mut names: Vec<String> = fs::read_dir("/dev/shm")
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| {
            n.strip_prefix(&prefix)
                .is_some_and(|rest| rest.starts_with(['-', '.']))
        })
        .collect();
    names.sort();
    names
}

fn write_executable(path: &Path, text: &str) {
    fs::write(path, text).unwrap();
    let mut perms = fs::metadata(path).unwrap().permissions();
    perms.set_mode(0o755);
    fs::set_permissions(path, perms).unwrap();
}

/// The README's main job without its displays (no vitrine, no web HMI), its Modbus server
/// on a port the system picks: a copy of examples/mixer in `dir`.
fn mixer_without_displays(dir: &Path) -> PathBuf {
    let mixer = Path::new(EXAMPLES).join("mixer");
    for f in ["mixer.pnml", "operator.csv"] {
        fs::copy(mixer.join(f), dir.join(f)).unwrap();
    }
    let conf = fs::read_to_string(mixer.join("plc.conf")).unwrap();
    let conf = &conf[..conf
        .find("[vitrine]")
        .expect("the mixer has a vitrine section")];
    let conf: String = conf
        .lines()
        .filter(|l| !l.starts_with("module vitrine") && !l.starts_with("module hmi"))
        .map(|l| format!("{l}\n"))
        .collect();
    let conf = conf.replace("listen = 127.0.0.1:5020", "listen = 127.0.0.1:0");
    let path = dir.join("plc.conf");
    fs::write(&path, conf).unwrap();
    path
}

/// `petriplc status`: exit code and the text of stdout and stderr.
fn status(id: &str) -> (i32, String) {
    let out = run_out(&["status", "--plc-id", id]);
    (
        out.status.code().unwrap_or(-1),
        text(&out.stdout) + &text(&out.stderr),
    )
}

/// Waits until `status` says the PLC runs with its modules' table (not only starting).
fn wait_running(id: &str, child: &mut Child) {
    let started = Instant::now();
    loop {
        let (code, out) = status(id);
        if code == 0 && out.contains(&format!("PLC {id} (process {}", child.id())) {
            return;
        }
        if let Some(exit) = child.try_wait().unwrap() {
            panic!("PLC {id} exited ({exit}) before running; status said: {out}");
        }
        assert!(started.elapsed() < SAFETY_NET, "PLC {id} never ran: {out}");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// A small deterministic generator for the kill moments (xorshift).
struct Moments(u64);

impl Moments {
    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0 % n
    }
}

fn sleep_ms(ms: u64) {
    std::thread::sleep(Duration::from_millis(ms));
}

#[test]
fn the_plc_comes_back_after_kill_9_at_any_moment() {
    let dir = TempDir::new().unwrap();
    let conf = mixer_without_displays(dir.path());
    let id = plc_id("mixer");
    let mut moments = Moments(0x9e37_79b9_7f4a_7c15);
    // Whether the previous PLC left something behind, so this run must say it removed it.
    let mut previous_left = false;
    // The PLC whose remains status reports: the last one killed after taking the id.
    let mut dead_pid = 0;
    // How often each moment came, and how often status found the PLC dead (5) or gone (4).
    let mut seen = [0u32; 4];
    let mut codes = [0u32; 2];
    for round in 0..100 {
        let log = dir.path().join(format!("run{round}.log"));
        let mut child = petriplc()
            .arg("run")
            .arg(&conf)
            .args(["--plc-id", &id, "--log"])
            .arg(&log)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let pid = child.id();
        let moment = moments.below(4);
        seen[moment as usize] += 1;
        let ran = match moment {
            // During start-up (now and then at once, before it can take the id).
            0 => {
                if round % 4 != 0 {
                    sleep_ms(moments.below(40));
                }
                false
            }
            // While running.
            1 | 2 => {
                wait_running(&id, &mut child);
                sleep_ms(moments.below(100));
                true
            }
            // While stopping (SIGTERM is what `petriplc stop` sends).
            _ => {
                wait_running(&id, &mut child);
                nix::sys::signal::kill(
                    nix::unistd::Pid::from_raw(pid as i32),
                    nix::sys::signal::Signal::SIGTERM,
                )
                .unwrap();
                sleep_ms(moments.below(20));
                true
            }
        };
        let _ = child.kill();
        let exit = child.wait().unwrap();
        if ran {
            // It had started, so this run removed what the one before it left (and said so
            // once) or found nothing.
            let log = fs::read_to_string(&log).unwrap();
            let said = log.matches(" exited without stopping").count();
            assert_eq!(
                said,
                usize::from(previous_left),
                "round {round}: the start's report of what the last PLC left:\n{log}"
            );
        }
        let (code, out) = status(&id);
        match code {
            // Killed before it took the id (or after it gave it up, stopping).
            4 => assert!(
                moment == 0 || (moment == 3 && exit.signal() != Some(9)) || !ran,
                "round {round}: a PLC that ran left nothing? {out}"
            ),
            5 => {
                // This PLC, or (killed before it took the id) the one before it, whose
                // remains are still there.
                let this = format!("the PLC (pid {pid}) exited without stopping at ");
                let before = format!("the PLC (pid {dead_pid}) exited without stopping at ");
                assert!(
                    out.contains(&this)
                        || (moment == 0 && out.contains(&before))
                        || out.contains("a PLC exited without stopping at "),
                    "round {round}: {out}"
                );
                if out.contains(&this) {
                    dead_pid = pid;
                }
            }
            _ => panic!("round {round}: status of a killed PLC: {code} {out}"),
        }
        if moment == 1 || moment == 2 {
            assert_eq!(code, 5, "round {round}: killed while running: {out}");
        }
        previous_left = code == 5;
        codes[usize::from(code == 5)] += 1;
    }
    eprintln!(
        "kills: {} at start-up, {} running, {} stopping; status: {} no such PLC, {} exited \
         without stopping",
        seen[0],
        seen[1] + seen[2],
        seen[3],
        codes[0],
        codes[1]
    );
    // A last run, stopped cleanly: nothing is left.
    let mut child = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &id])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    wait_running(&id, &mut child);
    let stop = run_out(&["stop", "--plc-id", &id]);
    assert!(stop.status.success(), "{}", text(&stop.stderr));
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert_eq!(status(&id).0, 4);
    assert_eq!(leftovers(&id), Vec::<String>::new());
}

/// Builds the victim module in `dir` against a copy of the `libpetriplc.so` built with this
/// test (it sits beside the test binary: petriplc-capi is a dev-dependency for it).
fn victim_program(dir: &Path) -> PathBuf {
    // Writes a = b = its scan count every scan: a reader that ever sees a != b has seen
    // half an update.
    common::c_module(
        dir,
        "victim",
        r#"#include <stdio.h>
#include "petriplc.h"
int main(int argc, char **argv) {
    if (plc_init("victim", &argc, argv) != PLC_OK) {
        fprintf(stderr, "victim: %s\n", plc_last_error());
        return 1;
    }
    plc_pt_t a = plc_pt_by_name("a"), b = plc_pt_by_name("b");
    uint32_t n = plc_get(a);
    while (plc_scan_beg() == PLC_OK) {
        n++;
        plc_set(a, n);
        plc_set(b, n);
        if (plc_scan_end() != PLC_OK)
            break;
    }
    plc_close();
    return 0;
}
"#,
        &[],
    )
}

#[test]
fn a_module_killed_holding_the_lock_never_blocks_the_others() {
    let dir = TempDir::new().unwrap();
    let victim = victim_program(dir.path());
    // Dies in its 3rd update (half its words out) or its 2nd firing (half a firing done).
    for (hook, name) in [("update:3", "update"), ("firing:2", "firing")] {
        write_executable(
            &dir.path().join(format!("victim-{name}.sh")),
            &format!(
                "#!/bin/sh\nPETRIPLC_TEST_DIE_HOLDING_LOCK={hook} exec {}\n",
                victim.display()
            ),
        );
    }
    // `victim` and `peer` lock-step (the firing victim dies inside its net); `ticker`
    // scans on its own; the logger records a and b, which must always be equal.
    let conf = |victim: &str| {
        format!(
            "[PLC]\nmodule victim victim-{victim}.sh\nmodule peer timeline\nmodule ticker timeline\n\
             module log logger\n\
             point a \"\" victim at 0 u32\npoint p \"\" peer at 1\npoint t \"\" ticker at 2\n\
             point b \"\" victim at 3 u32\n\
             synch victim -> peer\nsynch peer -> victim\nsynch_start victim\n\
             [victim]\non_failure = restart\nrestart_delay = 0\nrestart_limit = 0\n\
             [peer]\nfile = pulse.csv\nrepeat = yes\n\
             [ticker]\nfile = tick.csv\nrepeat = yes\nscan_period = 0.001\n\
             [log]\nfile = ab.csv\nlog a b\nscan_period = 0.001\n"
        )
    };
    fs::write(dir.path().join("pulse.csv"), "time,p\n0,1\n0.01,0\n").unwrap();
    fs::write(dir.path().join("tick.csv"), "time,t\n0,1\n0.002,0\n").unwrap();
    for (victim, deaths) in [("update", 200), ("firing", 200)] {
        let conf_path = dir.path().join(format!("{victim}.conf"));
        fs::write(&conf_path, conf(victim)).unwrap();
        let id = plc_id(&format!("lock-{victim}"));
        let mut child = petriplc()
            .arg("run")
            .arg(&conf_path)
            .args(["--plc-id", &id, "--log-level", "warn"])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        wait_running(&id, &mut child);
        // Until the victim has died `deaths` times; the others must scan on meanwhile.
        let started = Instant::now();
        let ticker_scans = loop {
            let (code, out) = status(&id);
            assert_eq!(code, 0, "{out}");
            let field = |module: &str, col: usize| -> u64 {
                out.lines()
                    .find(|l| l.starts_with(&format!("{module} ")))
                    .and_then(|l| l.split_whitespace().nth(col)?.parse().ok())
                    .unwrap_or(0)
            };
            let restarts = field("victim", 8);
            if restarts >= deaths {
                assert!(field("peer", 4) > 0, "{out}");
                break field("ticker", 4);
            }
            assert!(
                started.elapsed() < SAFETY_NET,
                "{victim}: only {restarts} deaths so far:\n{out}"
            );
            sleep_ms(50);
        };
        // The others still scan after all those deaths.
        let later = Instant::now();
        loop {
            let (_, out) = status(&id);
            let scans: u64 = out
                .lines()
                .find(|l| l.starts_with("ticker "))
                .and_then(|l| l.split_whitespace().nth(4)?.parse().ok())
                .unwrap_or(0);
            if scans > ticker_scans {
                break;
            }
            assert!(later.elapsed() < SAFETY_NET, "the ticker stopped:\n{out}");
            sleep_ms(10);
        }
        let stop = run_out(&["stop", "--plc-id", &id]);
        assert!(stop.status.success(), "{}", text(&stop.stderr));
        let out = child.wait_with_output().unwrap();
        let log = text(&out.stderr);
        assert!(out.status.success(), "{log}");
        // Every death went through on_failure (restart), none blocked anybody.
        let reported = log
            .matches("module victim failed (its process ended: signal: 9 (SIGKILL)); restarting it")
            .count();
        assert!(
            reported >= deaths as usize,
            "{reported} deaths reported:\n{log}"
        );
        // a and b were never seen apart: every half-done update was undone.
        let logged = fs::read_to_string(dir.path().join("ab.csv")).unwrap();
        check_a_equals_b(&logged);
        assert_eq!(leftovers(&id), Vec::<String>::new());
    }
}

/// The logger's `time,point,value` lines, grouped by time: a and b equal at every time.
fn check_a_equals_b(logged: &str) {
    let mut values: std::collections::BTreeMap<&str, (Option<&str>, Option<&str>)> =
        Default::default();
    for line in logged.lines().skip(1) {
        let mut f = line.split(',');
        let (Some(t), Some(p), Some(v)) = (f.next(), f.next(), f.next()) else {
            continue;
        };
        let e = values.entry(t).or_default();
        match p {
            "a" => e.0 = Some(v),
            "b" => e.1 = Some(v),
            _ => {}
        }
    }
    assert!(!values.is_empty(), "nothing logged:\n{logged}");
    let (mut a, mut b) = (None, None);
    for (t, (na, nb)) in values {
        a = na.or(a);
        b = nb.or(b);
        assert_eq!(a, b, "a and b apart at t={t}");
    }
}

#[test]
fn stop_never_signals_a_process_it_cannot_prove_is_the_plc() {
    let id = plc_id("stale");
    // An unrelated live process, named by a stale lock file (even with its true start time)
    // and status file: `stop` must leave it alone and clean up.
    let mut bystander = Process::new("sleep").arg("30").spawn().unwrap();
    let pid = bystander.id();
    let stat = fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    let start = stat[stat.rfind(')').unwrap() + 1..]
        .split_whitespace()
        .nth(19)
        .unwrap()
        .to_string();
    fs::write(
        format!("/dev/shm/petriplc-{id}.lock"),
        format!("{pid} {start}\n"),
    )
    .unwrap();
    fs::write(
        format!("/dev/shm/petriplc-{id}.status.json"),
        format!("{{\"plc_id\":\"{id}\",\"pid\":{pid}}}"),
    )
    .unwrap();
    let (code, out) = status(&id);
    assert_eq!(code, 5, "{out}");
    assert!(
        out.contains(&format!(
            "not running: the PLC (pid {pid}) exited without stopping at "
        )),
        "{out}"
    );
    let stop = run_out(&["stop", "--plc-id", &id]);
    assert!(stop.status.success(), "{}", text(&stop.stderr));
    assert!(
        text(&stop.stderr).contains("was not running") && text(&stop.stderr).contains("removed"),
        "{}",
        text(&stop.stderr)
    );
    assert!(
        bystander.try_wait().unwrap().is_none(),
        "the bystander lives"
    );
    assert_eq!(leftovers(&id), Vec::<String>::new());
    assert_eq!(status(&id).0, 4);
    assert_eq!(run_out(&["stop", "--plc-id", &id]).status.code(), Some(4));
    let _ = bystander.kill();
    let _ = bystander.wait();
}

fn run_config(dir: &Path, conf: &str, id: &str, extra: &[&str]) -> Output {
    let path = dir.join("plc.conf");
    fs::write(&path, conf).unwrap();
    petriplc()
        .arg("run")
        .arg(&path)
        .args(["--plc-id", id])
        .args(extra)
        .output()
        .unwrap()
}

#[test]
fn a_failed_start_removes_everything_it_made() {
    let dir = TempDir::new().unwrap();
    let id = plc_id("failed");
    // Not executable: refused before anything exists (exit 2).
    fs::write(dir.path().join("noexec.sh"), "#!/bin/sh\nexit 0\n").unwrap();
    let out = run_config(
        dir.path(),
        "[PLC]\nmodule q shutdown\nmodule p noexec.sh\npoint s \"\" q\n[q]\npoint = s\n",
        &id,
        &[],
    );
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("noexec.sh is not executable"), "{err}");
    assert_eq!(leftovers(&id), Vec::<String>::new());
    // Executable, but exec fails (no such interpreter): the PLC had started its threads and
    // shared memory; all of it goes, and the OS error is said once (exit 3).
    write_executable(&dir.path().join("badexec"), "#!/nonexistent/interpreter\n");
    let out = run_config(
        dir.path(),
        "[PLC]\nmodule q shutdown\nmodule p badexec\npoint s \"\" q\n[q]\npoint = s\nscan_period = 0.01\n",
        &id,
        &[],
    );
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(err.contains("cannot start program"), "{err}");
    assert_eq!(err.matches("(os error 2)").count(), 1, "said once: {err}");
    assert_eq!(leftovers(&id), Vec::<String>::new());
    // And the id is free at once.
    let out = run_config(
        dir.path(),
        "[PLC]\nmodule q shutdown\npoint s \"\" q\n[q]\npoint = s\nscan_period = 0.01\n",
        &id,
        &["--for", "100ms"],
    );
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(!text(&out.stderr).contains("exited without stopping"));
}

#[test]
fn checks_at_start_refuse_what_would_fail_later() {
    let dir = TempDir::new().unwrap();
    let base = "[PLC]\nmodule q shutdown\nmodule t timeline\npoint s \"\" q\npoint v \"\" t\n\
                point n \"\" t u8\n[q]\npoint = s\nscan_period = 0.01\n[t]\nfile = t.csv\n";
    fs::write(dir.path().join("t.csv"), "time,v,n\n0,1,3\n").unwrap();
    let cases: &[(&str, &str)] = &[
        (
            "synch q -> t\nsynch t -> q\n",
            "the synchronisation net can never let modules `q`, `t` scan",
        ),
        (
            "safe NOPE 1\n",
            "plc.conf:12: module t: `safe NOPE 1`: no point named `NOPE`",
        ),
        (
            "safe v 999\n",
            "plc.conf:12: module t: `safe v 999`: point `v` (unsigned, 1 bits) cannot hold 999",
        ),
        (
            "safe n -1\n",
            "`safe n -1`: not a value for a unsigned point",
        ),
        ("safe s 1\n", "`safe s 1`: the point belongs to module q"),
    ];
    for (i, (extra, message)) in cases.iter().enumerate() {
        let conf = if extra.starts_with("synch") {
            base.replacen("[q]", &format!("{extra}[q]"), 1)
        } else {
            format!("{base}{extra}")
        };
        let id = plc_id(&format!("check{i}"));
        let out = run_config(dir.path(), &conf, &id, &["--for", "5s"]);
        let err = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{conf}\n{err}");
        assert!(err.contains(message), "expected `{message}` in:\n{err}");
        assert_eq!(leftovers(&id), Vec::<String>::new());
    }
}

#[test]
fn restarts_back_off_and_give_up_at_the_limit() {
    let dir = TempDir::new().unwrap();
    write_executable(&dir.path().join("quits.sh"), "#!/bin/sh\nexit 3\n");
    let conf = |settings: &str| {
        format!(
            "[PLC]\nmodule quits quits.sh\nmodule q shutdown\npoint s \"\" q\npoint v \"\" quits\n\
             [quits]\non_failure = restart\nsafe v 0\n{settings}[q]\npoint = s\nscan_period = 0.01\n"
        )
    };
    // The limit: three restarts, then the module is failed and the PLC stops (exit 1).
    let id = plc_id("limit");
    let out = run_config(
        dir.path(),
        &conf("restart_delay = T#5ms\nrestart_delay_max = T#20ms\nrestart_limit = 3\n"),
        &id,
        &["--for", "60s"],
    );
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.matches("restarting it").count(), 3, "{err}");
    assert!(
        err.contains("after 3 restarts in a row (restart_limit = 3)"),
        "{err}"
    );
    assert!(err.contains("safe value v = 0"), "{err}");
    assert!(err.contains("quits        program       failed"), "{err}");
    assert!(err.contains("\n             quits.sh\n"), "{err}");
    // The defaults back off from 100 ms, doubling: a program that exits at once is not
    // restarted every few milliseconds (before the fix: over 100 times in 2 s). Read from
    // the log's own words as the restarts come, then stopped (counting the restarts of a
    // fixed run depended on how fast the machine started the program).
    let id = plc_id("backoff");
    let path = dir.path().join("backoff.conf");
    fs::write(&path, conf("")).unwrap();
    let mut child = petriplc()
        .arg("run")
        .arg(&path)
        .args(["--plc-id", &id, "--for", "120s"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = common::Lines::of(&mut child);
    for delay in ["100 ms", "200 ms", "400 ms"] {
        lines.until("restarting it", SAFETY_NET);
        let last = lines.seen.lines().last().unwrap_or_default();
        assert!(
            last.ends_with(&format!("restarting it in {delay}")),
            "expected a restart in {delay}:\n{}",
            lines.seen
        );
    }
    let stop = run_out(&["stop", "--plc-id", &id]);
    assert!(stop.status.success(), "{}", text(&stop.stderr));
    let err = lines.rest();
    assert!(child.wait().unwrap().success(), "{err}");
}

#[test]
fn plc_id_in_the_configuration_is_honoured() {
    let dir = TempDir::new().unwrap();
    let id = plc_id("fromconf");
    let conf = dir.path().join("plc.conf");
    fs::write(
        &conf,
        format!("[PLC]\nplc_id = {id}\nmodule q shutdown\npoint s \"\" q\n[q]\npoint = s\nscan_period = 0.01\n"),
    )
    .unwrap();
    let mut child = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--for", "30s"])
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    wait_running(&id, &mut child);
    assert!(run_out(&["stop", "--plc-id", &id]).status.success());
    assert!(child.wait().unwrap().success());
    // An id no shared memory can be named by, written in the file, is reported there.
    fs::write(
        &conf,
        "[PLC]\nplc_id = a/b\nmodule q shutdown\npoint s \"\" q\n[q]\npoint = s\n",
    )
    .unwrap();
    let out = petriplc().arg("run").arg(&conf).output().unwrap();
    let err = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("plc.conf:2: plc_id = a/b: use only letters"),
        "{err}"
    );
}
