//! `modbus_client` against a hostile device: a fake Modbus TCP device in the test answers
//! each request as a proptest script says (random register values with every NaN/Inf
//! pattern, wrong byte counts, wrong lengths, exceptions, garbage, silence, a hang-up) while
//! the module scans: it never fails, no float point ever holds a non-finite value, a refused
//! value leaves its point as it was with the stale point set, and once the device answers
//! well again everything lands. Also `connect_within`: a device that never answers fails the
//! module, one that answers in time does not.

mod client_support;

use std::collections::VecDeque;
use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use client_support::*;
use petriplc_config::PointValue;
use petriplc_runtime::harness::ms;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};

/// How the fake device answers one request.
#[derive(Clone, Debug)]
enum Answer {
    /// The right shape, with these register values (bits: their low bits), repeated as
    /// needed.
    Values(Vec<u16>),
    /// The right function, with `extra` more (or fewer) values than asked and a byte count
    /// that says so, or lies.
    WrongCount { extra: i8, lie: bool },
    /// An exception response with this code.
    Exception(u8),
    /// An answer whose MBAP header is right and whose PDU is these bytes.
    Pdu(Vec<u8>),
    /// Bytes instead of an answer.
    Garbage(Vec<u8>),
    /// No answer: the client's timeout.
    Silence,
    /// The connection closed.
    HangUp,
}

/// The values that make f32 points fail: every NaN/Inf pattern, as words.
fn word() -> impl Strategy<Value = u16> {
    prop_oneof![
        3 => any::<u16>(),
        2 => prop::sample::select(vec![0x7FC0u16, 0xFFC0, 0x7F80, 0xFF80, 0x7FFF, 0xFFFF, 0x0001, 0]),
    ]
}

fn answer() -> impl Strategy<Value = Answer> {
    prop_oneof![
        8 => proptest::collection::vec(word(), 1..8).prop_map(Answer::Values),
        1 => (-3i8..4, any::<bool>()).prop_map(|(extra, lie)| Answer::WrongCount { extra, lie }),
        1 => any::<u8>().prop_map(Answer::Exception),
        1 => proptest::collection::vec(any::<u8>(), 0..40).prop_map(Answer::Pdu),
        1 => proptest::collection::vec(any::<u8>(), 1..80).prop_map(Answer::Garbage),
        1 => Just(Answer::Silence),
        1 => Just(Answer::HangUp),
    ]
}

/// The fake device's state: the answers still to give, the values it answers once they are
/// given, and how many requests it has had.
struct Script {
    answers: VecDeque<Answer>,
    then: Vec<u16>,
    requests: u64,
}

/// The good values the device gives once its script is used up: fa 21.5, fb -0.75 (low word
/// first), small 200, s -7, coils on, off.
const GOOD: [u16; 6] = [0x41AC, 0x0000, 0x0000, 0xBF40, 200, 0xFFF9];

struct Device {
    addr: SocketAddr,
    script: Arc<Mutex<Script>>,
}

impl Device {
    fn start() -> Device {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let addr = listener.local_addr().unwrap();
        let script = Arc::new(Mutex::new(Script {
            answers: VecDeque::new(),
            then: GOOD.to_vec(),
            requests: 0,
        }));
        let shared = script.clone();
        std::thread::spawn(move || {
            for stream in listener.incoming() {
                let Ok(stream) = stream else { return };
                serve(stream, &shared);
            }
        });
        Device { addr, script }
    }
}

/// Answers one connection's requests until the client closes it or an answer hangs up.
fn serve(mut stream: TcpStream, script: &Mutex<Script>) {
    let _ = stream.set_nodelay(true);
    loop {
        let mut header = [0u8; 7];
        if stream.read_exact(&mut header).is_err() {
            return;
        }
        let len = usize::from(u16::from_be_bytes([header[4], header[5]]));
        let mut pdu = vec![0u8; len.saturating_sub(1)];
        if stream.read_exact(&mut pdu).is_err() {
            return;
        }
        let answer = {
            let mut s = script.lock().unwrap();
            s.requests += 1;
            let then = Answer::Values(s.then.clone());
            s.answers.pop_front().unwrap_or(then)
        };
        let fc = pdu[0];
        let quantity = usize::from(u16::from_be_bytes([pdu[3], pdu[4]]));
        let body: Vec<u8> = match answer {
            Answer::Values(words) => respond(fc, &pdu, quantity, &words),
            Answer::WrongCount { extra, lie } => {
                let n = (quantity as i64 + i64::from(extra)).max(0) as usize;
                let mut b = respond(fc, &pdu, n, &[0x4000, 0]);
                if lie && b.len() > 1 {
                    b[1] = b[1].wrapping_add(2);
                }
                b
            }
            Answer::Exception(code) => vec![fc | 0x80, code],
            Answer::Pdu(bytes) => bytes,
            Answer::Garbage(bytes) => {
                if stream.write_all(&bytes).is_err() {
                    return;
                }
                continue;
            }
            Answer::Silence => continue,
            Answer::HangUp => return,
        };
        let mut out = header[..4].to_vec();
        out.extend(((body.len() + 1) as u16).to_be_bytes());
        out.push(header[6]);
        out.extend(body);
        if stream.write_all(&out).is_err() {
            return;
        }
    }
}

/// A well-formed answer to `pdu` carrying `n` values from `words` (repeated).
fn respond(fc: u8, pdu: &[u8], n: usize, words: &[u16]) -> Vec<u8> {
    let w = |i: usize| words[i % words.len()];
    match fc {
        1 | 2 => {
            let mut b = vec![fc, n.div_ceil(8) as u8];
            b.extend((0..n.div_ceil(8)).map(|i| w(i) as u8));
            b
        }
        3 | 4 => {
            let mut b = vec![fc, (2 * n) as u8];
            b.extend((0..n).flat_map(|i| w(i).to_be_bytes()));
            b
        }
        // Writes: echoed.
        5 | 6 => pdu.to_vec(),
        _ => pdu[..5.min(pdu.len())].to_vec(),
    }
}

fn config(addr: SocketAddr, extra: &str) -> String {
    format!(
        r#"
[PLC]
module io modbus_client
module setter idle
point fa "f32, high word first" io f init 1.5
point fb "f32, low word first" io f init 2.5
point small "" io u8 init 9
point s "" io i16
point c0 "" io
point c1 "" io
point out "" setter f init 3.25
point offline "" io
[io]
backoff_max = 20ms
{extra}
device dev tcp:{addr} 1 10ms 100ms
read dev holding 0 fa
read dev holding 2 fb f32 low_first
read dev holding 4 small
read dev holding 5 s
read dev coil 0 c0
read dev coil 1 c1
write dev holding 20 out
stale dev offline
"#
    )
}

fn finite(run: &Run) -> Result<(), String> {
    for p in ["fa", "fb"] {
        match run.plc.get(p) {
            PointValue::Float(f) if f.is_finite() => {}
            v => return Err(format!("{p} = {v:?}; {}", run.status())),
        }
    }
    Ok(())
}

#[test]
fn no_bad_value_from_a_hostile_device_reaches_a_point() {
    let device = Device::start();
    // First NaN, -Inf and 300 for a u8, every cycle: refused, the points as they were, stale.
    device.script.lock().unwrap().then = vec![0x7FC0, 0, 0, 0xFF80, 300, 1];
    let mut run = Run::start(&config(device.addr, ""));
    run.until("the refusals", |p| {
        let status = p.status("io");
        status.starts_with("dev connected") && count(&status, "value") >= 3
    });
    assert_eq!(run.plc.get("fa"), PointValue::Float(1.5));
    assert_eq!(run.plc.get("fb"), PointValue::Float(2.5));
    assert_eq!(run.plc.get("small"), PointValue::Unsigned(9));
    assert_eq!(run.plc.value("offline"), 1, "{}", run.status());
    assert_eq!(run.plc.get("s"), PointValue::Signed(1));
    device.script.lock().unwrap().then = GOOD.to_vec();

    let mut runner = TestRunner::new(Config {
        cases: 48,
        failure_persistence: None,
        ..Config::default()
    });
    let run = std::cell::RefCell::new(run);
    runner
        .run(&proptest::collection::vec(answer(), 1..10), |answers| {
            let mut run = run.borrow_mut();
            let target = {
                let mut s = device.script.lock().unwrap();
                s.answers.extend(answers);
                s.requests + s.answers.len() as u64 + 1
            };
            // Scan until the device has given every answer and one more: every scan meanwhile
            // sees finite floats, and no scan fails (`tick` unwraps).
            let deadline = Instant::now() + Duration::from_secs(30);
            while device.script.lock().unwrap().requests < target {
                run.tick();
                finite(&run).map_err(TestCaseError::fail)?;
                prop_assert!(Instant::now() < deadline, "{}", run.status());
                std::thread::sleep(Duration::from_millis(2));
            }
            Ok(())
        })
        .unwrap();
    // The device answers well again: every value lands, the point is fresh, and what the
    // module writes arrives.
    let mut run = run.into_inner();
    run.until_values(
        "good values",
        &[
            ("fa", PointValue::Float(21.5)),
            ("fb", PointValue::Float(-0.75)),
            ("small", PointValue::Unsigned(200)),
            ("s", PointValue::Signed(-7)),
            ("offline", PointValue::Unsigned(0)),
        ],
    );
    let status = run.status();
    assert!(status.starts_with("dev connected ("), "{status}");
}

#[test]
fn connect_within_fails_only_a_device_that_never_answered() {
    // Nothing answers: the scan after 1 s of the module's time fails, naming the device.
    let silent = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = silent.local_addr().unwrap();
    drop(silent);
    let mut run = Run::start(&config(addr, "connect_within = 1s"));
    let mut error = None;
    for k in 1..=200u64 {
        match run.plc.tick(ms(10 * k)) {
            Ok(_) => {}
            Err(e) => {
                error = Some((k, e.to_string()));
                break;
            }
        }
    }
    let (k, e) = error.expect("the module failed");
    // The first scan is at 10 ms: 1 s later is the 101st.
    assert_eq!(k, 101, "{e}");
    assert!(
        e.contains(&format!(
            "device `dev` (tcp:{addr}, unit 1) never connected within connect_within = 1s"
        )),
        "{e}"
    );

    // A device that answers within the time: the module scans on past it, also once the
    // device has gone away.
    let device = Device::start();
    let mut run = Run::start(&config(device.addr, "connect_within = 1s"));
    run.until("a cycle", |p| p.status("io").starts_with("dev connected"));
    for _ in 0..200 {
        run.tick();
    }
    assert_eq!(run.plc.get("fa"), PointValue::Float(21.5));
}
