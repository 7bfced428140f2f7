//! Modbus TCP: each network thread runs its own event loop (mio: one epoll set) over the
//! connections given to it; the first one also accepts. The MBAP framing is ours rather than
//! tokio-modbus's because its codec turns a malformed PDU into a connection error (so a short
//! request could not get exception 03) and has no idle timeout; here every complete ADU in
//! what one read returned is answered, in order, in one write, with one lock of the image.
//!
//! Why not tokio: the loop does per request one `recv`, and per turn one `epoll_wait` and one
//! io_uring submission of the turn's answers ([`write_answers`]), with no task to wake, no
//! timer to arm and no clock to read per request. With
//! tokio's single-threaded runtime the same server spent three times the user time per
//! request (docs/modbus.md, Performance). The serial RTU slave, one port and one request at a
//! time, stays on tokio.
//!
//! After a request a thread keeps polling its sockets for `busy_poll` before it sleeps (see
//! [`run`]). Idle timeouts and stuck writes are found by a sweep every
//! [`SWEEP`].
//!
//! At `max_clients`, a new connection takes the place of the connection idle the longest, if
//! it has been idle [`EVICT_IDLE`] or more: idle connections must not lock active clients out
//! until their idle timeout. Only when every connection is busy is the newcomer refused; the
//! first refusal is logged with the limit, later ones are counted and logged every
//! [`REFUSALS_EVERY`].

use std::io::{ErrorKind, Read, Write};
use std::net::SocketAddr;
use std::os::fd::AsRawFd;
use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use mio::net::{TcpListener, TcpStream};
use mio::{Events, Interest, Poll, Token, Waker};

use super::pdu;
use super::sends::Sends;
use super::Shared;

/// MBAP header: transaction id, protocol id, length, unit id.
const HEADER: usize = 7;
/// The largest ADU: a 253-byte PDU after the header.
const MAX_ADU: usize = 260;
/// Enough for a burst of pipelined requests per read; always room for one whole ADU after
/// the unfinished one is moved to the front.
const BUFFER: usize = 4096;

/// At `max_clients`, a connection idle this long (or its idle timeout, if shorter) gives way
/// to a new one.
pub(super) const EVICT_IDLE: Duration = Duration::from_secs(1);
/// Refusals after the first are logged at most this often, as a count.
pub(super) const REFUSALS_EVERY: Duration = Duration::from_secs(10);
/// How often a loop looks for connections past their idle timeout (and, after an accept
/// error such as running out of file descriptors, tries to accept again).
const SWEEP: Duration = Duration::from_millis(50);

const LISTENER: Token = Token(0);
const WAKER: Token = Token(1);
/// Connection tokens are slots of [`Slots`] from here on.
const FIRST_CLIENT: usize = 2;

/// What the listener knows of one open connection.
struct Conn {
    /// When it last served a request, in ms since the server started.
    last_ms: AtomicU64,
    closed: AtomicBool,
    /// Set by the listener to make room for a new connection; the owning loop closes it.
    evict: AtomicBool,
}

/// A network thread's side that other threads use: connections handed to it, and its waker.
pub(super) struct Door {
    waker: Waker,
    inbox: Mutex<Vec<(TcpStream, SocketAddr, Arc<Conn>)>>,
}

/// One network thread's event loop, made on the starting thread so that failures to create
/// it stop the PLC's start with a message.
pub(super) struct Loop {
    poll: Poll,
    door: Arc<Door>,
}

impl Loop {
    pub(super) fn new() -> std::io::Result<Loop> {
        let poll = Poll::new()?;
        let waker = Waker::new(poll.registry(), WAKER)?;
        Ok(Loop {
            poll,
            door: Arc::new(Door {
                waker,
                inbox: Mutex::new(Vec::new()),
            }),
        })
    }

    pub(super) fn door(&self) -> Arc<Door> {
        self.door.clone()
    }
}

/// Stops every loop: set the flag, then wake them.
pub(super) fn stop(flag: &AtomicBool, doors: &[Arc<Door>]) {
    flag.store(true, Ordering::SeqCst);
    for d in doors {
        let _ = d.waker.wake();
    }
}

/// What the first loop does besides serving: accept and share out connections.
pub(super) struct Acceptor {
    pub listener: TcpListener,
    /// Every loop's door, its own first; connections are given to them in turn.
    pub doors: Vec<Arc<Door>>,
}

/// State of accepting, on the first loop only.
struct Accepting {
    listener: TcpListener,
    doors: Vec<Arc<Door>>,
    turn: usize,
    conns: Vec<Arc<Conn>>,
    refusals: Refusals,
    evict_after_ms: u64,
    /// After an accept error: when to try again.
    retry_at: Option<Instant>,
}

/// One open connection, owned by one loop.
struct Client {
    stream: TcpStream,
    peer: SocketAddr,
    conn: Arc<Conn>,
    buf: Box<[u8; BUFFER]>,
    filled: usize,
    /// Answers not yet written, from `out[sent..]`.
    out: Vec<u8>,
    sent: usize,
    /// Since when the client has not taken the answers written to it.
    stuck_since: Option<Instant>,
}

/// A loop's connections, by token slot; the free slots are used again.
#[derive(Default)]
struct Slots {
    clients: Vec<Option<Client>>,
    free: Vec<usize>,
}

impl Slots {
    fn is_empty(&self) -> bool {
        self.free.len() == self.clients.len()
    }
}

/// Why a connection ends, for the log.
enum Close {
    /// The client closed it.
    Gone,
    /// Logged at info, with the peer.
    Info(String),
    /// Logged at debug, with the peer (the connection failed).
    Debug(String),
    /// The server's code panicked serving it: logged as an error.
    Failed(String),
}

/// The message of a caught panic.
fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| p.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic".into())
}

/// How a loop serves, from the section's settings.
#[derive(Clone, Copy)]
pub(super) struct Options {
    pub busy_poll: Option<Duration>,
    pub io_uring: bool,
}

/// Runs one network thread's loop until `stop`. `accept` is the first loop's listener.
///
/// `busy_poll`: a thread that sleeps as soon as its sockets are quiet must be woken by the
/// kernel for the next request. On a loaded machine, and in virtual machines where waking a
/// CPU is an interrupt through the hypervisor, that wake-up costs more than the answer. So
/// for `busy_poll` after the last request the loop asks for ready sockets without blocking.
/// With one client that halves the round trip (docs/modbus.md, Performance).
pub(super) fn run(
    mut lp: Loop,
    accept: Option<Acceptor>,
    shared: Arc<Shared>,
    options: Options,
    start: Instant,
    stop: Arc<AtomicBool>,
) {
    let name = shared.name.clone();
    let busy_poll = options.busy_poll;
    let mut sends = if options.io_uring {
        match Sends::new() {
            Ok(s) => Some(s),
            Err(e) => {
                log::info!(
                    "modbus_server {name}: io_uring unavailable ({e}); answers are written \
                     with one send each"
                );
                None
            }
        }
    } else {
        None
    };
    let mut accepting = accept.map(|a| Accepting {
        listener: a.listener,
        doors: a.doors,
        turn: 0,
        conns: Vec::new(),
        refusals: Refusals::default(),
        evict_after_ms: shared
            .idle
            .map_or(EVICT_IDLE, |i| i.min(EVICT_IDLE))
            .as_millis() as u64,
        retry_at: None,
    });
    if let Some(a) = &mut accepting {
        if let Err(e) = lp
            .poll
            .registry()
            .register(&mut a.listener, LISTENER, Interest::READABLE)
        {
            log::error!("modbus_server {name}: cannot wait for connections: {e}");
            return;
        }
    }
    let mut slots = Slots::default();
    let mut events = Events::with_capacity(64);
    let mut to_write: Vec<usize> = Vec::new();
    let mut last_served = start;
    let mut next_sweep = Instant::now() + SWEEP;
    let now_ms = |t: Instant| t.saturating_duration_since(start).as_millis() as u64;
    while !stop.load(Ordering::Relaxed) {
        let now = Instant::now();
        // Busy polling: ask without blocking while requests came within the window.
        let timeout = match busy_poll {
            Some(w) if now.duration_since(last_served) < w => Some(Duration::ZERO),
            // Nothing to sweep and no accept to retry: sleep until an event.
            _ if slots.is_empty() && accepting.as_ref().is_none_or(|a| a.retry_at.is_none()) => {
                None
            }
            _ => Some(next_sweep.saturating_duration_since(now)),
        };
        if let Err(e) = lp.poll.poll(&mut events, timeout) {
            if e.kind() == ErrorKind::Interrupted {
                continue;
            }
            log::error!("modbus_server {name}: waiting for the network failed: {e}");
            break;
        }
        let now = Instant::now();
        let mut served_any = false;
        to_write.clear();
        for ev in events.iter() {
            match ev.token() {
                LISTENER => {
                    if let Some(a) = &mut accepting {
                        accept_all(a, &shared, &lp, &mut slots, now_ms(now));
                    }
                }
                WAKER => {
                    take_inbox(&lp, &shared, &mut slots);
                    for slot in 0..slots.clients.len() {
                        let evicted = slots.clients[slot]
                            .as_ref()
                            .is_some_and(|c| c.conn.evict.load(Ordering::Relaxed));
                        if evicted {
                            let why = format!(
                                "the connection idle the longest, closed to make room for a \
                                 new one (max_clients = {})",
                                shared.max_clients
                            );
                            drop_client(&lp, &shared, &mut slots, slot, Close::Info(why));
                        }
                    }
                }
                Token(t) => {
                    let slot = t - FIRST_CLIENT;
                    let Some(Some(c)) = slots.clients.get_mut(slot) else {
                        continue;
                    };
                    // A request that makes the server's code panic (a bug) closes its own
                    // connection only, as a failed task did on tokio; the image's lock
                    // survives poisoning.
                    let outcome = panic::catch_unwind(AssertUnwindSafe(|| {
                        if ev.is_writable() && c.sent < c.out.len() {
                            flush(c, now)?;
                        }
                        // With answers still unwritten, the requests wait: a client that does
                        // not read its answers gets no more of them.
                        if c.sent < c.out.len() {
                            return Ok(0);
                        }
                        // A client that sent its last requests and closed its side may have
                        // done both before this read: no further event would come for the
                        // end of file, so such a socket is read until it says so.
                        let to_the_end = ev.is_read_closed() || ev.is_error();
                        serve(c, &shared, to_the_end, now, now_ms(now))
                    }))
                    .unwrap_or_else(|p| Err(Close::Failed(panic_text(p.as_ref()))));
                    match outcome {
                        Ok(n) => {
                            served_any |= n > 0;
                            if n > 0 && !c.out.is_empty() {
                                to_write.push(slot);
                            }
                        }
                        Err(why) => drop_client(&lp, &shared, &mut slots, slot, why),
                    }
                }
            }
        }
        write_answers(&mut sends, &lp, &shared, &mut slots, &to_write, now);
        if served_any {
            last_served = now;
        }
        if now >= next_sweep {
            next_sweep = now + SWEEP;
            sweep(&lp, &shared, &mut slots, now, now_ms(now));
            if let Some(a) = &mut accepting {
                if a.retry_at.is_some_and(|t| now >= t) {
                    a.retry_at = None;
                    accept_all(a, &shared, &lp, &mut slots, now_ms(now));
                }
            }
        }
    }
    // Stopping: the connections close as their clients are dropped.
    for c in slots.clients.into_iter().flatten() {
        gone(&shared, &c.conn);
    }
    log::debug!("modbus_server {name}: network thread stops");
}

impl Client {
    /// Whether its answers of this turn wait for their first write.
    fn answers_waiting(&self) -> bool {
        self.sent == 0 && !self.out.is_empty() && self.stuck_since.is_none()
    }
}

/// Writes the answers of a turn to the connections `to_write`: together, after every ready
/// socket was read, in one system call where io_uring is there (see `sends`); else, or for
/// what it did not send, with one `send` each.
fn write_answers(
    sends: &mut Option<Sends>,
    lp: &Loop,
    shared: &Shared,
    slots: &mut Slots,
    to_write: &[usize],
    now: Instant,
) {
    if let Some(s) = sends {
        let batch = to_write.iter().filter_map(|&slot| {
            let c = slots.clients.get(slot)?.as_ref()?;
            c.answers_waiting()
                .then(|| (slot, c.stream.as_raw_fd(), c.out.as_slice()))
        });
        match s.send(batch) {
            Ok(results) => {
                for &(slot, ref r) in results {
                    let Some(Some(c)) = slots.clients.get_mut(slot) else {
                        continue;
                    };
                    let outcome = match r {
                        Ok(n) => {
                            // The rest of a partial send, if any, goes out (or waits) as a
                            // plain write would.
                            c.sent = *n;
                            flush(c, now)
                        }
                        Err(e) if e.kind() == ErrorKind::WouldBlock => {
                            c.stuck_since.get_or_insert(now);
                            Ok(())
                        }
                        Err(e) if e.kind() == ErrorKind::Interrupted => flush(c, now),
                        Err(e) => Err(Close::Info(e.to_string())),
                    };
                    if let Err(why) = outcome {
                        drop_client(lp, shared, slots, slot, why);
                    }
                }
            }
            Err(e) => {
                log::warn!(
                    "modbus_server {}: io_uring failed ({e}); answers are written with one \
                     send each from now on",
                    shared.name
                );
                *sends = None;
            }
        }
    }
    for &slot in to_write {
        let Some(Some(c)) = slots.clients.get_mut(slot) else {
            continue;
        };
        if c.answers_waiting() {
            if let Err(why) = flush(c, now) {
                drop_client(lp, shared, slots, slot, why);
            }
        }
    }
}

/// Accepts every pending connection and gives each to a loop in turn.
fn accept_all(a: &mut Accepting, shared: &Arc<Shared>, lp: &Loop, slots: &mut Slots, now_ms: u64) {
    loop {
        let (stream, peer) = match a.listener.accept() {
            Ok(c) => c,
            Err(e) if e.kind() == ErrorKind::WouldBlock => return,
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => {
                // Out of file descriptors, typically: try again after a while (the listener
                // reports no new readiness for connections already waiting).
                log::warn!("modbus_server {}: accept failed: {e}", shared.name);
                a.retry_at = Some(Instant::now() + Duration::from_millis(100));
                return;
            }
        };
        a.conns.retain(|c| !c.closed.load(Ordering::Relaxed));
        if a.conns.len() >= shared.max_clients {
            let idlest = a
                .conns
                .iter()
                .enumerate()
                .map(|(i, c)| (now_ms.saturating_sub(c.last_ms.load(Ordering::Relaxed)), i))
                .max();
            match idlest {
                Some((idle, i)) if idle >= a.evict_after_ms => {
                    let c = a.conns.swap_remove(i);
                    c.closed.store(true, Ordering::Relaxed);
                    c.evict.store(true, Ordering::Relaxed);
                    // Its loop closes it; this loop's own are looked at when its waker fires.
                    for d in &a.doors {
                        let _ = d.waker.wake();
                    }
                }
                _ => {
                    if let Some(line) = a.refusals.refused(Instant::now(), shared.max_clients) {
                        log::warn!("modbus_server {}: refused {peer}: {line}", shared.name);
                    }
                    drop(stream);
                    continue;
                }
            }
        }
        if let Some(line) = a.refusals.accepted() {
            log::warn!("modbus_server {}: {line}", shared.name);
        }
        shared.clients.fetch_add(1, Ordering::Relaxed);
        log::debug!("modbus_server {}: client {peer} connected", shared.name);
        let conn = Arc::new(Conn {
            last_ms: AtomicU64::new(now_ms),
            closed: AtomicBool::new(false),
            evict: AtomicBool::new(false),
        });
        a.conns.push(conn.clone());
        let door = &a.doors[a.turn % a.doors.len()];
        a.turn = a.turn.wrapping_add(1);
        if Arc::ptr_eq(door, &lp.door) {
            add_client(lp, shared, slots, stream, peer, conn);
        } else {
            door.inbox
                .lock()
                .unwrap_or_else(PoisonError::into_inner)
                .push((stream, peer, conn));
            let _ = door.waker.wake();
        }
    }
}

/// Takes the connections other threads handed to this loop.
fn take_inbox(lp: &Loop, shared: &Shared, slots: &mut Slots) {
    let handed = std::mem::take(&mut *lp.door.inbox.lock().unwrap_or_else(PoisonError::into_inner));
    for (stream, peer, conn) in handed {
        add_client(lp, shared, slots, stream, peer, conn);
    }
}

fn add_client(
    lp: &Loop,
    shared: &Shared,
    slots: &mut Slots,
    mut stream: TcpStream,
    peer: SocketAddr,
    conn: Arc<Conn>,
) {
    let name = &shared.name;
    if let Err(e) = stream.set_nodelay(true) {
        log::debug!("modbus_server {name}: {peer}: TCP_NODELAY not set: {e}");
    }
    let slot = slots.free.pop().unwrap_or_else(|| {
        slots.clients.push(None);
        slots.clients.len() - 1
    });
    // Edge-triggered: a read that returns less than it had room for emptied the socket, and
    // the next bytes bring a new event.
    if let Err(e) = lp.poll.registry().register(
        &mut stream,
        Token(slot + FIRST_CLIENT),
        Interest::READABLE | Interest::WRITABLE,
    ) {
        log::warn!("modbus_server {name}: {peer}: cannot wait for its requests: {e}");
        slots.free.push(slot);
        gone(shared, &conn);
        return;
    }
    slots.clients[slot] = Some(Client {
        stream,
        peer,
        conn,
        buf: Box::new([0; BUFFER]),
        filled: 0,
        out: Vec::with_capacity(BUFFER),
        sent: 0,
        stuck_since: None,
    });
}

/// A connection is over: counted down, and the listener no longer counts it.
fn gone(shared: &Shared, conn: &Conn) {
    conn.closed.store(true, Ordering::Relaxed);
    shared.clients.fetch_sub(1, Ordering::Relaxed);
}

fn drop_client(lp: &Loop, shared: &Shared, slots: &mut Slots, slot: usize, why: Close) {
    let Some(mut c) = slots.clients[slot].take() else {
        return;
    };
    let name = &shared.name;
    let peer = c.peer;
    match why {
        Close::Gone => log::debug!("modbus_server {name}: client {peer} disconnected"),
        Close::Info(why) => log::info!("modbus_server {name}: closing {peer}: {why}"),
        Close::Debug(why) => log::debug!("modbus_server {name}: {peer}: {why}"),
        Close::Failed(why) => log::error!(
            "modbus_server {name}: closing {peer}: serving it failed ({why}); other \
             connections are served on"
        ),
    }
    let _ = lp.poll.registry().deregister(&mut c.stream);
    gone(shared, &c.conn);
    slots.free.push(slot);
}

/// Reads and answers until the socket is empty (or an answer cannot be written at once):
/// the number of requests served. A read that returns less than it had room for emptied
/// the socket, unless `to_the_end` (its end of file or error has come): then it is read
/// until it says so.
fn serve(
    c: &mut Client,
    shared: &Shared,
    to_the_end: bool,
    now: Instant,
    now_ms: u64,
) -> Result<u64, Close> {
    let mut served = 0;
    loop {
        let space = BUFFER - c.filled;
        let n = match c.stream.read(&mut c.buf[c.filled..]) {
            Ok(0) => return Err(Close::Gone),
            Ok(n) => n,
            Err(e) if e.kind() == ErrorKind::WouldBlock => return Ok(served),
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => return Err(Close::Debug(e.to_string())),
        };
        c.filled += n;
        let batch = answer(&c.buf[..c.filled], shared, &mut c.out);
        if batch.served > 0 {
            served += batch.served;
            c.conn.last_ms.store(now_ms, Ordering::Relaxed);
        }
        c.buf.copy_within(batch.used..c.filled, 0);
        c.filled -= batch.used;
        if let Some(why) = batch.close {
            flush(c, now)?;
            return Err(Close::Info(why));
        }
        debug_assert!(BUFFER - c.filled >= MAX_ADU);
        if n < space && !to_the_end {
            // Emptied: the next request brings a new event. The answers are written after
            // the other ready sockets are read (see `run`).
            return Ok(served);
        }
        if !c.out.is_empty() {
            flush(c, now)?;
            if c.sent < c.out.len() {
                return Ok(served);
            }
        }
    }
}

/// Writes what it can of the unwritten answers; what the socket does not take waits for the
/// socket's next writable event.
fn flush(c: &mut Client, now: Instant) -> Result<(), Close> {
    while c.sent < c.out.len() {
        match c.stream.write(&c.out[c.sent..]) {
            Ok(0) => return Err(Close::Debug("the connection takes no more bytes".into())),
            Ok(n) => c.sent += n,
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                c.stuck_since.get_or_insert(now);
                return Ok(());
            }
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(e) => return Err(Close::Info(e.to_string())),
        }
    }
    c.out.clear();
    c.sent = 0;
    c.stuck_since = None;
    Ok(())
}

/// Closes the connections past their idle timeout (by the time of their last request, which
/// the listener reads too), and those whose client has taken no answer for that long.
fn sweep(lp: &Loop, shared: &Shared, slots: &mut Slots, now: Instant, now_ms: u64) {
    let Some(idle) = shared.idle else { return };
    let idle_ms = idle.as_millis() as u64;
    for slot in 0..slots.clients.len() {
        let Some(c) = &slots.clients[slot] else {
            continue;
        };
        let why = if c.stuck_since.is_some_and(|t| now.duration_since(t) >= idle) {
            "the client reads no responses (idle_timeout)".to_string()
        } else if c.stuck_since.is_none()
            && now_ms.saturating_sub(c.conn.last_ms.load(Ordering::Relaxed)) >= idle_ms
        {
            format!("no request for {} s (idle_timeout)", idle.as_secs_f64())
        } else {
            continue;
        };
        drop_client(lp, shared, slots, slot, Close::Info(why));
    }
}

/// The log of refused connections: the first of a run of refusals says the limit, the next
/// ones are counted and told every [`REFUSALS_EVERY`], and the run's last count when a
/// connection is accepted again.
#[derive(Debug, Default)]
pub(super) struct Refusals {
    /// When the current run of refusals was last logged; `None`: not refusing.
    logged: Option<Instant>,
    /// Refusals since then.
    count: u64,
}

impl Refusals {
    /// A connection was refused at `now`: the line to log, if any.
    pub(super) fn refused(&mut self, now: Instant, max_clients: usize) -> Option<String> {
        match self.logged {
            None => {
                self.logged = Some(now);
                self.count = 0;
                Some(format!(
                    "max_clients = {max_clients} connections are open and none has been idle \
                     for {} s; new connections are refused until one closes (further \
                     refusals are counted, logged every {} s)",
                    EVICT_IDLE.as_secs(),
                    REFUSALS_EVERY.as_secs()
                ))
            }
            Some(at) => {
                self.count += 1;
                if now.duration_since(at) < REFUSALS_EVERY {
                    return None;
                }
                self.logged = Some(now);
                Some(format!(
                    "{} more connections refused in the last {} s (max_clients)",
                    std::mem::take(&mut self.count),
                    now.duration_since(at).as_secs()
                ))
            }
        }
    }

    /// A connection was accepted: the count of the run of refusals it ends, if not logged.
    pub(super) fn accepted(&mut self) -> Option<String> {
        self.logged.take()?;
        let n = std::mem::take(&mut self.count);
        (n > 0).then(|| format!("{n} more connections were refused (max_clients)"))
    }
}

/// What [`answer`] did with a read's bytes.
pub(super) struct Batch {
    /// Bytes consumed (whole ADUs).
    pub used: usize,
    served: u64,
    /// A header that is not Modbus TCP: the connection is closed after the answers so far.
    pub close: Option<String>,
}

/// Answers every complete ADU at the start of `buf` into `out`, under one lock of the image.
pub(super) fn answer(buf: &[u8], shared: &Shared, out: &mut Vec<u8>) -> Batch {
    let mut pos = 0;
    let mut image = None;
    let mut served = 0u64;
    let mut exceptions = 0u64;
    let close = loop {
        let rest = &buf[pos..];
        if rest.len() < 6 {
            break None;
        }
        let protocol = u16::from_be_bytes([rest[2], rest[3]]);
        let length = u16::from_be_bytes([rest[4], rest[5]]);
        if protocol != 0 {
            break Some(format!(
                "protocol id {protocol} in an MBAP header (Modbus TCP is 0)"
            ));
        }
        if !(2..=254).contains(&length) {
            break Some(format!("MBAP length {length} (must be 2 to 254)"));
        }
        let total = 6 + usize::from(length);
        if rest.len() < total {
            break None;
        }
        let image = image.get_or_insert_with(|| shared.lock());
        let start = out.len();
        out.extend_from_slice(&rest[..HEADER]);
        let request = &rest[HEADER..total];
        let outcome = pdu::respond(&shared.map, image, request, out);
        if shared.outcome(image, request, outcome) {
            exceptions += 1;
        }
        let length = (out.len() - start - 6) as u16;
        out[start + 4..start + 6].copy_from_slice(&length.to_be_bytes());
        served += 1;
        pos += total;
    };
    drop(image);
    if served > 0 {
        shared.requests.fetch_add(served, Ordering::Relaxed);
    }
    if exceptions > 0 {
        shared.exceptions.fetch_add(exceptions, Ordering::Relaxed);
    }
    Batch {
        used: pos,
        served,
        close,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Refusals at the given seconds (after the first), then an accept: the lines logged.
    fn check(refused_at: &[f64], expect: &[&str]) {
        let t0 = Instant::now();
        let mut r = Refusals::default();
        let mut got: Vec<String> = refused_at
            .iter()
            .filter_map(|&s| r.refused(t0 + Duration::from_secs_f64(s), 4))
            .collect();
        got.extend(r.accepted());
        let got: Vec<&str> = got.iter().map(|l| l.split(';').next().unwrap()).collect();
        assert_eq!(got, expect);
    }

    #[test]
    fn refusals_are_logged_once_with_the_limit_then_counted() {
        check(&[], &[]);
        check(
            &[0.0],
            &["max_clients = 4 connections are open and none has been idle for 1 s"],
        );
        // Hundreds in a second: one line, and the count when a client gets in again.
        let burst: Vec<f64> = (0..300).map(|i| f64::from(i) / 300.0).collect();
        check(
            &burst,
            &[
                "max_clients = 4 connections are open and none has been idle for 1 s",
                "299 more connections were refused (max_clients)",
            ],
        );
        check(
            &[0.0, 1.0, 5.0, 10.5, 11.0],
            &[
                "max_clients = 4 connections are open and none has been idle for 1 s",
                "3 more connections refused in the last 10 s (max_clients)",
                "1 more connections were refused (max_clients)",
            ],
        );
    }
}
