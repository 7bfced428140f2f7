//! The connection to the broker: rumqttc's event loop on a tokio runtime in a thread of its
//! own, reconnected with back-off; a publisher task that sends the latest value of every
//! changed point (and all of them after each connection); received values checked against
//! their points and left for the next scan.

use std::collections::HashMap;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use petriplc_config::{PointKind, PointValue};
use petriplc_modules::common::{self, error};
use petriplc_runtime::module::ModuleError;
use rumqttc::{
    AsyncClient, ConnectReturnCode, Event, EventLoop, LastWill, MqttOptions, Packet, QoS,
    SubscribeFilter, SubscribeReasonCode, TlsConfiguration, Transport,
};
use tokio::sync::{oneshot, watch};

use crate::settings::{Plan, Settings};
use crate::{lock, payload, sparkplug, Shared, Spb};

/// The first wait after a failed connection; it doubles up to `backoff_max`.
const BACKOFF_MIN: Duration = Duration::from_millis(100);

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
        let mut options = MqttOptions::new(client_id, b.host.clone(), b.port);
        options.set_keep_alive(settings.keep_alive);
        options.set_clean_session(true);
        // Retained values tell a reconnecting subscriber the current state; what was in
        // flight when the link broke is superseded by the republish after reconnecting.
        options.set_max_packet_size(1 << 20, 1 << 20);
        if let Some(user) = &settings.username {
            let password = match &settings.password_file {
                None => String::new(),
                Some(p) => {
                    let path = base.join(p);
                    let text = std::fs::read_to_string(&path).map_err(|e| {
                        error(
                            &name,
                            format!(
                                "`password_file = {}`: cannot read {}: {}",
                                p.display(),
                                path.display(),
                                common::chain(&e)
                            ),
                        )
                    })?;
                    text.lines().next().unwrap_or("").to_string()
                }
            };
            options.set_credentials(user.clone(), password);
        }
        if b.tls {
            let config = tls_config(settings, base).map_err(|why| error(&name, why))?;
            options.set_transport(Transport::tls_with_config(TlsConfiguration::Rustls(
                Arc::new(config),
            )));
        }
        let mut topics: HashMap<String, Vec<(usize, PointKind, u8)>> = HashMap::new();
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
        for (i, s) in plan.subscribe.iter().enumerate() {
            let entry = topics.entry(s.topic.clone()).or_default();
            if entry.is_empty() {
                filters.push(SubscribeFilter::new(s.topic.clone(), QoS::AtLeastOnce));
            }
            entry.push((i, s.handle.kind(), s.handle.bits()));
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
                let (client, mut eventloop) = AsyncClient::new(options, 256);
                // Without TCP_NODELAY, Nagle's algorithm and delayed acknowledgements hold a
                // QoS 1 publish behind the previous one's PUBACK: tens of ms per change.
                let mut network = rumqttc::NetworkOptions::new();
                network.set_tcp_nodelay(true);
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
                    goodbye(&mut eventloop, &client, &shared).await;
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
        let certs = CertificateDer::pem_file_iter(&path)
            .and_then(|it| it.collect::<Result<Vec<_>, _>>())
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
            let key = PrivateKeyDer::from_pem_file(&path).map_err(|e| {
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
/// keep-alive; the event loop is driven until it is sent, 2 s at most.
async fn goodbye(eventloop: &mut EventLoop, client: &AsyncClient, shared: &Shared) {
    if !shared.up.load(Ordering::Acquire) {
        return;
    }
    if let Some(spb) = &shared.spb {
        let w = will(spb);
        let _ = client.try_publish(w.topic, w.qos, w.retain, w.message.to_vec());
    }
    let _ = client.try_disconnect();
    let _ = tokio::time::timeout(Duration::from_secs(2), async {
        loop {
            match eventloop.poll().await {
                Ok(Event::Outgoing(rumqttc::Outgoing::Disconnect)) | Err(_) => return,
                Ok(_) => {}
            }
        }
    })
    .await;
}

/// Drives the connection: (re)connects with back-off, subscribes after each connection,
/// hands received values to the inbox. `conn` counts connections (0: down).
async fn drive(
    eventloop: &mut EventLoop,
    client: AsyncClient,
    shared: Arc<Shared>,
    filters: Vec<SubscribeFilter>,
    topics: HashMap<String, Vec<(usize, PointKind, u8)>>,
    conn: watch::Sender<u64>,
    backoff_max: Duration,
) {
    let name = shared.name.clone();
    let mut backoff = BACKOFF_MIN;
    let mut connections = 0u64;
    // When the current outage began and whether it has been logged (once per outage).
    let mut down_since: Option<Instant> = Some(Instant::now());
    let mut logged = false;
    // Payloads already complained about, per topic: a bad publisher is logged once.
    let mut complained: HashMap<String, bool> = HashMap::new();
    loop {
        match eventloop.poll().await {
            Ok(Event::Incoming(Packet::ConnAck(ack))) => {
                if ack.code != ConnectReturnCode::Success {
                    // rumqttc reports a refused CONNACK as an error on the next poll.
                    continue;
                }
                connections += 1;
                backoff = BACKOFF_MIN;
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
                    Ok(true) => {
                        log::info!("mqtt {name}: rebirth requested (NCMD)");
                        spb.rebirth.store(true, Ordering::Release);
                        shared.wake.notify_one();
                    }
                    Ok(false) => {}
                    Err(why) => {
                        shared.rejected.fetch_add(1, Ordering::Relaxed);
                        if !complained.contains_key(p.topic.as_str()) {
                            complained.insert(p.topic.clone(), true);
                            log::warn!("mqtt {name}: {}: {why} (logged once)", p.topic);
                        }
                    }
                }
            }
            Ok(Event::Incoming(Packet::Publish(p))) => {
                let Some(targets) = topics.get(p.topic.as_str()) else {
                    continue;
                };
                shared.received.fetch_add(1, Ordering::Relaxed);
                let number = payload::decode(&p.payload);
                let mut inbox = lock(&shared.inbox);
                for &(i, kind, bits) in targets {
                    match number
                        .clone()
                        .and_then(|n| payload::to_point(n, kind, bits))
                    {
                        Ok(v) => {
                            inbox[i] = Some(v);
                            complained.remove(p.topic.as_str());
                        }
                        Err(why) => {
                            shared.rejected.fetch_add(1, Ordering::Relaxed);
                            if !complained.contains_key(p.topic.as_str()) {
                                complained.insert(p.topic.clone(), true);
                                log::warn!(
                                    "mqtt {name}: {}: {why}; the point keeps its value (logged \
                                     once until a good value arrives)",
                                    p.topic
                                );
                            }
                        }
                    }
                }
            }
            Ok(Event::Outgoing(rumqttc::Outgoing::Publish(_))) => {
                shared.published.fetch_add(1, Ordering::Relaxed);
            }
            Ok(_) => {}
            Err(e) => {
                shared.up.store(false, Ordering::Release);
                let _ = conn.send(0);
                if let Some(spb) = &shared.spb {
                    // Every CONNECT carries the next bdSeq in its will, and the NBIRTH after
                    // it the same.
                    let next = spb.bd_seq.load(Ordering::Acquire).wrapping_add(1);
                    spb.bd_seq.store(next, Ordering::Release);
                    eventloop.mqtt_options.set_last_will(will(spb));
                }
                let why = e.to_string();
                if down_since.is_none() {
                    down_since = Some(Instant::now());
                    shared.outages.fetch_add(1, Ordering::Relaxed);
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
                *lock(&shared.last_error) = why;
                tokio::time::sleep(backoff).await;
                backoff = (backoff * 2).min(backoff_max);
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
