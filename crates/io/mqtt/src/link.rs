//! The connection to the broker: rumqttc's event loop on a tokio runtime in a thread of its
//! own, through the module's relay (`relay.rs`: oversized messages dropped and counted),
//! reconnected with back-off; a publisher task that sends the latest value of every changed
//! point (and all of them after each connection); received values checked against their
//! points and left for the next scan.

use std::collections::{HashMap, HashSet};
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use petriplc_config::{PointKind, PointValue};
use petriplc_modules::common::error;
use petriplc_runtime::module::ModuleError;
use rumqttc::{
    AsyncClient, ConnectReturnCode, ConnectionError, Event, EventLoop, LastWill, MqttOptions,
    Packet, QoS, StateError, SubscribeFilter, SubscribeReasonCode, Transport,
};
use tokio::sync::{oneshot, watch};

use crate::relay::{self, Filter, Relay};
use crate::settings::{Plan, Settings};
use crate::{lock, payload, sparkplug, Shared, Spb};

/// The first wait after a failed connection; it doubles up to `backoff_max`.
const BACKOFF_MIN: Duration = Duration::from_millis(100);

/// How long a connection must last for the back-off to start again from [`BACKOFF_MIN`]:
/// one that the broker ends sooner (a message it cannot deliver, a client id taken over, an
/// access rule) is a failed attempt, or the module would reconnect every 100 ms for ever.
const HEALTHY: Duration = Duration::from_secs(10);

/// The largest packet the module sends (an NBIRTH of many metrics).
const MAX_OUTGOING: usize = 1 << 20;

/// The wait before each reconnection attempt.
#[derive(Debug)]
struct Backoff {
    next: Duration,
    max: Duration,
    /// When the current connection was made (CONNACK).
    connected: Option<Instant>,
}

impl Backoff {
    fn new(max: Duration) -> Backoff {
        Backoff {
            next: BACKOFF_MIN,
            max,
            connected: None,
        }
    }

    fn connected(&mut self, now: Instant) {
        self.connected = Some(now);
    }

    /// The wait after a failure at `now`: [`BACKOFF_MIN`] after a connection that lasted
    /// [`HEALTHY`], else twice the last one, up to the maximum.
    fn failed(&mut self, now: Instant) -> Duration {
        if let Some(since) = self.connected.take() {
            if now.saturating_duration_since(since) >= HEALTHY {
                self.next = BACKOFF_MIN;
            }
        }
        let wait = self.next;
        self.next = (self.next * 2).min(self.max);
        wait
    }
}

/// The running network side.
pub(crate) struct Link {
    stop: Option<oneshot::Sender<()>>,
    thread: Option<JoinHandle<()>>,
}

impl Link {
    pub fn stop(&mut self) {
        if let Some(stop) = self.stop.take() {
            let _ = stop.send(());
        }
        if let Some(t) = self.thread.take() {
            if t.join().is_err() {
                log::error!("mqtt: the network thread panicked");
            }
        }
    }

    /// Reads the TLS and password files (a missing file stops the PLC's start), then starts
    /// the network thread; the broker itself may be away: that is an outage, not an error.
    pub fn start(
        settings: &Settings,
        base: &Path,
        client_id: &str,
        plan: &Plan,
        shared: Arc<Shared>,
    ) -> Result<Link, ModuleError> {
        let name = shared.name.clone();
        let b = &settings.broker;
        let tls = if b.tls {
            Some(Arc::new(
                tls_config(settings, base).map_err(|why| error(&name, why))?,
            ))
        } else {
            None
        };
        let mut topics: HashMap<String, Vec<Target>> = HashMap::new();
        for (i, s) in plan.subscribe.iter().enumerate() {
            topics.entry(s.topic.clone()).or_default().push(Target {
                index: i,
                kind: s.handle.kind(),
                bits: s.handle.bits(),
                point: s.point.clone(),
            });
        }
        let mut counted: HashSet<String> = topics.keys().cloned().collect();
        if let Some(spb) = &shared.spb {
            counted.insert(spb.node.topic("NCMD"));
        }
        let relay = Relay::new(
            &b.host,
            b.port,
            tls,
            Filter {
                max_payload: settings.max_payload,
                topics: counted,
                shared: Arc::clone(&shared),
            },
        )
        .map_err(|why| error(&name, why))?;
        // rumqttc speaks MQTT over the relay's Unix socket; the relay reaches the broker.
        let mut options = MqttOptions::new(client_id, relay.socket().to_string_lossy(), 0);
        options.set_transport(Transport::Unix);
        options.set_keep_alive(settings.keep_alive);
        options.set_clean_session(true);
        // Retained values tell a reconnecting subscriber the current state; what was in
        // flight when the link broke is superseded by the republish after reconnecting.
        // Nothing larger than max_payload and a topic comes through the relay.
        options.set_max_packet_size(settings.max_payload + relay::HEADROOM, MAX_OUTGOING);
        if let Some(user) = &settings.username {
            let password = match &settings.password_file {
                None => String::new(),
                Some(p) => {
                    let path = base.join(p);
                    let text = petriplc_files::read_to_string(&path, petriplc_files::SMALL)
                        .map_err(|e| {
                            error(&name, format!("`password_file = {}`: {e}", p.display()))
                        })?;
                    text.lines().next().unwrap_or("").to_string()
                }
            };
            options.set_credentials(user.clone(), password);
        }
        let mut filters: Vec<SubscribeFilter> = Vec::new();
        if let Some(spb) = &shared.spb {
            // The will is the NDEATH of this connection's bdSeq (drive() renews it before
            // each new connection); commands come on NCMD.
            options.set_last_will(will(spb));
            filters.push(SubscribeFilter::new(
                spb.node.topic("NCMD"),
                QoS::AtLeastOnce,
            ));
        }
        for s in &plan.subscribe {
            if !filters.iter().any(|f| f.path == s.topic) {
                filters.push(SubscribeFilter::new(s.topic.clone(), QoS::AtLeastOnce));
            }
        }
        let backoff_max = settings.backoff_max;
        let published: Vec<String> = plan.publish.iter().map(|p| p.topic.clone()).collect();
        let rt = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| error(&name, format!("cannot start the network runtime: {e}")))?;
        let (stop, stopped) = oneshot::channel::<()>();
        let thread = std::thread::Builder::new()
            .name(format!("mqtt {name}"))
            .spawn(move || {
                let mut relay = relay;
                let (client, mut eventloop) = AsyncClient::new(options, 256);
                let mut network = rumqttc::NetworkOptions::new();
                network.set_connection_timeout(5);
                eventloop.network_options = network;
                let (conn_tx, conn_rx) = watch::channel(0u64);
                rt.block_on(async move {
                    let publisher = tokio::spawn(publish(
                        client.clone(),
                        Arc::clone(&shared),
                        published,
                        conn_rx,
                    ));
                    let link = drive(
                        &mut eventloop,
                        &mut relay,
                        client.clone(),
                        Arc::clone(&shared),
                        filters,
                        topics,
                        conn_tx,
                        backoff_max,
                    );
                    tokio::select! {
                        _ = stopped => {}
                        _ = link => {}
                    }
                    publisher.abort();
                    goodbye(&mut eventloop, &mut relay, &client, &shared).await;
                });
                rt.shutdown_timeout(Duration::from_millis(200));
            })
            .map_err(|e| error(&name, format!("cannot start the network thread: {e}")))?;
        Ok(Link {
            stop: Some(stop),
            thread: Some(thread),
        })
    }
}

fn tls_config(settings: &Settings, base: &Path) -> Result<rustls::ClientConfig, String> {
    use rustls::pki_types::pem::PemObject;
    use rustls::pki_types::{CertificateDer, PrivateKeyDer};
    let read_certs = |setting: &str, p: &Path| -> Result<Vec<CertificateDer<'static>>, String> {
        let path = base.join(p);
        let bytes = petriplc_files::read(&path, petriplc_files::SMALL)
            .map_err(|e| format!("`{setting} = {}`: {e}", p.display()))?;
        let certs = CertificateDer::pem_slice_iter(&bytes)
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| {
                format!(
                    "`{setting} = {}`: cannot read PEM certificates from {}: {e}",
                    p.display(),
                    path.display()
                )
            })?;
        if certs.is_empty() {
            return Err(format!(
                "`{setting} = {}`: {} holds no PEM certificate",
                p.display(),
                path.display()
            ));
        }
        Ok(certs)
    };
    let mut roots = rustls::RootCertStore::empty();
    match &settings.tls.ca_file {
        Some(p) => {
            for c in read_certs("ca_file", p)? {
                roots
                    .add(c)
                    .map_err(|e| format!("`ca_file = {}`: {e}", p.display()))?;
            }
        }
        None => {
            let found = rustls_native_certs::load_native_certs();
            for c in found.certs {
                let _ = roots.add(c);
            }
            if roots.is_empty() {
                return Err("no system CA certificates found to check the broker's \
                            certificate; set `ca_file = CA.pem`"
                    .to_string());
            }
        }
    }
    let provider = Arc::new(rustls::crypto::ring::default_provider());
    let builder = rustls::ClientConfig::builder_with_provider(provider)
        .with_safe_default_protocol_versions()
        .map_err(|e| format!("TLS: {e}"))?
        .with_root_certificates(roots);
    match (&settings.tls.client_cert, &settings.tls.client_key) {
        (Some(c), Some(k)) => {
            let certs = read_certs("client_cert", c)?;
            let path = base.join(k);
            let bytes = petriplc_files::read(&path, petriplc_files::SMALL)
                .map_err(|e| format!("`client_key = {}`: {e}", k.display()))?;
            let key = PrivateKeyDer::from_pem_slice(&bytes).map_err(|e| {
                format!(
                    "`client_key = {}`: cannot read a PEM private key from {}: {e}",
                    k.display(),
                    path.display()
                )
            })?;
            builder
                .with_client_auth_cert(certs, key)
                .map_err(|e| format!("`client_cert`/`client_key`: {e}"))
        }
        _ => Ok(builder.with_no_client_auth()),
    }
}

/// The NDEATH will of the next connection.
fn will(spb: &Spb) -> LastWill {
    let bd_seq = u64::from(spb.bd_seq.load(Ordering::Acquire));
    // QoS 1, not retained, as Sparkplug B requires of NDEATH.
    LastWill::new(
        spb.node.topic("NDEATH"),
        sparkplug::death(bd_seq, crate::now_ms()),
        QoS::AtLeastOnce,
        false,
    )
}

/// At a clean stop while connected: the NDEATH of a Sparkplug B node (the broker sends no
/// will after a DISCONNECT), then a DISCONNECT so the broker does not wait for the
/// keep-alive; the event loop is driven until it is sent and the relay until it has passed
/// it on, 2 s at most.
async fn goodbye(
    eventloop: &mut EventLoop,
    relay: &mut Relay,
    client: &AsyncClient,
    shared: &Shared,
) {
    if !shared.up.load(Ordering::Acquire) {
        return;
    }
    if let Some(spb) = &shared.spb {
        let w = will(spb);
        let _ = client.try_publish(w.topic, w.qos, w.retain, w.message.to_vec());
    }
    let _ = client.try_disconnect();
    let deadline = tokio::time::Instant::now() + Duration::from_secs(2);
    let _ = tokio::time::timeout_at(deadline, async {
        loop {
            match eventloop.poll().await {
                Ok(Event::Outgoing(rumqttc::Outgoing::Disconnect)) | Err(_) => return,
                Ok(_) => {}
            }
        }
    })
    .await;
    // Closing rumqttc's end lets the relay flush the rest to the broker and close.
    eventloop.network = None;
    relay
        .finish(deadline.saturating_duration_since(tokio::time::Instant::now()))
        .await;
}

/// A point that takes the values of a subscribed topic.
struct Target {
    /// Its row in the plan's `subscribe` (and in the inbox).
    index: usize,
    kind: PointKind,
    bits: u8,
    point: String,
}

/// Hands a message on a subscribed topic to the inbox, or refuses it (counted; the first
/// refusal on a topic logged).
fn receive(shared: &Shared, topic: &str, targets: &[Target], bytes: &[u8]) {
    shared.received.fetch_add(1, Ordering::Relaxed);
    let number = payload::decode(bytes);
    let mut refused = None;
    {
        let mut inbox = lock(&shared.inbox);
        for t in targets {
            match number
                .clone()
                .and_then(|n| payload::to_point(n, t.kind, t.bits))
            {
                Ok(v) => inbox[t.index] = Some(v),
                Err(why) => {
                    refused.get_or_insert((why, t));
                }
            }
        }
    }
    match refused {
        None => shared.accepted(topic),
        Some((why, t)) => shared.refuse(topic, || {
            format!(
                "payload {} {why} for {} point {}",
                payload::show(bytes),
                payload::type_name(t.kind, t.bits),
                t.point
            )
        }),
    }
}

/// Drives the connection: (re)connects with back-off, subscribes after each connection,
/// hands received values to the inbox. `conn` counts connections (0: down).
#[allow(clippy::too_many_arguments)]
async fn drive(
    eventloop: &mut EventLoop,
    relay: &mut Relay,
    client: AsyncClient,
    shared: Arc<Shared>,
    filters: Vec<SubscribeFilter>,
    topics: HashMap<String, Vec<Target>>,
    conn: watch::Sender<u64>,
    backoff_max: Duration,
) {
    let name = shared.name.clone();
    let mut backoff = Backoff::new(backoff_max);
    let mut connections = 0u64;
    // When the current outage began and whether it has been logged (once per outage).
    let mut down_since: Option<Instant> = Some(Instant::now());
    let mut logged = false;
    loop {
        let failure = if eventloop.network.is_none() {
            // rumqttc connects next: the relay reaches the broker first.
            relay.open().await.err()
        } else {
            None
        };
        let event = match failure {
            Some(why) => Err(why),
            None => eventloop.poll().await.map_err(|e| match e {
                // rumqttc sees only its end of the relay closed: the broker's side says
                // why. A refused CONNACK and the like keep rumqttc's words.
                ConnectionError::MqttState(StateError::ConnectionAborted | StateError::Io(_))
                | ConnectionError::Io(_) => relay.ended().unwrap_or_else(|| e.to_string()),
                e => e.to_string(),
            }),
        };
        match event {
            Ok(Event::Incoming(Packet::ConnAck(ack))) => {
                if ack.code != ConnectReturnCode::Success {
                    // rumqttc reports a refused CONNACK as an error on the next poll.
                    continue;
                }
                connections += 1;
                backoff.connected(Instant::now());
                if filters.is_empty() {
                    shared.up.store(true, Ordering::Release);
                } else if let Err(e) = client.try_subscribe_many(filters.clone()) {
                    log::error!("mqtt {name}: cannot subscribe: {e}");
                }
                if let Some(since) = down_since.take() {
                    if logged {
                        log::info!(
                            "mqtt {name}: connected to {} again after {:.1} s",
                            shared.broker,
                            since.elapsed().as_secs_f64()
                        );
                    } else {
                        log::info!("mqtt {name}: connected to {}", shared.broker);
                    }
                }
                logged = false;
                lock(&shared.last_error).clear();
                let _ = conn.send(connections);
            }
            Ok(Event::Incoming(Packet::SubAck(ack))) => {
                let refused = ack
                    .return_codes
                    .iter()
                    .zip(&filters)
                    .filter(|(c, _)| matches!(c, SubscribeReasonCode::Failure))
                    .map(|(_, f)| f.path.clone())
                    .collect::<Vec<_>>();
                if !refused.is_empty() {
                    log::error!(
                        "mqtt {name}: the broker refused the subscription to {} (its access \
                         rules?); those points keep their values",
                        refused.join(", ")
                    );
                }
                shared.up.store(true, Ordering::Release);
            }
            Ok(Event::Incoming(Packet::Publish(p)))
                if shared
                    .spb
                    .as_ref()
                    .is_some_and(|spb| p.topic == spb.node.topic("NCMD")) =>
            {
                let spb = shared.spb.as_ref().expect("matched above");
                shared.received.fetch_add(1, Ordering::Relaxed);
                match sparkplug::asks_rebirth(&p.payload) {
                    Ok(rebirth) => {
                        shared.accepted(&p.topic);
                        if rebirth {
                            log::info!("mqtt {name}: rebirth requested (NCMD)");
                            spb.rebirth.store(true, Ordering::Release);
                            shared.wake.notify_one();
                        }
                    }
                    Err(why) => shared.refuse(&p.topic, || why),
                }
            }
            Ok(Event::Incoming(Packet::Publish(p))) => {
                // Not a subscribed topic: relay::CUT (an oversized message, counted by the
                // relay), or nothing the module asked for.
                if let Some(targets) = topics.get(p.topic.as_str()) {
                    receive(&shared, &p.topic, targets, &p.payload);
                }
            }
            Ok(Event::Outgoing(rumqttc::Outgoing::Publish(_))) => {
                shared.published.fetch_add(1, Ordering::Relaxed);
            }
            Ok(_) => {}
            Err(why) => {
                // The status says why before it says stale (a reader that sees the flag sees
                // the reason and the outage counted).
                if down_since.is_none() {
                    down_since = Some(Instant::now());
                    shared.outages.fetch_add(1, Ordering::Relaxed);
                }
                *lock(&shared.last_error) = why.clone();
                shared.up.store(false, Ordering::Release);
                let _ = conn.send(0);
                if let Some(spb) = &shared.spb {
                    // Every CONNECT carries the next bdSeq in its will, and the NBIRTH after
                    // it the same.
                    let next = spb.bd_seq.load(Ordering::Acquire).wrapping_add(1);
                    spb.bd_seq.store(next, Ordering::Release);
                    eventloop.mqtt_options.set_last_will(will(spb));
                }
                if !logged {
                    logged = true;
                    log::warn!(
                        "mqtt {name}: broker {} unreachable: {why}; retrying with back-off up \
                         to {:?}, subscribed points stale (logged once per outage)",
                        shared.broker,
                        backoff_max
                    );
                }
                tokio::time::sleep(backoff.failed(Instant::now())).await;
            }
        }
    }
}

/// Sends the latest value of every changed point while connected, and every point's after
/// each (re)connection (a Sparkplug B node: an NBIRTH, then NDATA). Only this task waits for
/// the broker; the scan never does.
async fn publish(
    client: AsyncClient,
    shared: Arc<Shared>,
    topics: Vec<String>,
    mut conn: watch::Receiver<u64>,
) {
    let mut seen = 0u64;
    // The seq of the next NDATA (the NBIRTH is 0).
    let mut seq = 0u8;
    let mut batch: Vec<(usize, PointValue, u64)> = Vec::new();
    loop {
        tokio::select! {
            _ = shared.wake.notified() => {}
            r = conn.changed() => if r.is_err() { return },
        }
        let now = *conn.borrow_and_update();
        if now == 0 {
            continue;
        }
        let mut birth = false;
        {
            let mut outbox = lock(&shared.outbox);
            let all = now != seen;
            if let Some(spb) = &shared.spb {
                if all || spb.rebirth.load(Ordering::Acquire) {
                    // An NBIRTH carries every metric: wait for the first scan to fill them.
                    if outbox.iter().any(|s| s.value.is_none()) {
                        continue;
                    }
                    spb.rebirth.store(false, Ordering::Release);
                    birth = true;
                }
            }
            seen = now;
            for (i, slot) in outbox.iter_mut().enumerate() {
                if slot.dirty || all || birth {
                    if let Some((v, ts)) = slot.value {
                        batch.push((i, v, ts));
                    }
                    slot.dirty = false;
                }
            }
        }
        if *conn.borrow() == 0 {
            // Lost again: the next connection republishes everything.
            batch.clear();
            continue;
        }
        let sent = match &shared.spb {
            Some(spb) => {
                let ts = crate::now_ms();
                let (topic, payload) = if birth {
                    seq = 1;
                    let values: Vec<PointValue> = batch.iter().map(|b| b.1).collect();
                    let bd_seq = u64::from(spb.bd_seq.load(Ordering::Acquire));
                    (
                        spb.node.topic("NBIRTH"),
                        sparkplug::birth(bd_seq, ts, &spb.metrics, &values),
                    )
                } else if batch.is_empty() {
                    continue;
                } else {
                    let changes: Vec<_> = batch
                        .iter()
                        .map(|&(i, v, at)| (&spb.metrics[i], v, at))
                        .collect();
                    let payload = sparkplug::data(seq, ts, &changes);
                    seq = seq.wrapping_add(1);
                    (spb.node.topic("NDATA"), payload)
                };
                batch.clear();
                // NBIRTH and NDATA: QoS 0, not retained (Sparkplug B).
                client
                    .publish(topic, QoS::AtMostOnce, false, payload)
                    .await
                    .is_ok()
            }
            None => {
                let mut ok = true;
                for (i, v, ts) in batch.drain(..) {
                    if *conn.borrow() == 0 {
                        break;
                    }
                    let payload = payload::encode(v, shared.format, ts);
                    if client
                        .publish(topics[i].clone(), QoS::AtLeastOnce, true, payload)
                        .await
                        .is_err()
                    {
                        ok = false;
                        break;
                    }
                }
                batch.clear();
                ok
            }
        };
        if !sent {
            return;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_back_off_grows_until_a_connection_lasts() {
        let t0 = Instant::now();
        let ms = |n: u64| Duration::from_millis(n);
        let mut b = Backoff::new(Duration::from_secs(5));
        // The broker away: 0.1, 0.2, 0.4 s ...
        assert_eq!(b.failed(t0), ms(100));
        assert_eq!(b.failed(t0), ms(200));
        assert_eq!(b.failed(t0), ms(400));
        // Each attempt connects but the link drops at once: still a failure, still growing,
        // up to the maximum.
        let mut at = t0;
        let mut waits = Vec::new();
        for _ in 0..6 {
            b.connected(at);
            at += ms(50);
            waits.push(b.failed(at));
        }
        assert_eq!(waits, [800, 1600, 3200, 5000, 5000, 5000].map(ms));
        // A connection that lasted HEALTHY starts again from the minimum.
        b.connected(at);
        assert_eq!(b.failed(at + HEALTHY), ms(100));
        assert_eq!(b.failed(at + HEALTHY), ms(200));
        // A connection just short of it does not.
        b.connected(at);
        assert_eq!(b.failed(at + HEALTHY - ms(1)), ms(400));
    }
}
