//! The `modbus_client` module against Modbus servers started in the test (tokio-modbus's
//! TCP and RTU servers over a register bank that records every request; a TCP server that
//! accepts and never answers; one that hangs up at once), driven scan by scan through the
//! runtime's harness while the client polls on real time.

mod client_support;

use std::net::TcpListener as StdListener;
use std::time::{Duration, Instant};

use client_support::*;
use petriplc_runtime::harness::{self, ms};

// ---------------------------------------------------------------------------------------
// Tests.

#[test]
fn reads_every_table_with_merged_requests_in_both_word_orders() {
    let mut b = Bank::default();
    b.coils.extend([(0, true), (1, false), (2, true)]);
    b.discrete.extend([(4, true)]);
    // holding 0: u16 1234; 1: i16 -5; 2-3: u32 0x12345678 high first; 4-5: the same low
    // first; 7 (a gap at 6): 300, too big for its u8 point; 8: 77 into another u8.
    b.holding.extend([
        (0, 1234),
        (1, (-5i16) as u16),
        (2, 0x1234),
        (3, 0x5678),
        (4, 0x5678),
        (5, 0x1234),
        (7, 300),
        (8, 77),
    ]);
    // input 10-11: f32 1.5 high first; 12-13: f32 -2.25 low first; 14-15: i32 -70000
    // low first.
    let minus = (-70000i32) as u32;
    b.input.extend([
        (10, 0x3FC0),
        (11, 0),
        (12, 0),
        (13, 0xC010),
        (14, minus as u16),
        (15, (minus >> 16) as u16),
    ]);
    let banks = banks([(1, b)]);
    let server = TcpServer::start(banks.clone());
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point c0 "coil 0" io
point c2 "coil 2" io
point c1 "coil 1" io
point d4 "discrete input 4" io
point h0 "" io u16
point h1 "" io i16
point big "" io u32
point little "" io u32
point small "" io u8 init 9
point h8 "" io u8
point fa "" io f
point fb "" io f
point s32 "" io i32
point stale "" io
[io]
device dev tcp:{} 1 20ms 2s
read dev coil 2 c2
read dev coil 0 c0
read dev coil 1 c1
read dev discrete_input 4 d4
read dev holding 0 h0
read dev holding 1 h1
read dev holding 2 big u32 high_first
read dev holding 4 little u32 low_first
read dev holding 7 small
read dev holding 8 h8
read dev input 10 fa
read dev input 12 fb f32 low_first
read dev input 14 s32 low_first
stale dev stale
"#,
        server.addr
    ));
    // 300 does not fit a u8: the point keeps its value; its neighbour is read all the same.
    let expected = [
        ("c0", u(1)),
        ("c1", u(0)),
        ("c2", u(1)),
        ("d4", u(1)),
        ("h0", u(1234)),
        ("h1", i(-5)),
        ("big", u(0x1234_5678)),
        ("little", u(0x1234_5678)),
        ("fa", f(1.5)),
        ("fb", f(-2.25)),
        ("s32", i(-70000)),
        ("h8", u(77)),
        ("small", u(9)),
    ];
    run.until_values("every value read", &expected);
    // A whole cycle done and the refusal counted: the next scan sees the device answering,
    // and still the stale point is set, since `small` holds an older value than the device.
    run.until("a whole cycle and the refusal", |p| {
        let status = p.status("io");
        status.starts_with("dev connected (") && count(&status, "value") >= 1
    });
    run.tick();
    assert_eq!(run.plc.value("stale"), 1, "{}", run.status());

    // One request per run of adjacent addresses, tables in order, gaps never read.
    let cycle = [
        "read coil 0+3",
        "read discrete_input 4+1",
        "read holding 0+6",
        "read holding 7+2",
        "read input 10+6",
    ];
    run.until("a steady cycle", |_| steady(&log_of(&banks, 1), &cycle));
    assert!(!log_of(&banks, 1).iter().any(|l| l.contains("holding 6")));
    assert!(
        run.status().starts_with("dev connected ("),
        "{}",
        run.status()
    );

    // A value that fits again lands, and the point is fresh again.
    banks
        .lock()
        .unwrap()
        .get_mut(&1)
        .unwrap()
        .holding
        .insert(7, 200);
    run.until_values("the fitting value", &[("small", u(200)), ("stale", u(0))]);
}

#[test]
fn writes_out_coils_and_registers_every_cycle() {
    let banks = banks([(7, Bank::default())]);
    // The cycle's last write (holding 30-31) comes 100 ms after the others: a test that
    // waits for one register and asserts another sees it missing.
    let server = TcpServer::start_slow(banks.clone(), Some((30, ms(100))));
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
module setter idle
point V1 "valve 1" setter
point V2 "valve 2" setter
point lamp "" setter
point sp "set point" setter f
point n32 "" setter u32
point s16 "" setter i16
point back "" setter f
[io]
device out tcp:{} 7 20ms
write out coil 0 V1
write out coil 1 V2
write out coil 5 lamp
write out holding 10 sp f32 low_first
write out holding 12 n32
write out holding 20 s16
write out holding 30 back f32 high_first
"#,
        server.addr
    ));
    run.set("V1", u(1));
    run.set("lamp", u(1));
    run.set("sp", f(-2.25));
    run.set("n32", u(0x1234_5678));
    run.set("s16", i(-2));
    run.set("back", f(1.5));
    let reg = |a: u16| banks.lock().unwrap()[&7].holding.get(&a).copied();
    let coil = |a: u16| banks.lock().unwrap()[&7].coils.get(&a).copied();
    // A cycle writes its requests one after the other: wait for every value asserted, not
    // for one of them (holding 20 is written before holding 30-31).
    let written = || ([0, 1, 5].map(coil), [10, 11, 12, 13, 20, 30, 31].map(reg));
    // -2.25f32 = 0xC0100000, low word first; 0x12345678 high word first by default; -2 as
    // i16; 1.5f32 = 0x3FC00000 high word first.
    run.until_eq(
        "the values written",
        written,
        (
            [Some(true), Some(false), Some(true)],
            [0, 0xC010, 0x1234, 0x5678, 0xFFFE, 0x3FC0, 0].map(Some),
        ),
    );
    let cycle = [
        "write coil 0+2",
        "write coil 5",
        "write holding 10+4",
        "write holding 20",
        "write holding 30+2",
    ];
    run.until("a steady cycle", |_| steady(&log_of(&banks, 7), &cycle));

    // New values go out with the next cycles.
    run.set("V1", u(0));
    run.set("V2", u(1));
    run.set("s16", i(300));
    run.until_eq(
        "the new values",
        || ([0, 1].map(coil), reg(20)),
        ([Some(false), Some(true)], Some(300)),
    );
}

#[test]
fn a_device_that_goes_away_is_stale_until_it_answers_again() {
    let mut b = Bank::default();
    b.holding.insert(0, 11);
    let banks = banks([(1, b)]);
    let mut server = TcpServer::start(banks.clone());
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
point offline "" io
[io]
backoff_max = 300ms
device dev tcp:{} 1 10ms 1s
read dev holding 0 x
stale dev offline
"#,
        server.addr
    ));
    run.until("the first value", |p| {
        p.value("x") == 11 && p.value("offline") == 0
    });

    server.stop();
    run.until("the device stale", |p| p.value("offline") == 1);
    assert!(
        run.status().starts_with("dev down since "),
        "{}",
        run.status()
    );
    // Several failed attempts, spaced by the back-off (at most 300 ms).
    run.until("three failed attempts", |p| {
        count(&p.status("io"), "failure") >= 3
    });

    banks
        .lock()
        .unwrap()
        .get_mut(&1)
        .unwrap()
        .holding
        .insert(0, 22);
    server.restart();
    run.until("the device back", |p| {
        p.value("offline") == 0 && p.value("x") == 22
    });
    let status = run.status();
    assert!(status.starts_with("dev connected ("), "{status}");
    assert!(count(&status, "failure") >= 3, "{status}");
}

#[test]
fn a_device_that_never_answers_times_out_and_close_does_not_wait_for_it() {
    let mute = Mute::start(false);
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
point offline "" io
[io]
device dev tcp:{} 1 20ms 100ms
read dev holding 0 x
stale dev offline
"#,
        mute.addr
    ));
    run.until("a timeout", |p| {
        p.status("io").contains("no answer within 100ms")
    });
    assert_eq!(run.plc.value("offline"), 1);
    // Each timeout drops the connection: the next attempt connects again. (The server's
    // reader sees the close on a thread of its own, maybe after the new connection came:
    // wait for both.)
    run.until("a connection closed and another made", |_| {
        let seen = mute.seen.lock().unwrap();
        seen.closed >= 1 && seen.accepted.len() >= 2
    });
    assert!(
        run.status().starts_with("dev never connected to "),
        "{}",
        run.status()
    );

    // A device in the middle of a long timeout: close must not wait for it.
    let slow = Mute::start(false);
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
[io]
device dev tcp:{} 1 20ms 1h
read dev holding 0 x
"#,
        slow.addr
    ));
    run.until("a request in flight", |_| {
        slow.seen.lock().unwrap().bytes > 0
    });
    // `close` waits a bounded time in any case; the polling thread must really have ended,
    // which closes the connection it was waiting on.
    run.plc.close();
    let deadline = Instant::now() + PATIENCE;
    while slow.seen.lock().unwrap().closed == 0 {
        assert!(Instant::now() < deadline, "the connection was never closed");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn reconnection_backs_off_doubling_up_to_the_maximum() {
    let hang_up = Mute::start(true);
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
[io]
backoff_max = 400ms
device dev tcp:{} 1 10ms
read dev holding 0 x
"#,
        hang_up.addr
    ));
    run.until("six attempts", |_| {
        hang_up.seen.lock().unwrap().accepted.len() >= 6
    });
    let times = hang_up.seen.lock().unwrap().accepted.clone();
    let gaps: Vec<Duration> = times.windows(2).map(|w| w[1] - w[0]).collect();
    // Waits of at least 100, 200, 400, 400 ms (then the next tick of the 10 ms period);
    // only lower bounds: a slow machine stretches them.
    for (gap, least) in gaps.iter().zip([100, 200, 400, 400, 400]) {
        assert!(*gap >= ms(least), "gaps {gaps:?}");
    }
}

#[test]
fn an_exception_response_marks_the_device_stale() {
    let mut b = Bank::default();
    b.holding.insert(0, 5);
    let banks = banks([(1, b)]);
    let server = TcpServer::start(banks.clone());
    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
point y "" io u16
point offline "" io
[io]
device dev tcp:{} 1 10ms
read dev holding 0 x
read dev holding 50 y
stale dev offline
"#,
        server.addr
    ));
    run.until("the exception", |p| {
        p.status("io")
            .contains("reading holding 50: exception 2 (Illegal data address)")
    });
    assert_eq!(run.plc.value("offline"), 1);
    // The request before the failing one was answered: its value is there.
    run.until("x", |p| p.value("x") == 5);
    banks
        .lock()
        .unwrap()
        .get_mut(&1)
        .unwrap()
        .holding
        .insert(50, 6);
    run.until("recovery", |p| p.value("offline") == 0 && p.value("y") == 6);
}

#[test]
fn rtu_devices_share_a_serial_line_through_a_pseudo_terminal() {
    use tokio_serial::SerialPort;

    let rt = runtime();
    let mut three = Bank::default();
    three.holding.extend([(0, 0x0102), (1, 0x0304)]);
    three.coils.insert(0, false);
    let mut four = Bank::default();
    four.input.insert(9, 4444);
    let banks = banks([(3, three), (4, four)]);
    let (master, slave) = {
        let _guard = rt.enter();
        tokio_serial::SerialStream::pair().unwrap()
    };
    let path = slave.name().unwrap();
    let service = Service {
        banks: banks.clone(),
        slow: None,
    };
    rt.spawn(tokio_modbus::server::rtu::Server::new(master).serve_forever(service));

    let mut run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
module setter idle
point wide "" io u32
point far "" io u16
point lamp "" setter
point stale3 "" io
point stale4 "" io
[io]
device three rtu:{path}:19200:8N1 3 20ms 1s
device four rtu:{path}:19200:8N1 4 30ms 1s
read three holding 0 wide
write three coil 0 lamp
read four input 9 far
stale three stale3
stale four stale4
"#
    ));
    run.set("lamp", u(1));
    // The values land at a scan that may come before their cycle ends: wait for the stale
    // points too.
    run.until("both devices read and the coil written", |p| {
        p.value("wide") == 0x0102_0304
            && p.value("far") == 4444
            && banks.lock().unwrap()[&3].coils.get(&0) == Some(&true)
            && (p.value("stale3"), p.value("stale4")) == (0, 0)
    });
    run.until("steady cycles", |_| {
        steady(&log_of(&banks, 3), &["read holding 0+2", "write coil 0"])
            && steady(&log_of(&banks, 4), &["read input 9+1"])
    });
    drop(run);
    drop(slave);
}

// ---------------------------------------------------------------------------------------
// Configuration errors.

fn start_err(section: &str) -> String {
    let text = format!(
        r#"[PLC]
module io modbus_client
module other idle
point mine "" io u16
point flag "" io
point theirs "" other u16
point fl "" io f
[io]
{section}"#
    );
    harness::start_err(&text, &std::env::temp_dir(), registry)
}

#[test]
fn bad_configurations_say_where_and_how_to_fix() {
    // Line 9 is the first row of the section.
    for (section, says) in [
        ("", "no devices: add rows `device NAME ENDPOINT UNIT PERIOD [TIMEOUT]`"),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 nope",
            "test.conf:10: no point named `nope`; declare it with `point nope \"...\" io`",
        ),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 theirs",
            "test.conf:10: point `theirs` is owned by module `other`",
        ),
        (
            "device d tcp:h:502 1 10ms\nread e holding 0 mine",
            "test.conf:10: unknown device `e`",
        ),
        (
            "device d tcp:h:502 1 10ms\ndevice d tcp:h:503 1 10ms\nread d holding 0 mine",
            "test.conf:10: device `d` is declared twice (first at test.conf:9)",
        ),
        ("device d udp:h:502 1 10ms\nread d holding 0 mine", "test.conf:9: device `d`: endpoint `udp:h:502` is not valid"),
        ("device d tcp:h 1 10ms\nread d holding 0 mine", "has no port"),
        ("device d tcp:h:502 248 10ms\nread d holding 0 mine", "unit `248` is not valid"),
        (
            "device d rtu:/dev/ttyS0:9600:8N1 0 10ms\nread d holding 0 mine",
            "unit 0 is the RTU broadcast address",
        ),
        ("device d tcp:h:502 1\nread d holding 0 mine", "test.conf:9: a device row is"),
        ("device d tcp:h:502 1 0ms\nread d holding 0 mine", "the period must be more than 0"),
        ("device d tcp:h:502 1 fast\nread d holding 0 mine", "period: `fast` is not a duration"),
        ("device d tcp:h:502 1 10ms", "device `d` has no read or write rows"),
        (
            "device d tcp:h:502 1 10ms\nwrite d input 0 mine",
            "table `input` is read-only in Modbus",
        ),
        ("device d tcp:h:502 1 10ms\nread d regs 0 mine", "unknown table `regs`"),
        ("device d tcp:h:502 1 10ms\nread d holding 70000 mine", "address `70000` is not valid"),
        (
            "device d tcp:h:502 1 10ms\nread d holding 65535 fl",
            "f32 at address 65535 runs past the last address",
        ),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine u16 big", "`big` is neither"),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 mine low_first",
            "a word order only applies to two-register types",
        ),
        (
            "device d tcp:h:502 1 10ms\nread d coil 0 flag u16",
            "a coil carries one bit",
        ),
        ("device d tcp:h:502 1 10ms\nread d coil 0 fl", "`fl` is a float point"),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine f32", "point `mine` (u16) cannot be read as f32"),
        ("device d tcp:h:502 1 10ms\nwrite d holding 0 theirs i16", "point `theirs` (u16) cannot be written as i16"),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 mine\nread d holding 1 mine",
            "test.conf:11: point `mine` is already set by the row at test.conf:10",
        ),
        (
            "device d tcp:h:502 1 10ms\nwrite d holding 0 fl\nwrite d holding 1 theirs",
            "test.conf:11: `theirs` writes holding 1 of device `d`, which the row at test.conf:10",
        ),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 mine\nstale d theirs",
            "test.conf:11: point `theirs` is owned by module `other`",
        ),
        (
            "device d tcp:h:502 1 10ms\nread d holding 0 mine\nstale d fl",
            "stale point `fl` is a float point",
        ),
        (
            "device a rtu:/dev/ttyS0:9600:8N1 1 10ms\ndevice b rtu:/dev/ttyS0:19200:8N1 2 10ms\nread a coil 0 flag\nread b holding 0 mine",
            "devices on one line share its settings",
        ),
        (
            "device a rtu:/dev/ttyS0:9600:8N1 1 10ms\ndevice b rtu:/dev/ttyS0:9600:8N1 1 10ms\nread a coil 0 flag\nread b holding 0 mine",
            "are both unit 1 on serial port /dev/ttyS0",
        ),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine\nbackoff_max = never", "`backoff_max = never`"),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine\nbackoff = 1s", "unknown setting `backoff`"),
        ("device d tcp:h:502 1 10ms\nread d holding 0 mine\npoll d 1", "reads only device, read, write, stale rows, not `poll`"),
    ] {
        let e = start_err(section);
        assert!(e.contains(says), "{section}:\n{e}\nshould say: {says}");
        assert!(e.starts_with("module io: "), "{e}");
    }
}

#[test]
fn every_problem_is_reported_at_once() {
    let e = start_err("device d tcp:h:502 1 10ms\nread d holding 0 nope\nread x coil 0 flag\nwrite d input 0 mine");
    assert_eq!(e.matches("\nmodule io: ").count(), 2, "{e}");
    for line in ["test.conf:10", "test.conf:11", "test.conf:12"] {
        assert!(e.contains(line), "{e}");
    }
}

#[test]
fn status_and_default_scan_period() {
    // Nothing listens on this port once the listener is dropped: the device stays stale.
    let addr = StdListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap();
    let run = Run::start(&format!(
        r#"
[PLC]
module io modbus_client
point x "" io u16
[io]
device slow tcp:{addr} 1 1s
device fast tcp:{addr} 2 40ms
read slow holding 0 x
write fast coil 0 x
"#
    ));
    let (_, m, _) = &run.plc.modules[0];
    assert_eq!(m.default_scan_period(), Some(ms(40)));
    let status = run.status();
    assert!(
        status.starts_with("slow ") && status.contains("; fast "),
        "{status}"
    );
}

// ---------------------------------------------------------------------------------------
// End to end: this crate's client against this crate's server, in one PLC.

#[test]
fn the_client_reads_and_writes_a_modbus_server_module() {
    // A port nobody listens on right now, for the server module to take.
    let port = StdListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let mut run = Run::start(&format!(
        r#"
[PLC]
module mb modbus_server
module io modbus_client
module setter idle
point temp "" setter f
point total "" setter u32
point alarm "" setter
point sp "set by the client" mb i16
point cmd "" mb
point temp_copy "" io f
point total_copy "" io u32
point alarm_copy "" io
point sp_out "" setter i16
point cmd_out "" setter
point offline "" io
[mb]
listen = 127.0.0.1:{port}
holding 10 temp f32 low_first
input 0 total
discrete_input 3 alarm
holding 20 sp
coil 0 cmd
[io]
device plc tcp:127.0.0.1:{port} 1 20ms
read plc holding 10 temp_copy f32 low_first
read plc input 0 total_copy
read plc discrete_input 3 alarm_copy
write plc holding 20 sp_out
write plc coil 0 cmd_out
stale plc offline
"#
    ));
    run.set("temp", f(21.5));
    run.set("total", u(100_000));
    run.set("alarm", u(1));
    run.set("sp_out", i(-40));
    run.set("cmd_out", u(1));
    run.until("values both ways", |p| {
        p.get("temp_copy") == f(21.5)
            && p.get("total_copy") == u(100_000)
            && p.value("alarm_copy") == 1
            && p.get("sp") == i(-40)
            && p.value("cmd") == 1
            && p.value("offline") == 0
    });
}
