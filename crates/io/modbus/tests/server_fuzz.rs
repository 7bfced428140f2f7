//! modbus_server against hostile clients: random request frames (function codes, addresses,
//! counts, byte counts, truncated and oversized frames, register values with every NaN/Inf
//! pattern) sent to a PLC in the real runner, whose `iec` module computes with the float
//! points, get valid answers while the PLC scans on; no float point ever holds a non-finite
//! value, and memory stays bounded. The only test of its binary, so that the process's VmRSS
//! is this test's (bad values one by one: `server_values.rs`).

mod server_support;

use std::cell::RefCell;
use std::io::Read;
use std::net::SocketAddr;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use petriplc_plc::{ModuleState, Plc, RunOptions};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use server_support::{adu, count, fc16, tcp_address, Raw, PATIENCE};

// ---------------------------------------------------------------------------------------
// Random frames against a PLC in the real runner.

const CALC: &str = "\
PROGRAM main
VAR_INPUT temp : REAL; temp_lo : REAL; END_VAR
VAR_OUTPUT half : REAL; half_lo : REAL; END_VAR
half := temp * 0.5;
half_lo := temp_lo * 0.5;
END_PROGRAM
";

/// The float points are written by clients and halved by the `iec` module (which fails,
/// stopping the PLC, on a NaN operand); the halves are read back at holding 10-13.
const PLC: &str = "\
[PLC]
module fz modbus_server
module calc iec
point temp \"\" fz f32 init 20
point temp_lo \"\" fz f32 init -1.5
point small \"\" fz u8
point s \"\" fz i16
point w \"\" fz u32
point c \"\" fz
point half \"\" calc f32
point half_lo \"\" calc f32
[fz]
listen = 127.0.0.1:0
holding 0 temp
holding 2 temp_lo f32 low_first
holding 4 small
holding 5 s
holding 6 w
holding 10 half
holding 12 half_lo f32 low_first
input 0 half
coil 0 c
[calc]
program = calc.st
scan_period = 5ms
on_failure = stop
";

fn registry(kind: &str) -> Option<petriplc_runtime::module::Factory> {
    petriplc_modbus::builtin(kind).or_else(|| petriplc_modules::builtin(kind))
}

/// The process's resident memory, kB.
fn vm_rss_kb() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmRSS in /proc/self/status")
}

/// What a fuzz case sends.
#[derive(Clone, Debug)]
enum Frame {
    /// One well-framed request on the connection that stays open: answered, always.
    Request(Vec<u8>),
    /// Bytes on a fresh connection, which the client then half-closes: any mix of garbage,
    /// truncated and oversized frames.
    Raw(Vec<u8>),
}

/// A register value: random, or one of the NaN/Inf words.
fn word() -> impl Strategy<Value = u16> {
    prop_oneof![
        3 => any::<u16>(),
        1 => prop::sample::select(vec![0x7FC0u16, 0xFFC0, 0x7F80, 0xFF80, 0x7FBF, 0xFFFF, 0x0001, 0]),
    ]
}

/// A request PDU: a function the server serves (or any code), near the mapped addresses,
/// quantities and byte counts mostly consistent, register values with NaN/Inf words.
fn pdu() -> impl Strategy<Value = Vec<u8>> {
    (
        prop_oneof![
            6 => prop::sample::select(vec![1u8, 2, 3, 4, 5, 6, 15, 16, 23]),
            1 => any::<u8>(),
        ],
        prop_oneof![6 => 0u16..16, 1 => any::<u16>()],
        proptest::collection::vec(word(), 1..8),
        prop_oneof![6 => Just(None), 1 => any::<u16>().prop_map(Some)],
        prop_oneof![6 => Just(None), 1 => any::<u8>().prop_map(Some)],
    )
        .prop_map(|(fc, address, words, q, count)| {
            let q = q.unwrap_or(words.len() as u16);
            let data: Vec<u8> = words.iter().flat_map(|w| w.to_be_bytes()).collect();
            let count = count.unwrap_or(data.len() as u8);
            let mut pdu = vec![fc];
            pdu.extend(address.to_be_bytes());
            match fc {
                5 => pdu
                    .extend([[0xFF, 0], [0, 0], words[0].to_be_bytes()][usize::from(words[0] % 3)]),
                6 => pdu.extend(words[0].to_be_bytes()),
                15 => {
                    pdu.extend(q.to_be_bytes());
                    pdu.push(count.min(q.div_ceil(8) as u8));
                    pdu.extend(data.iter().take(usize::from(q.div_ceil(8))));
                }
                16 => {
                    pdu.extend(q.to_be_bytes());
                    pdu.push(count);
                    pdu.extend(&data);
                }
                23 => {
                    pdu.extend(q.to_be_bytes());
                    pdu.extend(address.to_be_bytes());
                    pdu.extend((words.len() as u16).to_be_bytes());
                    pdu.push(count);
                    pdu.extend(&data);
                }
                _ => pdu.extend(q.to_be_bytes()),
            }
            pdu
        })
}

fn frame() -> impl Strategy<Value = Frame> {
    prop_oneof![
        // Structured requests, and random PDUs of every length up to the largest.
        6 => pdu().prop_map(Frame::Request),
        2 => proptest::collection::vec(any::<u8>(), 1..=253).prop_map(Frame::Request),
        // Garbage, of up to twice the largest frame.
        1 => proptest::collection::vec(any::<u8>(), 0..520).prop_map(Frame::Raw),
        // A request cut anywhere.
        1 => (pdu(), any::<prop::sample::Index>()).prop_map(|(p, cut)| {
            let a = adu(1, 1, &p);
            let n = cut.index(a.len());
            Frame::Raw(a[..n].to_vec())
        }),
        // Oversized: a header whose length says more than any frame holds, or a whole frame
        // followed by more bytes than the length says.
        1 => (any::<u16>(), proptest::collection::vec(any::<u8>(), 0..300)).prop_map(|(len, rest)| {
            let mut a = vec![0, 9, 0, 0];
            a.extend(len.max(255).to_be_bytes());
            a.extend(rest);
            Frame::Raw(a)
        }),
        1 => (pdu(), proptest::collection::vec(any::<u8>(), 1..300)).prop_map(|(p, tail)| {
            let mut a = adu(2, 1, &p);
            a.extend(tail);
            Frame::Raw(a)
        }),
    ]
}

/// Whether `response` is a valid answer to `pdu`: the function echoed with a body of the
/// right shape, or an exception 01-03.
fn valid(pdu: &[u8], response: &[u8]) -> Result<(), String> {
    let fc = pdu[0];
    let bad = || Err(format!("{pdu:02X?} -> {response:02X?}"));
    match response {
        [e, code] if *e == fc | 0x80 && (1..=3).contains(code) => Ok(()),
        [f, n, rest @ ..]
            if *f == fc && matches!(fc, 1..=4 | 23) && usize::from(*n) == rest.len() =>
        {
            Ok(())
        }
        [f, ..] if *f == fc && matches!(fc, 5 | 6) && response == pdu => Ok(()),
        [f, ..] if *f == fc && matches!(fc, 15 | 16) && response == &pdu[..5] => Ok(()),
        _ => bad(),
    }
}

/// The four float register pairs (temp, temp_lo, half, half_lo) as read by a client.
fn floats(raw: &mut Raw) -> [f32; 4] {
    let mut words = Vec::new();
    for address in [0u8, 10] {
        let r = raw.request(999, &[0x03, 0, address, 0, 4]);
        assert_eq!(r[..2], [0x03, 8], "{r:?}");
        words.extend(
            r[2..]
                .chunks(2)
                .map(|b| u32::from(u16::from_be_bytes([b[0], b[1]]))),
        );
    }
    let w = |i: usize| words[i];
    [
        f32::from_bits((w(0) << 16) | w(1)),
        f32::from_bits((w(3) << 16) | w(2)),
        f32::from_bits((w(4) << 16) | w(5)),
        f32::from_bits((w(7) << 16) | w(6)),
    ]
}

fn started(dir: &std::path::Path) -> (Plc, SocketAddr) {
    std::fs::write(dir.join("calc.st"), CALC).unwrap();
    let conf = dir.join("plc.conf");
    std::fs::write(&conf, PLC).unwrap();
    let opts = RunOptions {
        plc_id: petriplc_runtime::harness::plc_id(),
        duration: Some(Duration::from_secs(600)),
        known_kinds: &["modbus_server", "modbus_client", "iec"],
        overrides: Vec::new(),
    };
    let plc = Plc::start(&conf, registry, &opts).unwrap_or_else(|e| panic!("{e}"));
    let start = Instant::now();
    let addr = loop {
        let detail = detail(&plc, "fz");
        if let Some(a) = tcp_address(&detail) {
            break a;
        }
        assert!(start.elapsed() < PATIENCE, "no address in `{detail}`");
        std::thread::sleep(Duration::from_millis(10));
    };
    (plc, addr)
}

fn detail(plc: &Plc, module: &str) -> String {
    plc.status()
        .modules
        .iter()
        .find(|m| m.name == module)
        .map(|m| m.detail.clone())
        .unwrap_or_default()
}

fn scans(plc: &Plc, module: &str) -> u64 {
    plc.status()
        .modules
        .iter()
        .find(|m| m.name == module)
        .map_or(0, |m| m.scans)
}

fn failed(plc: &Plc) -> Vec<String> {
    plc.status()
        .modules
        .iter()
        .filter(|m| m.state == ModuleState::Failed)
        .map(|m| format!("{}: {}", m.name, m.detail))
        .collect()
}

#[test]
fn random_frames_never_stop_the_plc_nor_let_a_bad_value_in() {
    let dir = tempfile::tempdir().unwrap();
    let (plc, addr) = started(dir.path());
    let good = RefCell::new(Raw::connect(addr));
    let conn = RefCell::new(Raw::connect(addr));
    // Warm up (the first answers allocate what the server keeps), then measure.
    for _ in 0..200 {
        assert!(floats(&mut good.borrow_mut()).iter().all(|f| f.is_finite()));
    }
    let rss_before = vm_rss_kb();
    let scans_before = scans(&plc, "calc");
    let tid = RefCell::new(0u16);
    let mut runner = TestRunner::new(Config {
        cases: 300,
        failure_persistence: None,
        ..Config::default()
    });
    runner
        .run(&proptest::collection::vec(frame(), 1..12), |frames| {
            for f in &frames {
                match f {
                    Frame::Request(pdu) => {
                        let mut t = tid.borrow_mut();
                        *t = t.wrapping_add(1);
                        let response = conn.borrow_mut().request(*t, pdu);
                        if let Err(e) = valid(pdu, &response) {
                            return Err(TestCaseError::fail(e));
                        }
                    }
                    Frame::Raw(bytes) => {
                        let mut raw = Raw::connect(addr);
                        raw.send(bytes);
                        raw.stream.shutdown(std::net::Shutdown::Write).unwrap();
                        // The server answers what is whole and closes once the client has:
                        // reading to the end must finish (the read timeout is PATIENCE).
                        let mut sink = Vec::new();
                        let read = raw.stream.read_to_end(&mut sink);
                        prop_assert!(read.is_ok(), "{bytes:02X?}: {read:?}");
                    }
                }
            }
            let values = floats(&mut good.borrow_mut());
            prop_assert!(values.iter().all(|f| f.is_finite()), "{values:?}");
            let failed = failed(&plc);
            prop_assert!(failed.is_empty(), "{failed:?}");
            Ok(())
        })
        .unwrap();
    // The PLC scanned on: the program's scans kept coming, and a good write still goes
    // through the program.
    let start = Instant::now();
    let target = scans(&plc, "calc") + 10;
    while scans(&plc, "calc") < target {
        assert!(start.elapsed() < PATIENCE, "calc stopped scanning");
        std::thread::sleep(Duration::from_millis(5));
    }
    assert!(scans(&plc, "calc") > scans_before);
    let mut good = good.into_inner();
    assert_eq!(
        good.request(1, &fc16(0, &[0x4120, 0])),
        fc16(0, &[0x4120, 0])[..5]
    );
    let start = Instant::now();
    while floats(&mut good)[2] != 5.0 {
        assert!(start.elapsed() < PATIENCE, "{:?}", floats(&mut good));
        std::thread::sleep(Duration::from_millis(5));
    }
    // Bounded memory: the connections and requests of the run leave nothing behind but
    // what a generous allowance covers (the allocator keeps some).
    let rss_after = vm_rss_kb();
    assert!(
        rss_after < rss_before + 32 * 1024,
        "VmRSS grew from {rss_before} kB to {rss_after} kB"
    );
    let status = detail(&plc, "fz");
    assert!(count(&status, " values refused") > 0, "{status}");
    plc.stop();
    let last = plc.wait(&AtomicBool::new(false));
    assert!(
        last.modules.iter().all(|m| m.state != ModuleState::Failed),
        "{last}"
    );
}
