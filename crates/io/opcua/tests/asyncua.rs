//! The `opcua_server` module in the real runner (petriplc_plc::Plc, modules on threads) with
//! the mixer PLC (operator timeline, tank plant, controller net), checked by a third-party
//! client, Python's asyncua (pinned in scripts/test-all.sh, in target/py; `PETRIPLC_PYTHON`
//! overrides): browse, read every point, marking and status, subscribe at the scan and see
//! B1, N1, N2, N3 change, anonymous read-only, a user's write to an owned point (which stops
//! the PLC through the `shutdown` module) and refusals; and a Sign & Encrypt endpoint with a
//! certificate made on first start, an operator trusting the client's certificate, and
//! sessions refused without credentials; every kind of variant written into every kind of
//! point, and non-finite values refused before an `iec` module could read them.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use petriplc_plc::{Plc, RunOptions};

fn registry(kind: &str) -> Option<petriplc_runtime::module::Factory> {
    petriplc_opcua::builtin(kind).or_else(|| petriplc_modules::builtin(kind))
}

const KINDS: &[&str] = &[
    "opcua_server",
    "iec",
    "petrinet",
    "plant",
    "timeline",
    "logger",
    "shutdown",
];

fn python() -> PathBuf {
    std::env::var_os("PETRIPLC_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../target/py/bin/python")
        })
}

fn script() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/asyncua_client.py")
}

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../examples/mixer")
}

/// The mixer of examples/mixer with an OPC UA server owning `setpoint` and `stop`.
fn mixer_conf(dir: &Path, opcua: &str) -> PathBuf {
    let ex = examples();
    let text = format!(
        "[PLC]\nmodule operator timeline\nmodule tank plant\nmodule controller petrinet\n\
         module opcua opcua_server\nmodule remote_stop shutdown\n\
         synch operator -> tank\nsynch tank -> controller\nsynch controller -> operator\n\
         synch_start operator\n\
         point B1 \"start button\" operator\npoint N1 \"level sensor: empty\" tank\n\
         point N2 \"level sensor: half\" tank\npoint N3 \"level sensor: full\" tank\n\
         point L1 \"lamp: ready\" controller\npoint L2 \"lamp: filling\" controller\n\
         point L3 \"lamp: draining\" controller\npoint V1 \"valve: solvent\" controller\n\
         point V2 \"valve: solute\" controller\npoint V3 \"valve: drain\" controller\n\
         point A1 \"heater\" controller\npoint M1 \"mixer motor\" controller\n\
         point setpoint \"operator set point\" opcua u16\n\
         point stop \"stop request\" opcua\n\
         [operator]\nfile = {ex}/operator.csv\nrepeat = yes\nscan_period = T#10ms\n\
         [tank]\nplant = tank\nspeed = 5\nscan_period = T#10ms\n\
         [controller]\nnet = {ex}/mixer.pnml\nnames = sipn\nscan_period = T#10ms\n\
         [remote_stop]\npoint = stop\n\
         [opcua]\nlisten = 127.0.0.1:0\nstate_dir = {state}\n{opcua}",
        ex = ex.display(),
        state = dir.join("state").display(),
    );
    let conf = dir.join("plc.conf");
    std::fs::write(&conf, text).unwrap();
    conf
}

/// A password file with one user (bcrypt at the lowest cost: tests only).
fn users(dir: &Path, user: &str, password: &str) -> PathBuf {
    let path = dir.join("opcua.users");
    let hash = bcrypt::hash(password, 4).unwrap();
    std::fs::write(&path, format!("# test users\n{user}:{hash}\n")).unwrap();
    path
}

fn start(conf: &Path) -> (Plc, String) {
    let opts = RunOptions {
        plc_id: petriplc_runtime::harness::plc_id(),
        duration: Some(Duration::from_secs(60)),
        known_kinds: KINDS,
        overrides: Vec::new(),
    };
    let plc = Plc::start(conf, registry, &opts).unwrap_or_else(|e| panic!("{e}"));
    let start = Instant::now();
    let url = loop {
        let status = plc.status();
        let detail = status
            .modules
            .iter()
            .find(|m| m.name == "opcua")
            .map(|m| m.detail.clone())
            .unwrap_or_default();
        if let Some(url) = detail
            .split_whitespace()
            .find(|w| w.starts_with("opc.tcp://"))
        {
            break url.to_string();
        }
        assert!(start.elapsed() < Duration::from_secs(20), "no endpoint");
        std::thread::sleep(Duration::from_millis(20));
    };
    (plc, url)
}

fn run_client(args: &[&str]) -> String {
    let out = Command::new(python())
        .arg(script())
        .args(args)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "cannot run {} ({e}): scripts/test-all.sh installs asyncua into target/py",
                python().display()
            )
        });
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "asyncua check failed:\n{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

#[test]
fn asyncua_browses_reads_subscribes_and_writes_the_mixer() {
    let dir = tempfile::tempdir().unwrap();
    users(dir.path(), "operator", "op-pass");
    let conf = mixer_conf(dir.path(), "anonymous = read\nusers = opcua.users\n");
    let (plc, url) = start(&conf);
    let plc_id = plc.status().plc_id.clone();
    let (tx, rx) = std::sync::mpsc::channel();
    let waiter = std::thread::spawn(move || {
        let last = plc.wait(&AtomicBool::new(false));
        let _ = tx.send(last);
    });
    // 4 s of subscription hold two of the operator's presses and a whole fill.
    let out = run_client(&["mixer", &url, &plc_id, "operator", "op-pass", "4"]);
    let json = out.lines().last().unwrap_or_default();
    assert!(json.contains("\"read\": 14"), "{out}");
    // The client's write of `stop` reached the shutdown module: the PLC stops by itself.
    let last = rx
        .recv_timeout(Duration::from_secs(20))
        .expect("the PLC stops once the shutdown module sees `stop`");
    waiter.join().unwrap();
    let opcua = last.modules.iter().find(|m| m.name == "opcua").unwrap();
    assert!(opcua.scans > 0, "{opcua:?}");
    eprintln!("asyncua: {json}");
}

#[test]
fn a_secured_endpoint_refuses_sessions_without_credentials() {
    let dir = tempfile::tempdir().unwrap();
    users(dir.path(), "operator", "op-pass");
    let conf = mixer_conf(
        dir.path(),
        "security = encrypt\nusers = opcua.users\nanonymous = no\n",
    );
    let pki = dir.path().join("state/pki");
    let (plc, url) = start(&conf);
    let plc_id = plc.status().plc_id.clone();
    let cert = std::fs::read(pki.join("own/cert.der")).expect("the server certificate");
    assert!(pki.join("private/private.pem").exists());
    let out = run_client(&[
        "secure",
        &url,
        &plc_id,
        "operator",
        "op-pass",
        pki.to_str().unwrap(),
    ]);
    let json = out.lines().last().unwrap_or_default();
    for want in [
        "\"no credentials\": \"Bad",
        "\"a wrong password\": \"Bad",
        "\"secure_write\": true",
    ] {
        assert!(json.contains(want), "{want} not in {json}");
    }
    plc.wait(&AtomicBool::new(true));
    // The next start uses the same certificate (clients keep trusting it).
    let (plc, _) = start(&conf);
    assert_eq!(std::fs::read(pki.join("own/cert.der")).unwrap(), cert);
    plc.wait(&AtomicBool::new(true));
}

#[test]
fn settings_are_checked_at_start_with_file_and_line() {
    let check = |section: &str, expect: &[&str]| {
        let dir = tempfile::tempdir().unwrap();
        let text =
            format!("[PLC]\nmodule opcua opcua_server\npoint P \"p\" opcua\n[opcua]\n{section}");
        let e = petriplc_runtime::harness::start_err(&text, dir.path(), registry);
        for want in expect {
            assert!(e.contains(want), "expected `{want}` in:\n{e}");
        }
    };
    check(
        "listen = 0.0.0.0:4840\nsecurity = none\nanonymous = read\n",
        &[
            "test.conf:6: security policy None on 0.0.0.0:4840",
            "allowed on a loopback address only",
        ],
    );
    check(
        "listen = nowhere\nanonymous = maybe\nsecurity = tls\n",
        &[
            "test.conf:5: `listen = nowhere`",
            "test.conf:6: `anonymous = maybe`",
            "test.conf:7: `security = tls`: unknown `tls`",
        ],
    );
    check("listen = 127.0.0.1:0\n", &["nobody could connect"]);
    check(
        "anonymous = read\nmax_sessions = 0\nlisten = 127.0.0.1:0\n",
        &["test.conf:6: `max_sessions = 0`"],
    );
    check(
        "anonymous = read\nlisten = 127.0.0.1:0\nusers = missing.users\n",
        &["test.conf:7: `users = missing.users`: cannot read"],
    );
    check(
        "anonymous = read\nlisten = 127.0.0.1:0\nrows = 1\n",
        &["unknown setting `rows`"],
    );
    // A taken port stops the start with the address and how to move it.
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    check(
        &format!("anonymous = read\nlisten = 127.0.0.1:{port}\n"),
        &[
            &format!("cannot listen on 127.0.0.1:{port}"),
            "--set opcua:listen=",
        ],
    );
}

/// A PLC whose server owns a point of every kind, `temp` read by an `iec` module that
/// doubles it into `dbl` (`on_failure = stop`, the default).
fn values_conf(dir: &Path) -> PathBuf {
    std::fs::write(
        dir.join("twice.st"),
        "PROGRAM twice\nVAR_INPUT\n    temp : REAL;\nEND_VAR\nVAR_OUTPUT\n    dbl : REAL;\n\
         END_VAR\ndbl := temp * 2.0;\nEND_PROGRAM\n",
    )
    .unwrap();
    let text = format!(
        "[PLC]\nmodule opcua opcua_server\nmodule calc iec\n\
         point temp \"temperature\" opcua f32 init 20\npoint dbl \"twice temp\" calc f32\n\
         point b \"a bool\" opcua u1\npoint u3 \"3 bits\" opcua u3\npoint u8 \"8 bits\" opcua u8\n\
         point u16 \"16 bits\" opcua u16\npoint u32 \"32 bits\" opcua u32\n\
         point i1 \"signed bit\" opcua i1\npoint i8 \"signed 8\" opcua i8\n\
         point i12 \"signed 12\" opcua i12\npoint i16 \"signed 16\" opcua i16\n\
         point i32 \"signed 32\" opcua i32\npoint f \"a float nobody reads\" opcua f32\n\
         [calc]\nprogram = twice.st\nscan_period = T#10ms\n\
         [opcua]\nlisten = 127.0.0.1:0\nanonymous = write\nstate_dir = {}\n",
        dir.join("state").display()
    );
    let conf = dir.join("plc.conf");
    std::fs::write(&conf, text).unwrap();
    conf
}

/// The module's state in the PLC's status.
fn state(plc: &Plc, module: &str) -> String {
    plc.status()
        .modules
        .iter()
        .find(|m| m.name == module)
        .map(|m| m.state.as_str().to_string())
        .unwrap_or_default()
}

/// Issue 27: a client's `Float(NaN)` reached an `iec` module, whose `temp * 2.0` faulted and
/// stopped the whole PLC. NaN, ±Inf and 1e39 (an f32's Inf) are refused with BadOutOfRange;
/// the module goes on scanning and computes from the next good value.
#[test]
fn non_finite_writes_are_refused_and_the_plc_keeps_running() {
    let dir = tempfile::tempdir().unwrap();
    let (plc, url) = start(&values_conf(dir.path()));
    let plc_id = plc.status().plc_id.clone();
    let out = run_client(&["nonfinite", &url, &plc_id, "temp", "21.5", "43"]);
    assert!(out.contains("\"refused\": 6"), "{out}");
    // The client saw `dbl` computed from 21.5: the module scanned after every write.
    assert_eq!(state(&plc, "calc"), "running");
    assert!(!plc.failed());
    let last = plc.wait(&AtomicBool::new(true));
    let calc = last.modules.iter().find(|m| m.name == "calc").unwrap();
    assert_ne!(calc.state.as_str(), "failed", "{calc:?}");
}

/// Every kind of variant a client can send (integers of every width at their edges, Float and
/// Double with NaN, ±Inf, out-of-range and tiny values, Boolean, strings, byte strings, other
/// scalars, Null, arrays) into a point of every kind: converted exactly as docs/opcua.md says,
/// or refused with its status and the point unchanged (an oracle in the client written from
/// the documentation).
#[test]
fn every_variant_into_every_point_is_converted_exactly_or_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (plc, url) = start(&values_conf(dir.path()));
    let plc_id = plc.status().plc_id.clone();
    let out = run_client(&["values", &url, &plc_id]);
    let json = out.lines().last().unwrap_or_default();
    for want in ["\"BadOutOfRange\"", "\"BadTypeMismatch\"", "\"good\""] {
        assert!(json.contains(want), "{want} not in {json}");
    }
    assert_eq!(state(&plc, "calc"), "running");
    plc.wait(&AtomicBool::new(true));
}

/// Issue 27's siblings of `retain_file = /dev/full`: the users file, and the certificate and
/// key the stack reads at every connection, must be regular files of a sane size; a FIFO
/// blocked the start for ever and a device would have been read without end.
#[test]
fn users_and_certificate_files_must_be_regular_files() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("fifo");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    let start = |section: &str| {
        let text =
            format!("[PLC]\nmodule opcua opcua_server\npoint P \"p\" opcua\n[opcua]\n{section}");
        petriplc_runtime::harness::start_err(&text, dir.path(), registry)
    };
    for users in ["/dev/zero", fifo.to_str().unwrap()] {
        let e = start(&format!(
            "listen = 127.0.0.1:0\nanonymous = read\nusers = {users}\n"
        ));
        assert!(
            e.contains(&format!(
                "test.conf:7: `users = {users}`: cannot read {users}: it is"
            )) && e.contains("not a regular file; name a settings file"),
            "{e}"
        );
    }
    let pki = dir.path().join("state/pki");
    std::fs::create_dir_all(pki.join("own")).unwrap();
    std::fs::create_dir_all(pki.join("private")).unwrap();
    std::fs::rename(&fifo, pki.join("own/cert.der")).unwrap();
    std::fs::write(pki.join("private/private.pem"), "not a key").unwrap();
    let e = start(&format!(
        "listen = 127.0.0.1:0\nanonymous = read\nsecurity = encrypt\nstate_dir = {}\n",
        dir.path().join("state").display()
    ));
    assert!(
        e.contains("own/cert.der: it is a pipe (FIFO), not a regular file"),
        "{e}"
    );
    assert!(
        e.contains("remove own/ and private/ there to make a new one"),
        "{e}"
    );
}
