//! modbus_server and the values clients write: every NaN/Inf bit pattern a client can write
//! to a float point is refused with exception 03 (in FC 16 and 23, in both word orders, beside
//! good values), half of a pair with 02; the point keeps its value; refusals are counted in the
//! status line and logged once per point until a write to it is accepted; integers out of range
//! alike. (Random frames against a running PLC: `server_fuzz.rs`.)

mod server_support;

use std::sync::{Mutex, OnceLock};

use petriplc_config::PointValue;
use server_support::{count, fc16, fc23, Server};

// ---------------------------------------------------------------------------------------
// The log, captured.

/// Every log line of this test binary, as `LEVEL message`.
fn log_lines() -> &'static Mutex<Vec<String>> {
    static LINES: OnceLock<Mutex<Vec<String>>> = OnceLock::new();
    LINES.get_or_init(|| Mutex::new(Vec::new()))
}

struct Capture;

impl log::Log for Capture {
    fn enabled(&self, _: &log::Metadata) -> bool {
        true
    }
    fn log(&self, record: &log::Record) {
        log_lines()
            .lock()
            .unwrap()
            .push(format!("{} {}", record.level(), record.args()));
    }
    fn flush(&self) {}
}

fn capture_log() {
    static CAPTURE: Capture = Capture;
    let _ = log::set_logger(&CAPTURE);
    log::set_max_level(log::LevelFilter::Info);
}

/// The captured lines containing `text`.
fn logged(text: &str) -> Vec<String> {
    log_lines()
        .lock()
        .unwrap()
        .iter()
        .filter(|l| l.contains(text))
        .cloned()
        .collect()
}

// ---------------------------------------------------------------------------------------
// Values.

/// Every class of NaN and infinity as an f32's registers, high word first.
const NOT_FINITE: [[u16; 2]; 7] = [
    [0x7FC0, 0x0000], // the quiet NaN every tool writes
    [0xFFC0, 0x0000], // a negative quiet NaN
    [0x7F80, 0x0001], // the smallest signalling NaN
    [0x7FBF, 0xFFFF], // the largest signalling NaN
    [0xFFFF, 0xFFFF], // NaN with every bit set
    [0x7F80, 0x0000], // +Inf
    [0xFF80, 0x0000], // -Inf
];

const FLOATS: &str = "\
[PLC]
module mb modbus_server
point hi \"float, high word first\" mb f32 init 1.5
point lo \"float, low word first\" mb f32 init -2.25
point small \"u8\" mb u8 init 7
[mb]
listen = 127.0.0.1:0
holding 0 hi
holding 2 lo f32 low_first
holding 4 small
";

#[test]
fn every_nan_and_inf_pattern_is_refused_counted_and_logged_once_per_point() {
    capture_log();
    let mut srv = Server::start(FLOATS);
    let mut raw = srv.raw();
    let mut tid = 0;
    let mut request = |pdu: &[u8]| {
        tid += 1;
        raw.request(tid, pdu)
    };
    let mut refused = 0;
    for [high, low] in NOT_FINITE {
        for pdu in [
            fc16(0, &[high, low]),
            fc16(2, &[low, high]),
            fc23(0, &[high, low]),
            fc23(2, &[low, high]),
            // With a good value beside it: nothing of the request is written.
            fc16(0, &[0x4000, 0, low, high]),
        ] {
            assert_eq!(request(&pdu), [pdu[0] | 0x80, 0x03], "{pdu:02X?}");
            refused += 1;
        }
    }
    // Half of a pair: 02, whatever the value.
    for pdu in [vec![0x06, 0, 0, 0x7F, 0xC0], vec![0x06, 0, 3, 0x7F, 0xC0]] {
        assert_eq!(request(&pdu), [0x86, 0x02], "{pdu:02X?}");
    }
    srv.tick();
    assert_eq!(srv.plc.get("hi"), PointValue::Float(1.5));
    assert_eq!(srv.plc.get("lo"), PointValue::Float(-2.25));
    let status = srv.status();
    assert_eq!(count(&status, " values refused"), refused, "{status}");
    assert_eq!(count(&status, " exceptions"), refused + 2, "{status}");
    // One warning per point, not one per request.
    let hi = logged("modbus_server mb: refused a write of 0x7FC0 0x0000 to holding 0-1");
    let lo = logged("modbus_server mb: refused a write of 0x0000 0x7FC0 to holding 2-3");
    assert_eq!((hi.len(), lo.len()), (1, 1), "{:#?}", logged("mb"));
    assert!(hi[0].starts_with("WARN "), "{hi:?}");
    assert!(
        hi[0].contains("point `hi` (test.conf:8): NaN is not a finite number"),
        "{hi:?}"
    );
    assert_eq!(logged("modbus_server mb: refused a write").len(), 2);

    // An accepted write re-arms the warning of its point only; an integer out of range is
    // refused and logged alike.
    assert_eq!(request(&fc16(0, &[0x4000, 0])), fc16(0, &[0x4000, 0])[..5]);
    assert_eq!(request(&fc16(0, &[0xFF80, 0])), [0x90, 0x03]);
    assert_eq!(request(&fc16(2, &[0, 0xFF80])), [0x90, 0x03]);
    assert_eq!(request(&[0x06, 0, 4, 1, 0x2C]), [0x86, 0x03]);
    assert_eq!(request(&[0x06, 0, 4, 1, 0x2C]), [0x86, 0x03]);
    srv.tick();
    assert_eq!(srv.plc.get("hi"), PointValue::Float(2.0));
    assert_eq!(srv.plc.get("small"), PointValue::Unsigned(7));
    assert_eq!(
        logged("modbus_server mb: refused a write of 0xFF80 0x0000 to holding 0-1").len(),
        1
    );
    assert!(logged("0x0000 0xFF80 to holding 2-3").is_empty());
    let small = logged("refused a write of 0x012C to holding 4 (u16), point `small`");
    assert_eq!(small.len(), 1, "{:#?}", logged("mb"));
    assert!(small[0].contains("300 is outside the point's range 0 to 255"));
    assert_eq!(count(&srv.status(), " values refused"), refused + 4);
}
