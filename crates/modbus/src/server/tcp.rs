//! Modbus TCP: the listener and one task per connection. The MBAP framing is ours rather
//! than tokio-modbus's because its codec turns a malformed PDU into a connection error (so a
//! short request could not get exception 03) and has no idle timeout; here every complete ADU
//! in what one read returned is answered, in order, in one write, with one lock of the image.

use std::net::SocketAddr;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::Duration;

use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};
use tokio::runtime::Handle;
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

/// Accepts connections and hands them to the `runtimes` in turn (each a single thread), where
/// each is served by one task for its whole life.
pub(super) async fn serve(listener: TcpListener, shared: Arc<Shared>, runtimes: Vec<Handle>) {
    let mut turn = 0usize;
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
        let clients = shared.clients.load(Ordering::Relaxed);
        if clients >= shared.max_clients {
            log::warn!(
                "modbus_server {}: refused {peer}: {clients} clients already connected \
                 (max_clients = {})",
                shared.name,
                shared.max_clients
            );
            drop(stream);
            continue;
        }
        shared.clients.fetch_add(1, Ordering::Relaxed);
        log::debug!("modbus_server {}: client {peer} connected", shared.name);
        let shared = shared.clone();
        let guard = ClientGuard(shared);
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
                Ok(stream) => connection(stream, peer, &guard.0).await,
                Err(e) => log::warn!("modbus_server {}: {peer}: {e}", guard.0.name),
            }
        });
        turn = turn.wrapping_add(1);
    }
}

/// Counts the connection down however its task ends.
struct ClientGuard(Arc<Shared>);

impl Drop for ClientGuard {
    fn drop(&mut self) {
        self.0.clients.fetch_sub(1, Ordering::Relaxed);
    }
}

async fn connection(mut stream: TcpStream, peer: SocketAddr, shared: &Shared) {
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
    loop {
        let n = tokio::select! {
            biased;
            r = stream.read(&mut buf[filled..]) => r,
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
