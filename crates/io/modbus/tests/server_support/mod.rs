//! Shared by the modbus_server tests: a server driven scan by scan through the runtime's
//! harness next to a `probe` module that owns the points clients may not write (and sets them
//! to the values of its `set POINT VALUE` rows every scan), a raw TCP client for hand-made
//! frames, a serial line made of two pseudo-terminals, and where the third-party tools are.

#![allow(dead_code)]

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::os::fd::{AsFd, OwnedFd};
use std::path::PathBuf;
use std::time::{Duration, Instant};

use petriplc_config::{ModuleDecl, PointKind, PointValue};
use petriplc_runtime::harness::{self, Plc};
use petriplc_runtime::image::Handle;
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};

/// The kinds the tests use: this crate's and `probe`.
pub fn registry(kind: &str) -> Option<Factory> {
    match kind {
        "probe" => Some(probe),
        k => petriplc_modbus::builtin(k),
    }
}

fn probe(_: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Probe { sets: Vec::new() }))
}

/// Writes its `set POINT VALUE` rows every scan.
struct Probe {
    sets: Vec<(Handle, PointValue)>,
}

impl Module for Probe {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let Some(section) = ctx.config.sections.get(&ctx.decl.name) else {
            return Ok(());
        };
        for row in &section.rows {
            let [point, value] = row.cells.as_slice() else {
                return Err(ModuleError::new(format!("{}: set POINT VALUE", row.origin)));
            };
            let h = ctx
                .map
                .handle(point)
                .map_err(|e| ModuleError::new(e.to_string()))?;
            let v = match h.kind() {
                PointKind::Float => PointValue::Float(value.parse().unwrap()),
                PointKind::Signed => PointValue::Signed(value.parse().unwrap()),
                PointKind::Unsigned => PointValue::Unsigned(value.parse().unwrap()),
            };
            self.sets.push((h, v));
        }
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        for (h, v) in &self.sets {
            ctx.map
                .set(h, *v)
                .map_err(|e| ModuleError::new(e.to_string()))?;
        }
        Ok(Control::Continue)
    }
}

/// A PLC with a modbus_server `mb`, stepped by [`Server::tick`].
pub struct Server {
    pub plc: Plc,
    pub addr: SocketAddr,
    now: Duration,
    _dir: tempfile::TempDir,
}

impl Server {
    /// Starts the configuration and makes two scans, so that the image holds the probe's
    /// values (the server scans first).
    pub fn start(text: &str) -> Server {
        let dir = tempfile::tempdir().unwrap();
        let plc = harness::start(text, dir.path(), registry).unwrap_or_else(|e| panic!("{e}"));
        let status = plc.status("mb");
        let addr = tcp_address(&status).unwrap_or_else(|| SocketAddr::from(([127, 0, 0, 1], 0)));
        let mut s = Server {
            plc,
            addr,
            now: Duration::ZERO,
            _dir: dir,
        };
        s.tick();
        s.tick();
        s
    }

    /// One scan of every module.
    pub fn tick(&mut self) {
        self.now += Duration::from_millis(10);
        self.plc.tick(self.now).unwrap();
    }

    pub fn status(&self) -> String {
        self.plc.status("mb")
    }

    /// The status line's `N clients, N requests, N exceptions` as numbers.
    pub fn counts(&self) -> (u64, u64, u64) {
        let s = self.status();
        let n = |what: &str| -> u64 {
            let end = s
                .find(what)
                .unwrap_or_else(|| panic!("no `{what}` in `{s}`"));
            s[..end]
                .trim_end()
                .rsplit([' ', ';', ','])
                .next()
                .unwrap()
                .parse()
                .unwrap()
        };
        (n(" client"), n(" request"), n(" exception"))
    }

    pub fn raw(&self) -> Raw {
        Raw::connect(self.addr)
    }
}

/// `tcp 127.0.0.1:PORT` in a status line.
pub fn tcp_address(status: &str) -> Option<SocketAddr> {
    let rest = status.strip_prefix("tcp ")?;
    let end = rest.find([',', ';']).unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// The error starting `text` gives.
pub fn start_err(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    match harness::start(text, dir.path(), registry) {
        Ok(_) => panic!("started without an error:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// A current-thread tokio runtime for the clients.
pub fn runtime() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap()
}

/// Waits up to 10 s for `ok`, ticking the PLC meanwhile.
pub fn eventually(srv: &mut Server, what: &str, mut ok: impl FnMut(&Server) -> bool) {
    let start = Instant::now();
    while !ok(srv) {
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "timed out waiting for {what}: {}",
            srv.status()
        );
        srv.tick();
        std::thread::sleep(Duration::from_millis(5));
    }
}

/// A blocking TCP client for hand-made frames.
pub struct Raw {
    pub stream: TcpStream,
}

/// How long a test waits for an answer before failing (not a timing assertion).
pub const PATIENCE: Duration = Duration::from_secs(10);

impl Raw {
    pub fn connect(addr: SocketAddr) -> Raw {
        let stream = TcpStream::connect(addr).unwrap();
        stream.set_read_timeout(Some(PATIENCE)).unwrap();
        stream.set_nodelay(true).unwrap();
        Raw { stream }
    }

    pub fn send(&mut self, bytes: &[u8]) {
        self.stream.write_all(bytes).unwrap();
    }

    /// Reads one response ADU: (transaction id, unit, PDU).
    pub fn read_adu(&mut self) -> (u16, u8, Vec<u8>) {
        let mut h = [0u8; 7];
        self.stream.read_exact(&mut h).expect("a response header");
        assert_eq!(&h[2..4], &[0, 0], "protocol id");
        let len = usize::from(u16::from_be_bytes([h[4], h[5]]));
        let mut pdu = vec![0u8; len - 1];
        self.stream.read_exact(&mut pdu).expect("a response PDU");
        (u16::from_be_bytes([h[0], h[1]]), h[6], pdu)
    }

    /// Sends one request and returns the response PDU.
    pub fn request(&mut self, tid: u16, pdu: &[u8]) -> Vec<u8> {
        self.send(&adu(tid, 1, pdu));
        let (t, unit, response) = self.read_adu();
        assert_eq!((t, unit), (tid, 1));
        response
    }

    /// Whether the server closes the connection (end of file or reset) within [`PATIENCE`].
    pub fn closed(&mut self) -> bool {
        let mut b = [0u8; 64];
        match self.stream.read(&mut b) {
            Ok(0) => true,
            Ok(_) => false,
            Err(e) => !matches!(
                e.kind(),
                std::io::ErrorKind::WouldBlock | std::io::ErrorKind::TimedOut
            ),
        }
    }
}

/// An MBAP ADU.
pub fn adu(tid: u16, unit: u8, pdu: &[u8]) -> Vec<u8> {
    let mut v = Vec::with_capacity(7 + pdu.len());
    v.extend_from_slice(&tid.to_be_bytes());
    v.extend_from_slice(&[0, 0]);
    v.extend_from_slice(&(pdu.len() as u16 + 1).to_be_bytes());
    v.push(unit);
    v.extend_from_slice(pdu);
    v
}

/// FC 16 of `words` at `address`.
pub fn fc16(address: u16, words: &[u16]) -> Vec<u8> {
    let mut pdu = vec![0x10];
    pdu.extend(address.to_be_bytes());
    pdu.extend((words.len() as u16).to_be_bytes());
    pdu.push(2 * words.len() as u8);
    for w in words {
        pdu.extend(w.to_be_bytes());
    }
    pdu
}

/// FC 23: read one register at 0, write `words` at `address`.
pub fn fc23(address: u16, words: &[u16]) -> Vec<u8> {
    let mut pdu = vec![0x17, 0, 0, 0, 1];
    pdu.extend(address.to_be_bytes());
    pdu.extend((words.len() as u16).to_be_bytes());
    pdu.push(2 * words.len() as u8);
    for w in words {
        pdu.extend(w.to_be_bytes());
    }
    pdu
}

/// The number before `word` in a status line (`3 values refused`).
pub fn count(status: &str, word: &str) -> u64 {
    let end = status
        .find(word)
        .unwrap_or_else(|| panic!("no `{word}` in `{status}`"));
    status[..end]
        .trim_end()
        .rsplit([' ', ';', ','])
        .next()
        .unwrap()
        .parse()
        .unwrap()
}

/// A serial line between two paths: two pseudo-terminal pairs whose master sides a thread
/// each copies to the other (what `socat pty pty` does). The server opens one slave path, a
/// client the other; both set raw mode as serial libraries do.
pub struct Line {
    pub server: PathBuf,
    pub client: PathBuf,
    // The slave sides stay open so that the masters do not see a hang-up between opens.
    _slaves: [OwnedFd; 2],
}

pub fn serial_line() -> Line {
    let a = nix::pty::openpty(None, None).unwrap();
    let b = nix::pty::openpty(None, None).unwrap();
    let path = |fd: &OwnedFd| nix::unistd::ttyname(fd.as_fd()).unwrap();
    let (server, client) = (path(&a.slave), path(&b.slave));
    for fd in [&a.slave, &b.slave] {
        raw_mode(fd);
    }
    let (am, bm) = (std::fs::File::from(a.master), std::fs::File::from(b.master));
    copy(am.try_clone().unwrap(), bm.try_clone().unwrap());
    copy(bm, am);
    Line {
        server,
        client,
        _slaves: [a.slave, b.slave],
    }
}

fn raw_mode(fd: &OwnedFd) {
    use nix::sys::termios;
    let mut t = termios::tcgetattr(fd.as_fd()).unwrap();
    termios::cfmakeraw(&mut t);
    termios::tcsetattr(fd.as_fd(), termios::SetArg::TCSANOW, &t).unwrap();
}

/// Copies until either side closes (the process ends, or every slave fd is closed).
fn copy(mut from: std::fs::File, mut to: std::fs::File) {
    std::thread::spawn(move || {
        let mut buf = [0u8; 1024];
        loop {
            match from.read(&mut buf) {
                Ok(0) | Err(_) => return,
                Ok(n) => {
                    if to.write_all(&buf[..n]).is_err() {
                        return;
                    }
                }
            }
        }
    });
}

/// A third-party tool: `$env` if set, else `default` under the repository's target/ folder or
/// on the PATH, else a failure that says to run scripts/test-all.sh.
pub fn tool(env: &str, default: &str, install: &str) -> PathBuf {
    if let Some(p) = std::env::var_os(env) {
        return PathBuf::from(p);
    }
    let under_target =
        PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../target")).join(default);
    if under_target.exists() {
        return under_target;
    }
    if !default.contains('/') {
        for dir in std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default()) {
            let p = dir.join(default);
            if p.exists() {
                return p;
            }
        }
    }
    panic!("{default} not found: run scripts/test-all.sh, which installs {install}, or set {env}");
}
