//! Retentive points through the real binary: a C module counts in a retentive point every
//! scan; the PLC is killed with SIGKILL at random moments 200 times and started again. The
//! value given back is never lower than the last one the PLC acknowledged as written (its
//! status file says which) nor higher than the last one the module wrote (it logs each value
//! before committing it), the file is never damaged, and the module goes on from the value
//! given back. Then a damaged copy falls back to the other with a warning, two damaged
//! copies and a changed point are refused, and a module process killed alone goes on from
//! the image rather than from its init value.
//!
//! No timing assertions: waits poll for a state with a generous safety limit.

mod common;

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command as Process, Stdio};
use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use petriplc_retain::Value;
use tempfile::TempDir;

const SAFETY_NET: Duration = Duration::from_secs(60);

fn petriplc() -> Process {
    Process::cargo_bin("petriplc").unwrap()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Builds the counter module in `dir` against the `libpetriplc.so` built with this test:
/// every scan it adds one to `count`, logging the new value to its first argument before
/// the scan commits it.
fn counter_program(dir: &Path) -> PathBuf {
    common::c_module(
        dir,
        "counter",
        r#"#include <stdio.h>
#include "petriplc.h"
int main(int argc, char **argv) {
    if (plc_init("counter", &argc, argv) != PLC_OK) {
        fprintf(stderr, "counter: %s\n", plc_last_error());
        return 1;
    }
    FILE *log = fopen(argv[1], "a");
    plc_pt_t count = plc_pt_by_name("count");
    while (plc_scan_beg() == PLC_OK) {
        uint32_t v = plc_get(count) + 1;
        fprintf(log, "%u\n", v);
        fflush(log);
        plc_set(count, v);
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

fn config(dir: &Path, name: &str, write: &str, extra: &str) -> PathBuf {
    let path = dir.join(name);
    fs::write(
        &path,
        format!(
            "[PLC]\nmodule counter counter {}\n\
             point count \"scans counted\" counter u32 retain\n\
             retain_file = state/count.retain\nretain_write = {write}\n{extra}\
             [counter]\nscan_period = T#1ms\n",
            dir.join("written.log").display()
        ),
    )
    .unwrap();
    path
}

fn status_json(id: &str) -> Option<serde_json::Value> {
    let text = fs::read_to_string(format!("/dev/shm/petriplc-{id}.status.json")).ok()?;
    serde_json::from_str(&text).ok()
}

/// Waits until the counter has scanned; returns its process.
fn wait_counting(id: &str, plc: &mut Child) -> u32 {
    let started = Instant::now();
    loop {
        if let Some(s) = status_json(id) {
            let m = &s["modules"][0];
            if m["state"] == "running" && m["pid"].as_u64().unwrap_or(0) > 0 {
                return m["pid"].as_u64().unwrap() as u32;
            }
        }
        if let Some(exit) = plc.try_wait().unwrap() {
            panic!("the PLC exited ({exit}) before running");
        }
        assert!(started.elapsed() < SAFETY_NET, "the PLC never ran");
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// The count the PLC last acknowledged as written, per its status file.
fn acknowledged(id: &str) -> Option<u64> {
    let s = status_json(id)?;
    let r = &s["retain"];
    if r["sequence"].as_u64()? == 0 {
        return None;
    }
    r["values"]["count"].as_str()?.parse().ok()
}

fn gone(pid: u32) {
    let started = Instant::now();
    while Path::new(&format!("/proc/{pid}")).exists() {
        let stat = fs::read_to_string(format!("/proc/{pid}/stat")).unwrap_or_default();
        if stat.contains(") Z ") {
            return;
        }
        assert!(started.elapsed() < SAFETY_NET, "process {pid} lives on");
        std::thread::sleep(Duration::from_millis(1));
    }
}

/// The newest snapshot's count, failing on any damage.
fn stored(path: &Path) -> Option<u64> {
    let loaded = petriplc_retain::file::peek(path).unwrap();
    assert_eq!(
        loaded.warnings,
        Vec::<String>::new(),
        "the retain file is damaged"
    );
    let snap = loaded.snapshot?;
    assert_eq!(snap.entries.len(), 1);
    match snap.entries[0].value {
        Value::Point { raw, .. } => Some(u64::from(raw)),
        Value::Data { .. } => panic!("{snap:?}"),
    }
}

fn written(dir: &Path) -> Vec<u64> {
    fs::read_to_string(dir.join("written.log"))
        .unwrap_or_default()
        .lines()
        .filter_map(|l| l.parse().ok())
        .collect()
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

#[test]
fn retained_values_survive_kill_9_at_any_moment() {
    let dir = TempDir::new().unwrap();
    counter_program(dir.path());
    // Every change, and at most every 20 ms: one file for both.
    let confs = [
        config(dir.path(), "change.conf", "change", ""),
        config(dir.path(), "every.conf", "T#20ms", ""),
    ];
    let retain = dir.path().join("state/count.retain");
    let id = format!("retain-{}", std::process::id());
    let mut moments = Moments(0x2545_f491_4f6c_dd1d);
    // What the last round left in the file: the next start must give exactly that back.
    let mut expect: Option<u64> = None;
    let mut acks = 0;
    for round in 0..200 {
        fs::write(dir.path().join("written.log"), "").unwrap();
        let mut plc = petriplc()
            .arg("run")
            .arg(&confs[round % 2])
            .args(["--plc-id", &id, "--log-level", "warn"])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let counter = wait_counting(&id, &mut plc);
        // Half the rounds (of both configurations) are killed only after a first acknowledged
        // write, so that both kinds of kill are tested whatever the machine's speed (counting
        // the rounds that happened to see one was at the mercy of the load).
        if round % 4 >= 2 {
            let started = Instant::now();
            while acknowledged(&id).is_none() {
                assert!(started.elapsed() < SAFETY_NET, "no write acknowledged");
                std::thread::sleep(Duration::from_millis(1));
            }
        }
        std::thread::sleep(Duration::from_millis(moments.below(60)));
        let ack = acknowledged(&id);
        plc.kill().unwrap();
        let out = plc.wait_with_output().unwrap();
        gone(counter);
        let log = text(&out.stderr);
        assert!(!log.contains("damaged"), "round {round}: {log}");
        let values = written(dir.path());
        // The module went on from exactly what the file gave back.
        if let Some(&first) = values.first() {
            assert_eq!(
                first,
                expect.unwrap_or(0) + 1,
                "round {round}: the first count after the restart"
            );
        }
        let now = stored(&retain);
        if let Some(a) = ack {
            acks += 1;
            let now = now.expect("an acknowledged snapshot is in the file");
            assert!(now >= a, "round {round}: {now} restored < {a} acknowledged");
        }
        if let Some(now) = now {
            let max = values
                .iter()
                .copied()
                .max()
                .unwrap_or(0)
                .max(expect.unwrap_or(0));
            assert!(now <= max, "round {round}: {now} restored > {max} written");
        }
        expect = now.or(expect);
    }
    assert!(acks >= 100, "only {acks} rounds saw an acknowledged write");
    eprintln!("200 kills, {acks} after an acknowledged write; last count {expect:?}");
}

#[test]
fn a_damaged_copy_falls_back_and_mismatches_are_refused() {
    let dir = TempDir::new().unwrap();
    counter_program(dir.path());
    let conf = config(dir.path(), "plc.conf", "T#10ms", "");
    let retain = dir.path().join("state/count.retain");
    let id = format!("retain-damage-{}", std::process::id());
    let run = |conf: &Path, extra: &[&str]| {
        petriplc()
            .arg("run")
            .arg(conf)
            .args(["--plc-id", &id, "--for", "0.3s"])
            .args(extra)
            .output()
            .unwrap()
    };
    for _ in 0..2 {
        let out = run(&conf, &[]);
        assert!(out.status.success(), "{}", text(&out.stderr));
    }
    let newest = petriplc_retain::file::peek(&retain)
        .unwrap()
        .snapshot
        .unwrap();
    // Damage the newest copy: the other one is used, with a warning.
    let mut bytes = fs::read(&retain).unwrap();
    let slot = bytes.len() / 2;
    bytes[(newest.seq as usize % 2) * slot + 45] ^= 0x10;
    fs::write(&retain, &bytes).unwrap();
    let older = stored_unchecked(&retain);
    fs::write(dir.path().join("written.log"), "").unwrap();
    let out = run(&conf, &[]);
    let log = text(&out.stderr);
    assert!(out.status.success(), "{log}");
    assert!(
        log.contains(&format!(
            "copy {} is damaged (checksum mismatch: a write cut short by a crash or power loss, \
             or a failing disk); using the other copy, snapshot {}",
            newest.seq % 2,
            newest.seq - 1
        )),
        "{log}"
    );
    assert_eq!(written(dir.path()).first(), Some(&(older + 1)), "{log}");
    // Both copies damaged: refused, nothing started.
    let mut bytes = fs::read(&retain).unwrap();
    let slot = bytes.len() / 2;
    bytes[50] ^= 1;
    bytes[slot + 50] ^= 1;
    fs::write(&retain, &bytes).unwrap();
    let out = run(&conf, &[]);
    let log = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{log}");
    assert!(
        log.contains("no copy is whole") && log.contains("Move it away"),
        "{log}"
    );
    fs::remove_file(&retain).unwrap();
    let out = run(&conf, &[]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    // The point changed size: refused, naming it.
    let wider = dir.path().join("wider.conf");
    fs::write(
        &wider,
        fs::read_to_string(&conf)
            .unwrap()
            .replace("counter u32 retain", "counter u16 retain"),
    )
    .unwrap();
    let out = run(&wider, &[]);
    let log = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{log}");
    assert!(
        log.contains("point `count` was stored as u32 and is u16 in the configuration"),
        "{log}"
    );
    // Another PLC id with this file: refused.
    let out = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &format!("{id}-other"), "--for", "0.3s"])
        .output()
        .unwrap();
    let log = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{log}");
    assert!(log.contains(&format!("belongs to PLC `{id}`")), "{log}");
}

fn stored_unchecked(path: &Path) -> u64 {
    match petriplc_retain::file::peek(path)
        .unwrap()
        .snapshot
        .unwrap()
        .entries[0]
        .value
    {
        Value::Point { raw, .. } => u64::from(raw),
        Value::Data { .. } => unreachable!(),
    }
}

#[test]
fn a_restarted_module_goes_on_from_its_retained_value() {
    let dir = TempDir::new().unwrap();
    counter_program(dir.path());
    let conf = config(
        dir.path(),
        "plc.conf",
        "T#10ms",
        "counter: on_failure = restart\ncounter: restart_delay = 0\n",
    );
    let id = format!("retain-restart-{}", std::process::id());
    let mut plc = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &id])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let first = wait_counting(&id, &mut plc);
    std::thread::sleep(Duration::from_millis(50));
    nix::sys::signal::kill(
        nix::unistd::Pid::from_raw(first as i32),
        nix::sys::signal::Signal::SIGKILL,
    )
    .unwrap();
    let before = written(dir.path()).len();
    let started = Instant::now();
    while written(dir.path()).len() < before + 20 {
        assert!(
            started.elapsed() < SAFETY_NET,
            "the counter did not come back"
        );
        std::thread::sleep(Duration::from_millis(5));
    }
    let stop = petriplc().args(["stop", "--plc-id", &id]).output().unwrap();
    assert!(stop.status.success(), "{}", text(&stop.stderr));
    let out = plc.wait_with_output().unwrap();
    assert!(out.status.success(), "{}", text(&out.stderr));
    // One count per scan, never back to 1: the new process took the count from the image
    // (a value written but not committed by the killed one is counted again).
    let values = written(dir.path());
    for w in values.windows(2) {
        assert!(
            w[1] == w[0] + 1 || w[1] == w[0],
            "the count went from {} to {}",
            w[0],
            w[1]
        );
    }
}

/// A PLC with one retentive point, counted by an IEC program (no C compiler needed), whose
/// retain file is `retain_file` (as written in the configuration).
fn iec_config(dir: &Path, retain_file: &str) -> PathBuf {
    fs::write(
        dir.join("count.st"),
        "PROGRAM main\nVAR_OUTPUT count : UDINT; END_VAR\ncount := count + 1;\nEND_PROGRAM\n",
    )
    .unwrap();
    let path = dir.join("iec.conf");
    fs::write(
        &path,
        format!(
            "[PLC]\nmodule logic iec\npoint count \"scans counted\" logic u32 retain\n\
             retain_file = {retain_file}\nretain_write = change\n\
             [logic]\nprogram = count.st\nscan_period = T#1ms\n"
        ),
    )
    .unwrap();
    path
}

fn shm_left(id: &str) -> Vec<String> {
    fs::read_dir("/dev/shm")
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(&format!("petriplc-{id}")))
        .collect()
}

/// Issue 27: `retain_file=/dev/full` read without end until the OOM killer struck, and a
/// FIFO blocked the start for ever. Both are refused at once, exit 2, naming the file;
/// nothing is left in /dev/shm.
#[test]
fn a_retain_file_that_is_not_a_regular_file_is_refused_at_start() {
    let dir = TempDir::new().unwrap();
    let conf = iec_config(dir.path(), "state/plc.retain");
    let fifo = dir.path().join("fifo.retain");
    nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
    let id = format!("retain-odd-{}", std::process::id());
    for (file, kind) in [
        ("/dev/full".to_string(), "a character device"),
        ("/dev/zero".to_string(), "a character device"),
        (fifo.display().to_string(), "a FIFO (named pipe)"),
        (dir.path().display().to_string(), "a folder"),
    ] {
        let out = petriplc()
            .arg("run")
            .arg(&conf)
            .args(["--plc-id", &id, "--for", "0.3s"])
            .arg("--set")
            .arg(format!("PLC:retain_file={file}"))
            .output()
            .unwrap();
        let log = text(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{file}: {log}");
        assert!(
            log.contains(&format!("retain file {file} is {kind}, not a regular file")),
            "{log}"
        );
        assert_eq!(shm_left(&id), Vec::<String>::new());
    }
}

/// Issue 27: a zero-filled or empty retain file (what a power cut leaves on some file
/// systems) gave "[INFO] nothing stored yet" and every value from its init; a file cut so
/// that one copy is lost said nothing. Each is now a warning that says what was lost.
#[test]
fn a_wiped_or_cut_retain_file_is_a_warning() {
    let dir = TempDir::new().unwrap();
    let conf = iec_config(dir.path(), "state/plc.retain");
    let retain = dir.path().join("state/plc.retain");
    let id = format!("retain-wiped-{}", std::process::id());
    let run = || {
        let out = petriplc()
            .arg("run")
            .arg(&conf)
            .args(["--plc-id", &id, "--for", "0.3s"])
            .output()
            .unwrap();
        let log = text(&out.stderr);
        assert!(out.status.success(), "{log}");
        log
    };
    // A new file: made and stamped, said as INFO.
    let log = run();
    assert!(
        log.contains("[INFO] retain file") && log.contains("created"),
        "{log}"
    );
    assert!(!log.contains("WARN"), "{log}");
    for (bytes, what) in [
        (vec![0u8; 8192], "holds only zeros (8192 bytes)"),
        (Vec::new(), "is empty"),
    ] {
        fs::write(&retain, bytes).unwrap();
        let log = run();
        assert!(
            log.contains("[WARN]") && log.contains(what) && log.contains("values were lost"),
            "{log}"
        );
        assert!(!log.contains("nothing stored yet"), "{log}");
    }
    // Several snapshots, then the file cut to its first page: the copy beyond is lost.
    run();
    let seq = petriplc_retain::file::peek(&retain)
        .unwrap()
        .snapshot
        .unwrap()
        .seq;
    assert!(seq >= 2, "{seq}");
    fs::OpenOptions::new()
        .write(true)
        .open(&retain)
        .unwrap()
        .set_len(4096)
        .unwrap();
    let log = run();
    assert!(
        log.contains("[WARN]") && log.contains("is 4096 bytes, not two copies of whole pages"),
        "{log}"
    );
    // The next writes made the file whole again.
    assert!(petriplc_retain::file::peek(&retain)
        .unwrap()
        .warnings
        .is_empty());
}

/// Issue 27: a retentive point that a module recomputes at every scan from state that
/// starts afresh (a net's output) would be overwritten at the first scan: refused at start.
#[test]
fn a_retentive_net_output_is_refused() {
    let dir = TempDir::new().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let conf = dir.path().join("net.conf");
    fs::write(
        &conf,
        format!(
            "[PLC]\nmodule blink petrinet\nmodule stop shutdown\npoint input0 \"key\" stop\n\
             point out0 \"lamp\" blink u1 retain\npoint out1 \"lamp\" blink\n\
             point out2 \"lamp\" blink\n[blink]\nnet = {}\n[stop]\npoint = input0\n",
            root.join("examples/blink/blink.pnml").display()
        ),
    )
    .unwrap();
    let out = petriplc()
        .arg("run")
        .arg(&conf)
        .args(["--plc-id", &format!("retain-net-{}", std::process::id())])
        .args(["--for", "0.3s"])
        .output()
        .unwrap();
    let log = text(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{log}");
    assert!(
        log.contains("drives point `out0`, which is retentive (`retain`)")
            && log.contains("drop `retain` from point `out0`"),
        "{log}"
    );
}
