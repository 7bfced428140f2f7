//! The `mqtt` module against a real broker, Debian's mosquitto (started by each test on a free
//! loopback port), with the third-party clients `mosquitto_pub`/`mosquitto_sub` on the other
//! side: published points are retained on the broker, subscribed topics reach owned points,
//! bad payloads are refused, a broker outage raises the stale flag and the safe values and
//! its end clears them and republishes; TLS with a password; every setting checked at start.

mod common;

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use common::{registry, set};
use petriplc_config::PointValue;
use petriplc_mqtt::testing::Broker;
use petriplc_runtime::harness::{self, Plc};

const PATIENCE: Duration = Duration::from_secs(10);

/// Scans every 10 ms (time passed in) until `done` holds; panics after 10 s.
fn scan_until(plc: &mut Plc, now: &mut Duration, what: &str, done: impl Fn(&Plc) -> bool) {
    let start = Instant::now();
    loop {
        plc.tick(*now).unwrap();
        *now += Duration::from_millis(10);
        if done(plc) {
            return;
        }
        assert!(
            start.elapsed() < PATIENCE,
            "{what}: not within {PATIENCE:?}; status: {}",
            plc.status("mqtt")
        );
        std::thread::sleep(Duration::from_millis(10));
    }
}

fn client(tool: &str, broker: &Broker) -> Command {
    let mut c = Command::new(tool);
    c.args(["-h", "127.0.0.1", "-p", &broker.port.to_string()]);
    c
}

/// `mosquitto_pub -t TOPIC -m MESSAGE`.
fn publish(broker: &Broker, topic: &str, message: &str) {
    let out = client("mosquitto_pub", broker)
        .args(["-t", topic, "-m", message])
        .output()
        .expect("mosquitto_pub (Debian's mosquitto-clients)");
    assert!(out.status.success(), "{out:?}");
}

/// The retained messages under `filter`, as `topic value` lines, read by mosquitto_sub.
fn retained(broker: &Broker, filter: &str) -> Vec<String> {
    let out = client("mosquitto_sub", broker)
        // --retained-only: stop at the first live message; -W: give up after 2 s.
        .args(["-t", filter, "-v", "--retained-only", "-W", "2"])
        .output()
        .expect("mosquitto_sub (Debian's mosquitto-clients)");
    let mut lines: Vec<String> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(str::to_string)
        .collect();
    lines.sort();
    lines
}

fn start(text: &str) -> Plc {
    let dir = tempfile::tempdir().unwrap();
    harness::start(text, dir.path(), registry).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn points_travel_both_ways_through_the_broker() {
    let broker = Broker::start();
    let mut plc = start(&format!(
        "[PLC]\nmodule probe probe\nmodule mqtt mqtt\n\
         point X \"a count\" probe u8 init 5\npoint F \"a float\" probe f init 2.5\n\
         point S \"signed\" probe i16 init -12\n\
         point IN \"from the broker\" mqtt u16\npoint INF \"a float from the broker\" mqtt f\n\
         point down \"broker away\" mqtt init 1\n\
         [mqtt]\nbroker = {}\ntopic_prefix = cell/one\nstale = down\n\
         publish X F\npublish S\nsubscribe other/in IN\nsubscribe other/f INF\n",
        broker.address()
    ));
    let mut now = Duration::ZERO;
    scan_until(&mut plc, &mut now, "connected", |p| p.value("down") == 0);
    let want = ["cell/one/F 2.5", "cell/one/S -12", "cell/one/X 5"];
    let start = Instant::now();
    while retained(&broker, "cell/one/#") != want {
        plc.tick(now).unwrap();
        now += Duration::from_millis(10);
        assert!(
            start.elapsed() < PATIENCE,
            "{:?}",
            retained(&broker, "cell/one/#")
        );
    }
    // A change is published (retained) within a scan or two.
    set("X", PointValue::Unsigned(6));
    set("F", PointValue::Float(-0.1));
    // Both, not X then F: F goes out after X, and may not be on the broker yet when X is.
    scan_until(&mut plc, &mut now, "X and F published", |_| {
        retained(&broker, "cell/one/#") == ["cell/one/F -0.1", "cell/one/S -12", "cell/one/X 6"]
    });

    publish(&broker, "other/in", "42");
    publish(&broker, "other/f", "{\"value\": 1.5, \"ts\": 0}");
    scan_until(&mut plc, &mut now, "IN = 42", |p| p.value("IN") == 42);
    scan_until(&mut plc, &mut now, "INF = 1.5", |p| {
        p.get("INF") == PointValue::Float(1.5)
    });
    // A payload that is not a number, or does not fit the point, is refused: the point keeps
    // its value and the module counts it.
    publish(&broker, "other/in", "lots");
    publish(&broker, "other/in", "70000");
    scan_until(&mut plc, &mut now, "two rejected", |p| {
        p.status("mqtt").contains("2 rejected")
    });
    assert_eq!(plc.value("IN"), 42);
    publish(&broker, "other/in", "true");
    scan_until(&mut plc, &mut now, "IN = 1", |p| p.value("IN") == 1);
    // NaN and the infinities, in every spelling, and numbers beyond a point's range are
    // refused at the boundary: one NaN in an IEC program spreads through all it computes.
    let bad = [
        "NaN",
        "nan",
        "-nan",
        "inf",
        "-inf",
        "Infinity",
        "-Infinity",
        "1e39",
        "-1e39",
        "1e400",
        "{\"value\": 1e39}",
    ];
    for payload in bad {
        publish(&broker, "other/f", payload);
    }
    publish(&broker, "other/in", "inf");
    publish(&broker, "other/in", "1e10");
    let refused = 2 + bad.len() + 2;
    scan_until(&mut plc, &mut now, "non-finite values refused", |p| {
        p.status("mqtt").contains(&format!(" {refused} rejected"))
    });
    assert_eq!(plc.get("INF"), PointValue::Float(1.5));
    assert_eq!(plc.value("IN"), 1);
    publish(&broker, "other/f", "-2.25");
    scan_until(&mut plc, &mut now, "INF = -2.25", |p| {
        p.get("INF") == PointValue::Float(-2.25)
    });
    assert!(
        plc.status("mqtt").contains(" up;"),
        "{}",
        plc.status("mqtt")
    );
    plc.close();
}

#[test]
fn a_broker_outage_raises_stale_and_safe_values_and_its_end_clears_them() {
    let mut broker = Broker::start();
    // The broker is down when the PLC starts.
    broker.kill();
    let mut plc = start(&format!(
        "[PLC]\nmodule probe probe\nmodule mqtt mqtt\n\
         point P \"published\" probe u8 init 3\n\
         point H \"held\" mqtt u8\npoint V \"safe when stale\" mqtt u8\n\
         point down \"broker away\" mqtt\n\
         [mqtt]\nbroker = {}\ntopic_prefix = out\nstale = down\nbackoff_max = 0.2\n\
         publish P\nsubscribe in/h H\nsubscribe in/v V 9\n",
        broker.address()
    ));
    let mut now = Duration::ZERO;
    // Until the first connection the link is stale: V holds its safe value.
    for _ in 0..5 {
        plc.tick(now).unwrap();
        now += Duration::from_millis(10);
        assert_eq!((plc.value("down"), plc.value("V")), (1, 9));
    }
    broker.restart();
    scan_until(&mut plc, &mut now, "connected", |p| p.value("down") == 0);
    publish(&broker, "in/h", "4");
    publish(&broker, "in/v", "5");
    scan_until(&mut plc, &mut now, "values in", |p| {
        (p.value("H"), p.value("V")) == (4, 5)
    });

    broker.kill();
    scan_until(&mut plc, &mut now, "stale", |p| p.value("down") == 1);
    // H holds its last value, V takes its safe value; nothing panicked, the scan goes on.
    assert_eq!((plc.value("H"), plc.value("V")), (4, 9));
    let status = plc.status("mqtt");
    assert!(
        status.contains("stale: ") && status.contains("1 outages"),
        "{status}"
    );
    // The point changes while the broker is away; the module must not block on it.
    set("P", PointValue::Unsigned(7));
    for _ in 0..20 {
        let t = Instant::now();
        plc.tick(now).unwrap();
        now += Duration::from_millis(10);
        assert!(t.elapsed() < Duration::from_millis(200), "a scan waited");
        std::thread::sleep(Duration::from_millis(10));
    }

    // The broker comes back empty (no persistence): the module reconnects, clears the flag
    // and republishes the current value.
    broker.restart();
    scan_until(&mut plc, &mut now, "up again", |p| p.value("down") == 0);
    scan_until(&mut plc, &mut now, "republished", |_| {
        retained(&broker, "out/#") == ["out/P 7"]
    });
    publish(&broker, "in/v", "6");
    scan_until(&mut plc, &mut now, "V from the broker again", |p| {
        p.value("V") == 6
    });
    plc.close();
}

#[test]
fn json_payloads_are_published_when_asked() {
    let broker = Broker::start();
    let mut plc = start(&format!(
        "[PLC]\nmodule probe probe\nmodule mqtt mqtt\npoint J \"j\" probe i8 init -3\n\
         [mqtt]\nbroker = mqtt://{}\ntopic_prefix = js\npayload = json\npublish J\n",
        broker.address()
    ));
    let mut now = Duration::ZERO;
    let start = Instant::now();
    let line = loop {
        plc.tick(now).unwrap();
        now += Duration::from_millis(10);
        if let Some(l) = retained(&broker, "js/J").pop() {
            break l;
        }
        assert!(start.elapsed() < PATIENCE);
    };
    let json: serde_json::Value =
        serde_json::from_str(line.strip_prefix("js/J ").unwrap()).unwrap();
    assert_eq!(json["value"], -3);
    assert!(json["ts"].as_u64().unwrap() > 1_600_000_000_000, "{json}");
    plc.close();
}

/// A CA, and a broker certificate for 127.0.0.1 signed by it, made by openssl.
fn certificates(dir: &Path) {
    let run = |args: &[&str]| {
        let out = Command::new("openssl")
            .args(args)
            .current_dir(dir)
            .output()
            .expect("openssl");
        assert!(out.status.success(), "openssl {args:?}: {out:?}");
    };
    run(&[
        "req",
        "-x509",
        "-newkey",
        "rsa:2048",
        "-nodes",
        "-days",
        "2",
        "-subj",
        "/CN=test CA",
        "-keyout",
        "ca.key",
        "-out",
        "ca.pem",
    ]);
    run(&[
        "req",
        "-newkey",
        "rsa:2048",
        "-nodes",
        "-subj",
        "/CN=127.0.0.1",
        "-keyout",
        "broker.key",
        "-out",
        "broker.csr",
    ]);
    std::fs::write(dir.join("ext.cnf"), "subjectAltName=IP:127.0.0.1\n").unwrap();
    run(&[
        "x509",
        "-req",
        "-in",
        "broker.csr",
        "-CA",
        "ca.pem",
        "-CAkey",
        "ca.key",
        "-CAcreateserial",
        "-days",
        "2",
        "-extfile",
        "ext.cnf",
        "-out",
        "broker.pem",
    ]);
}

#[test]
fn tls_and_a_password_reach_a_broker_that_requires_them() {
    let certs = tempfile::tempdir().unwrap();
    certificates(certs.path());
    let passwords = certs.path().join("passwords");
    std::fs::write(&passwords, "").unwrap();
    let out = Command::new("mosquitto_passwd")
        .args(["-b"])
        .arg(&passwords)
        .args(["plc", "s3cret"])
        .output()
        .expect("mosquitto_passwd");
    assert!(out.status.success(), "{out:?}");
    let c = certs.path().display();
    let broker = Broker::start_with(&format!(
        "password_file {}\nallow_anonymous false\ncafile {c}/ca.pem\ncertfile {c}/broker.pem\n\
         keyfile {c}/broker.key\n",
        passwords.display()
    ));
    std::fs::write(certs.path().join("plc.password"), "s3cret\n").unwrap();
    let conf = |password: &str| {
        format!(
            "[PLC]\nmodule probe probe\nmodule mqtt mqtt\npoint T \"t\" probe u8 init 11\n\
             point down \"d\" mqtt\n\
             [mqtt]\nbroker = mqtts://{}\ntopic_prefix = tls\nstale = down\nusername = plc\n\
             password_file = {c}/{password}\nca_file = {c}/ca.pem\npublish T\n",
            broker.address()
        )
    };
    std::fs::write(certs.path().join("wrong.password"), "guess\n").unwrap();
    // A wrong password: the broker refuses, the link stays stale, the module says why.
    let mut wrong = start(&conf("wrong.password"));
    let mut now = Duration::ZERO;
    scan_until(&mut wrong, &mut now, "refused", |p| {
        p.status("mqtt").contains("stale: ")
    });
    assert_eq!(wrong.value("down"), 1);
    wrong.close();

    let mut plc = start(&conf("plc.password"));
    scan_until(&mut plc, &mut now, "connected over TLS", |p| {
        p.value("down") == 0
    });
    let start = Instant::now();
    loop {
        let out = Command::new("mosquitto_sub")
            .args(["-h", "127.0.0.1", "-p", &broker.port.to_string()])
            .args([
                "--cafile",
                &format!("{c}/ca.pem"),
                "-u",
                "plc",
                "-P",
                "s3cret",
            ])
            .args(["-t", "tls/T", "-v", "--retained-only", "-W", "2"])
            .output()
            .unwrap();
        if String::from_utf8_lossy(&out.stdout).trim() == "tls/T 11" {
            break;
        }
        plc.tick(now).unwrap();
        now += Duration::from_millis(10);
        assert!(start.elapsed() < PATIENCE, "{out:?}");
    }
    plc.close();
}

#[test]
fn settings_and_rows_are_checked_at_start_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let check = |section: &str, expect: &[&str]| {
        let text = format!(
            "[PLC]\nmodule probe probe\nmodule mqtt mqtt\npoint A \"a\" probe\n\
             point M \"m\" mqtt\npoint F \"f\" mqtt f\n[mqtt]\n{section}"
        );
        let e = harness::start_err(&text, dir.path(), registry);
        for want in expect {
            assert!(e.contains(want), "expected `{want}` in:\n{e}");
        }
    };
    check("publish A\n", &["no `broker` setting"]);
    check(
        "broker = ws://x\npayload = xml\nkeep_alive = 0.5\npublish A\n",
        &[
            "test.conf:8: `broker = ws://x`",
            "test.conf:9: `payload = xml`",
            "test.conf:10: `keep_alive",
        ],
    );
    check(
        "broker = h\nca_file = ca.pem\npublish A\n",
        &["test.conf:9: `ca_file` is a TLS setting", "mqtts://h:8883"],
    );
    check(
        "broker = h\nsubscribe t/a A\nsubscribe t/# M\nsubscribe t/x NOPE\n",
        &[
            "test.conf:9: `subscribe t/a A`: point `A` is owned by module `probe`",
            "test.conf:10: `subscribe t/# M`: `t/#` has a wildcard",
            "test.conf:11: `subscribe t/x NOPE`",
        ],
    );
    check(
        "broker = h\nsubscribe t/m M 2\nsubscribe t/f F\nsubscribe t/g F\n",
        &[
            "test.conf:9: `subscribe t/m M 2`: `2` is out of range (0 to 1) for a u1 point",
            "test.conf:11: point `F` is subscribed twice",
        ],
    );
    check(
        "broker = h\nsubscribe t/f F nan\n",
        &["test.conf:9: `subscribe t/f F nan`: `nan` is not a finite number for a f32 point"],
    );
    check(
        "broker = h\nmax_payload = 10 GiB\npublish A\n",
        &["test.conf:9: `max_payload = 10 GiB`: write a size from 16 bytes to 255 MiB"],
    );
    check(
        "broker = h\ntopic_prefix = p\npublish M\nsubscribe p/M M\n",
        &["test.conf:11: topic `p/M` is both published"],
    );
    check(
        "broker = h\nstale = A\npublish A A\n",
        &[
            "`stale = A`: point `A` is owned by module `probe`",
            "test.conf:10: point `A` is published twice",
        ],
    );
    check("broker = h\n", &["nothing to do"]);
    check(
        "broker = h\nbrokr = x\npublish A\n",
        &["unknown setting `brokr`"],
    );
    check(
        "broker = h\nusername = u\npassword_file = /nonexistent/pw\npublish A\n",
        &["`password_file = /nonexistent/pw`: cannot read"],
    );
}

/// `mosquitto_pub` reading one message per line from stdin (`-l`), at QoS 1.
fn publish_lines(broker: &Broker, topic: &str, lines: &str, retain: bool) {
    use std::io::Write;
    let mut c = client("mosquitto_pub", broker);
    c.args(["-t", topic, "-q", "1", "-l"]);
    if retain {
        c.arg("-r");
    }
    let mut child = c
        .stdin(std::process::Stdio::piped())
        .spawn()
        .expect("mosquitto_pub (Debian's mosquitto-clients)");
    child
        .stdin
        .take()
        .unwrap()
        .write_all(lines.as_bytes())
        .unwrap();
    assert!(child.wait().unwrap().success());
}

#[test]
fn oversized_messages_are_dropped_and_counted_and_the_link_stays_up() {
    let broker = Broker::start();
    // Retained before the PLC subscribes: the broker sends it with every subscription.
    publish_lines(&broker, "in/x", &format!("{}\n", "7".repeat(101)), true);
    let mut plc = start(&format!(
        "[PLC]\nmodule mqtt mqtt\npoint X \"x\" mqtt u16 init 3\npoint Y \"y\" mqtt u16\n\
         point down \"d\" mqtt\n\
         [mqtt]\nbroker = {}\nstale = down\nmax_payload = 100\n\
         subscribe in/x X\nsubscribe in/y Y\n",
        broker.address()
    ));
    let mut now = Duration::ZERO;
    scan_until(
        &mut plc,
        &mut now,
        "up, the retained message refused",
        |p| {
            let s = p.status("mqtt");
            s.contains(" up;") && s.contains("1 received, 1 rejected")
        },
    );
    // 40 more at QoS 1: each must still be acknowledged, or the broker would stop sending
    // after its 20 unacknowledged messages, and the good value after them never arrive.
    let big = format!("{}\n", "8".repeat(101));
    publish_lines(&broker, "in/x", &big.repeat(40), false);
    publish(&broker, "in/x", "5");
    publish(&broker, "in/y", "6");
    scan_until(&mut plc, &mut now, "X = 5 and Y = 6 after them", |p| {
        (p.value("X"), p.value("Y")) == (5, 6)
    });
    let status = plc.status("mqtt");
    assert!(
        status.contains(" up;") && status.contains("43 received, 41 rejected, 0 outages"),
        "{status}"
    );
    // A payload of exactly max_payload is taken.
    publish(&broker, "in/x", &format!("{:0>100}", 9));
    scan_until(&mut plc, &mut now, "X = 9", |p| p.value("X") == 9);
    plc.close();
}

#[test]
fn the_back_off_grows_when_each_connection_is_dropped_right_after_connack() {
    use std::io::{Read, Write};
    use std::net::TcpListener;
    use std::sync::{Arc, Mutex};
    // A broker that accepts every CONNECT and hangs up at once (as mosquitto does when a
    // second client takes the id, or when a message cannot be delivered).
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let accepted: Arc<Mutex<Vec<Instant>>> = Arc::default();
    let log = Arc::clone(&accepted);
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut s) = stream else { return };
            let mut connect = [0u8; 256];
            if s.read(&mut connect).unwrap_or(0) == 0 {
                continue;
            }
            log.lock().unwrap().push(Instant::now());
            let _ = s.write_all(&[0x20, 0x02, 0x00, 0x00]);
        }
    });
    let mut plc = start(&format!(
        "[PLC]\nmodule mqtt mqtt\npoint X \"x\" mqtt\n\
         [mqtt]\nbroker = 127.0.0.1:{port}\nbackoff_max = 60\nsubscribe in/x X\n"
    ));
    let mut now = Duration::ZERO;
    scan_until(&mut plc, &mut now, "six connections", |_| {
        accepted.lock().unwrap().len() >= 6
    });
    plc.close();
    let at = accepted.lock().unwrap().clone();
    // Each connection failed within HEALTHY of its CONNACK, so the waits kept doubling from
    // 0.1 s: the fifth was 1.6 s. A lower bound only (a sleep never ends early): before, the
    // wait went back to 0.1 s at every CONNACK, about 80 connections in 8 s.
    let gap = at[5] - at[4];
    assert!(gap >= Duration::from_millis(1600), "{gap:?} between {at:?}");
}
