//! `modbus_server`: a Modbus slave (TCP and RTU) that exposes points as coils, discrete
//! inputs, holding and input registers (docs/modbus.md).
//!
//! ```text
//! [mb]
//! listen = 127.0.0.1:5020          # default; `off`: no TCP (RTU only, or the server off)
//! serial = /dev/ttyUSB0:19200:8E1  # optional RTU endpoint
//! unit = 1                         # RTU slave address; TCP answers every unit id
//! idle_timeout = 60s               # 0 = never
//! max_clients = 64
//! threads = 1                      # network threads; default 1
//! busy_poll = 50us                 # poll this long after a request before sleeping; 0 = off
//! io_uring = yes                   # write a turn's answers in one submission (default yes)
//! word_order = high_first          # default for 32-bit values
//! coil      0   B1
//! holding   10  temp  f32  low_first
//! ```
//!
//! The network runs on single-threaded tokio runtimes (`threads`, default one), started by
//! `init` and stopped by `close`. It answers from a register image under a mutex (never held
//! across an await): `scan` applies the client writes received since the last scan to the
//! points, in order, and then copies every mapped point into the image, one consistent
//! snapshot per scan. A write is shown in the image at once, so a client reads back what it
//! wrote.

mod map;
mod pdu;
mod rtu;
mod sends;
mod tcp;

use std::net::{SocketAddr, ToSocketAddrs};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use petriplc_config::ModuleDecl;
use petriplc_modules::common::{self, error};
use petriplc_runtime::image::ModuleMap;
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};
use tokio::sync::oneshot;

use crate::serial::SerialSettings;
use crate::value::WordOrder;

pub use map::{Table, TABLE_NAMES};
pub use rtu::{crc16, crc_ok};

const KIND: &str = "modbus_server";

/// The settings a `modbus_server` section may have (besides the runner's).
pub const SETTINGS: &[&str] = &[
    "listen",
    "serial",
    "unit",
    "idle_timeout",
    "max_clients",
    "threads",
    "busy_poll",
    "io_uring",
    "word_order",
];

/// `listen` when the section has none.
pub const DEFAULT_LISTEN: &str = "127.0.0.1:5020";
pub const DEFAULT_IDLE_TIMEOUT: Duration = Duration::from_secs(60);
pub const DEFAULT_MAX_CLIENTS: usize = 64;
/// `busy_poll` when the section sets none.
pub const DEFAULT_BUSY_POLL: Duration = Duration::from_micros(50);
/// The longest `busy_poll`: longer would only burn a core between sparse requests.
pub const MAX_BUSY_POLL: Duration = Duration::from_millis(10);
/// The scan period when the section sets none: client writes reach the points, and the
/// points the image, within this time.
pub const DEFAULT_SCAN_PERIOD: Duration = Duration::from_millis(10);

pub fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(ModbusServer::new(decl)?))
}

/// The checked settings of a section.
#[derive(Clone, Debug)]
pub struct Settings {
    /// `None`: `listen = off`.
    pub listen: Option<SocketAddr>,
    pub serial: Option<SerialSettings>,
    pub unit: u8,
    /// `None`: never.
    pub idle_timeout: Option<Duration>,
    pub max_clients: usize,
    /// Network threads, each serving its share of the TCP connections.
    pub threads: usize,
    /// How long a network thread keeps polling its sockets after a request before it sleeps;
    /// `None`: it sleeps at once.
    pub busy_poll: Option<Duration>,
    /// Whether to write the answers of a loop's turn with one io_uring submission (where the
    /// kernel allows it) rather than one `send` each.
    pub io_uring: bool,
    pub word_order: WordOrder,
}

impl Settings {
    pub fn parse(decl: &ModuleDecl) -> Result<Settings, ModuleError> {
        common::check_decl(decl, KIND, SETTINGS)?;
        let name = decl.name.as_str();
        let bad = |setting: &str, why: String| {
            let at = decl
                .settings
                .get(setting)
                .filter(|s| !s.origin.file.is_empty())
                .map(|s| format!("{}: ", s.origin))
                .unwrap_or_default();
            error(name, format!("{at}{why}"))
        };
        let listen = match common::setting(decl, "listen").unwrap_or(DEFAULT_LISTEN) {
            "off" | "no" | "none" => None,
            text => Some(parse_listen(text).map_err(|why| bad("listen", why))?),
        };
        let serial = common::setting(decl, "serial")
            .filter(|s| !s.is_empty())
            .map(|s| SerialSettings::parse(s).map_err(|why| bad("serial", why)))
            .transpose()?;
        let unit = match common::setting(decl, "unit") {
            None => 1,
            Some(v) => match v.parse::<u8>() {
                Ok(u @ 1..=247) => u,
                _ => {
                    return Err(bad(
                        "unit",
                        format!("`unit = {v}`: an RTU slave address is 1 to 247 (0 is broadcast)"),
                    ))
                }
            },
        };
        let idle_timeout = match common::setting(decl, "idle_timeout") {
            None => Some(DEFAULT_IDLE_TIMEOUT),
            Some(v) => match petriplc_net::time::parse_duration(v) {
                Ok(d) if d.is_zero() => None,
                Ok(d) => Some(d),
                Err(e) => {
                    return Err(bad(
                        "idle_timeout",
                        format!(
                            "`idle_timeout = {v}`: {e}; write seconds (60) or an IEC time \
                             (T#1m), 0 for never"
                        ),
                    ))
                }
            },
        };
        let max_clients = match common::setting(decl, "max_clients") {
            None => DEFAULT_MAX_CLIENTS,
            Some(v) => match v.parse::<usize>() {
                Ok(n) if n >= 1 => n,
                _ => {
                    return Err(bad(
                        "max_clients",
                        format!("`max_clients = {v}`: write a whole number of 1 or more"),
                    ))
                }
            },
        };
        let threads = match common::setting(decl, "threads") {
            None => 1,
            Some(v) => match v.parse::<usize>() {
                Ok(n @ 1..=64) => n,
                _ => {
                    return Err(bad(
                        "threads",
                        format!("`threads = {v}`: write a whole number from 1 to 64"),
                    ))
                }
            },
        };
        let busy_poll = match common::setting(decl, "busy_poll") {
            None => Some(DEFAULT_BUSY_POLL),
            Some(v) => match petriplc_net::time::parse_duration(v) {
                Ok(d) if d.is_zero() => None,
                Ok(d) if d <= MAX_BUSY_POLL => Some(d),
                Ok(_) => {
                    return Err(bad(
                        "busy_poll",
                        format!(
                            "`busy_poll = {v}`: at most {} ms; a network thread polls this \
                             long after each request, so a long one burns a core between \
                             sparse requests (0 turns polling off)",
                            MAX_BUSY_POLL.as_millis()
                        ),
                    ))
                }
                Err(e) => {
                    return Err(bad(
                        "busy_poll",
                        format!(
                            "`busy_poll = {v}`: {e}; write a time such as 50us or T#50us, \
                             0 for off"
                        ),
                    ))
                }
            },
        };
        let io_uring =
            common::setting(decl, "io_uring").is_none() || common::flag(decl, "io_uring")?;
        let word_order = match common::setting(decl, "word_order") {
            None => WordOrder::HighFirst,
            Some(v) => WordOrder::parse(v).ok_or_else(|| {
                bad(
                    "word_order",
                    format!("`word_order = {v}`: write high_first or low_first"),
                )
            })?,
        };
        Ok(Settings {
            listen,
            serial,
            unit,
            idle_timeout,
            max_clients,
            threads,
            busy_poll,
            io_uring,
            word_order,
        })
    }
}

fn parse_listen(text: &str) -> Result<SocketAddr, String> {
    let fix = format!(
        "`listen = {text}`: write HOST:PORT (e.g. {DEFAULT_LISTEN}, 0.0.0.0:502, [::1]:5020; \
         port 0 picks a free one) or `off`"
    );
    if let Ok(a) = text.parse::<SocketAddr>() {
        return Ok(a);
    }
    match text.to_socket_addrs() {
        Ok(mut addrs) => addrs.next().ok_or(fix),
        Err(e) => Err(format!("{fix} ({e})")),
    }
}

/// What the network side and the module share.
pub(crate) struct Shared {
    name: String,
    map: map::AddressMap,
    image: Mutex<map::Image>,
    idle: Option<Duration>,
    max_clients: usize,
    clients: AtomicUsize,
    requests: AtomicU64,
    exceptions: AtomicU64,
    /// Writes refused for a value its point cannot hold (counted in `exceptions` too).
    bad_values: AtomicU64,
    refusals: Mutex<Refusals>,
}

impl Shared {
    /// The image; a panic elsewhere while it was held leaves values that are still values.
    fn lock(&self) -> MutexGuard<'_, map::Image> {
        self.image.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Logs why a request was refused (exception `code`), so that the user whose client
    /// fails learns why: the first at once, then at most one line every 10 s, saying how
    /// many were not logged meanwhile. Every refusal is counted in the status line anyway.
    fn refused(&self, pdu: &[u8], code: u8) {
        let now = std::time::Instant::now();
        let mut log = self.refusals.lock().unwrap_or_else(PoisonError::into_inner);
        if log
            .last
            .is_some_and(|t| now.duration_since(t) < REFUSALS_EVERY)
        {
            log.quiet += 1;
            return;
        }
        let quiet = std::mem::take(&mut log.quiet);
        log.last = Some(now);
        drop(log);
        let more = match quiet {
            0 => String::new(),
            n => format!(
                " ({n} more refused in the last {} s)",
                REFUSALS_EVERY.as_secs()
            ),
        };
        log::warn!(
            "modbus_server {}: refused {}{more}",
            self.name,
            pdu::explain(&self.map, pdu, code)
        );
    }
}

impl Shared {
    /// Counts, and logs if it is the point's first since its last accepted write, a write
    /// refused for its value: a client that keeps writing NaN to a point every 10 ms gets one
    /// line, not one per request. `image` is the locked image the refusal was decided under.
    fn bad_value(&self, image: &mut map::Image, bad: &pdu::BadValue) {
        self.bad_values.fetch_add(1, Ordering::Relaxed);
        let point = self.map.entries[bad.entry as usize].point;
        if image.refuse(point) {
            log::warn!(
                "modbus_server {}: refused {}; further bad values for `{}` are only counted \
                 (status line: values refused) until a write to it is accepted",
                self.name,
                pdu::explain_value(&self.map, bad),
                self.map.points[point as usize].name
            );
        }
    }

    /// Counts and logs what [`pdu::respond`] did with a request that was not served: a bad
    /// value per point ([`Shared::bad_value`]), any other refusal at most every 10 s
    /// ([`Shared::refused`]). Returns whether the answer was an exception.
    fn outcome(&self, image: &mut map::Image, pdu: &[u8], outcome: pdu::Outcome) -> bool {
        match outcome {
            pdu::Outcome::Served => false,
            pdu::Outcome::Exception(code) => {
                self.refused(pdu, code);
                true
            }
            pdu::Outcome::BadValue(bad) => {
                self.bad_value(image, &bad);
                true
            }
        }
    }
}

/// At most one log line about refused requests in this time.
const REFUSALS_EVERY: Duration = Duration::from_secs(10);

/// The refusals logged: when last, and how many since were not.
#[derive(Default)]
struct Refusals {
    last: Option<std::time::Instant>,
    quiet: u64,
}

/// The running network side.
struct Net {
    /// Tells the TCP loops to stop; they see it when woken through their doors.
    stop: Arc<AtomicBool>,
    doors: Vec<Arc<tcp::Door>>,
    rtu_stop: Option<oneshot::Sender<()>>,
    threads: Vec<JoinHandle<()>>,
}

impl Net {
    fn stop(&mut self) {
        tcp::stop(&self.stop, &self.doors);
        if let Some(stop) = self.rtu_stop.take() {
            let _ = stop.send(());
        }
        for t in self.threads.drain(..) {
            if t.join().is_err() {
                log::error!("modbus_server: a network thread panicked");
            }
        }
    }
}

/// The `modbus_server` module.
pub struct ModbusServer {
    name: String,
    settings: Settings,
    shared: Option<Arc<Shared>>,
    net: Option<Net>,
    tcp: Option<SocketAddr>,
    rtu: Option<String>,
}

impl ModbusServer {
    /// Checks the settings; the table rows are read and the network started by `init`.
    pub fn new(decl: &ModuleDecl) -> Result<ModbusServer, ModuleError> {
        Ok(ModbusServer {
            name: decl.name.clone(),
            settings: Settings::parse(decl)?,
            shared: None,
            net: None,
            tcp: None,
            rtu: None,
        })
    }

    /// The address the TCP listener is bound to (the port chosen for `listen = HOST:0`).
    pub fn local_addr(&self) -> Option<SocketAddr> {
        self.tcp
    }

    fn start(&mut self, shared: Arc<Shared>) -> Result<(), ModuleError> {
        let name = self.name.clone();
        // By default one network thread, which waits on every connection's socket and answers
        // them in turn, as a select() server does. With two workers of a multi-threaded
        // runtime the 16-client p99 was 1.3 to 2.3 times libmodbus's: a request waited for
        // the other worker to be scheduled (the threads compete with the clients for the
        // cores). `threads = N` runs N loops, each owning the connections handed to it in
        // turn, for more requests per second at the cost of that tail (docs/modbus.md,
        // Performance).
        let mut net = Net {
            stop: Arc::new(AtomicBool::new(false)),
            doors: Vec::new(),
            rtu_stop: None,
            threads: Vec::new(),
        };
        if let Some(addr) = self.settings.listen {
            // Bind here, so that a taken port stops the PLC's start with a message instead
            // of failing later in the background.
            let listener = bind(addr)
                .map(mio::net::TcpListener::from_std)
                .map_err(|e| {
                    error(
                        &name,
                        format!(
                            "cannot listen on {addr}: {e}; choose another `listen` address \
                             or port (`listen = off` for RTU only)"
                        ),
                    )
                })?;
            let local = listener.local_addr().unwrap_or(addr);
            let loops = (0..self.settings.threads)
                .map(|_| tcp::Loop::new())
                .collect::<Result<Vec<_>, _>>()
                .map_err(|e| error(&name, format!("cannot start the network loop: {e}")))?;
            net.doors = loops.iter().map(tcp::Loop::door).collect();
            let mut acceptor = Some(tcp::Acceptor {
                listener,
                doors: net.doors.clone(),
            });
            let start = std::time::Instant::now();
            let options = tcp::Options {
                busy_poll: self.settings.busy_poll,
                io_uring: self.settings.io_uring,
            };
            for (i, lp) in loops.into_iter().enumerate() {
                let accept = acceptor.take();
                let shared = shared.clone();
                let stop = net.stop.clone();
                let thread = std::thread::Builder::new()
                    .name(format!("modbus {name} {i}"))
                    .spawn(move || tcp::run(lp, accept, shared, options, start, stop));
                match thread {
                    Ok(t) => net.threads.push(t),
                    Err(e) => {
                        net.stop();
                        return Err(error(
                            &name,
                            format!("cannot start the network thread: {e}"),
                        ));
                    }
                }
            }
            self.tcp = Some(local);
            log::info!("modbus_server {name}: listening on {local}");
        }
        if let Some(s) = &self.settings.serial {
            let rt = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .map_err(|e| error(&name, format!("cannot start the serial runtime: {e}")))?;
            // Opened here, so that a missing device stops the PLC's start with a message.
            let port = {
                let _enter = rt.enter();
                s.open().map_err(|e| {
                    net.stop();
                    error(
                        &name,
                        format!("{}; fix `serial` in [{name}]", common::chain(&e)),
                    )
                })?
            };
            let unit = self.settings.unit;
            log::info!("modbus_server {name}: RTU slave {unit} on {s}");
            self.rtu = Some(format!("{s} unit {unit}"));
            let (stop, stopped) = oneshot::channel::<()>();
            let s = s.clone();
            let thread = std::thread::Builder::new()
                .name(format!("modbus {name} rtu"))
                .spawn(move || {
                    rt.block_on(async move {
                        tokio::spawn(rtu::serve(port, s, unit, shared));
                        let _ = stopped.await;
                    });
                    // The serial task is dropped at its next await; it never blocks.
                    rt.shutdown_timeout(Duration::from_secs(1));
                });
            match thread {
                Ok(t) => {
                    net.rtu_stop = Some(stop);
                    net.threads.push(t);
                }
                Err(e) => {
                    net.stop();
                    return Err(error(&name, format!("cannot start the serial thread: {e}")));
                }
            }
        }
        self.net = Some(net);
        Ok(())
    }
}

fn bind(addr: SocketAddr) -> std::io::Result<std::net::TcpListener> {
    let l = std::net::TcpListener::bind(addr)?;
    l.set_nonblocking(true)?;
    Ok(l)
}

/// For the fuzz target `modbus_tcp` (fuzz/): serves `bytes`, as received on one TCP
/// connection, with the register map of module `module` of `config` (its points at their init
/// values) and returns the answers, exactly as a connection would answer them, stopping where
/// a connection would be closed. No network, no threads.
#[doc(hidden)]
pub fn answer_tcp_bytes(
    config: &petriplc_config::PlcConfig,
    module: &str,
    bytes: &[u8],
) -> Result<Vec<u8>, String> {
    let layout = petriplc_runtime::image::Layout::new(config).map_err(|e| e.to_string())?;
    let points = ModuleMap::new(&layout, module, petriplc_config::Location::Local)
        .map_err(|e| e.to_string())?;
    let rows = common::module_rows(config, module);
    let map =
        map::AddressMap::build(&rows, &points, WordOrder::HighFirst).map_err(|p| p.join("\n"))?;
    let mut image = map::Image::new(&map);
    image.refresh(&map, &points);
    let shared = Shared {
        name: module.to_string(),
        map,
        image: Mutex::new(image),
        idle: None,
        max_clients: 1,
        clients: AtomicUsize::new(0),
        requests: AtomicU64::new(0),
        exceptions: AtomicU64::new(0),
        bad_values: AtomicU64::new(0),
        refusals: Mutex::new(Refusals::default()),
    };
    let mut out = Vec::new();
    let mut pos = 0;
    while pos < bytes.len() {
        let batch = tcp::answer(&bytes[pos..], &shared, &mut out);
        if batch.close.is_some() || batch.used == 0 {
            break;
        }
        pos += batch.used;
    }
    Ok(out)
}

impl Module for ModbusServer {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let name = self.name.clone();
        let rows = common::module_rows(ctx.config, &name);
        let map = map::AddressMap::build(&rows, ctx.map, self.settings.word_order)
            .map_err(|p| error(&name, p.join(&format!("\nmodule {name}: "))))?;
        let mut image = map::Image::new(&map);
        image.refresh(&map, ctx.map);
        let shared = Arc::new(Shared {
            name: name.clone(),
            map,
            image: Mutex::new(image),
            idle: self.settings.idle_timeout,
            max_clients: self.settings.max_clients,
            clients: AtomicUsize::new(0),
            requests: AtomicU64::new(0),
            exceptions: AtomicU64::new(0),
            bad_values: AtomicU64::new(0),
            refusals: Mutex::new(Refusals::default()),
        });
        self.shared = Some(shared.clone());
        if self.settings.listen.is_none() && self.settings.serial.is_none() {
            log::info!("modbus_server {name}: off (listen = off and no serial)");
        }
        self.start(shared)
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(shared) = &self.shared else {
            return Err(error(&self.name, "scanned before init"));
        };
        let mut image = shared.lock();
        let pending = std::mem::take(&mut image.pending);
        for &(p, v) in &pending {
            let point = &shared.map.points[p as usize];
            // Values were checked against the point when they arrived; an error here would
            // be a bug, not the client's fault, and must not stop the PLC.
            if let Err(e) = ctx.map.set(&point.handle, v) {
                log::warn!("modbus_server {}: client write not applied: {e}", self.name);
            }
        }
        image.refresh(&shared.map, ctx.map);
        // Keep the vector's capacity for the next scan's writes.
        let mut pending = pending;
        pending.clear();
        image.pending = pending;
        Ok(Control::Continue)
    }

    fn close(&mut self) {
        if let Some(mut net) = self.net.take() {
            net.stop();
        }
    }

    fn status(&self) -> String {
        let mut s = String::new();
        if self.settings.listen.is_none() && self.settings.serial.is_none() {
            s.push_str("off (listen = off, no serial)");
        }
        if let Some(a) = self.tcp {
            s.push_str(&format!("tcp {a}"));
        }
        if let Some(r) = &self.rtu {
            if !s.is_empty() {
                s.push_str(", ");
            }
            s.push_str(&format!("rtu {r}"));
        }
        if let Some(sh) = &self.shared {
            let count = |n: u64, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
            s.push_str(&format!(
                "; {}, {}, {}, {} refused",
                count(sh.clients.load(Ordering::Relaxed) as u64, "client"),
                count(sh.requests.load(Ordering::Relaxed), "request"),
                count(sh.exceptions.load(Ordering::Relaxed), "exception"),
                count(sh.bad_values.load(Ordering::Relaxed), "value")
            ));
        }
        s
    }

    fn listens(&self) -> Vec<(&'static str, SocketAddr)> {
        self.settings
            .listen
            .filter(|a| a.port() != 0)
            .map(|a| ("listen", a))
            .into_iter()
            .collect()
    }

    fn default_scan_period(&self) -> Option<Duration> {
        Some(DEFAULT_SCAN_PERIOD)
    }
}

impl Drop for ModbusServer {
    fn drop(&mut self) {
        self.close();
    }
}

#[cfg(test)]
mod fuzz_entry_tests {
    use std::path::Path;

    use super::answer_tcp_bytes;

    #[test]
    fn the_fuzz_entry_answers_like_a_connection() {
        let text =
            "[PLC]\nmodule mb modbus_server\npoint h \"h\" mb u16 init 7\n[mb]\nholding 0 h\n";
        let cfg = petriplc_config::parse_str(text, "t.conf", Path::new(".")).unwrap();
        let read = [0, 1, 0, 0, 0, 6, 1, 3, 0, 0, 0, 1];
        let mut two = read.to_vec();
        two.extend(read);
        two.extend([0, 2, 0, 0, 0, 2, 1, 0x55]); // unknown function: exception 01
        two.extend([0, 3, 9, 9, 0, 6, 1, 3, 0, 0, 0, 1]); // not Modbus TCP: closes
        two.extend(read);
        let out = answer_tcp_bytes(&cfg, "mb", &two).unwrap();
        let answer = [0, 1, 0, 0, 0, 5, 1, 3, 2, 0, 7];
        let mut expected = answer.to_vec();
        expected.extend(answer);
        expected.extend([0, 2, 0, 0, 0, 3, 1, 0xD5, 1]);
        assert_eq!(out, expected);
    }
}
