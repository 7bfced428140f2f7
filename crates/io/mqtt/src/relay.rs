//! The module's own hop between rumqttc and the broker, so that an oversized message is
//! dropped and counted instead of ending the connection.
//!
//! rumqttc ends the connection on any packet larger than its `max_incoming_packet_size`, and
//! buffers every packet whole before handing it over: a retained 1 MiB message on a
//! subscribed topic made every connection fail right after subscribing, for ever. MQTT 3.1.1
//! cannot ask the broker for a limit (MQTT 5's Maximum Packet Size can, but the broker then
//! drops the message silently: nothing to count or log). So the module connects to the
//! broker itself (TCP, then TLS) and gives rumqttc a Unix socket to it instead: the packets
//! from the broker are read here as a stream, and a PUBLISH whose payload is larger than
//! `max_payload` is passed on as its header with the topic [`CUT`] and no payload (so that
//! rumqttc still acknowledges it at QoS 1) while its payload is skipped in fixed-size reads,
//! never held. Everything else passes through unchanged, in both directions.
//!
//! The Unix socket lives in a folder of the module's own (mode 0700, a random name under the
//! system's temporary folder), made at start and removed at stop (or, after a SIGKILL, by the
//! next start of a PLC of the same user); each connection binds it, takes rumqttc's one
//! connection, and unlinks it.

use std::collections::HashSet;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use rumqttc::tokio_rustls::rustls::pki_types::ServerName;
use rumqttc::tokio_rustls::TlsConnector;
use tokio::io::{AsyncBufReadExt, AsyncRead, AsyncWrite, AsyncWriteExt, BufReader};
use tokio::net::{TcpStream, UnixListener};
use tokio::task::JoinHandle;

use crate::{lock, payload, Shared};

/// The topic an oversized PUBLISH is passed to rumqttc with: a wildcard, which no PUBLISH
/// may carry and no `subscribe` row may name, so the module never takes it for a value.
pub(crate) const CUT: &str = "#";

/// The longest wait for the broker's TCP and TLS handshakes, and for rumqttc to connect.
const CONNECT: Duration = Duration::from_secs(5);

/// The size of the reads from the broker: what the relay holds at most besides one topic.
const CHUNK: usize = 16 * 1024;

/// A topic (65 535 bytes at most), its length and a packet id: what a PUBLISH of an allowed
/// payload adds. rumqttc's own limit is `max_payload` plus this.
pub(crate) const HEADROOM: usize = 2 + 65_535 + 2;

trait Stream: AsyncRead + AsyncWrite + Send + Unpin {}
impl<T: AsyncRead + AsyncWrite + Send + Unpin> Stream for T {}

/// Where the broker is and how to reach it.
pub(crate) struct Relay {
    dir: PathBuf,
    socket: PathBuf,
    host: String,
    port: u16,
    tls: Option<(TlsConnector, ServerName<'static>)>,
    filter: Arc<Filter>,
    /// Why the broker's side of the current connection ended (rumqttc only sees its end).
    ended: Arc<Mutex<Option<String>>>,
    task: Option<JoinHandle<()>>,
}

/// What the stream from the broker is checked against.
pub(crate) struct Filter {
    pub max_payload: usize,
    /// The subscribed topics: an oversized message on one of them is counted and logged.
    pub topics: HashSet<String>,
    pub shared: Arc<Shared>,
}

impl Relay {
    /// Makes the module's private folder for the socket rumqttc connects to (its path goes
    /// into rumqttc's options: [`Relay::socket`]).
    pub fn new(
        host: &str,
        port: u16,
        tls: Option<Arc<rustls::ClientConfig>>,
        filter: Filter,
    ) -> Result<Relay, String> {
        let tls = match tls {
            None => None,
            Some(config) => {
                let name = ServerName::try_from(host.to_string()).map_err(|e| {
                    format!("`broker`: `{host}` cannot be checked against a certificate: {e}")
                })?;
                Some((TlsConnector::from(config), name))
            }
        };
        let dir = private_dir().map_err(|e| {
            format!(
                "cannot make a private folder under {} for the connection to the broker: {e}",
                std::env::temp_dir().display()
            )
        })?;
        Ok(Relay {
            socket: dir.join("broker"),
            dir,
            host: host.to_string(),
            port,
            tls,
            filter: Arc::new(filter),
            ended: Arc::new(Mutex::new(None)),
            task: None,
        })
    }

    /// The Unix socket rumqttc connects to.
    pub fn socket(&self) -> &Path {
        &self.socket
    }

    /// Connects to the broker (TCP, TLS) and binds the socket for rumqttc's next
    /// connection, which a task then relays; an error says why the broker cannot be reached.
    pub async fn open(&mut self) -> Result<(), String> {
        if let Some(old) = self.task.take() {
            old.abort();
        }
        *lock(&self.ended) = None;
        let tcp =
            tokio::time::timeout(CONNECT, TcpStream::connect((self.host.as_str(), self.port)))
                .await
                .map_err(|_| "Network timeout".to_string())?
                .map_err(|e| format!("I/O: {e}"))?;
        // Without it, each QoS 1 publish waits for the previous one's PUBACK (Nagle).
        let _ = tcp.set_nodelay(true);
        let broker: Box<dyn Stream> = match &self.tls {
            None => Box::new(tcp),
            Some((connector, name)) => Box::new(
                tokio::time::timeout(CONNECT, connector.connect(name.clone(), tcp))
                    .await
                    .map_err(|_| "TLS: handshake timeout".to_string())?
                    .map_err(|e| format!("TLS: {e}"))?,
            ),
        };
        let _ = std::fs::remove_file(&self.socket);
        let listener = UnixListener::bind(&self.socket)
            .map_err(|e| format!("cannot listen on {}: {e}", self.socket.display()))?;
        let socket = self.socket.clone();
        let filter = Arc::clone(&self.filter);
        let ended = Arc::clone(&self.ended);
        self.task = Some(tokio::spawn(async move {
            let accepted = tokio::time::timeout(CONNECT, listener.accept()).await;
            let _ = std::fs::remove_file(&socket);
            drop(listener);
            let Ok(Ok((client, _))) = accepted else {
                return;
            };
            let (mut from_client, mut to_client) = client.into_split();
            let (from_broker, mut to_broker) = tokio::io::split(broker);
            let up = async {
                // Until rumqttc closes its end (after a DISCONNECT, or dropping the link):
                // the rest is flushed and the broker's side closed in order.
                let _ = tokio::io::copy(&mut from_client, &mut to_broker).await;
                let _ = to_broker.shutdown().await;
            };
            tokio::select! {
                _ = up => {}
                why = filter.down(from_broker, &mut to_client) => {
                    *lock(&ended) = Some(why);
                }
            }
        }));
        Ok(())
    }

    /// Why the broker's side of the last connection ended, if it did.
    pub fn ended(&self) -> Option<String> {
        lock(&self.ended).clone()
    }

    /// Waits (at most `within`) until the last connection's relay has passed on everything
    /// rumqttc wrote before closing its end.
    pub async fn finish(&mut self, within: Duration) {
        if let Some(task) = self.task.take() {
            let _ = tokio::time::timeout(within, task).await;
        }
    }
}

impl Drop for Relay {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The start of the name of a relay's folder, followed by the PID and a random number.
const DIR_PREFIX: &str = "petriplc-mqtt-";

/// A new folder only this user may enter, with a name nobody can guess ahead of us: a
/// socket in it is reachable by this PLC alone. The folders of this user's PLCs that died
/// without removing theirs (SIGKILL) are removed on the way.
fn private_dir() -> io::Result<PathBuf> {
    use std::io::Read;
    use std::os::unix::fs::DirBuilderExt;
    let mut random = [0u8; 8];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut random)?;
    let tmp = std::env::temp_dir();
    let dir = tmp.join(format!(
        "{DIR_PREFIX}{}-{:016x}",
        std::process::id(),
        u64::from_ne_bytes(random)
    ));
    std::fs::DirBuilder::new().mode(0o700).create(&dir)?;
    remove_dead(&tmp, &dir);
    Ok(dir)
}

/// Removes the relay folders under `tmp` that belong to `ours`' owner and to a process that
/// no longer exists (a PID reused since only delays that).
fn remove_dead(tmp: &Path, ours: &Path) {
    use std::os::unix::fs::MetadataExt;
    let Ok(me) = std::fs::metadata(ours).map(|m| m.uid()) else {
        return;
    };
    let Ok(entries) = std::fs::read_dir(tmp) else {
        return;
    };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(DIR_PREFIX))
            .and_then(|rest| rest.split('-').next())
            .and_then(|pid| pid.parse::<u32>().ok())
        else {
            continue;
        };
        let path = entry.path();
        let mine = std::fs::symlink_metadata(&path).is_ok_and(|m| m.is_dir() && m.uid() == me);
        if mine && !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_dir_all(&path);
        }
    }
}

/// Reads MQTT packets from the broker and writes them on, flushing only when the broker
/// has nothing more for the moment (one write for a burst of small packets).
struct Packets<R, W> {
    from: BufReader<R>,
    to: W,
    unflushed: bool,
}

impl<R: AsyncRead + Unpin, W: AsyncWrite + Unpin> Packets<R, W> {
    /// The next bytes from the broker (flushing what waits before a read that may block).
    async fn fill(&mut self) -> io::Result<&[u8]> {
        if self.from.buffer().is_empty() && self.unflushed {
            self.to.flush().await?;
            self.unflushed = false;
        }
        let got = self.from.fill_buf().await?;
        if got.is_empty() {
            return Err(io::ErrorKind::UnexpectedEof.into());
        }
        Ok(got)
    }

    async fn byte(&mut self) -> io::Result<u8> {
        let b = self.fill().await?[0];
        self.from.consume(1);
        Ok(b)
    }

    async fn exact(&mut self, out: &mut [u8]) -> io::Result<()> {
        let mut at = 0;
        while at < out.len() {
            let got = self.fill().await?;
            let n = got.len().min(out.len() - at);
            out[at..at + n].copy_from_slice(&got[..n]);
            self.from.consume(n);
            at += n;
        }
        Ok(())
    }

    async fn write(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.to.write_all(bytes).await?;
        self.unflushed = true;
        Ok(())
    }

    /// Passes `n` bytes on (`pass`) or skips them, a chunk at a time.
    async fn forward(&mut self, mut n: usize, pass: bool) -> io::Result<()> {
        while n > 0 {
            if self.from.buffer().is_empty() && self.unflushed {
                self.to.flush().await?;
                self.unflushed = false;
            }
            let got = self.from.fill_buf().await?;
            if got.is_empty() {
                return Err(io::ErrorKind::UnexpectedEof.into());
            }
            let k = got.len().min(n);
            if pass {
                self.to.write_all(&got[..k]).await?;
                self.unflushed = true;
            }
            self.from.consume(k);
            n -= k;
        }
        Ok(())
    }

    /// MQTT's remaining length: 1 to 4 bytes, 7 bits each, low first.
    async fn remaining_length(&mut self) -> io::Result<usize> {
        let mut len = 0usize;
        for i in 0..4 {
            let b = self.byte().await?;
            len |= usize::from(b & 0x7f) << (7 * i);
            if b & 0x80 == 0 {
                return Ok(len);
            }
        }
        Err(malformed("a remaining length longer than 4 bytes"))
    }
}

fn malformed(what: &str) -> io::Error {
    io::Error::new(
        io::ErrorKind::InvalidData,
        format!("the broker sent a malformed packet ({what})"),
    )
}

/// MQTT's remaining length as bytes.
fn encode_length(mut n: usize, out: &mut Vec<u8>) {
    loop {
        let mut b = (n % 128) as u8;
        n /= 128;
        if n > 0 {
            b |= 0x80;
        }
        out.push(b);
        if n == 0 {
            return;
        }
    }
}

impl Filter {
    /// Relays the broker's packets to rumqttc until the broker's side ends; returns why.
    pub async fn down<R: AsyncRead + Unpin, W: AsyncWrite + Unpin>(
        &self,
        from: R,
        to: &mut W,
    ) -> String {
        let mut packets = Packets {
            from: BufReader::with_capacity(CHUNK, from),
            to,
            unflushed: false,
        };
        match self.relay(&mut packets).await {
            Ok(()) => unreachable!("relay returns only on errors"),
            Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => {
                "the broker closed the connection".to_string()
            }
            Err(e) if e.kind() == io::ErrorKind::InvalidData => e.to_string(),
            Err(e) => format!("I/O: {e}"),
        }
    }

    async fn relay<R: AsyncRead + Unpin, W: AsyncWrite + Unpin>(
        &self,
        p: &mut Packets<R, W>,
    ) -> io::Result<()> {
        let mut head = Vec::with_capacity(8);
        loop {
            let first = p.byte().await?;
            let len = p.remaining_length().await?;
            head.clear();
            head.push(first);
            if first >> 4 != 3 {
                // Not a PUBLISH: acknowledgements and pings, a few bytes each. rumqttc
                // would end the connection on a larger one; so does the relay, unread.
                if len > self.max_payload + HEADROOM {
                    return Err(malformed(&format!(
                        "a packet of type {} and {len} bytes",
                        first >> 4
                    )));
                }
                encode_length(len, &mut head);
                p.write(&head).await?;
                p.forward(len, true).await?;
                continue;
            }
            let id_len = if (first >> 1) & 3 == 0 { 0 } else { 2 };
            if len < 2 + id_len {
                return Err(malformed("a PUBLISH shorter than its header"));
            }
            let mut topic_len = [0u8; 2];
            p.exact(&mut topic_len).await?;
            let topic_len = usize::from(u16::from_be_bytes(topic_len));
            let Some(size) = len.checked_sub(2 + topic_len + id_len) else {
                return Err(malformed("a PUBLISH topic longer than the packet"));
            };
            // The topic (at most 65 535 bytes) and the packet id, if any.
            let mut rest = vec![0u8; topic_len + id_len];
            p.exact(&mut rest).await?;
            let (topic, id) = rest.split_at(topic_len);
            if size <= self.max_payload {
                encode_length(len, &mut head);
                head.extend_from_slice(&(topic_len as u16).to_be_bytes());
                p.write(&head).await?;
                p.write(&rest).await?;
                p.forward(size, true).await?;
                continue;
            }
            // Oversized: rumqttc gets the header with the topic CUT and no payload (and
            // acknowledges it); the payload is skipped.
            encode_length(2 + CUT.len() + id_len, &mut head);
            head.extend_from_slice(&(CUT.len() as u16).to_be_bytes());
            head.extend_from_slice(CUT.as_bytes());
            head.extend_from_slice(id);
            p.write(&head).await?;
            let topic = String::from_utf8_lossy(topic);
            if self.topics.contains(topic.as_ref()) {
                let shared = &self.shared;
                shared
                    .received
                    .fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                shared.refuse(&topic, || {
                    let max = self.max_payload;
                    format!("a payload {}", payload::Refusal::TooLarge { size, max })
                });
            }
            p.forward(size, false).await?;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::pin::Pin;
    use std::task::{Context, Poll};

    fn filter(max_payload: usize) -> Filter {
        Filter {
            max_payload,
            topics: ["a/b".to_string()].into_iter().collect(),
            shared: Arc::new(Shared::for_tests()),
        }
    }

    fn publish(qos: u8, topic: &str, id: u16, payload: &[u8]) -> Vec<u8> {
        let mut body = (topic.len() as u16).to_be_bytes().to_vec();
        body.extend_from_slice(topic.as_bytes());
        if qos > 0 {
            body.extend_from_slice(&id.to_be_bytes());
        }
        body.extend_from_slice(payload);
        let mut p = vec![0x30 | (qos << 1) | 1];
        encode_length(body.len(), &mut p);
        p.extend(body);
        p
    }

    /// The packets a stream of bytes from the broker becomes, and why the relay stopped.
    async fn relay(f: &Filter, from: impl AsyncRead + Unpin) -> (Vec<u8>, String) {
        let mut out = Vec::new();
        let why = f.down(from, &mut out).await;
        (out, why)
    }

    #[tokio::test(flavor = "current_thread")]
    async fn small_packets_pass_unchanged_and_oversized_ones_lose_their_payload() {
        let f = filter(10);
        let ping = [0xd0u8, 0x00];
        let suback = [0x90u8, 0x03, 0x00, 0x01, 0x01];
        let mut input = Vec::new();
        input.extend(publish(1, "a/b", 7, b"1234567890"));
        input.extend(ping);
        input.extend(publish(1, "a/b", 8, b"12345678901"));
        input.extend(suback);
        input.extend(publish(0, "a/b", 0, &[b'x'; 300]));
        input.extend(publish(0, "other", 0, &[b'x'; 20]));
        let (out, why) = relay(&f, &input[..]).await;
        let mut want = Vec::new();
        want.extend(publish(1, "a/b", 7, b"1234567890"));
        want.extend(ping);
        want.extend(publish(1, CUT, 8, b""));
        want.extend(suback);
        want.extend(publish(0, CUT, 0, b""));
        want.extend(publish(0, CUT, 0, b""));
        assert_eq!(out, want);
        assert_eq!(why, "the broker closed the connection");
        // Counted on subscribed topics only (the broker sends no others).
        let s = &f.shared;
        use std::sync::atomic::Ordering::Relaxed;
        assert_eq!((s.received.load(Relaxed), s.rejected.load(Relaxed)), (2, 2));
    }

    /// A PUBLISH of 200 MiB, made up as it is read, 64 KiB at a time.
    struct Huge {
        head: Vec<u8>,
        left: usize,
    }

    impl AsyncRead for Huge {
        fn poll_read(
            mut self: Pin<&mut Self>,
            _: &mut Context<'_>,
            buf: &mut tokio::io::ReadBuf<'_>,
        ) -> Poll<io::Result<()>> {
            if !self.head.is_empty() {
                let n = self.head.len().min(buf.remaining());
                let head: Vec<u8> = self.head.drain(..n).collect();
                buf.put_slice(&head);
            } else {
                let n = self.left.min(buf.remaining()).min(64 * 1024);
                buf.put_slice(&vec![b'9'; n]);
                self.left -= n;
            }
            Poll::Ready(Ok(()))
        }
    }

    #[tokio::test(flavor = "current_thread")]
    async fn an_oversized_payload_is_skipped_as_it_streams() {
        let size = 200 << 20;
        let mut head = vec![0x33u8];
        encode_length(2 + 3 + 2 + size, &mut head);
        head.extend_from_slice(&[0, 3, b'a', b'/', b'b', 0, 9]);
        let f = filter(1024);
        let (out, why) = relay(&f, Huge { head, left: size }).await;
        assert_eq!(out, publish(1, CUT, 9, b""));
        assert_eq!(why, "the broker closed the connection");
    }

    #[test]
    fn the_folders_of_dead_plcs_are_removed() {
        let tmp = tempfile::tempdir().unwrap();
        let mut dead = std::process::Command::new("true").spawn().unwrap();
        let dead_pid = dead.id();
        dead.wait().unwrap();
        let left = tmp
            .path()
            .join(format!("{DIR_PREFIX}{dead_pid}-0123456789abcdef"));
        let alive = tmp
            .path()
            .join(format!("{DIR_PREFIX}{}-0", std::process::id()));
        let other = tmp.path().join("petriplc-other-1");
        for d in [&left, &alive, &other] {
            std::fs::create_dir(d).unwrap();
        }
        std::fs::write(left.join("broker"), "").unwrap();
        let ours = tmp
            .path()
            .join(format!("{DIR_PREFIX}{}-1", std::process::id()));
        std::fs::create_dir(&ours).unwrap();
        remove_dead(tmp.path(), &ours);
        assert!(!left.exists());
        assert!(alive.exists() && other.exists() && ours.exists());
    }

    #[tokio::test(flavor = "current_thread")]
    async fn malformed_packets_end_the_connection_with_a_reason() {
        let f = filter(10);
        // A topic longer than the packet.
        let (_, why) = relay(&f, &[0x30u8, 0x03, 0x00, 0x09, b'a'][..]).await;
        assert!(why.contains("topic longer than the packet"), "{why}");
        // A remaining length of five bytes.
        let (_, why) = relay(&f, &[0x30u8, 0xff, 0xff, 0xff, 0xff, 0x01][..]).await;
        assert!(why.contains("longer than 4 bytes"), "{why}");
        // A huge non-PUBLISH packet is not read.
        let (out, why) = relay(&f, &[0x90u8, 0xff, 0xff, 0xff, 0x7f][..]).await;
        assert!(why.contains("a packet of type 9"), "{why}");
        assert!(out.is_empty());
        // A QoS 1 PUBLISH without room for its packet id.
        let (_, why) = relay(&f, &[0x32u8, 0x01, 0x00][..]).await;
        assert!(why.contains("shorter than its header"), "{why}");
    }
}
