//! What the `modbus_client` tests share: tokio-modbus's TCP server over a register bank that
//! records every request (optionally slow to apply some writes), a TCP server that accepts and
//! never answers (or hangs up at once), and a PLC driven scan by scan through the runtime's
//! harness while the client polls on real time.

#![allow(dead_code)]

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
pub struct Bank {
    pub coils: BTreeMap<u16, bool>,
    pub discrete: BTreeMap<u16, bool>,
    pub holding: BTreeMap<u16, u16>,
    pub input: BTreeMap<u16, u16>,
    pub log: Vec<String>,
}

pub type Banks = Arc<Mutex<BTreeMap<u8, Bank>>>;

/// Serves one bank per unit; a request for another unit gets no answer (as on a serial
/// line).
#[derive(Clone)]
pub struct Service {
    pub banks: Banks,
    /// Writes to holding registers starting at this address wait this long before they are
    /// applied: a device slow at the end of a cycle, as on a loaded machine.
    pub slow: Option<(u16, Duration)>,
}

pub fn bits(map: &BTreeMap<u16, bool>, a: u16, n: u16) -> Result<Vec<bool>, ExceptionCode> {
    (a..a + n)
        .map(|i| {
            map.get(&i)
                .copied()
                .ok_or(ExceptionCode::IllegalDataAddress)
        })
        .collect()
}

pub fn words(map: &BTreeMap<u16, u16>, a: u16, n: u16) -> Result<Vec<u16>, ExceptionCode> {
    (a..a + n)
        .map(|i| {
            map.get(&i)
                .copied()
                .ok_or(ExceptionCode::IllegalDataAddress)
        })
        .collect()
}

impl Service {
    pub fn answer(&self, req: SlaveRequest<'static>) -> Result<Option<Response>, ExceptionCode> {
        if let (Some((slow, wait)), Request::WriteMultipleRegisters(a, _)) =
            (self.slow, &req.request)
        {
            if *a == slow {
                std::thread::sleep(wait);
            }
        }
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

pub fn runtime() -> Runtime {
    tokio::runtime::Builder::new_multi_thread()
        .worker_threads(1)
        .enable_all()
        .build()
        .unwrap()
}

/// A Modbus TCP server on a fixed local port that can be stopped (listener and
/// connections closed) and started again.
pub struct TcpServer {
    pub rt: Runtime,
    pub addr: SocketAddr,
    pub banks: Banks,
    pub slow: Option<(u16, Duration)>,
    pub abort: Option<oneshot::Sender<()>>,
}

impl TcpServer {
    pub fn start(banks: Banks) -> TcpServer {
        TcpServer::start_slow(banks, None)
    }

    /// A server whose writes to holding registers from `slow`'s address wait its time.
    pub fn start_slow(banks: Banks, slow: Option<(u16, Duration)>) -> TcpServer {
        let listener = StdListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let mut s = TcpServer {
            rt: runtime(),
            addr,
            banks,
            slow,
            abort: None,
        };
        s.serve(listener);
        s
    }

    pub fn serve(&mut self, listener: StdListener) {
        listener.set_nonblocking(true).unwrap();
        let (abort, aborted) = oneshot::channel::<()>();
        let banks = self.banks.clone();
        let slow = self.slow;
        let _guard = self.rt.enter();
        let listener = tokio::net::TcpListener::from_std(listener).unwrap();
        self.rt.spawn(async move {
            let server = Server::new(listener);
            let service = Service { banks, slow };
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
    pub fn stop(&mut self) {
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

    pub fn restart(&mut self) {
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

pub fn banks(units: impl IntoIterator<Item = (u8, Bank)>) -> Banks {
    Arc::new(Mutex::new(units.into_iter().collect()))
}

pub fn log_of(banks: &Banks, unit: u8) -> Vec<String> {
    banks.lock().unwrap()[&unit].log.clone()
}

/// Whether `log` ends with `cycle` repeated twice: a steady cycle made of these requests
/// in this order.
pub fn steady(log: &[String], cycle: &[&str]) -> bool {
    let n = cycle.len();
    log.len() >= 2 * n
        && log[log.len() - 2 * n..]
            .iter()
            .zip(cycle.iter().chain(cycle))
            .all(|(a, b)| a == b)
}

/// A TCP server that accepts connections and reads requests but never answers; it counts
/// the connections, the bytes received, and the connections the client closed.
pub struct Mute {
    pub addr: SocketAddr,
    pub seen: Arc<Mutex<MuteLog>>,
}

#[derive(Default, Debug)]
pub struct MuteLog {
    /// When each connection came.
    pub accepted: Vec<Instant>,
    pub bytes: usize,
    pub closed: usize,
}

impl Mute {
    /// `hang_up`: close each connection at once instead of keeping it silent.
    pub fn start(hang_up: bool) -> Mute {
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

// ---------------------------------------------------------------------------------------
// Driving the PLC.

/// A module that does nothing: the owner of the points the client writes out, which the
/// test sets through its map.
pub struct Idle;

impl Module for Idle {
    fn init(&mut self, _: &mut InitContext<'_>) -> Result<(), ModuleError> {
        Ok(())
    }
    fn scan(&mut self, _: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        Ok(Control::Continue)
    }
}

pub fn idle(_: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Idle))
}

pub fn registry(kind: &str) -> Option<Factory> {
    match kind {
        "idle" => Some(idle),
        k => petriplc_modbus::builtin(k),
    }
}

/// The longest any condition is waited for: far above what a loaded machine needs, only
/// there so that a broken client fails the test instead of hanging it.
pub const PATIENCE: Duration = Duration::from_secs(30);

pub struct Run {
    pub plc: Plc,
    pub t: u64,
}

impl Run {
    pub fn start(text: &str) -> Run {
        let plc = harness::start(text, &std::env::temp_dir(), registry).unwrap_or_else(|e| {
            panic!("{e}");
        });
        Run { plc, t: 0 }
    }

    pub fn tick(&mut self) {
        self.t += 10;
        self.plc.tick(ms(self.t)).unwrap();
    }

    /// Scans every 5 ms of real time until `cond` holds.
    pub fn until(&mut self, what: &str, mut cond: impl FnMut(&Plc) -> bool) {
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

    /// Scans until the points hold `expected`; on time-out, fails showing every value.
    pub fn until_values(&mut self, what: &str, expected: &[(&str, PointValue)]) {
        let names: Vec<&str> = expected.iter().map(|(n, _)| *n).collect();
        let want: Vec<PointValue> = expected.iter().map(|(_, v)| *v).collect();
        self.until_eq_plc(what, |p| names.iter().map(|n| p.get(n)).collect(), want);
    }

    /// Scans until `seen()` equals `expected`; on time-out, fails showing both.
    pub fn until_eq<T: PartialEq + std::fmt::Debug>(
        &mut self,
        what: &str,
        mut seen: impl FnMut() -> T,
        expected: T,
    ) {
        self.until_eq_plc(what, |_| seen(), expected);
    }

    pub fn until_eq_plc<T: PartialEq + std::fmt::Debug>(
        &mut self,
        what: &str,
        mut seen: impl FnMut(&Plc) -> T,
        expected: T,
    ) {
        let deadline = Instant::now() + PATIENCE;
        loop {
            self.tick();
            let now = seen(&self.plc);
            if now == expected {
                return;
            }
            if Instant::now() > deadline {
                assert_eq!(
                    now,
                    expected,
                    "timed out waiting for {what}; client status: {}",
                    self.plc.status("io")
                );
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }

    /// Writes a point owned by the `setter` module, as that module would.
    pub fn set(&mut self, point: &str, v: PointValue) {
        let (_, _, map) = self
            .plc
            .modules
            .iter_mut()
            .find(|m| m.0 == "setter")
            .unwrap();
        let h = map.handle(point).unwrap();
        map.set(&h, v).unwrap();
    }

    pub fn status(&self) -> String {
        self.plc.status("io")
    }
}

impl Drop for Run {
    fn drop(&mut self) {
        self.plc.close();
    }
}

pub fn u(v: u32) -> PointValue {
    PointValue::Unsigned(v)
}

pub fn i(v: i32) -> PointValue {
    PointValue::Signed(v)
}

pub fn f(v: f32) -> PointValue {
    PointValue::Float(v)
}

/// The number after `word` in a status line (`3 cycles`).
pub fn count(status: &str, word: &str) -> u64 {
    let words: Vec<&str> = status.split([' ', ',', '(', ')']).collect();
    words
        .windows(2)
        .filter(|w| w[1].starts_with(word))
        .filter_map(|w| w[0].parse().ok())
        .next_back()
        .unwrap_or_else(|| panic!("no `{word}` count in `{status}`"))
}
