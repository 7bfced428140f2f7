//! The `modbus_client` module against Modbus servers started in the test (tokio-modbus's
//! TCP and RTU servers over a register bank that records every request; a TCP server that
//! accepts and never answers; one that hangs up at once), driven scan by scan through the
//! runtime's harness while the client polls on real time.

use std::collections::BTreeMap;
use std::io::Read;
use std::net::{SocketAddr, TcpListener as StdListener};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use petriplc_config::{ModuleDecl, PointValue};
use petriplc_runtime::harness::{self, ms, Plc};
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};
use tokio::runtime::Runtime;
use tokio::sync::oneshot;
use tokio_modbus::server::tcp::{accept_tcp_connection, Server};
use tokio_modbus::{ExceptionCode, Request, Response, SlaveRequest};

// ---------------------------------------------------------------------------------------
// A register bank served over Modbus.

/// Coils, discrete inputs, holding and input registers (an address not in a map answers
/// "illegal data address"), and every request served, as text.
#[derive(Default)]
struct Bank {
    coils: BTreeMap<u16, bool>,
    discrete: BTreeMap<u16, bool>,
    holding: BTreeMap<u16, u16>,
    input: BTreeMap<u16, u16>,
    log: Vec<String>,
}

type Banks = Arc<Mutex<BTreeMap<u8, Bank>>>;

/// Serves one bank per unit; a request for another unit gets no answer (as on a serial
/// line).
#[derive(Clone)]
struct Service {
    banks: Banks,
}

fn bits(map: &BTreeMap<u16, bool>, a: u16, n: u16) -> Result<Vec<bool>, ExceptionCode> {
    (a..a + n)
        .map(|i| {
            map.get(&i)
                .copied()
                .ok_or(ExceptionCode::IllegalDataAddress)
        })
        .collect()
}

fn words(map: &BTreeMap<u16, u16>, a: u16, n: u16) -> Result<Vec<u16>, ExceptionCode> {
    (a..a + n)
        .map(|i| {
            map.get(&i)
                .copied()
                .ok_or(ExceptionCode::IllegalDataAddress)
        })
        .collect()
}

impl Service {
    fn answer(&self, req: SlaveRequest<'static>) -> Result<Option<Response>, ExceptionCode> {
        let mut banks = self.banks.lock().unwrap();
        let Some(b) = banks.get_mut(&req.slave) else {
            return Ok(None);
        };
        let (text, result) = match req.request {
            Request::ReadCoils(a, n) => (
                format!("read coil {a}+{n}"),
                bits(&b.coils, a, n).map(Response::ReadCoils),
            ),
            Request::ReadDiscreteInputs(a, n) => (
                format!("read discrete_input {a}+{n}"),
                bits(&b.discrete, a, n).map(Response::ReadDiscreteInputs),
            ),
            Request::ReadHoldingRegisters(a, n) => (
                format!("read holding {a}+{n}"),
                words(&b.holding, a, n).map(Response::ReadHoldingRegisters),
            ),
            Request::ReadInputRegisters(a, n) => (
                format!("read input {a}+{n}"),
                words(&b.input, a, n).map(Response::ReadInputRegisters),
            ),
            Request::WriteSingleCoil(a, v) => {
                b.coils.insert(a, v);
                (
                    format!("write coil {a}"),
                    Ok(Response::WriteSingleCoil(a, v)),
                )
            }
            Request::WriteMultipleCoils(a, vs) => {
                for (i, v) in vs.iter().enumerate() {
                    b.coils.insert(a + i as u16, *v);
                }
                (
                    format!("write coil {a}+{}", vs.len()),
                    Ok(Response::WriteMultipleCoils(a, vs.len() as u16)),
                )
            }
            Request::WriteSingleRegister(a, v) => {
                b.holding.insert(a, v);
                (
                    format!("write holding {a}"),
                    Ok(Response::WriteSingleRegister(a, v)),
                )
            }
            Request::WriteMultipleRegisters(a, vs) => {
                for (i, v) in vs.iter().enumerate() {
                    b.holding.insert(a + i as u16, *v);
                }
                (
                    format!("write holding {a}+{}", vs.len()),
                    Ok(Response::WriteMultipleRegisters(a, vs.len() as u16)),
                )
            }
            other => (format!("{other:?}"), Err(ExceptionCode::IllegalFunction)),
        };
        b.log.push(text);
        result.map(Some)
    }
}

impl tokio_modbus::server::Service for Service {
    type Request = SlaveRequest<'static>;
    type Response = Option<Response>;
    type Exception = ExceptionCode;
    type Future = std::future::Ready<Result<Option<Response>, ExceptionCode>>;

    fn call(&self, req: Self::Request) -> Self::Future {
        std::future::ready(self.answer(req))
    }
}

fn runtime() -> Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap()
}

/// A Modbus TCP server on a fixed local port that can be stopped (listener and
/// connections closed) and started again.
struct TcpServer {
    rt: Runtime,
    addr: SocketAddr,
    banks: Banks,
    abort: Option<oneshot::Sender<()>>,
}

impl TcpServer {
    fn start(banks: Banks) -> TcpServer {
        let listener = StdListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let mut s = TcpServer {
            rt: runtime(),
            addr,
            banks,
            abort: None,
        };
        s.serve(listener);
        s
    }

    fn serve(&mut self, listener: StdListener) {
        listener.set_nonblocking(true).unwrap();
        let (abort, aborted) = oneshot::channel::<()>();
        let banks = self.banks.clone();
        let _guard = self.rt.enter();
        let listener = tokio::net::TcpListener::from_std(listener).unwrap();
        self.rt.spawn(async move {
            let server = Server::new(listener);
            let service = Service { banks };
            let on_connected = move |stream, addr| {
                let service = service.clone();
                async move { accept_tcp_connection(stream, addr, move |_| Ok(Some(service.clone()))) }
            };
            let _ = server
                .serve_until(&on_connected, |_| {}, async move {
                    let _ = aborted.await;
                })
                .await;
        });
        self.abort = Some(abort);
    }

    /// Closes the listener and every connection.
    fn stop(&mut self) {
        if let Some(a) = self.abort.take() {
            let _ = a.send(());
        }
        // The port is free once the listener is gone: bind it again to be sure.
        let deadline = Instant::now() + Duration::from_secs(10);
        loop {
            match StdListener::bind(self.addr) {
                Ok(_) => return,
                Err(e) if Instant::now() > deadline => panic!("port {} not freed: {e}", self.addr),
                Err(_) => std::thread::sleep(Duration::from_millis(10)),
            }
        }
    }

    fn restart(&mut self) {
        let listener = StdListener::bind(self.addr).unwrap();
        self.serve(listener);
    }
}

impl Drop for TcpServer {
    fn drop(&mut self) {
        if let Some(a) = self.abort.take() {
            let _ = a.send(());
        }
    }
}

fn banks(units: impl IntoIterator<Item = (u8, Bank)>) -> Banks {
    Arc::new(Mutex::new(units.into_iter().collect()))
}

fn log_of(banks: &Banks, unit: u8) -> Vec<String> {
    banks.lock().unwrap()[&unit].log.clone()
}

/// Whether `log` ends with `cycle` repeated twice: a steady cycle made of these requests
/// in this order.
fn steady(log: &[String], cycle: &[&str]) -> bool {
    let n = cycle.len();
    log.len() >= 2 * n
        && log[log.len() - 2 * n..]
            .iter()
            .zip(cycle.iter().chain(cycle))
            .all(|(a, b)| a == b)
}

// ---------------------------------------------------------------------------------------
// Driving the PLC.

/// A module that does nothing: the owner of the points the client writes out, which the
/// test sets through its map.
struct Idle;

impl Module for Idle {
    fn init(&mut self, _: &mut InitContext<'_>) -> Result<(), ModuleError> {
        Ok(())
    }
    fn scan(&mut self, _: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        Ok(Control::Continue)
    }
}

fn idle(_: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Idle))
}

fn registry(kind: &str) -> Option<Factory> {
    match kind {
        "idle" => Some(idle),
        k => petriplc_modbus::builtin(k),
    }
}

/// The longest any condition is waited for: far above what a loaded machine needs, only
/// there so that a broken client fails the test instead of hanging it.
const PATIENCE: Duration = Duration::from_secs(30);

struct Run {
    plc: Plc,
    t: u64,
}

impl Run {
    fn start(text: &str) -> Run {
        let plc = harness::start(text, &std::env::temp_dir(), registry).unwrap_or_else(|e| {
            panic!("{e}");
        });
        Run { plc, t: 0 }
    }

    fn tick(&mut self) {
        self.t += 10;
        self.plc.tick(ms(self.t)).unwrap();
    }

    /// Scans every 5 ms of real time until `cond` holds.
    fn until(&mut self, what: &str, mut cond: impl FnMut(&Plc) -> bool) {
        let deadline = Instant::now() + PATIENCE;
        loop {
            self.tick();
            if cond(&self.plc) {
                return;
            }
            assert!(
                Instant::now() < deadline,
                "timed out waiting for {what}; client status: {}",
                self.plc.status("io")
            );
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Writes a point owned by the `setter` module, as that module would.
    fn set(&mut self, point: &str, v: PointValue) {
        let (_, _, map) = self
            .plc
            .modules
            .iter_mut()
            .find(|m| m.0 == "setter")
            .unwrap();
        let h = map.handle(point).unwrap();
        map.set(&h, v).unwrap();
    }

    fn status(&self) -> String {
        self.plc.status("io")
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        self.plc.close();
    }
}

fn u(v: u32) -> PointValue {
    PointValue::Unsigned(v)
}

fn i(v: i32) -> PointValue {
    PointValue::Signed(v)
}

fn f(v: f32) -> PointValue {
    PointValue::Float(v)
}

/// The number after `word` in a status line (`3 cycles`).
fn count(status: &str, word: &str) -> u64 {
    let words: Vec<&str> = status.split([' ', ',', '(', ')']).collect();
    words
        .windows(2)
        .filter(|w| w[1].starts_with(word))
        .filter_map(|w| w[0].parse().ok())
        .next_back()
        .unwrap_or_else(|| panic!("no `{word}` count in `{status}`"))
}

// ---------------------------------------------------------------------------------------
// Tests.

#[test]
fn reads_every_table_with_merged_requests_in_both_word_orders() {
    let mut b = Bank::default();
    b.coils.extend([(0, true), (1, false), (2, true)]);
    b.discrete.extend([(4, true)]);
    // holding 0: u16 1234; 1: i16 -5; 2-3: u32 0x12345678 high first; 4-5: the same low
    // first; 7 (a gap at 6): 300, too big for its u8 point; 8: 77 into another u8.
    b.holding.extend([
        (0, 1234),
        (1, (-5i16) as u16),
        (2, 0x1234),
        (3, 0x5678),
        (4, 0x5678),
        (5, 0x1234),
        (7, 300),
        (8, 77),
    ]);
    // input 10-11: f32 1.5 high first; 12-13: f32 -2.25 low first; 14-15: i32 -70000
    // low first.
    let minus = (-70000i32) as u32;
    b.input.extend([
        (10, 0x3FC0),
        (11, 0),
        (12, 0),
        (13, 0xC010),
        (14, minus as u16),
        (15, (minus >> 16) as u16),
    ]);
    let banks = banks([(1, b)]);
    let server = TcpServer::start(banks.clone());
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point c0 "coil 0" io
point c2 "coil 2" io
point c1 "coil 1" io
point d4 "discrete input 4" io
point h0 "" io u16
point h1 "" io i16
point big "" io u32
point little "" io u32
point small "" io u8 init 9
point h8 "" io u8
point fa "" io f
point fb "" io f
point s32 "" io i32
point stale "" io
[io]
device dev tcp:{} 1 20ms 2s
read dev coil 2 c2
read dev coil 0 c0
read dev coil 1 c1
read dev discrete_input 4 d4
read dev holding 0 h0
read dev holding 1 h1
read dev holding 2 big u32 high_first
read dev holding 4 little u32 low_first
read dev holding 7 small
read dev holding 8 h8
read dev input 10 fa
read dev input 12 fb f32 low_first
read dev input 14 s32 low_first
stale dev stale
"#,
        server.addr
    ));
    run.until("every value read", |p| {
        p.value("h8") == 77 && p.value("stale") == 0
    });
    let p = &run.plc;
    assert_eq!(
        (p.value("c0"), p.value("c1"), p.value("c2"), p.value("d4")),
        (1, 0, 1, 1)
    );
    assert_eq!(p.get("h0"), u(1234));
    assert_eq!(p.get("h1"), i(-5));
    assert_eq!(p.get("big"), u(0x1234_5678));
    assert_eq!(p.get("little"), u(0x1234_5678));
    assert_eq!(p.get("fa"), f(1.5));
    assert_eq!(p.get("fb"), f(-2.25));
    assert_eq!(p.get("s32"), i(-70000));
    // 300 does not fit a u8: the point keeps its value; its neighbour is read all the same.
    assert_eq!(p.get("small"), u(9));

    // One request per run of adjacent addresses, tables in order, gaps never read.
    let cycle = [
        "read coil 0+3",
        "read discrete_input 4+1",
        "read holding 0+6",
        "read holding 7+2",
        "read input 10+6",
    ];
    run.until("a steady cycle", |_| steady(&log_of(&banks, 1), &cycle));
    assert!(!log_of(&banks, 1).iter().any(|l| l.contains("holding 6")));
    assert!(run.status().starts_with("dev up ("), "{}", run.status());

    // A value that fits again lands.
    banks
        .lock()
        .unwrap()
        .get_mut(&1)
        .unwrap()
        .holding
        .insert(7, 200);
    run.until("the fitting value", |p| p.value("small") == 200);
}

#[test]
fn writes_out_coils_and_registers_every_cycle() {
    let banks = banks([(7, Bank::default())]);
    let server = TcpServer::start(banks.clone());
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
module setter idle
point V1 "valve 1" setter
point V2 "valve 2" setter
point lamp "" setter
point sp "set point" setter f
point n32 "" setter u32
point s16 "" setter i16
point back "" setter f
[io]
device out tcp:{} 7 20ms
write out coil 0 V1
write out coil 1 V2
write out coil 5 lamp
write out holding 10 sp f32 low_first
write out holding 12 n32
write out holding 20 s16
write out holding 30 back f32 high_first
"#,
        server.addr
    ));
    run.set("V1", u(1));
    run.set("lamp", u(1));
    run.set("sp", f(-2.25));
    run.set("n32", u(0x1234_5678));
    run.set("s16", i(-2));
    run.set("back", f(1.5));
    let reg = |a: u16| banks.lock().unwrap()[&7].holding.get(&a).copied();
    let coil = |a: u16| banks.lock().unwrap()[&7].coils.get(&a).copied();
    run.until("the values written", |_| reg(20) == Some(0xFFFE));
    assert_eq!(
        (coil(0), coil(1), coil(5)),
        (Some(true), Some(false), Some(true))
    );
    // -2.25f32 = 0xC0100000, low word first; 0x12345678 high word first by default.
    assert_eq!(
        [10, 11, 12, 13].map(reg),
        [Some(0), Some(0xC010), Some(0x1234), Some(0x5678)]
    );
    assert_eq!([30, 31].map(reg), [Some(0x3FC0), Some(0)]);
    let cycle = [
        "write coil 0+2",
        "write coil 5",
        "write holding 10+4",
        "write holding 20",
        "write holding 30+2",
    ];
    run.until("a steady cycle", |_| steady(&log_of(&banks, 7), &cycle));

    // New values go out with the next cycles.
    run.set("V1", u(0));
    run.set("V2", u(1));
    run.set("s16", i(300));
    run.until("the new values", |_| {
        reg(20) == Some(300) && coil(1) == Some(true)
    });
    assert_eq!(coil(0), Some(false));
}

#[test]
fn a_device_that_goes_away_is_stale_until_it_answers_again() {
    let mut b = Bank::default();
    b.holding.insert(0, 11);
    let banks = banks([(1, b)]);
    let mut server = TcpServer::start(banks.clone());
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
point offline "" io
[io]
backoff_max = 300ms
device dev tcp:{} 1 10ms 1s
read dev holding 0 x
stale dev offline
"#,
        server.addr
    ));
    run.until("the first value", |p| {
        p.value("x") == 11 && p.value("offline") == 0
    });

    server.stop();
    run.until("the device stale", |p| p.value("offline") == 1);
    assert!(run.status().starts_with("dev stale: "), "{}", run.status());
    // Several failed attempts, spaced by the back-off (at most 300 ms).
    run.until("three failed attempts", |p| {
        count(&p.status("io"), "error") >= 3
    });

    banks
        .lock()
        .unwrap()
        .get_mut(&1)
        .unwrap()
        .holding
        .insert(0, 22);
    server.restart();
    run.until("the device back", |p| {
        p.value("offline") == 0 && p.value("x") == 22
    });
    let status = run.status();
    assert!(status.starts_with("dev up ("), "{status}");
    assert!(count(&status, "error") >= 3, "{status}");
}

/// A TCP server that accepts connections and reads requests but never answers; it counts
/// the connections, the bytes received, and the connections the client closed.
struct Mute {
    addr: SocketAddr,
    seen: Arc<Mutex<MuteLog>>,
}

#[derive(Default, Debug)]
struct MuteLog {
    /// When each connection came.
    accepted: Vec<Instant>,
    bytes: usize,
    closed: usize,
}

impl Mute {
    /// `hang_up`: close each connection at once instead of keeping it silent.
    fn start(hang_up: bool) -> Mute {
        let listener = StdListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let seen = Arc::new(Mutex::new(MuteLog::default()));
        let log = seen.clone();
        std::thread::spawn(move || {
            for stream in listener.incoming() {
                let Ok(mut stream) = stream else { return };
                log.lock().unwrap().accepted.push(Instant::now());
                if hang_up {
                    continue;
                }
                let log = log.clone();
                std::thread::spawn(move || {
                    let mut buf = [0u8; 512];
                    loop {
                        match stream.read(&mut buf) {
                            Ok(0) | Err(_) => {
                                log.lock().unwrap().closed += 1;
                                return;
                            }
                            Ok(n) => log.lock().unwrap().bytes += n,
                        }
                    }
                });
            }
        });
        Mute { addr, seen }
    }
}

#[test]
fn a_device_that_never_answers_times_out_and_close_does_not_wait_for_it() {
    let mute = Mute::start(false);
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
point offline "" io
[io]
device dev tcp:{} 1 20ms 100ms
read dev holding 0 x
stale dev offline
"#,
        mute.addr
    ));
    run.until("a timeout", |p| {
        p.status("io").contains("no answer within 100ms")
    });
    assert_eq!(run.plc.value("offline"), 1);
    // Each timeout drops the connection: the next attempt connects again.
    run.until("a reconnection", |_| {
        mute.seen.lock().unwrap().accepted.len() >= 2
    });
    let closed = mute.seen.lock().unwrap().closed;
    assert!(closed >= 1, "{:?}", mute.seen.lock().unwrap());

    // A device in the middle of a long timeout: close must not wait for it.
    let slow = Mute::start(false);
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
[io]
device dev tcp:{} 1 20ms 1h
read dev holding 0 x
"#,
        slow.addr
    ));
    run.until("a request in flight", |_| {
        slow.seen.lock().unwrap().bytes > 0
    });
    // `close` waits a bounded time in any case; the polling thread must really have ended,
    // which closes the connection it was waiting on.
    run.plc.close();
    let deadline = Instant::now() + PATIENCE;
    while slow.seen.lock().unwrap().closed == 0 {
        assert!(Instant::now() < deadline, "the connection was never closed");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn reconnection_backs_off_doubling_up_to_the_maximum() {
    let hang_up = Mute::start(true);
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
[io]
backoff_max = 400ms
device dev tcp:{} 1 10ms
read dev holding 0 x
"#,
        hang_up.addr
    ));
    run.until("six attempts", |_| {
        hang_up.seen.lock().unwrap().accepted.len() >= 6
    });
    let times = hang_up.seen.lock().unwrap().accepted.clone();
    let gaps: Vec<Duration> = times.windows(2).map(|w| w[1] - w[0]).collect();
    // Waits of at least 100, 200, 400, 400 ms (then the next tick of the 10 ms period);
    // only lower bounds: a slow machine stretches them.
    for (gap, least) in gaps.iter().zip([100, 200, 400, 400, 400]) {
        assert!(*gap >= ms(least), "gaps {gaps:?}");
    }
}

#[test]
fn an_exception_response_marks_the_device_stale() {
    let mut b = Bank::default();
    b.holding.insert(0, 5);
    let banks = banks([(1, b)]);
    let server = TcpServer::start(banks.clone());
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
point y "" io u16
point offline "" io
[io]
device dev tcp:{} 1 10ms
read dev holding 0 x
read dev holding 50 y
stale dev offline
"#,
        server.addr
    ));
    run.until("the exception", |p| {
        p.status("io")
            .contains("reading holding 50: exception 2 (Illegal data address)")
    });
    assert_eq!(run.plc.value("offline"), 1);
    // The request before the failing one was answered: its value is there.
    run.until("x", |p| p.value("x") == 5);
    banks
        .lock()
        .unwrap()
        .get_mut(&1)
        .unwrap()
        .holding
        .insert(50, 6);
    run.until("recovery", |p| p.value("offline") == 0 && p.value("y") == 6);
}

#[test]
fn rtu_devices_share_a_serial_line_through_a_pseudo_terminal() {
    use tokio_serial::SerialPort;

    let rt = runtime();
    let mut three = Bank::default();
    three.holding.extend([(0, 0x0102), (1, 0x0304)]);
    three.coils.insert(0, false);
    let mut four = Bank::default();
    four.input.insert(9, 4444);
    let banks = banks([(3, three), (4, four)]);
    let (master, slave) = {
        let _guard = rt.enter();
        tokio_serial::SerialStream::pair().unwrap()
    };
    let path = slave.name().unwrap();
    let service = Service {
        banks: banks.clone(),
    };
    rt.spawn(tokio_modbus::server::rtu::Server::new(master).serve_forever(service));

    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
module setter idle
point wide "" io u32
point far "" io u16
point lamp "" setter
point stale3 "" io
point stale4 "" io
[io]
device three rtu:{path}:19200:8N1 3 20ms 1s
device four rtu:{path}:19200:8N1 4 30ms 1s
read three holding 0 wide
write three coil 0 lamp
read four input 9 far
stale three stale3
stale four stale4
"#
    ));
    run.set("lamp", u(1));
    run.until("both devices read and the coil written", |p| {
        p.value("wide") == 0x0102_0304
            && p.value("far") == 4444
            && banks.lock().unwrap()[&3].coils.get(&0) == Some(&true)
    });
    assert_eq!((run.plc.value("stale3"), run.plc.value("stale4")), (0, 0));
    run.until("steady cycles", |_| {
        steady(&log_of(&banks, 3), &["read holding 0+2", "write coil 0"])
            && steady(&log_of(&banks, 4), &["read input 9+1"])
    });
    drop(run);
    drop(slave);
}

// ---------------------------------------------------------------------------------------
// Configuration errors.

fn start_err(section: &str) -> String {
    let text = format!(
        r#"[PLC]
module io modbus_client
module other idle
point mine "" io u16
point flag "" io
point theirs "" other u16
point fl "" io f
[io]
{section}"#
    );
    harness::start_err(&text, &std::env::temp_dir(), registry)
}

#[test]
fn bad_configurations_say_where_and_how_to_fix() {
    // Line 9 is the first row of the section.
    for (section, says) in [
        ("", "no devices: add rows `device NAME ENDPOINT UNIT PERIOD [TIMEOUT]`"),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 nope",
            "test.conf:10: no point named `nope`; declare it with `point nope \"...\" io`",
        ),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 theirs",
            "test.conf:10: point `theirs` is owned by module `other`",
        ),
        (
            "device d tcp:h:502 1 10ms\nread e holding 0 mine",
            "test.conf:10: unknown device `e`",
        ),
        (
            "device d tcp:h:502 1 10ms\ndevice d tcp:h:503 1 10ms\nread d holding 0 mine",
            "test.conf:10: device `d` is declared twice (first at test.conf:9)",
        ),
        ("device d udp:h:502 1 10ms\nread d holding 0 mine", "test.conf:9: device `d`: endpoint `udp:h:502` is not valid"),
        ("device d tcp:h 1 10ms\nread d holding 0 mine", "has no port"),
        ("device d tcp:h:502 248 10ms\nread d holding 0 mine", "unit `248` is not valid"),
        (
            "device d rtu:/dev/ttyS0:9600:8N1 0 10ms\nread d holding 0 mine",
            "unit 0 is the RTU broadcast address",
        ),
        ("device d tcp:h:502 1\nread d holding 0 mine", "test.conf:9: a device row is"),
        ("device d tcp:h:502 1 0ms\nread d holding 0 mine", "the period must be more than 0"),
        ("device d tcp:h:502 1 fast\nread d holding 0 mine", "period: `fast` is not a duration"),
        ("device d tcp:h:502 1 10ms", "device `d` has no read or write rows"),
        (
            "device d tcp:h:502 1 10ms\nwrite d input 0 mine",
            "table `input` is read-only in Modbus",
        ),
        ("device d tcp:h:502 1 10ms\nread d regs 0 mine", "unknown table `regs`"),
        ("device d tcp:h:502 1 10ms\nread d holding 70000 mine", "address `70000` is not valid"),
        (
            "device d tcp:h:502 1 10ms\nread d holding 65535 fl",
            "f32 at address 65535 runs past the last address",
        ),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine u16 big", "`big` is neither"),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 mine low_first",
            "a word order only applies to two-register types",
        ),
        (
            "device d tcp:h:502 1 10ms\nread d coil 0 flag u16",
            "a coil carries one bit",
        ),
        ("device d tcp:h:502 1 10ms\nread d coil 0 fl", "`fl` is a float point"),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine f32", "point `mine` (u16) cannot be read as f32"),
        ("device d tcp:h:502 1 10ms\nwrite d holding 0 theirs i16", "point `theirs` (u16) cannot be written as i16"),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 mine\nread d holding 1 mine",
            "test.conf:11: point `mine` is already set by the row at test.conf:10",
        ),
        (
            "device d tcp:h:502 1 10ms\nwrite d holding 0 fl\nwrite d holding 1 theirs",
            "test.conf:11: `theirs` writes holding 1 of device `d`, which the row at test.conf:10",
        ),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 mine\nstale d theirs",
            "test.conf:11: point `theirs` is owned by module `other`",
        ),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 mine\nstale d fl",
            "stale point `fl` is a float point",
        ),
        (
            "device a rtu:/dev/ttyS0:9600:8N1 1 10ms\ndevice b rtu:/dev/ttyS0:19200:8N1 2 10ms\nread a coil 0 flag\nread b holding 0 mine",
            "devices on one line share its settings",
        ),
        (
            "device a rtu:/dev/ttyS0:9600:8N1 1 10ms\ndevice b rtu:/dev/ttyS0:9600:8N1 1 10ms\nread a coil 0 flag\nread b holding 0 mine",
            "are both unit 1 on serial port /dev/ttyS0",
        ),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine\nbackoff_max = never", "`backoff_max = never`"),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine\nbackoff = 1s", "unknown setting `backoff`"),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine\npoll d 1", "reads only device, read, write, stale rows, not `poll`"),
    ] {
        let e = start_err(section);
        assert!(e.contains(says), "{section}:\n{e}\nshould say: {says}");
        assert!(e.starts_with("module io: "), "{e}");
    }
}

#[test]
fn every_problem_is_reported_at_once() {
    let e = start_err("device d tcp:h:502 1 10ms\nread d holding 0 nope\nread x coil 0 flag\nwrite d input 0 mine");
    assert_eq!(e.matches("\nmodule io: ").count(), 2, "{e}");
    for line in ["test.conf:10", "test.conf:11", "test.conf:12"] {
        assert!(e.contains(line), "{e}");
    }
}

#[test]
fn status_and_default_scan_period() {
    // Nothing listens on this port once the listener is dropped: the device stays stale.
    let addr = StdListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
[io]
device slow tcp:{addr} 1 1s
device fast tcp:{addr} 2 40ms
read slow holding 0 x
write fast coil 0 x
"#
    ));
    let (_, m, _) = &run.plc.modules[0];
    assert_eq!(m.default_scan_period(), Some(ms(40)));
    let status = run.status();
    assert!(
        status.starts_with("slow ") && status.contains("; fast "),
        "{status}"
    );
}

// ---------------------------------------------------------------------------------------
// End to end: this crate's client against this crate's server, in one PLC.

#[test]
fn the_client_reads_and_writes_a_modbus_server_module() {
    // A port nobody listens on right now, for the server module to take.
    let port = StdListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let mut run = Run::start(&format!(
        r#"
[PLC]
module mb modbus_server
module io modbus_client
module setter idle
point temp "" setter f
point total "" setter u32
point alarm "" setter
point sp "set by the client" mb i16
point cmd "" mb
point temp_copy "" io f
point total_copy "" io u32
point alarm_copy "" io
point sp_out "" setter i16
point cmd_out "" setter
point offline "" io
[mb]
listen = 127.0.0.1:{port}
holding 10 temp f32 low_first
input 0 total
discrete_input 3 alarm
holding 20 sp
coil 0 cmd
[io]
device plc tcp:127.0.0.1:{port} 1 20ms
read plc holding 10 temp_copy f32 low_first
read plc input 0 total_copy
read plc discrete_input 3 alarm_copy
write plc holding 20 sp_out
write plc coil 0 cmd_out
stale plc offline
"#
    ));
    run.set("temp", f(21.5));
    run.set("total", u(100_000));
    run.set("alarm", u(1));
    run.set("sp_out", i(-40));
    run.set("cmd_out", u(1));
    run.until("values both ways", |p| {
        p.get("temp_copy") == f(21.5)
            && p.get("total_copy") == u(100_000)
            && p.value("alarm_copy") == 1
            && p.get("sp") == i(-40)
            && p.value("cmd") == 1
            && p.value("offline") == 0
    });
}
