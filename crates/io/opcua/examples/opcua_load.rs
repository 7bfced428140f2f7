//! An OPC UA load generator for bench/opcua.sh (async-opcua's client, security None,
//! anonymous). Prints one line of `key=value`s.
//!
//! ```text
//! opcua_load read URL NAMESPACE_URI CLIENTS SECONDS NODE...   # reads of all NODEs back to back
//! opcua_load sub URL NAMESPACE_URI SECONDS NODE                # data changes of NODE
//! ```
//!
//! `read`: CLIENTS sessions, each sending Read requests for every NODE (string ids) one after
//! the other; requests/s and latency percentiles. `sub`: one subscription (publishing 10 ms,
//! sampling 0 = as fast as the server grants) on NODE; the latency of a notification is its
//! arrival minus the value's source timestamp (the scan that saw the change; same machine,
//! same clock).

use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use opcua::client::{ClientBuilder, DataChangeCallback, IdentityToken, Session};
use opcua::crypto::SecurityPolicy;
use opcua::types::{
    DateTime, MessageSecurityMode, MonitoredItemCreateRequest, NodeId, ReadValueId,
    TimestampsToReturn, UserTokenPolicy,
};

fn usage() -> ExitCode {
    eprintln!(
        "usage: opcua_load read URL NAMESPACE_URI CLIENTS SECONDS NODE...\n       \
         opcua_load sub URL NAMESPACE_URI SECONDS NODE"
    );
    ExitCode::from(2)
}

fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

async fn connect(url: &str) -> Result<Arc<Session>, String> {
    let mut client = ClientBuilder::new()
        .application_name("opcua_load")
        .application_uri("urn:petriplc:opcua_load")
        .create_sample_keypair(false)
        .trust_server_certs(true)
        .session_retry_limit(0)
        .client()
        .map_err(|e| e.join(", "))?;
    let (session, event_loop) = client
        .connect_to_matching_endpoint(
            (
                url,
                SecurityPolicy::None.to_str(),
                MessageSecurityMode::None,
                UserTokenPolicy::anonymous(),
            ),
            IdentityToken::Anonymous,
        )
        .await
        .map_err(|e| e.to_string())?;
    event_loop.spawn();
    if !session.wait_for_connection().await {
        return Err(format!("cannot connect to {url}"));
    }
    Ok(session)
}

async fn namespace(session: &Session, uri: &str) -> Result<u16, String> {
    session
        .get_namespace_index(uri)
        .await
        .map_err(|e| format!("namespace {uri}: {e}"))
}

async fn read(
    url: String,
    uri: String,
    clients: usize,
    seconds: f64,
    nodes: Vec<String>,
) -> Result<String, String> {
    let mut tasks = Vec::new();
    let start = Instant::now() + Duration::from_millis(500);
    let duration = Duration::from_secs_f64(seconds);
    for _ in 0..clients {
        let (url, uri, nodes) = (url.clone(), uri.clone(), nodes.clone());
        tasks.push(tokio::spawn(async move {
            let session = connect(&url).await?;
            let ns = namespace(&session, &uri).await?;
            let ids: Vec<ReadValueId> = nodes
                .iter()
                .map(|n| ReadValueId::from(NodeId::new(ns, n.clone())))
                .collect();
            let mut lat = Vec::new();
            tokio::time::sleep_until(tokio::time::Instant::from_std(start)).await;
            while start.elapsed() < duration {
                let t = Instant::now();
                let values = session
                    .read(&ids, TimestampsToReturn::Neither, 0.0)
                    .await
                    .map_err(|e| e.to_string())?;
                if values.iter().any(|v| v.value.is_none()) {
                    return Err(format!("a read returned no value: {values:?}"));
                }
                lat.push(t.elapsed().as_secs_f64() * 1e6);
            }
            let _ = session.disconnect().await;
            Ok::<Vec<f64>, String>(lat)
        }));
    }
    let mut lat = Vec::new();
    for t in tasks {
        lat.extend(t.await.map_err(|e| e.to_string())??);
    }
    lat.sort_by(f64::total_cmp);
    Ok(format!(
        "requests={} req_per_s={:.0} p50_us={:.1} p99_us={:.1}",
        lat.len(),
        lat.len() as f64 / seconds,
        percentile(&lat, 0.5),
        percentile(&lat, 0.99)
    ))
}

async fn sub(url: String, uri: String, seconds: f64, node: String) -> Result<String, String> {
    let session = connect(&url).await?;
    let ns = namespace(&session, &uri).await?;
    let lat: Arc<Mutex<Vec<f64>>> = Arc::default();
    let sink = Arc::clone(&lat);
    let id = session
        .create_subscription(
            Duration::from_millis(10),
            1000,
            100,
            0,
            0,
            true,
            DataChangeCallback::new(move |dv, _| {
                if let Some(src) = dv.source_timestamp {
                    let ms = DateTime::now().as_chrono() - src.as_chrono();
                    if let Some(us) = ms.num_microseconds() {
                        sink.lock().unwrap().push(us as f64);
                    }
                }
            }),
        )
        .await
        .map_err(|e| e.to_string())?;
    let mut item: MonitoredItemCreateRequest = NodeId::new(ns, node).into();
    item.requested_parameters.sampling_interval = 0.0;
    item.requested_parameters.queue_size = 100;
    session
        .create_monitored_items(id, TimestampsToReturn::Both, vec![item])
        .await
        .map_err(|e| e.to_string())?;
    tokio::time::sleep(Duration::from_secs_f64(seconds)).await;
    let _ = session.disconnect().await;
    let mut lat = lat.lock().unwrap().clone();
    // The first notification is the initial value, whose source timestamp is older.
    if !lat.is_empty() {
        lat.remove(0);
    }
    lat.sort_by(f64::total_cmp);
    Ok(format!(
        "notifications={} per_s={:.0} p50_us={:.1} p99_us={:.1} max_us={:.1}",
        lat.len(),
        lat.len() as f64 / seconds,
        percentile(&lat, 0.5),
        percentile(&lat, 0.99),
        lat.last().copied().unwrap_or(0.0)
    ))
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .expect("a tokio runtime");
    let result = match args.first().map(String::as_str) {
        Some("read") if args.len() >= 6 => {
            let (Ok(clients), Ok(seconds)) = (args[3].parse(), args[4].parse()) else {
                return usage();
            };
            rt.block_on(read(
                args[1].clone(),
                args[2].clone(),
                clients,
                seconds,
                args[5..].to_vec(),
            ))
        }
        Some("sub") if args.len() == 5 => {
            let Ok(seconds) = args[3].parse() else {
                return usage();
            };
            rt.block_on(sub(
                args[1].clone(),
                args[2].clone(),
                seconds,
                args[4].clone(),
            ))
        }
        _ => return usage(),
    };
    match result {
        Ok(line) => {
            println!("{line}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("opcua_load: {e}");
            ExitCode::FAILURE
        }
    }
}
