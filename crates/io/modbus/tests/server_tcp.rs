//! modbus_server over TCP, driven scan by scan: every function code through tokio-modbus's
//! client, 32-bit and f32 values in both word orders, every exception, writes reaching only
//! owned points and only at the next scan, pipelined requests, many clients at once, idle
//! timeouts, max_clients, malformed frames (by hand and random) while another client is
//! served, and a close that does not hang.

mod server_support;

use std::cell::RefCell;
use std::io::Read;
use std::sync::mpsc;
use std::time::Duration;

use petriplc_config::PointValue;
use proptest::prelude::*;
use proptest::test_runner::{Config, TestRunner};
use server_support::{adu, eventually, runtime, start_err, Raw, Server, PATIENCE};
use tokio_modbus::prelude::*;

/// Points owned by `mb` may be written by clients; `probe`'s are read-only and set by it.
const CONF: &str = "\
[PLC]
module mb modbus_server
module probe probe
point C0 \"coil 0\" mb
point C1 \"coil 1\" mb
point C2 \"coil 2\" mb
point Cn \"coil of another module\" probe
point D0 \"input bit\" probe
point D1 \"input bit\" probe
point H8 \"8-bit\" mb u8
point H16 \"16-bit\" mb u16
point Hi \"signed\" mb i16
point H32 \"32-bit\" mb u32
point Hf \"float\" mb f32
point Hfl \"float, low first\" mb f32
point Hro \"read-only holding\" probe u16
point I16 \"input\" probe u16
point I32 \"signed input\" probe i32
point If \"float input\" probe f32
point N4 \"a counter\" probe u4
[mb]
listen = 127.0.0.1:0
coil 0 C0
coil 1 C1
coil 2 C2
coil 3 Cn
discrete_input 0 D0
discrete_input 1 D1
discrete_input 2 C0
discrete_input 3 N4
holding 0 H8
holding 1 H16
holding 2 Hi
holding 3 H32 u32
holding 5 Hf f32
holding 7 Hfl f32 low_first
holding 9 Hro
input 0 I16
input 1 I32 i32 low_first
input 3 If
[probe]
set Cn 1
set D0 1
set Hro 77
set I16 4660
set I32 -2
set If 1.5
set N4 9
";

/// [`CONF`] with more settings in the `[mb]` section (lines).
fn with_settings(extra: &str) -> String {
    CONF.replace(
        "listen = 127.0.0.1:0",
        &format!("listen = 127.0.0.1:0\n{extra}"),
    )
}

async fn connect(srv: &Server) -> client::Context {
    tcp::connect(srv.addr).await.unwrap()
}

#[test]
fn reads_every_table() {
    let srv = Server::start(CONF);
    let rt = runtime();
    rt.block_on(async {
        let mut c = connect(&srv).await;
        assert_eq!(
            c.read_coils(0, 4).await.unwrap().unwrap(),
            [false, false, false, true]
        );
        // An integer point in a bit table reads as non-zero.
        assert_eq!(
            c.read_discrete_inputs(0, 4).await.unwrap().unwrap(),
            [true, false, false, true]
        );
        assert_eq!(c.read_holding_registers(9, 1).await.unwrap().unwrap(), [77]);
        // I32 = -2 low word first; If = 1.5 (0x3FC00000) high word first.
        assert_eq!(
            c.read_input_registers(0, 5).await.unwrap().unwrap(),
            [4660, 0xFFFE, 0xFFFF, 0x3FC0, 0x0000]
        );
        // Half of a 32-bit value may be read.
        assert_eq!(
            c.read_input_registers(2, 1).await.unwrap().unwrap(),
            [0xFFFF]
        );
    });
    assert!(srv.status().contains("requests"), "{}", srv.status());
}

#[test]
fn writes_reach_owned_points_at_the_next_scan() {
    let mut srv = Server::start(CONF);
    let rt = runtime();
    let mut c = rt.block_on(connect(&srv));
    rt.block_on(async {
        c.write_single_coil(0, true).await.unwrap().unwrap();
        c.write_multiple_coils(1, &[false, true])
            .await
            .unwrap()
            .unwrap();
        c.write_single_register(0, 200).await.unwrap().unwrap();
        c.write_single_register(2, 0xFFFF).await.unwrap().unwrap();
        c.write_multiple_registers(3, &[0x0001, 0x0002])
            .await
            .unwrap()
            .unwrap();
        // 2.5f32 = 0x40200000, high word first at 5, low word first at 7.
        c.write_multiple_registers(5, &[0x4020, 0, 0, 0x4020])
            .await
            .unwrap()
            .unwrap();
        // A client reads its own writes at once, before any scan.
        assert_eq!(
            c.read_coils(0, 3).await.unwrap().unwrap(),
            [true, false, true]
        );
        assert_eq!(c.read_discrete_inputs(2, 1).await.unwrap().unwrap(), [true]);
        assert_eq!(
            c.read_holding_registers(0, 9).await.unwrap().unwrap(),
            [200, 0, 0xFFFF, 1, 2, 0x4020, 0, 0, 0x4020]
        );
    });
    // The points change only at the server's next scan.
    assert_eq!(srv.plc.get("C0"), PointValue::Unsigned(0));
    assert_eq!(srv.plc.get("H32"), PointValue::Unsigned(0));
    srv.tick();
    assert_eq!(srv.plc.get("C0"), PointValue::Unsigned(1));
    assert_eq!(srv.plc.get("C1"), PointValue::Unsigned(0));
    assert_eq!(srv.plc.get("C2"), PointValue::Unsigned(1));
    assert_eq!(srv.plc.get("H8"), PointValue::Unsigned(200));
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(0));
    assert_eq!(srv.plc.get("Hi"), PointValue::Signed(-1));
    assert_eq!(srv.plc.get("H32"), PointValue::Unsigned(0x0001_0002));
    assert_eq!(srv.plc.get("Hf"), PointValue::Float(2.5));
    assert_eq!(srv.plc.get("Hfl"), PointValue::Float(2.5));
    // Later writes win, in order.
    rt.block_on(async {
        c.write_single_register(1, 1).await.unwrap().unwrap();
        c.write_single_register(1, 2).await.unwrap().unwrap();
        c.write_single_register(1, 3).await.unwrap().unwrap();
    });
    srv.tick();
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(3));
    // The image still shows the points after more scans.
    srv.tick();
    rt.block_on(async {
        assert_eq!(
            c.read_holding_registers(0, 3).await.unwrap().unwrap(),
            [200, 3, 0xFFFF]
        );
    });
}

#[test]
fn read_write_multiple_writes_first() {
    let mut srv = Server::start(CONF);
    let rt = runtime();
    rt.block_on(async {
        let mut c = connect(&srv).await;
        let read = c
            .read_write_multiple_registers(0, 10, 1, &[4321, 0x8000])
            .await
            .unwrap()
            .unwrap();
        assert_eq!(read, [0, 4321, 0x8000, 0, 0, 0, 0, 0, 0, 77]);
    });
    srv.tick();
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(4321));
    assert_eq!(srv.plc.get("Hi"), PointValue::Signed(-32768));
}

#[test]
fn every_exception() {
    let mut srv = Server::start(CONF);
    let rt = runtime();
    rt.block_on(async {
        let mut c = connect(&srv).await;
        use ExceptionCode::*;
        // 01: a function the server does not implement.
        let r = c
            .call(Request::Custom(0x41, vec![0x0E, 1, 0].into()))
            .await
            .unwrap();
        assert_eq!(r.unwrap_err(), IllegalFunction);
        // 02: a read range not fully mapped.
        assert_eq!(
            c.read_holding_registers(9, 2).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.read_coils(0, 5).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.read_input_registers(100, 1).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.read_discrete_inputs(65535, 1).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        // 02: writes to points of other modules, to unmapped addresses, to half a 32-bit value.
        assert_eq!(
            c.write_single_coil(3, false).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.write_multiple_coils(2, &[true, true])
                .await
                .unwrap()
                .unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.write_single_register(9, 1).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.write_single_register(10, 1).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.write_single_register(3, 1).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.write_single_register(4, 1).await.unwrap().unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.write_multiple_registers(4, &[1, 2])
                .await
                .unwrap()
                .unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.read_write_multiple_registers(0, 1, 9, &[1])
                .await
                .unwrap()
                .unwrap_err(),
            IllegalDataAddress
        );
        assert_eq!(
            c.read_write_multiple_registers(8, 3, 0, &[1])
                .await
                .unwrap()
                .unwrap_err(),
            IllegalDataAddress
        );
        // 03: quantities out of the specification's limits.
        assert_eq!(
            c.read_holding_registers(0, 0).await.unwrap().unwrap_err(),
            IllegalDataValue
        );
        assert_eq!(
            c.read_holding_registers(0, 126).await.unwrap().unwrap_err(),
            IllegalDataValue
        );
        assert_eq!(
            c.read_coils(0, 2001).await.unwrap().unwrap_err(),
            IllegalDataValue
        );
        // 03: a value that does not fit its point (300 into u8), in any write function;
        // nothing of such a request is written.
        assert_eq!(
            c.write_single_register(0, 300).await.unwrap().unwrap_err(),
            IllegalDataValue
        );
        assert_eq!(
            c.write_multiple_registers(0, &[300, 5])
                .await
                .unwrap()
                .unwrap_err(),
            IllegalDataValue
        );
        assert_eq!(
            c.read_write_multiple_registers(0, 1, 0, &[256])
                .await
                .unwrap()
                .unwrap_err(),
            IllegalDataValue
        );
        assert_eq!(
            c.read_holding_registers(0, 2).await.unwrap().unwrap(),
            [0, 0]
        );
    });
    let mut raw = srv.raw();
    // 03: a coil value other than 0x0000 and 0xFF00.
    assert_eq!(raw.request(1, &[0x05, 0, 0, 0x12, 0x34]), [0x85, 0x03]);
    // 03: byte counts that do not match the quantity or the data.
    assert_eq!(
        raw.request(2, &[0x10, 0, 1, 0, 1, 4, 0, 1, 0, 2]),
        [0x90, 0x03]
    );
    assert_eq!(raw.request(3, &[0x10, 0, 1, 0, 1, 2, 0]), [0x90, 0x03]);
    assert_eq!(
        raw.request(4, &[0x0F, 0, 0, 0, 3, 2, 0xFF, 0xFF]),
        [0x8F, 0x03]
    );
    // 03: write quantities above the limits (123 registers, 1968 coils, 121 in FC23).
    let mut big = vec![0x10, 0, 0, 0, 124, 248];
    big.resize(6 + 248, 0);
    assert_eq!(raw.request(5, &big[..253]), [0x90, 0x03]);
    let mut rw = vec![0x17, 0, 0, 0, 1, 0, 0, 0, 122, 244];
    rw.resize(10 + 244, 0);
    assert_eq!(raw.request(6, &rw[..253]), [0x97, 0x03]);
    let mut coils = vec![0x0F, 0, 0, 0x07, 0xB1, 247];
    coils.resize(6 + 247, 0);
    assert_eq!(raw.request(7, &coils), [0x8F, 0x03]);
    // 03: a PDU shorter than its function needs, or longer.
    assert_eq!(raw.request(8, &[0x03, 0, 0]), [0x83, 0x03]);
    assert_eq!(raw.request(9, &[0x01, 0, 0, 0, 1, 0]), [0x81, 0x03]);
    assert_eq!(raw.request(10, &[0x17, 0, 0, 0, 1, 0, 0]), [0x97, 0x03]);
    // 01: codes that are no function, and the exception-response range.
    assert_eq!(raw.request(11, &[0x00]), [0x80, 0x01]);
    assert_eq!(raw.request(12, &[0x83, 0, 0, 0, 1]), [0x83, 0x01]);
    assert_eq!(raw.request(13, &[0x07]), [0x87, 0x01]);
    srv.tick();
    assert_eq!(srv.plc.get("H8"), PointValue::Unsigned(0));
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(0));
    assert_eq!(srv.plc.get("C0"), PointValue::Unsigned(0));
    let (_, requests, exceptions) = srv.counts();
    assert_eq!((requests, exceptions), (34, 33), "{}", srv.status());
}

#[test]
fn every_unit_id_is_answered_on_tcp() {
    let srv = Server::start(CONF);
    let mut raw = srv.raw();
    for unit in [0u8, 1, 17, 247, 255] {
        raw.send(&adu(7, unit, &[0x03, 0, 9, 0, 1]));
        assert_eq!(raw.read_adu(), (7, unit, vec![0x03, 2, 0, 77]));
    }
}

#[test]
fn several_requests_in_one_segment_are_all_answered_in_order() {
    pipelined("");
}

/// The same without io_uring: the answers are written with one send each.
#[test]
fn several_requests_in_one_segment_are_all_answered_in_order_without_io_uring() {
    pipelined("io_uring = no");
}

fn pipelined(setting: &str) {
    let mut srv = Server::start(&with_settings(setting));
    let mut raw = srv.raw();
    let requests: Vec<Vec<u8>> = vec![
        adu(1, 1, &[0x03, 0, 9, 0, 1]),
        adu(2, 1, &[0x06, 0, 1, 0x12, 0x34]),
        adu(3, 1, &[0x03, 0, 1, 0, 1]),
        adu(4, 1, &[0x2B, 0x0E]),
        adu(5, 1, &[0x05, 0, 0, 0xFF, 0]),
        adu(6, 1, &[0x01, 0, 0, 0, 4]),
        adu(7, 1, &[0x04, 0, 0, 0, 1]),
        adu(8, 1, &[0x03, 0, 100, 0, 1]),
    ];
    let expected: Vec<(u16, u8, Vec<u8>)> = vec![
        (1, 1, vec![0x03, 2, 0, 77]),
        (2, 1, vec![0x06, 0, 1, 0x12, 0x34]),
        (3, 1, vec![0x03, 2, 0x12, 0x34]),
        (4, 1, vec![0xAB, 0x01]),
        (5, 1, vec![0x05, 0, 0, 0xFF, 0]),
        (6, 1, vec![0x01, 1, 0b1001]),
        (7, 1, vec![0x04, 2, 0x12, 0x34]),
        (8, 1, vec![0x83, 0x02]),
    ];
    let all: Vec<u8> = requests.concat();
    raw.send(&all);
    for e in &expected {
        assert_eq!(&raw.read_adu(), e);
    }
    // Many at once (more than one read's buffer of 4096 bytes: a read that fills it must not
    // be taken as having drained the socket), and one split across two writes mid-header.
    let burst: Vec<u8> = (0..700u16)
        .flat_map(|t| adu(t, 1, &[0x03, 0, 9, 0, 1]))
        .collect();
    raw.send(&burst);
    for t in 0..700u16 {
        assert_eq!(raw.read_adu(), (t, 1, vec![0x03, 2, 0, 77]));
    }
    let one = adu(999, 1, &[0x03, 0, 9, 0, 1]);
    raw.send(&one[..3]);
    std::thread::sleep(Duration::from_millis(20));
    raw.send(&one[3..]);
    assert_eq!(raw.read_adu(), (999, 1, vec![0x03, 2, 0, 77]));
    srv.tick();
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(0x1234));
    assert_eq!(srv.plc.get("C0"), PointValue::Unsigned(1));
}

#[test]
fn many_clients_at_once() {
    const CLIENTS: usize = 20;
    let mut srv = Server::start(CONF);
    let addr = srv.addr;
    // Channels rather than barriers: a client that fails drops its sender, and the test
    // fails instead of waiting for it forever.
    let (connected_tx, connected) = mpsc::channel::<()>();
    let (done_tx, done) = mpsc::channel::<()>();
    let mut releases = Vec::new();
    let threads: Vec<_> = (0..CLIENTS)
        .map(|i| {
            let (connected_tx, done_tx) = (connected_tx.clone(), done_tx.clone());
            let (release_tx, release) = mpsc::channel::<()>();
            releases.push(release_tx);
            std::thread::spawn(move || {
                let mut raw = Raw::connect(addr);
                connected_tx.send(()).unwrap();
                for k in 0..200u16 {
                    let tid = (i as u16) << 8 | (k & 0xFF);
                    assert_eq!(raw.request(tid, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
                    assert_eq!(raw.request(tid, &[0x04, 0, 0, 0, 1]), [0x04, 2, 0x12, 0x34]);
                }
                if i == 0 {
                    assert_eq!(raw.request(1, &[0x06, 0, 1, 0, 42]), [0x06, 0, 1, 0, 42]);
                }
                done_tx.send(()).unwrap();
                let _ = release.recv_timeout(PATIENCE);
            })
        })
        .collect();
    drop((connected_tx, done_tx));
    for _ in 0..CLIENTS {
        connected
            .recv_timeout(PATIENCE)
            .expect("every client connects");
    }
    // Every client is connected, and served, at the same time as the others.
    eventually(&mut srv, "20 clients", |s| s.counts().0 == CLIENTS as u64);
    for _ in 0..CLIENTS {
        done.recv_timeout(PATIENCE)
            .expect("every client gets its answers");
    }
    assert_eq!(srv.counts().0, CLIENTS as u64);
    for r in releases {
        r.send(()).unwrap();
    }
    for t in threads {
        t.join().unwrap();
    }
    srv.tick();
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(42));
    eventually(&mut srv, "all clients gone", |s| s.counts().0 == 0);
    assert_eq!(srv.counts().1, (CLIENTS * 400 + 1) as u64);
}

#[test]
fn max_clients_refuses_further_connections() {
    let mut srv = Server::start(&with_settings("max_clients = 2"));
    let mut a = srv.raw();
    let mut b = srv.raw();
    assert_eq!(a.request(1, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    assert_eq!(b.request(1, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    let mut c = srv.raw();
    c.send(&adu(1, 1, &[0x03, 0, 9, 0, 1]));
    assert!(c.closed(), "a third client is closed");
    assert_eq!(a.request(2, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    drop(b);
    eventually(&mut srv, "one client gone", |s| s.counts().0 == 1);
    let mut d = srv.raw();
    assert_eq!(d.request(1, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
}

#[test]
fn at_max_clients_the_longest_idle_connection_makes_room() {
    let srv = Server::start(&with_settings("max_clients = 2\nidle_timeout = 60"));
    let mut a = srv.raw();
    let mut b = srv.raw();
    assert_eq!(a.request(1, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    assert_eq!(b.request(1, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    // Both idle for more than a second (not the 60 s idle timeout): a third client gets in
    // in place of the one idle the longest, `a`.
    std::thread::sleep(Duration::from_millis(1300));
    assert_eq!(b.request(2, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    let mut c = srv.raw();
    assert_eq!(c.request(1, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    assert!(a.closed(), "the idlest connection made room");
    assert_eq!(b.request(3, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
}

#[test]
fn several_network_threads_share_the_connections() {
    let mut srv = Server::start(&with_settings("threads = 3\nmax_clients = 4"));
    // Connections are handed to the threads in turn; every one is answered, the count of
    // clients is shared, and one closing frees a place on any thread.
    let mut clients: Vec<_> = (0..4).map(|_| srv.raw()).collect();
    for round in 0..3 {
        for c in clients.iter_mut() {
            assert_eq!(c.request(round, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
        }
    }
    let mut refused = srv.raw();
    refused.send(&adu(1, 1, &[0x03, 0, 9, 0, 1]));
    assert!(refused.closed(), "a fifth client is closed");
    clients.pop();
    eventually(&mut srv, "one client gone", |s| s.counts().0 == 3);
    let mut again = srv.raw();
    assert_eq!(again.request(7, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    assert_eq!(srv.counts().1, 13);
}

/// Whether the server has closed `raw`'s connection, without waiting.
fn closed_now(raw: &Raw) -> bool {
    raw.stream.set_nonblocking(true).unwrap();
    let mut b = [0u8; 16];
    let closed = match (&raw.stream).read(&mut b) {
        Ok(0) => true,
        Ok(_) => false,
        Err(e) => e.kind() != std::io::ErrorKind::WouldBlock,
    };
    raw.stream.set_nonblocking(false).unwrap();
    closed
}

#[test]
fn idle_connections_time_out() {
    let srv = Server::start(&with_settings("idle_timeout = T#1s"));
    // A half header that never completes, and a connection that never sends.
    let mut half = srv.raw();
    half.send(&[0, 1, 0]);
    let silent = srv.raw();
    // A client that keeps asking (every 20 ms, far inside the 1 s: a margin a loaded
    // machine's scheduling does not eat) stays connected, although its requests span several
    // idle periods and the others are closed meanwhile.
    let mut busy = srv.raw();
    let started = std::time::Instant::now();
    let mut t = 0u16;
    while !(closed_now(&half) && closed_now(&silent))
        || started.elapsed() < Duration::from_millis(2500)
    {
        assert!(
            started.elapsed() < PATIENCE,
            "the idle connections were never closed"
        );
        t = t.wrapping_add(1);
        assert_eq!(busy.request(t, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(busy.request(99, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
}

#[test]
fn a_client_that_reads_no_answers_is_closed_at_its_idle_timeout() {
    reads_no_answers("");
}

#[test]
fn a_client_that_reads_no_answers_is_closed_without_io_uring_too() {
    reads_no_answers("io_uring = no");
}

fn reads_no_answers(setting: &str) {
    let srv = Server::start(&with_settings(&format!(
        "idle_timeout = T#300ms\n{setting}"
    )));
    // It sends requests and never reads: once the socket buffers are full the server stops
    // reading its requests, and closes it when it has taken no answer for the idle timeout.
    // Its writes then fail.
    let mut stuck = std::net::TcpStream::connect(srv.addr).unwrap();
    let (done, ended) = mpsc::channel();
    std::thread::spawn(move || {
        use std::io::Write;
        let burst: Vec<u8> = (0..1000u16)
            .flat_map(|t| adu(t, 1, &[0x03, 0, 9, 0, 1]))
            .collect();
        let e = loop {
            if let Err(e) = stuck.write_all(&burst) {
                break e;
            }
        };
        let _ = done.send(e.kind());
    });
    // Meanwhile another client is served.
    let mut other = srv.raw();
    for t in 0..20 {
        assert_eq!(other.request(t, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    }
    let kind = ended
        .recv_timeout(PATIENCE)
        .expect("the client that reads nothing is closed");
    assert!(
        matches!(
            kind,
            std::io::ErrorKind::ConnectionReset | std::io::ErrorKind::BrokenPipe
        ),
        "{kind:?}"
    );
    // (`other` has been idle meanwhile: a new client.)
    assert_eq!(srv.raw().request(99, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
}

/// The scheduler state of this process's thread named `name` ('R' running, 'S' sleeping).
fn thread_state(name: &str) -> Option<char> {
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let dir = task.ok()?.path();
        if std::fs::read_to_string(dir.join("comm")).ok()?.trim_end() != name {
            continue;
        }
        let stat = std::fs::read_to_string(dir.join("stat")).ok()?;
        // The state follows the command name, which is in parentheses and may hold spaces.
        return stat.rsplit_once(") ")?.1.chars().next();
    }
    None
}

#[test]
fn busy_polling_stops_when_the_requests_stop() {
    let srv = Server::start(&with_settings("busy_poll = 10ms\nidle_timeout = 0"));
    let mut raw = srv.raw();
    for round in 0..3u16 {
        for t in 0..50 {
            assert_eq!(raw.request(t, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
        }
        // The network thread polls for 10 ms after the last request, then sleeps until the
        // next: seen asleep a few times in a row, it is not polling any more.
        let deadline = std::time::Instant::now() + PATIENCE;
        let mut asleep = 0;
        while asleep < 5 {
            assert!(
                std::time::Instant::now() < deadline,
                "round {round}: the network thread still runs (state {:?}) long after the \
                 last request",
                thread_state("modbus mb 0")
            );
            std::thread::sleep(Duration::from_millis(20));
            match thread_state("modbus mb 0") {
                Some('S') => asleep += 1,
                Some(_) => asleep = 0,
                None => panic!("no thread `modbus mb 0`"),
            }
        }
    }
    assert_eq!(raw.request(7, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
}

#[test]
fn malformed_headers_close_only_their_connection() {
    let srv = Server::start(CONF);
    let mut good = srv.raw();
    let bad_headers: [&[u8]; 6] = [
        // protocol id 1
        &[0, 1, 0, 1, 0, 6, 1, 3, 0, 0, 0, 1],
        // length 0, 1, 255, 0xFFFF
        &[0, 1, 0, 0, 0, 0, 1],
        &[0, 1, 0, 0, 0, 1, 1],
        &[0, 1, 0, 0, 0, 255, 1, 3],
        &[0, 1, 0, 0, 0xFF, 0xFF, 1],
        // text
        b"GET / HTTP/1.1\r\n\r\n",
    ];
    for bytes in bad_headers {
        let mut bad = srv.raw();
        bad.send(bytes);
        assert!(bad.closed(), "{bytes:?} closes the connection");
        assert_eq!(good.request(1, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    }
    // Requests before a bad header in the same segment are still answered.
    let mut mixed = srv.raw();
    let mut bytes = adu(5, 1, &[0x03, 0, 9, 0, 1]);
    bytes.extend_from_slice(&[0, 6, 0, 9, 0, 2, 1, 3]);
    mixed.send(&bytes);
    assert_eq!(mixed.read_adu(), (5, 1, vec![0x03, 2, 0, 77]));
    assert!(mixed.closed());
    // A wrong length that still frames (too short for its function) gets 03 and the
    // connection stays.
    assert_eq!(good.request(2, &[0x03, 0, 9]), [0x83, 0x03]);
    assert_eq!(good.request(3, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
}

#[test]
fn random_garbage_never_stops_the_server() {
    let srv = Server::start(CONF);
    let addr = srv.addr;
    let good = RefCell::new(srv.raw());
    let mut runner = TestRunner::new(Config {
        cases: 128,
        failure_persistence: None,
        ..Config::default()
    });
    let garbage = prop_oneof![
        proptest::collection::vec(any::<u8>(), 0..600),
        // Valid-looking headers with random PDUs, so that the PDU decoding sees garbage too.
        (
            any::<u16>(),
            any::<u8>(),
            proptest::collection::vec(any::<u8>(), 1..253)
        )
            .prop_map(|(t, u, pdu)| adu(t, u, &pdu)),
    ];
    runner
        .run(&garbage, |bytes| {
            let mut raw = Raw::connect(addr);
            raw.send(&bytes);
            raw.stream.shutdown(std::net::Shutdown::Write).unwrap();
            // Whatever the server answers, it ends the connection once the client has.
            let mut sink = Vec::new();
            let _ = raw.stream.read_to_end(&mut sink);
            assert_eq!(
                good.borrow_mut().request(1, &[0x03, 0, 9, 0, 1]),
                [0x03, 2, 0, 77]
            );
            Ok(())
        })
        .unwrap();
    // Random PDUs on one connection that stays open: every one is answered with a well
    // formed response or exception.
    let raw = RefCell::new(Raw::connect(addr));
    let mut runner = TestRunner::new(Config {
        cases: 512,
        failure_persistence: None,
        ..Config::default()
    });
    runner
        .run(&proptest::collection::vec(any::<u8>(), 1..253), |pdu| {
            let response = raw.borrow_mut().request(77, &pdu);
            let fc = pdu[0];
            prop_assert!(
                response[0] == fc || response[0] == fc | 0x80,
                "{pdu:?} -> {response:?}"
            );
            if response[0] & 0x80 != 0 {
                prop_assert_eq!(response.len(), 2);
                prop_assert!((1..=3).contains(&response[1]));
            }
            Ok(())
        })
        .unwrap();
    assert_eq!(
        good.borrow_mut().request(2, &[0x03, 0, 9, 0, 1]),
        [0x03, 2, 0, 77]
    );
}

#[test]
fn close_does_not_hang_with_clients_connected() {
    let srv = Server::start(CONF);
    let mut a = srv.raw();
    let mut b = srv.raw();
    b.send(&[0, 1, 0, 0]);
    assert_eq!(a.request(1, &[0x03, 0, 9, 0, 1]), [0x03, 2, 0, 77]);
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut srv = srv;
        srv.plc.close();
        drop(srv);
        tx.send(()).unwrap();
    });
    rx.recv_timeout(Duration::from_secs(10))
        .expect("close returns");
    assert!(a.closed());
    assert!(b.closed());
}

#[test]
fn port_zero_is_reported() {
    let srv = Server::start(CONF);
    assert_ne!(srv.addr.port(), 0);
    assert!(
        srv.status()
            .starts_with(&format!("tcp {}; 0 clients", srv.addr)),
        "{}",
        srv.status()
    );
}

fn conf(section: &str) -> String {
    format!(
        "[PLC]\nmodule mb modbus_server\nmodule probe probe\npoint B \"bool\" mb\n\
         point N \"u8\" mb u8\npoint S \"i16\" mb i16\npoint F \"float\" mb f32\n\
         point W \"u32\" probe u32\npoint Q \"i1\" mb i1\n[mb]\nlisten = 127.0.0.1:0\n{section}"
    )
}

#[test]
fn bad_rows_are_refused_with_their_line() {
    for (rows, says) in [
        ("coil 0 nope\n", "test.conf:12: no point named `nope`"),
        ("coils 0 B\nregisters 1 N\n", "test.conf:13: unknown table `registers`"),
        ("holding 0 N\nholding 0 S\n", "test.conf:13: holding address 0 of point `S` is already taken by point `N` (test.conf:12)"),
        ("holding 0 W\nholding 1 S\n", "address 1 of point `S` is already taken by point `W`"),
        ("holding 65535 W\n", "test.conf:12: u32 at address 65535 takes 2 registers"),
        ("holding 70000 N\n", "test.conf:12: address `70000` is not valid"),
        ("holding 0 N f32\n", "type f32 cannot hold point `N` (u8); use u16"),
        ("holding 0 F u32\n", "type u32 cannot hold point `F` (a float); use f32"),
        ("holding 0 S u16\n", "type u16 cannot hold point `S` (i16); use i16"),
        ("holding 0 N u16 low_first\n", "a word order means nothing for u16"),
        ("holding 0 W u32 big\n", "`big` is neither a register type"),
        ("holding 0\n", "a holding row is `holding ADDRESS POINT"),
        ("coil 0 F\n", "point `F` is a float: a coil is one bit"),
        ("coil 0 B u16\n", "a coil row is `coil ADDRESS POINT`"),
        ("discrete_input 0 Q\n", "declare it `u1`"),
    ] {
        let e = start_err(&conf(rows));
        assert!(e.contains(says), "{rows}: {e}");
        assert!(e.starts_with("module mb: "), "{e}");
    }
    // Every problem at once, one per line.
    let e = start_err(&conf("coil 0 x\ncoil 1 y\n"));
    assert_eq!(e.lines().count(), 2, "{e}");
}

#[test]
fn bad_settings_are_refused() {
    for (settings, says) in [
        ("unit = 0\n", "`unit = 0`: an RTU slave address is 1 to 247"),
        ("unit = 248\n", "1 to 247"),
        ("idle_timeout = soon\n", "`idle_timeout = soon`"),
        ("max_clients = 0\n", "`max_clients = 0`"),
        (
            "threads = 0\n",
            "`threads = 0`: write a whole number from 1 to 64",
        ),
        ("threads = many\n", "`threads = many`"),
        ("busy_poll = soon\n", "`busy_poll = soon`: "),
        ("busy_poll = 1s\n", "`busy_poll = 1s`: at most 10 ms"),
        (
            "io_uring = maybe\n",
            "`io_uring = maybe`: write `io_uring = yes`",
        ),
        ("word_order = big\n", "write high_first or low_first"),
        ("serial = /dev/ttyS0:9600:9Z1\n", "frame `9Z1`"),
        ("port = 502\n", "unknown setting `port`"),
        (
            "serial = /nonexistent/tty\n",
            "cannot open serial port /nonexistent/tty",
        ),
    ] {
        let e = start_err(&conf(settings));
        assert!(e.contains(says), "{settings}: {e}");
    }
    let e = start_err(&conf("").replace("listen = 127.0.0.1:0", "listen = nowhere"));
    assert!(e.contains("`listen = nowhere`: write HOST:PORT"), "{e}");
}

#[test]
fn listen_off_without_serial_turns_the_server_off() {
    let srv = Server::start(
        &conf(
            "coil 0 B
",
        )
        .replace("listen = 127.0.0.1:0", "listen = off"),
    );
    assert!(
        srv.status()
            .starts_with("off (listen = off, no serial); 0 clients"),
        "{}",
        srv.status()
    );
}

#[test]
fn a_taken_port_is_an_init_error() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port();
    let e = start_err(&conf("").replace("127.0.0.1:0", &format!("127.0.0.1:{port}")));
    assert!(
        e.contains(&format!("cannot listen on 127.0.0.1:{port}")),
        "{e}"
    );
}

#[test]
fn writes_piling_up_between_scans_keep_the_last_value() {
    let mut srv = Server::start(CONF);
    let mut raw = srv.raw();
    let burst: Vec<u8> = (0..3000u16)
        .flat_map(|v| adu(v, 1, &[0x06, 0, 1, (v >> 8) as u8, v as u8]))
        .collect();
    raw.send(&burst);
    for v in 0..3000u16 {
        assert_eq!(raw.read_adu().0, v);
    }
    srv.tick();
    assert_eq!(srv.plc.get("H16"), PointValue::Unsigned(2999));
}
