//! modbus_server against third-party Modbus masters: pymodbus (pinned in scripts/test-all.sh,
//! in target/py; `PETRIPLC_PYTHON` overrides) over TCP and RTU runs tests/server_pymodbus.py,
//! which reads and writes every table; mbpoll (Debian; `PETRIPLC_MBPOLL` overrides) reads
//! coils, registers and floats and writes a register, a coil and a float, over TCP and RTU.

mod server_support;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use petriplc_config::PointValue;
use server_support::{serial_line, tool, Line, Server};

const CONF: &str = "\
[PLC]
module mb modbus_server
module probe probe
point C0 \"coil\" mb
point C1 \"coil\" mb
point Cn \"coil of another module\" probe
point D0 \"input bit\" probe
point D1 \"input bit\" probe
point H16 \"u16\" mb u16
point Hi \"i16\" mb i16
point H32 \"u32\" mb u32
point Hf \"f32\" mb f32
point Hfl \"f32, low word first\" mb f32
point Hro \"read-only\" probe u16
point I16 \"input\" probe u16
point If \"float input\" probe f32
point Il \"i32 input\" probe i32
[mb]
listen = 127.0.0.1:0
coil 0 C0
coil 1 C1
coil 2 Cn
discrete_input 0 D0
discrete_input 1 D1
holding 0 H16
holding 1 Hi
holding 2 H32
holding 4 Hf
holding 6 Hfl f32 low_first
holding 8 Hro
input 0 I16
input 1 If
input 3 Il i32 low_first
[probe]
set Cn 1
set D0 1
set Hro 77
set I16 4660
set If 1.5
set Il -2
";

/// RTU at 8N1: Linux pseudo-terminals drop the parity bit from their settings, and pyserial
/// fails (EINVAL) when it sets parity on one.
fn rtu_conf(line: &Line) -> String {
    CONF.replace(
        "listen = 127.0.0.1:0",
        &format!(
            "listen = off\nserial = {}:19200:8N1\nunit = 7",
            line.server.display()
        ),
    )
}

fn python() -> std::path::PathBuf {
    tool(
        "PETRIPLC_PYTHON",
        "py/bin/python",
        "pymodbus==3.16.1 and pyserial==3.5 into target/py",
    )
}

fn mbpoll() -> std::path::PathBuf {
    tool("PETRIPLC_MBPOLL", "mbpoll", "the Debian package mbpoll")
}

/// Runs `cmd` to its end, killing it after 60 s.
fn run(cmd: &mut Command) -> Output {
    let mut child = cmd
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("{cmd:?} did not finish in 60 s");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "status {}\nstdout:\n{}\nstderr:\n{}",
        o.status,
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn script() -> &'static Path {
    Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/server_pymodbus.py"
    ))
}

fn check_pymodbus_writes(srv: &mut Server) {
    srv.tick();
    assert_eq!(srv.plc.get("C0"), PointValue::Unsigned(1));
    assert_eq!(srv.plc.get("C1"), PointValue::Unsigned(1));
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(4321));
    assert_eq!(srv.plc.get("Hi"), PointValue::Signed(-1));
    assert_eq!(srv.plc.get("H32"), PointValue::Unsigned(70000));
    assert_eq!(srv.plc.get("Hf"), PointValue::Float(2.5));
    assert_eq!(srv.plc.get("Hfl"), PointValue::Float(-0.5));
    assert_eq!(srv.plc.get("Hro"), PointValue::Unsigned(77));
}

#[test]
fn pymodbus_over_tcp() {
    let mut srv = Server::start(CONF);
    let port = srv.addr.port().to_string();
    let o = run(Command::new(python())
        .arg(script())
        .args(["tcp", "127.0.0.1", &port]));
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim(),
        "ok",
        "{}",
        text(&o)
    );
    check_pymodbus_writes(&mut srv);
}

#[test]
fn pymodbus_over_rtu() {
    let line = serial_line();
    let mut srv = Server::start(&rtu_conf(&line));
    let o = run(Command::new(python())
        .arg(script())
        .arg("serial")
        .arg(&line.client)
        .arg("7"));
    assert!(o.status.success(), "{}", text(&o));
    assert_eq!(
        String::from_utf8_lossy(&o.stdout).trim(),
        "ok",
        "{}",
        text(&o)
    );
    check_pymodbus_writes(&mut srv);
}

/// The `[REF]: VALUE` lines of mbpoll's output, in order.
fn mbpoll_values(o: &Output) -> Vec<(u32, String)> {
    String::from_utf8_lossy(&o.stdout)
        .lines()
        .filter_map(|l| {
            let l = l.trim();
            let rest = l.strip_prefix('[')?;
            let (r, v) = rest.split_once("]:")?;
            Some((r.parse().ok()?, v.trim().to_string()))
        })
        .collect()
}

/// Runs mbpoll once with 0-based references (`-0`, the addresses on the wire) and `args`.
fn mbpoll_run(endpoint: &[String], args: &[&str]) -> Output {
    let mut cmd = Command::new(mbpoll());
    cmd.args(["-0", "-1", "-o", "5"]).args(args).args(endpoint);
    let o = run(&mut cmd);
    assert!(o.status.success(), "mbpoll {args:?}: {}", text(&o));
    o
}

fn mbpoll_reads_and_writes(srv: &mut Server, endpoint: &[String], with: &[&str]) {
    let call = |args: &[&str]| {
        let all: Vec<&str> = with.iter().chain(args).copied().collect();
        mbpoll_run(endpoint, &all)
    };
    let v = |pairs: &[(u32, &str)]| -> Vec<(u32, String)> {
        pairs.iter().map(|(r, s)| (*r, s.to_string())).collect()
    };
    assert_eq!(
        mbpoll_values(&call(&["-t", "4", "-r", "8", "-c", "1"])),
        v(&[(8, "77")])
    );
    assert_eq!(
        mbpoll_values(&call(&["-t", "0", "-r", "0", "-c", "3"])),
        v(&[(0, "0"), (1, "0"), (2, "1")])
    );
    assert_eq!(
        mbpoll_values(&call(&["-t", "1", "-r", "0", "-c", "2"])),
        v(&[(0, "1"), (1, "0")])
    );
    assert_eq!(
        mbpoll_values(&call(&["-t", "3", "-r", "0", "-c", "1"])),
        v(&[(0, "4660")])
    );
    // mbpoll's 32-bit types are low word first unless -B.
    assert_eq!(
        mbpoll_values(&call(&["-t", "3:float", "-B", "-r", "1", "-c", "1"])),
        v(&[(1, "1.5")])
    );
    assert_eq!(
        mbpoll_values(&call(&["-t", "3:int", "-r", "3", "-c", "1"])),
        v(&[(3, "-2")])
    );
    // Writes: the value list comes after the endpoint.
    let write = |args: &[&str], values: &[&str]| {
        let mut cmd = Command::new(mbpoll());
        cmd.args(["-0", "-1", "-o", "5"])
            .args(with)
            .args(args)
            .args(endpoint)
            .arg("--")
            .args(values);
        let o = run(&mut cmd);
        assert!(
            o.status.success(),
            "mbpoll write {args:?} {values:?}: {}",
            text(&o)
        );
    };
    write(&["-t", "4", "-r", "0"], &["555"]);
    write(&["-t", "0", "-r", "1"], &["1"]);
    write(&["-t", "4:float", "-r", "6"], &["-0.25"]);
    write(&["-t", "4:int", "-B", "-r", "2"], &["100000"]);
    assert_eq!(
        mbpoll_values(&call(&["-t", "4", "-r", "0", "-c", "1"])),
        v(&[(0, "555")])
    );
    srv.tick();
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(555));
    assert_eq!(srv.plc.get("C1"), PointValue::Unsigned(1));
    assert_eq!(srv.plc.get("Hfl"), PointValue::Float(-0.25));
    assert_eq!(srv.plc.get("H32"), PointValue::Unsigned(100000));
    // A write to a point of another module is refused: mbpoll reports the exception.
    let mut cmd = Command::new(mbpoll());
    cmd.args(["-0", "-1", "-o", "5"])
        .args(with)
        .args(["-t", "4", "-r", "8"])
        .args(endpoint)
        .arg("1");
    let o = run(&mut cmd);
    let all = text(&o);
    assert!(all.contains("Illegal data address"), "{all}");
}

#[test]
fn mbpoll_over_tcp() {
    let mut srv = Server::start(CONF);
    let endpoint = ["127.0.0.1".to_string()];
    let port = srv.addr.port().to_string();
    mbpoll_reads_and_writes(&mut srv, &endpoint, &["-m", "tcp", "-p", &port]);
}

#[test]
fn mbpoll_over_rtu() {
    let line = serial_line();
    let mut srv = Server::start(&rtu_conf(&line));
    let endpoint = [line.client.display().to_string()];
    mbpoll_reads_and_writes(
        &mut srv,
        &endpoint,
        &["-m", "rtu", "-a", "7", "-b", "19200", "-P", "none"],
    );
}
