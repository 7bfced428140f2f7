//! The `mqtt` module as a Sparkplug B edge node against Debian's mosquitto, with a host made
//! of third-party parts on the other side (tests/sparkplug_host.py: paho-mqtt, and
//! pysparkplug's decoders on Google's protobuf runtime, pinned in scripts/test-all.sh; in
//! target/py, `PETRIPLC_PYTHON` overrides): NBIRTH with every point as a metric, NDATA by
//! alias with consecutive sequence numbers through the wrap from 255 to 0, a rebirth on
//! NCMD, a broker outage (new bdSeq, new NBIRTH), the will, and NDEATH at a clean stop.

mod common;

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

use common::{registry, set};
use petriplc_config::PointValue;
use petriplc_mqtt::testing::Broker;
use petriplc_runtime::harness::{self, Plc};
use serde_json::Value;

const PATIENCE: Duration = Duration::from_secs(15);

fn python() -> PathBuf {
    std::env::var_os("PETRIPLC_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../target/py/bin/python")
        })
}

/// The Python host: its JSON lines arrive on a channel.
struct Host {
    child: Child,
    stdin: ChildStdin,
    lines: Receiver<Value>,
}

impl Host {
    fn start(broker: &Broker, group: &str, node: &str) -> Host {
        let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/sparkplug_host.py");
        let mut child = Command::new(python())
            .arg(script)
            .args([&broker.port.to_string(), group, node])
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .spawn()
            .unwrap_or_else(|e| {
                panic!(
                    "cannot run {} ({e}): scripts/test-all.sh installs paho-mqtt and \
                     pysparkplug into target/py",
                    python().display()
                )
            });
        let stdin = child.stdin.take().unwrap();
        let out = BufReader::new(child.stdout.take().unwrap());
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for line in out.lines().map_while(Result::ok) {
                let v: Value = serde_json::from_str(&line)
                    .unwrap_or_else(|e| panic!("the host wrote `{line}`: {e}"));
                if tx.send(v).is_err() {
                    return;
                }
            }
        });
        Host {
            child,
            stdin,
            lines: rx,
        }
    }

    fn command(&mut self, cmd: &str) {
        writeln!(self.stdin, "{cmd}").unwrap();
        self.stdin.flush().unwrap();
    }

    /// Scans the PLC (if any) until the host reports a message of `kind` for which `want`
    /// holds; every message on the way is checked for the host's errors.
    fn wait(
        &mut self,
        mut plc: Option<(&mut Plc, &mut Duration)>,
        kind: &str,
        want: impl Fn(&Value) -> bool,
    ) -> Value {
        let start = Instant::now();
        let mut seen = Vec::new();
        loop {
            if let Some((plc, now)) = plc.as_mut() {
                plc.tick(**now).unwrap();
                **now += Duration::from_millis(10);
            }
            while let Ok(v) = self.lines.try_recv() {
                assert_ne!(v["type"], "error", "the Sparkplug host: {}", v["why"]);
                if v["type"] == kind && want(&v) {
                    return v;
                }
                seen.push(v);
            }
            let status = plc.as_ref().map(|(p, _)| p.status("mqtt"));
            assert!(
                start.elapsed() < PATIENCE,
                "no {kind} as expected within {PATIENCE:?}; status {status:?}; the host saw {}",
                seen.iter()
                    .rev()
                    .take(5)
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join("\n")
            );
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

impl Drop for Host {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start(text: &str) -> Plc {
    let dir = tempfile::tempdir().unwrap();
    harness::start(text, dir.path(), registry).unwrap_or_else(|e| panic!("{e}"))
}

/// `[alias, datatype, value]` of a metric in an NBIRTH report.
fn metric<'a>(birth: &'a Value, name: &str) -> &'a Value {
    &birth["metrics"][name]
}

#[test]
fn an_edge_node_is_born_reports_changes_is_reborn_and_dies() {
    let mut broker = Broker::start();
    let mut host = Host::start(&broker, "plant", "cell-a");
    host.wait(None, "ready", |_| true);
    let mut plc = start(&format!(
        "[PLC]\nmodule probe probe\nmodule mqtt mqtt\n\
         point B \"a bool\" probe init 1\npoint C \"a count\" probe u8 init 7\n\
         point S \"signed\" probe i16 init -12\npoint F \"a float\" probe f init 2.5\n\
         point W \"a word\" probe u32 init 4000000000\n\
         [mqtt]\nbroker = {}\nsparkplug = plant/cell-a\npublish B C S F W\n",
        broker.address()
    ));
    let mut now = Duration::ZERO;

    let birth = host.wait(Some((&mut plc, &mut now)), "NBIRTH", |_| true);
    assert_eq!(birth["bdSeq"], 0, "{birth}");
    // [alias, Sparkplug datatype, value], decoded by pysparkplug.
    assert_eq!(metric(&birth, "B"), &serde_json::json!([1, 11, true]));
    assert_eq!(metric(&birth, "C"), &serde_json::json!([2, 5, 7]));
    assert_eq!(metric(&birth, "S"), &serde_json::json!([3, 2, -12]));
    assert_eq!(metric(&birth, "F"), &serde_json::json!([4, 9, 2.5]));
    assert_eq!(
        metric(&birth, "W"),
        &serde_json::json!([5, 7, 4000000000u32])
    );

    // Changes travel by alias in NDATA with the next seq.
    set("S", PointValue::Signed(-300));
    set("F", PointValue::Float(-0.5));
    let data = host.wait(Some((&mut plc, &mut now)), "NDATA", |v| {
        v["values"]["S"] == -300
    });
    assert_eq!(data["values"]["F"], -0.5, "{data}");

    // Enough changes for seq to wrap from 255 to 0 (the host checks every step).
    let mut c = 0u32;
    let start = Instant::now();
    loop {
        c += 1;
        set("C", PointValue::Unsigned(c % 256));
        plc.tick(now).unwrap();
        now += Duration::from_millis(10);
        std::thread::sleep(Duration::from_millis(1));
        let mut wrapped = false;
        while let Ok(v) = host.lines.try_recv() {
            assert_ne!(v["type"], "error", "the Sparkplug host: {}", v["why"]);
            wrapped |= v["type"] == "NDATA" && v["seq"] == 0;
        }
        if wrapped {
            break;
        }
        assert!(start.elapsed() < PATIENCE * 2, "seq did not wrap");
    }

    // A host's rebirth request: a new NBIRTH with seq 0, the same bdSeq and current values.
    host.command("rebirth");
    let reborn = host.wait(Some((&mut plc, &mut now)), "NBIRTH", |_| true);
    assert_eq!(reborn["bdSeq"], 0, "{reborn}");
    assert_eq!(metric(&reborn, "S"), &serde_json::json!([3, 2, -300]));
    set("B", PointValue::Unsigned(0));
    host.wait(Some((&mut plc, &mut now)), "NDATA", |v| {
        v["seq"] == 1 && v["values"]["B"] == false
    });

    // A broker outage: after it, a new connection with a newer bdSeq and a new NBIRTH.
    broker.kill();
    for _ in 0..30 {
        plc.tick(now).unwrap();
        now += Duration::from_millis(10);
        std::thread::sleep(Duration::from_millis(10));
    }
    broker.restart();
    // The node may be born again before the host has subscribed again: a host that comes
    // (back) online asks for a rebirth, as Sparkplug hosts do.
    host.wait(None, "ready", |_| true);
    host.command("rebirth");
    let again = host.wait(Some((&mut plc, &mut now)), "NBIRTH", |_| true);
    let bd_seq = again["bdSeq"].as_u64().unwrap();
    assert!(bd_seq > 0, "{again}");
    assert_eq!(metric(&again, "B"), &serde_json::json!([1, 11, false]));

    // A clean stop sends the NDEATH of that bdSeq.
    plc.close();
    let death = host.wait(None, "NDEATH", |_| true);
    assert_eq!(death["bdSeq"], bd_seq);
    // Nothing after it but, should the DISCONNECT not have gone out in time on a loaded
    // machine, the will: the same NDEATH again.
    std::thread::sleep(Duration::from_millis(300));
    for v in host.lines.try_iter() {
        assert_eq!(v, death, "after the NDEATH");
    }
    host.command("quit");
}

#[test]
fn the_will_is_the_ndeath_of_the_current_birth() {
    // A second client with the module's client id makes mosquitto drop the first connection
    // without a DISCONNECT, which sends its will.
    let broker = Broker::start();
    let mut host = Host::start(&broker, "g", "n");
    host.wait(None, "ready", |_| true);
    let mut plc = start(&format!(
        "[PLC]\nmodule probe probe\nmodule mqtt mqtt\npoint X \"x\" probe u8 init 3\n\
         [mqtt]\nbroker = {}\nsparkplug = g/n\nclient_id = node-n\npublish X\n\
         backoff_max = 60\n",
        broker.address()
    ));
    let mut now = Duration::ZERO;
    let birth = host.wait(Some((&mut plc, &mut now)), "NBIRTH", |_| true);
    let out = Command::new("mosquitto_pub")
        .args(["-h", "127.0.0.1", "-p", &broker.port.to_string()])
        .args(["-i", "node-n", "-t", "other", "-m", "x"])
        .output()
        .expect("mosquitto_pub (Debian's mosquitto-clients)");
    assert!(out.status.success(), "{out:?}");
    let death = host.wait(Some((&mut plc, &mut now)), "NDEATH", |_| true);
    assert_eq!(death["bdSeq"], birth["bdSeq"]);
    host.command("quit");
}

#[test]
fn sparkplug_settings_are_checked_at_start() {
    let check = |extra: &str, want: &str| {
        let text = format!(
            "[PLC]\nmodule probe probe\nmodule mqtt mqtt\npoint X \"x\" probe\n\
             point Y \"y\" mqtt\n[mqtt]\nbroker = 127.0.0.1:1\npublish X\n{extra}"
        );
        let dir = tempfile::tempdir().unwrap();
        let err = harness::start_err(&text, dir.path(), registry);
        assert!(err.contains(want), "{extra}: {err}");
    };
    check(
        "sparkplug = plant",
        "test.conf:9: `sparkplug = plant`: write GROUP/EDGE_NODE",
    );
    check("sparkplug = a/b/c", "write GROUP/EDGE_NODE");
    check(
        "sparkplug = a/b\ntopic_prefix = x",
        "`topic_prefix` does not apply with `sparkplug`",
    );
    check(
        "sparkplug = a/b\npayload = json",
        "`payload` does not apply with `sparkplug`",
    );
    check(
        "sparkplug = a/b\nsubscribe spBv1.0/a/NCMD/b Y",
        "Sparkplug B topics carry protobuf payloads",
    );
}
