//! Modbus TCP: the listener and one task per connection. The MBAP framing is ours rather
//! than tokio-modbus's because its codec turns a malformed PDU into a connection error (so a
//! short request could not get exception 03) and has no idle timeout; here every complete ADU
//! in what one read returned is answered, in order, in one write, with one lock of the image.
//!
//! At `max_clients`, a new connection takes the place of the connection idle the longest, if
//! it has been idle [`EVICT_IDLE`] or more: idle connections must not lock active clients out
//! until their idle timeout. Only when every connection is busy is the newcomer refused; the
//! first refusal is logged with the limit, later ones are counted and logged every
//! [`REFUSALS_EVERY`].

use std::net::SocketAddr;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Duration;

use std::io::Read;

use socket2::SockRef;
use tokio::io::{AsyncWriteExt, Interest};
use tokio::net::{TcpListener, TcpStream};
use tokio::runtime::Handle;
use tokio::sync::Notify;
use tokio::time::Instant;

use super::pdu;
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

/// What the listener knows of one open connection.
struct Conn {
    /// When it last served a request, in ms since the listener started.
    last_ms: AtomicU64,
    closed: AtomicBool,
    evict: Notify,
}

/// Accepts connections and hands them to the `runtimes` in turn (each a single thread), where
/// each is served by one task for its whole life.
pub(super) async fn serve(listener: TcpListener, shared: Arc<Shared>, runtimes: Vec<Handle>) {
    let mut turn = 0usize;
    let start = Instant::now();
    let now_ms = move || start.elapsed().as_millis() as u64;
    let evict_after = shared.idle.map_or(EVICT_IDLE, |i| i.min(EVICT_IDLE));
    let mut conns: Vec<Arc<Conn>> = Vec::new();
    let mut refusals = Refusals::default();
    loop {
        let (stream, peer) = match listener.accept().await {
            Ok(c) => c,
            Err(e) => {
                // Out of file descriptors, typically: wait for connections to close.
                log::warn!("modbus_server {}: accept failed: {e}", shared.name);
                tokio::time::sleep(Duration::from_millis(100)).await;
                continue;
            }
        };
        conns.retain(|c| !c.closed.load(Ordering::Relaxed));
        if conns.len() >= shared.max_clients {
            let now = now_ms();
            let idlest = conns
                .iter()
                .enumerate()
                .map(|(i, c)| (now.saturating_sub(c.last_ms.load(Ordering::Relaxed)), i))
                .max();
            match idlest {
                Some((idle, i)) if idle >= evict_after.as_millis() as u64 => {
                    let c = conns.swap_remove(i);
                    c.closed.store(true, Ordering::Relaxed);
                    c.evict.notify_one();
                }
                _ => {
                    if let Some(line) = refusals.refused(Instant::now(), shared.max_clients) {
                        log::warn!("modbus_server {}: refused {peer}: {line}", shared.name);
                    }
                    drop(stream);
                    continue;
                }
            }
        }
        if let Some(line) = refusals.accepted() {
            log::warn!("modbus_server {}: {line}", shared.name);
        }
        shared.clients.fetch_add(1, Ordering::Relaxed);
        log::debug!("modbus_server {}: client {peer} connected", shared.name);
        let conn = Arc::new(Conn {
            last_ms: AtomicU64::new(now_ms()),
            closed: AtomicBool::new(false),
            evict: Notify::new(),
        });
        conns.push(conn.clone());
        let guard = ClientGuard(shared.clone(), conn);
        // The socket is registered again with the reactor of the runtime that serves it, so
        // its readiness wakes that thread only.
        let stream = match stream.into_std() {
            Ok(s) => s,
            Err(e) => {
                log::warn!("modbus_server {}: {peer}: {e}", guard.0.name);
                continue;
            }
        };
        runtimes[turn % runtimes.len()].spawn(async move {
            match TcpStream::from_std(stream) {
                Ok(stream) => connection(stream, peer, &guard.0, &guard.1, now_ms).await,
                Err(e) => log::warn!("modbus_server {}: {peer}: {e}", guard.0.name),
            }
        });
        turn = turn.wrapping_add(1);
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

/// Counts the connection down however its task ends.
struct ClientGuard(Arc<Shared>, Arc<Conn>);

impl Drop for ClientGuard {
    fn drop(&mut self) {
        self.1.closed.store(true, Ordering::Relaxed);
        self.0.clients.fetch_sub(1, Ordering::Relaxed);
    }
}

async fn connection(
    mut stream: TcpStream,
    peer: SocketAddr,
    shared: &Shared,
    conn: &Conn,
    now_ms: impl Fn() -> u64,
) {
    let name = &shared.name;
    if let Err(e) = stream.set_nodelay(true) {
        log::debug!("modbus_server {name}: {peer}: TCP_NODELAY not set: {e}");
    }
    let mut buf = vec![0u8; BUFFER];
    let mut filled = 0usize;
    let mut out: Vec<u8> = Vec::with_capacity(BUFFER);
    // The idle timer fires at most once per idle period: it is pushed back lazily from the
    // time of the last request instead of being re-armed on every one.
    let idle = shared.idle;
    let mut last_request = Instant::now();
    let far = Duration::from_secs(86400 * 365);
    let timer = tokio::time::sleep(idle.unwrap_or(far));
    tokio::pin!(timer);
    // Registered once for the connection's life, not once per request.
    let evicted = conn.evict.notified();
    tokio::pin!(evicted);
    loop {
        let n = tokio::select! {
            biased;
            () = &mut evicted => {
                log::info!(
                    "modbus_server {name}: closing {peer}, the connection idle the longest, \
                     to make room for a new one (max_clients = {})",
                    shared.max_clients
                );
                return;
            }
            r = read_some(&stream, &mut buf[filled..]) => r,
            () = &mut timer => {
                let Some(idle) = idle else {
                    timer.as_mut().reset(Instant::now() + far);
                    continue;
                };
                let due = last_request + idle;
                if Instant::now() >= due {
                    log::info!(
                        "modbus_server {name}: closing {peer}: no request for {} s (idle_timeout)",
                        idle.as_secs_f64()
                    );
                    return;
                }
                timer.as_mut().reset(due);
                continue;
            }
        };
        let n = match n {
            Ok(0) => {
                log::debug!("modbus_server {name}: client {peer} disconnected");
                return;
            }
            Ok(n) => n,
            Err(e) => {
                log::debug!("modbus_server {name}: {peer}: {e}");
                return;
            }
        };
        filled += n;
        let batch = answer(&buf[..filled], shared, &mut out);
        if batch.served > 0 {
            last_request = Instant::now();
            conn.last_ms.store(now_ms(), Ordering::Relaxed);
        }
        buf.copy_within(batch.used..filled, 0);
        filled -= batch.used;
        if !out.is_empty() {
            let write = stream.write_all(&out);
            let written = match idle {
                Some(idle) => tokio::time::timeout(idle, write).await.unwrap_or_else(|_| {
                    Err(std::io::Error::new(
                        std::io::ErrorKind::TimedOut,
                        "the client reads no responses (idle_timeout)",
                    ))
                }),
                None => write.await,
            };
            out.clear();
            if let Err(e) = written {
                log::info!("modbus_server {name}: closing {peer}: {e}");
                return;
            }
        }
        if let Some(why) = batch.close {
            log::info!("modbus_server {name}: closing {peer}: {why}");
            return;
        }
        debug_assert!(BUFFER - filled >= MAX_ADU);
    }
}

/// One read once the socket is readable. A read that returns less than the space drained
/// the socket, so its readiness is cleared there and then (tokio clears it only if no event
/// came since it was observed): the next wait goes straight to the reactor instead of first
/// costing a read that fails with WouldBlock, one system call per request less.
async fn read_some(stream: &TcpStream, buf: &mut [u8]) -> std::io::Result<usize> {
    let space = buf.len();
    loop {
        stream.readable().await?;
        let mut got = 0;
        let r = stream.try_io(Interest::READABLE, || {
            let n = (&*SockRef::from(stream)).read(buf)?;
            got = n;
            if n > 0 && n < space {
                Err(std::io::ErrorKind::WouldBlock.into())
            } else {
                Ok(n)
            }
        });
        match r {
            Ok(n) => return Ok(n),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                if got > 0 {
                    return Ok(got);
                }
            }
            Err(e) => return Err(e),
        }
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
        if pdu::respond(&shared.map, image, &rest[HEADER..total], out) {
            exceptions += 1;
            shared.refused(&rest[HEADER..total], out[out.len() - 1]);
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
