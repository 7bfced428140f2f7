//! The OPC UA boundary under arbitrary input (issue 27): a PLC in the real runner whose server
//! owns a point of each kind, one of them read by an `iec` module (`half := temp * 0.5`,
//! which faults on NaN or ±Inf and stops the PLC, `on_failure = stop`), takes writes of
//! arbitrary variants (every type, NaN, ±Inf, extreme integers, strings and arrays up to and
//! beyond the stack's limits, index ranges, other attributes, nodes it does not own or that
//! do not exist) through async-opcua's client, and arbitrary bytes on its TCP port (garbage,
//! cut Hellos, message headers claiming gigabytes, sockets left idle). Afterwards every
//! module still scans (its scan count grew), no point holds a non-finite value, and the
//! process's memory grew by less than a generous bound between a first round and ten more.
//! The cases come from a fixed seed: a failure reproduces.

use std::io::Write;
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::{Duration, Instant};

use opcua::client::{ClientBuilder, IdentityToken, Session};
use opcua::crypto::SecurityPolicy;
use opcua::types::{
    AttributeId, DataValue, MessageSecurityMode, NodeId, NumericRange, ReadValueId, StatusCode,
    TimestampsToReturn, UserTokenPolicy, Variant, WriteValue,
};
use petriplc_config::PointValue;
use petriplc_plc::{Plc, RunOptions};
use petriplc_runtime::image::{GlobalMap, Layout};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

fn registry(kind: &str) -> Option<petriplc_runtime::module::Factory> {
    petriplc_opcua::builtin(kind).or_else(|| petriplc_modules::builtin(kind))
}

/// The points the server owns, then the one it does not (`half`, the iec module's).
const OWNED: [&str; 6] = ["temp", "f", "b", "u8", "i16", "u32"];

fn conf(dir: &Path) -> String {
    std::fs::write(
        dir.join("half.st"),
        "PROGRAM half_of\nVAR_INPUT\n    temp : REAL;\nEND_VAR\nVAR_OUTPUT\n    half : REAL;\n\
         END_VAR\nhalf := temp * 0.5;\nEND_PROGRAM\n",
    )
    .unwrap();
    format!(
        "[PLC]\nmodule opcua opcua_server\nmodule calc iec\n\
         point temp \"read by calc\" opcua f32 init 20\npoint half \"temp / 2\" calc f32\n\
         point f \"a float\" opcua f32\npoint b \"a bool\" opcua u1\npoint u8 \"8 bits\" opcua u8\n\
         point i16 \"signed 16\" opcua i16\npoint u32 \"32 bits\" opcua u32\n\
         [calc]\nprogram = half.st\nscan_period = T#10ms\n\
         [opcua]\nlisten = 127.0.0.1:0\nanonymous = write\nstate_dir = {}\n",
        dir.join("state").display()
    )
}

fn vm_rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmRSS in /proc/self/status")
}

async fn connect(url: &str) -> Arc<Session> {
    let mut client = ClientBuilder::new()
        .application_name("boundary test")
        .application_uri("urn:petriplc:boundary-test")
        .create_sample_keypair(false)
        .trust_server_certs(true)
        .session_retry_limit(0)
        .client()
        .unwrap();
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
        .unwrap();
    event_loop.spawn();
    assert!(
        session.wait_for_connection().await,
        "cannot connect to {url}"
    );
    session
}

/// A write of anything to anything.
#[derive(Clone, Debug)]
struct Write1 {
    /// Index into the targets: the owned points, `half`, a status variable, an unknown node.
    target: usize,
    value: Option<Variant>,
    attribute: AttributeId,
    range: NumericRange,
}

fn variant() -> impl Strategy<Value = Variant> {
    prop_oneof![
        any::<bool>().prop_map(Variant::Boolean),
        any::<i8>().prop_map(Variant::SByte),
        any::<u8>().prop_map(Variant::Byte),
        any::<i16>().prop_map(Variant::Int16),
        any::<u16>().prop_map(Variant::UInt16),
        any::<i32>().prop_map(Variant::Int32),
        any::<u32>().prop_map(Variant::UInt32),
        any::<i64>().prop_map(Variant::Int64),
        any::<u64>().prop_map(Variant::UInt64),
        prop_oneof![
            Just(i64::MIN),
            Just(i64::MAX),
            Just(0),
            Just(-1),
            Just(1 << 24 | 1)
        ]
        .prop_map(Variant::Int64),
        proptest::num::f32::ANY.prop_map(Variant::Float),
        proptest::num::f64::ANY.prop_map(Variant::Double),
        prop_oneof![
            Just(f64::NAN),
            Just(f64::INFINITY),
            Just(f64::NEG_INFINITY),
            Just(1e39),
            Just(-1e39),
            Just(f64::MAX),
            Just(f64::MIN_POSITIVE),
        ]
        .prop_map(Variant::Double),
        prop_oneof![Just(f32::NAN), Just(f32::INFINITY), Just(f32::NEG_INFINITY)]
            .prop_map(Variant::Float),
        // Strings and byte strings up to beyond the stack's 65535.
        (0usize..80_000).prop_map(|n| Variant::from("9".repeat(n))),
        (0usize..80_000).prop_map(|n| Variant::from(vec![0xffu8; n])),
        // Arrays up to beyond its 1000 elements.
        (0usize..1500).prop_map(|n| Variant::from(vec![f32::NAN; n])),
        (0usize..1500).prop_map(|n| Variant::from(vec![i32::MAX; n])),
        Just(Variant::Empty),
    ]
}

fn write1() -> impl Strategy<Value = Write1> {
    (
        0usize..OWNED.len() + 3,
        prop::option::weighted(0.95, variant()),
        prop_oneof![
            20 => Just(AttributeId::Value),
            1 => Just(AttributeId::DisplayName),
            1 => Just(AttributeId::AccessLevel),
        ],
        prop_oneof![
            20 => Just(NumericRange::None),
            1 => Just(NumericRange::Index(1)),
            1 => Just(NumericRange::Range(0, 7)),
        ],
    )
        .prop_map(|(target, value, attribute, range)| Write1 {
            target,
            value,
            attribute,
            range,
        })
}

/// Bytes a hostile or broken peer sends on the port, and whether it then stays idle.
fn garbage() -> impl Strategy<Value = (Vec<u8>, bool)> {
    let hello = {
        // A valid Hello (protocol 0, 64 KiB buffers, no limits) for endpoint "opc.tcp://x".
        let url = b"opc.tcp://x";
        let mut h = b"HELF".to_vec();
        h.extend_from_slice(&(32 + url.len() as u32).to_le_bytes());
        for v in [0u32, 65536, 65536, 0, 0] {
            h.extend_from_slice(&v.to_le_bytes());
        }
        h.extend_from_slice(&(url.len() as u32).to_le_bytes());
        h.extend_from_slice(url);
        h
    };
    (
        prop_oneof![
            proptest::collection::vec(any::<u8>(), 0..2000),
            // A Hello cut anywhere.
            (0..hello.len()).prop_map(move |n| hello[..n].to_vec()),
            // Headers claiming up to 4 GiB.
            (
                prop_oneof![
                    Just(*b"HELF"),
                    Just(*b"MSGF"),
                    Just(*b"OPNF"),
                    Just(*b"CLOF")
                ],
                any::<u32>()
            )
                .prop_map(|(kind, size)| {
                    let mut m = kind.to_vec();
                    m.extend_from_slice(&size.to_le_bytes());
                    m.extend_from_slice(&[0; 16]);
                    m
                }),
        ],
        any::<bool>(),
    )
}

/// The node ids of the write targets.
fn targets(ns: u16) -> Vec<NodeId> {
    let mut t: Vec<NodeId> = OWNED.iter().map(|p| NodeId::new(ns, *p)).collect();
    t.push(NodeId::new(ns, "half"));
    t.push(NodeId::new(ns, "module:calc.Status.Scans"));
    t.push(NodeId::new(ns, "no such node"));
    t
}

/// Statuses a write may get: its value refused, the node or attribute not writable.
const REFUSALS: [StatusCode; 9] = [
    StatusCode::BadOutOfRange,
    StatusCode::BadTypeMismatch,
    StatusCode::BadNotWritable,
    StatusCode::BadNodeIdUnknown,
    StatusCode::BadWriteNotSupported,
    StatusCode::BadAttributeIdInvalid,
    StatusCode::BadIndexRangeInvalid,
    StatusCode::BadIndexRangeNoData,
    StatusCode::BadUserAccessDenied,
];

/// One round: `writes` arbitrary writes and `peers` garbage connections; the idle sockets
/// are returned to be held.
fn round(
    rt: &tokio::runtime::Runtime,
    url: &str,
    ns: u16,
    rng_seed: u64,
    writes: u32,
    peers: u32,
) -> Vec<TcpStream> {
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: writes,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &seed(rng_seed)),
    );
    let targets = targets(ns);
    let session = std::cell::RefCell::new(rt.block_on(connect(url)));
    // Requests the stack refused whole (beyond its limits on strings, arrays, messages).
    let faults = std::cell::RefCell::new(0u32);
    runner
        .run(&write1(), |w| {
            let node = targets[w.target].clone();
            let value = DataValue {
                value: w.value.clone(),
                ..Default::default()
            };
            let request = WriteValue {
                node_id: node.clone(),
                attribute_id: w.attribute as u32,
                index_range: w.range.clone(),
                value,
            };
            let result = rt.block_on(session.borrow().write(&[request]));
            match result {
                Ok(statuses) => {
                    prop_assert_eq!(statuses.len(), 1);
                    let s = statuses[0];
                    if s.is_good() {
                        // Only a value, into a point the server owns.
                        prop_assert!(w.target < OWNED.len(), "{:?} written", node);
                        prop_assert!(w.attribute == AttributeId::Value);
                    } else {
                        prop_assert!(REFUSALS.contains(&s), "{:?}: {}", w, s);
                    }
                }
                // A request beyond the stack's limits is refused whole (a service fault);
                // the session goes on unless the connection ended, then a new one.
                Err(e) => {
                    let alive = rt.block_on(session.borrow().read(
                        &[ReadValueId::from(targets[0].clone())],
                        TimestampsToReturn::Neither,
                        0.0,
                    ));
                    *faults.borrow_mut() += 1;
                    prop_assert!(
                        [
                            StatusCode::BadEncodingLimitsExceeded,
                            StatusCode::BadDecodingError
                        ]
                        .contains(&e.status()),
                        "{:?}: {}",
                        w.value.as_ref().map(|v| v.type_id()),
                        e
                    );
                    if alive.is_err() {
                        let old = session.replace(rt.block_on(connect(url)));
                        let _ = rt.block_on(tokio::time::timeout(
                            Duration::from_secs(5),
                            old.disconnect(),
                        ));
                    }
                }
            }
            Ok(())
        })
        .unwrap();
    let _ = rt.block_on(session.borrow().disconnect());
    eprintln!(
        "{writes} writes, {} refused whole by the stack",
        faults.into_inner()
    );

    let addr = url
        .trim_start_matches("opc.tcp://")
        .trim_end_matches('/')
        .to_string();
    let mut runner = TestRunner::new_with_rng(
        Config {
            cases: peers,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &seed(rng_seed + 1)),
    );
    let idle = std::cell::RefCell::new(Vec::new());
    runner
        .run(&garbage(), |(bytes, stay)| {
            let mut s = TcpStream::connect(&addr).unwrap();
            // The server may close first: what it does with the bytes is its business.
            let _ = s.write_all(&bytes);
            if stay {
                idle.borrow_mut().push(s);
            }
            Ok(())
        })
        .unwrap();
    idle.into_inner()
}

fn seed(n: u64) -> [u8; 32] {
    let mut s = [0u8; 32];
    s[..8].copy_from_slice(&n.to_le_bytes());
    s
}

fn scans(plc: &Plc) -> Vec<(String, u64, String)> {
    plc.status()
        .modules
        .iter()
        .map(|m| (m.name.clone(), m.scans, m.state.as_str().to_string()))
        .collect()
}

#[test]
fn arbitrary_writes_and_bytes_never_stop_the_plc_nor_leave_a_non_finite_point() {
    let dir = tempfile::tempdir().unwrap();
    let text = conf(dir.path());
    let conf_path: PathBuf = dir.path().join("plc.conf");
    std::fs::write(&conf_path, &text).unwrap();
    let opts = RunOptions {
        plc_id: petriplc_runtime::harness::plc_id(),
        duration: Some(Duration::from_secs(600)),
        known_kinds: &["opcua_server", "iec"],
        overrides: Vec::new(),
    };
    let plc = Plc::start(&conf_path, registry, &opts).unwrap_or_else(|e| panic!("{e}"));
    let started = Instant::now();
    let url = loop {
        let detail = plc
            .status()
            .modules
            .iter()
            .find(|m| m.name == "opcua")
            .map(|m| m.detail.clone())
            .unwrap_or_default();
        if let Some(u) = detail
            .split_whitespace()
            .find(|w| w.starts_with("opc.tcp://"))
        {
            break u.to_string();
        }
        assert!(started.elapsed() < Duration::from_secs(30), "no endpoint");
        std::thread::sleep(Duration::from_millis(20));
    };
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()
        .unwrap();
    let ns = rt.block_on(async {
        let s = connect(&url).await;
        let ns = s
            .get_namespace_index(&format!("urn:petriplc:{}", opts.plc_id))
            .await
            .unwrap();
        let _ = s.disconnect().await;
        ns
    });
    let cfg = petriplc_runtime::harness::config(&text, dir.path());
    let layout = Layout::new(&cfg).unwrap();
    let global = GlobalMap::open(&opts.plc_id).unwrap();
    global.check_layout(&layout).unwrap();
    let check_points = || {
        for p in &cfg.points {
            let v = global.read_point(&layout, layout.lookup(&p.name).unwrap());
            if let PointValue::Float(f) = v {
                assert!(f.is_finite(), "point {} holds {f}", p.name);
            }
        }
    };

    // A first round brings the server's buffers, the sessions' tables and the allocator
    // to their working size; ten more must not grow the process much.
    let mut held = round(&rt, &url, ns, 1, 60, 30);
    let before = scans(&plc);
    let rss_before = vm_rss_kib();
    check_points();
    for r in 0..10 {
        held.extend(round(&rt, &url, ns, 100 + 2 * r, 60, 30));
        check_points();
        // The idle sockets of a round are closed by the next: at most two rounds' worth open.
        if r % 2 == 1 {
            held.clear();
        }
    }
    drop(held);
    let rss_after = vm_rss_kib();
    // Every module scanned on, and is still running.
    let deadline = Instant::now() + Duration::from_secs(30);
    loop {
        let after = scans(&plc);
        let grown = after
            .iter()
            .zip(&before)
            .all(|(a, b)| a.1 > b.1 && a.2 == "running");
        if grown {
            break;
        }
        assert!(
            Instant::now() < deadline && !plc.failed(),
            "scans before {before:?}, after {after:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    check_points();
    let grew_mib = rss_after.saturating_sub(rss_before) as f64 / 1024.0;
    eprintln!(
        "VmRSS {} MiB -> {} MiB after 600 writes and 300 connections ({grew_mib:.1} MiB)",
        rss_before / 1024,
        rss_after / 1024
    );
    assert!(grew_mib < 64.0, "the process grew {grew_mib:.1} MiB");
    let last = plc.wait(&AtomicBool::new(true));
    assert!(
        last.modules.iter().all(|m| m.state.as_str() != "failed"),
        "{last}"
    );
}
