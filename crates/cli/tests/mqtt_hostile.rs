//! Hostile MQTT peers against the real binary, through Debian's mosquitto on a free loopback
//! port: a retained message larger than `max_payload` on a subscribed topic (dropped and
//! counted, the link up, one log line), NaN and infinities in every spelling (refused, one
//! log line per topic until a good value), and a flood of arbitrary payloads from paho-mqtt
//! (pinned in scripts/test-all.sh) to every point type and a Sparkplug B command topic, with
//! an IEC program reading the float: the PLC keeps scanning, no point ever holds a
//! non-finite value, no module fails, and memory stays bounded.

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command as Process, Stdio};

use std::time::{Duration, Instant};

use assert_cmd::cargo::CommandCargoExt;
use petriplc_mqtt::testing::Broker;

const PATIENCE: Duration = Duration::from_secs(30);

fn python() -> PathBuf {
    std::env::var_os("PETRIPLC_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/py/bin/python"))
}

/// A child process killed if the test ends before it has waited for it.
struct Killed(Option<Child>);

impl Killed {
    fn id(&self) -> u32 {
        self.0.as_ref().unwrap().id()
    }
    fn take(&mut self) -> Child {
        self.0.take().unwrap()
    }
}

impl Drop for Killed {
    fn drop(&mut self) {
        if let Some(mut c) = self.0.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }
}

/// `petriplc run CONF --plc-id ID --log LOG` on the test's broker (every `mqtt` module of
/// `modules`), stopped by the test. Its stderr goes to LOG.err: a pipe nobody reads while it
/// runs would fill up and hold the PLC's threads in their log calls.
fn run(conf: &Path, id: &str, log: &Path, broker: &Broker, modules: &[&str]) -> Killed {
    let mut c = Process::cargo_bin("petriplc").unwrap();
    c.args(["run"])
        .arg(conf)
        .args(["--plc-id", id, "--for", "300s", "--log"])
        .arg(log);
    for m in modules {
        c.args(["--set", &format!("{m}:broker={}", broker.address())]);
    }
    let err = std::fs::File::create(log.with_extension("err")).unwrap();
    Killed(Some(
        c.stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(err)
            .spawn()
            .unwrap(),
    ))
}

/// `petriplc stop`, then the run's exit status and its report (stderr).
fn stop(id: &str, log: &Path, mut plc: Killed) -> (bool, String) {
    let mut plc = plc.take();
    let out = Process::cargo_bin("petriplc")
        .unwrap()
        .args(["stop", "--plc-id", id])
        .output()
        .unwrap();
    assert!(out.status.success(), "petriplc stop: {out:?}");
    let ok = plc.wait().unwrap().success();
    (
        ok,
        std::fs::read_to_string(log.with_extension("err")).unwrap(),
    )
}

/// `petriplc status` of PLC `id` (empty while it does not answer).
fn status(id: &str) -> String {
    let out = Process::cargo_bin("petriplc")
        .unwrap()
        .args(["status", "--plc-id", id])
        .output()
        .unwrap();
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// The status line of module `module` (`broker ...`), which follows its row.
fn module_line(id: &str, module: &str) -> String {
    let text = status(id);
    let mut lines = text.lines();
    while let Some(l) = lines.next() {
        if l.split_whitespace().next() == Some(module) {
            return lines.next().unwrap_or_default().trim().to_string();
        }
    }
    String::new()
}

/// The scans module `module` has made so far.
fn scans(id: &str, module: &str) -> u64 {
    let text = status(id);
    let row = text
        .lines()
        .find(|l| l.split_whitespace().next() == Some(module))
        .unwrap_or_else(|| panic!("no {module} in:\n{text}"));
    // module kind state pid scans ...
    row.split_whitespace().nth(4).unwrap().parse().unwrap()
}

fn wait_until(what: &str, done: impl Fn() -> bool) {
    let start = Instant::now();
    while !done() {
        assert!(
            start.elapsed() < PATIENCE,
            "{what}: not within {PATIENCE:?}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// `mosquitto_pub` with `payload` on stdin as one message.
fn publish(broker: &Broker, topic: &str, payload: &[u8], retain: bool) {
    let mut c = Process::new("mosquitto_pub");
    c.args(["-h", "127.0.0.1", "-p", &broker.port.to_string()])
        .args(["-t", topic, "-q", "1", "-s"]);
    if retain {
        c.arg("-r");
    }
    let mut child = c
        .stdin(Stdio::piped())
        .spawn()
        .expect("mosquitto_pub (Debian's mosquitto-clients)");
    child.stdin.take().unwrap().write_all(payload).unwrap();
    assert!(child.wait().unwrap().success());
}

/// The retained messages under `filter`, as sorted `topic value` lines.
fn retained(broker: &Broker, filter: &str) -> Vec<String> {
    let out = Process::new("mosquitto_sub")
        .args(["-h", "127.0.0.1", "-p", &broker.port.to_string()])
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

fn log_lines(log: &Path, needle: &str) -> Vec<String> {
    std::fs::read_to_string(log)
        .unwrap_or_default()
        .lines()
        .filter(|l| l.contains(needle))
        .map(str::to_string)
        .collect()
}

#[test]
fn an_oversized_retained_message_is_dropped_and_counted_and_the_link_stays_up() {
    let dir = tempfile::tempdir().unwrap();
    let broker = Broker::start();
    // 1 MiB, retained on a subscribed topic before the PLC starts: the broker sends it with
    // every subscription. Before, the client failed ("payload size limit exceeded"),
    // reconnected at once, got it again: 80 outages in 8 s, the points stale.
    let big: Vec<u8> = (0..1 << 20).map(|i| b'0' + (i % 10) as u8).collect();
    publish(&broker, "plant/big", &big, true);
    let conf = dir.path().join("plc.conf");
    std::fs::write(
        &conf,
        "[PLC]\nmodule mqtt mqtt\n\
         point big \"a value under a huge retained message\" mqtt u16 init 7\n\
         point level \"a level\" mqtt f32\npoint down \"broker away\" mqtt\n\
         [mqtt]\nbroker = 127.0.0.1:1\ntopic_prefix = cell\nstale = down\n\
         publish big level\nsubscribe plant/big big\nsubscribe plant/level level\n",
    )
    .unwrap();
    let log = dir.path().join("plc.log");
    let id = format!("oversized-{}", std::process::id());
    let plc = run(&conf, &id, &log, &broker, &["mqtt"]);
    wait_until("up, the retained message refused", || {
        let l = module_line(&id, "mqtt");
        l.contains(" up;") && l.contains("1 rejected")
    });
    // Messages on another topic flow; the point under the huge message keeps its value.
    for v in ["1.5", "2.5"] {
        publish(&broker, "plant/level", v.as_bytes(), false);
    }
    wait_until("level published back", || {
        retained(&broker, "cell/#") == ["cell/big 7", "cell/level 2.5"]
    });
    // More of them, not retained: counted, not logged again until a good value comes.
    publish(&broker, "plant/big", &big, false);
    publish(&broker, "plant/big", &big, false);
    wait_until("three rejected", || {
        module_line(&id, "mqtt").contains("3 rejected")
    });
    wait_until("logged", || !log_lines(&log, "topic plant/big:").is_empty());
    let warned = log_lines(&log, "topic plant/big:");
    assert_eq!(warned.len(), 1, "{warned:?}");
    assert!(
        warned[0].contains(
            "[WARN] mqtt mqtt: topic plant/big: a payload of 1048576 bytes is larger than \
             `max_payload = 65536` bytes"
        ) && warned[0].contains("; refused (further refusals on this topic are only counted"),
        "{warned:?}"
    );
    // A good value still comes through after them.
    publish(&broker, "plant/big", b"9", false);
    wait_until("big = 9", || {
        retained(&broker, "cell/big") == ["cell/big 9"]
    });
    publish(&broker, "plant/big", &big, false);
    wait_until("four rejected", || {
        module_line(&id, "mqtt").contains("4 rejected")
    });
    assert_eq!(retained(&broker, "cell/big"), ["cell/big 9"]);
    let (ok, report) = stop(&id, &log, plc);
    assert!(ok, "{report}");
    assert!(
        report.contains(" 0 outages") && report.contains("4 rejected"),
        "{report}"
    );
    assert!(log_lines(&log, "unreachable").is_empty(), "{report}");
}

/// The IEC program of the PLCs below: `half` is half of `level` (it cannot overflow, so
/// only a non-finite `level` can make it non-finite or fault the module).
const HALF: &str = "PROGRAM main\nVAR_INPUT level : REAL; END_VAR\n\
                    VAR_OUTPUT half : REAL; END_VAR\nhalf := level / 2.0;\nEND_PROGRAM\n";

#[test]
fn non_finite_values_are_refused_with_one_log_line_per_topic() {
    let dir = tempfile::tempdir().unwrap();
    let broker = Broker::start();
    std::fs::write(dir.path().join("main.st"), HALF).unwrap();
    let conf = dir.path().join("plc.conf");
    std::fs::write(
        &conf,
        "[PLC]\nmodule mqtt mqtt\nmodule logic iec\n\
         point level \"a level\" mqtt f32 init 4\npoint count \"a count\" mqtt i16\n\
         point half \"level / 2\" logic f32\n\
         [mqtt]\nbroker = 127.0.0.1:1\ntopic_prefix = cell\n\
         publish level half\nsubscribe plant/level level\nsubscribe plant/count count\n\
         [logic]\nprogram = main.st\npou = main\nscan_period = T#10ms\n",
    )
    .unwrap();
    let log = dir.path().join("plc.log");
    let id = format!("nonfinite-{}", std::process::id());
    let plc = run(&conf, &id, &log, &broker, &["mqtt"]);
    wait_until("up", || module_line(&id, "mqtt").contains(" up;"));
    // A peer publishing garbage fast: 300 messages, one log line.
    let spellings = [
        "NaN",
        "nan",
        "-nan",
        "inf",
        "-inf",
        "+Infinity",
        "-Infinity",
        "1e39",
        "-1e39",
        "1e400",
        "{\"value\": 1e39}",
    ];
    let mut flood = Vec::new();
    for i in 0..300 {
        flood.extend_from_slice(spellings[i % spellings.len()].as_bytes());
        flood.push(b'\n');
    }
    let mut c = Process::new("mosquitto_pub")
        .args(["-h", "127.0.0.1", "-p", &broker.port.to_string()])
        .args(["-t", "plant/level", "-q", "1", "-l"])
        .stdin(Stdio::piped())
        .spawn()
        .unwrap();
    c.stdin.take().unwrap().write_all(&flood).unwrap();
    assert!(c.wait().unwrap().success());
    publish(&broker, "plant/count", b"inf", false);
    wait_until("301 rejected", || {
        module_line(&id, "mqtt").contains("301 rejected")
    });
    wait_until("logged", || {
        !log_lines(&log, "topic plant/level:").is_empty()
            && !log_lines(&log, "topic plant/count:").is_empty()
    });
    let level = log_lines(&log, "topic plant/level:");
    assert_eq!(level.len(), 1, "{level:?}");
    assert!(
        level[0].contains(
            "[WARN] mqtt mqtt: topic plant/level: payload \"NaN\" is not a finite number for \
             f32 point level; refused (further refusals on this topic are only counted until \
             a good message arrives)"
        ),
        "{level:?}"
    );
    let count = log_lines(&log, "topic plant/count:");
    assert_eq!(count.len(), 1, "{count:?}");
    assert!(
        count[0].contains("payload \"inf\" is not a finite number for i16 point count"),
        "{count:?}"
    );
    // The points kept their values; the program never saw a NaN.
    assert_eq!(retained(&broker, "cell/#"), ["cell/half 2", "cell/level 4"]);
    // A good value still comes through after them.
    publish(&broker, "plant/level", b"3", false);
    wait_until("level = 3", || {
        retained(&broker, "cell/#") == ["cell/half 1.5", "cell/level 3"]
    });
    let (ok, report) = stop(&id, &log, plc);
    assert!(ok, "{report}");
    assert!(!report.contains("failed"), "{report}");
}

/// xorshift64*: the same payloads on every run.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
    fn digits(&mut self, max: u64) -> String {
        (0..self.below(max + 1))
            .map(|_| char::from(b'0' + self.below(10) as u8))
            .collect()
    }
}

/// A number in a random spelling: sign, digits, fraction, exponent, spaces.
fn spelling(rng: &mut Rng) -> Vec<u8> {
    let mut s = String::new();
    match rng.below(4) {
        0 => s.push('-'),
        1 => s.push('+'),
        _ => {}
    }
    let most = if rng.below(8) == 0 { 400 } else { 12 };
    s += &rng.digits(most);
    if rng.below(2) == 0 {
        s.push('.');
        s += &rng.digits(10);
    }
    if rng.below(3) == 0 {
        s.push(['e', 'E'][rng.below(2) as usize]);
        if rng.below(2) == 0 {
            s.push('-');
        }
        s += &rng.digits(4);
    }
    if rng.below(6) == 0 {
        s = format!(" {s}\n");
    }
    if rng.below(5) == 0 {
        s = format!("{{\"value\": {s}}}");
    }
    s.into_bytes()
}

/// Payloads every topic gets: the spellings of NaN and the infinities, range edges, JSON
/// oddities, deep nesting, huge digit strings, bytes that are not UTF-8.
fn specials() -> Vec<Vec<u8>> {
    let mut v: Vec<Vec<u8>> = [
        "",
        " ",
        "NaN",
        "nan",
        "-nan",
        "+NaN",
        "inf",
        "-inf",
        "+inf",
        "Infinity",
        "-Infinity",
        "INF",
        "infinity",
        "1e39",
        "-1e39",
        "1e400",
        "-1e400",
        "3.4028236e38",
        "3.4028235e38",
        "-0",
        "-0.0",
        "0",
        "1",
        "-1",
        "127",
        "128",
        "-129",
        "255",
        "256",
        "32767",
        "-32769",
        "65535",
        "65536",
        "2147483648",
        "-2147483649",
        "4294967295",
        "4294967296",
        "1.5",
        "0.1",
        "1e-50",
        "1e-400",
        "true",
        "false",
        "on",
        "off",
        "0x10",
        "1_000",
        ".5",
        "5.",
        "--5",
        "1e",
        "e5",
        "1.2.3",
        "1 2",
        "1\n2",
        "\u{2212}1",
        "\u{ff11}",
        "{\"value\":1e39}",
        "{\"value\":NaN}",
        "{\"value\":null}",
        "{\"value\":\"1\"}",
        "{\"value\":1e400}",
        "{\"value\":-0}",
        "{\"value\":true}",
        "{\"value\":{\"value\":1}}",
        "{\"value\":[1]}",
        "{}",
        "{",
        "null",
        "[1]",
    ]
    .iter()
    .map(|s| s.as_bytes().to_vec())
    .collect();
    v.push("9".repeat(5000).into_bytes());
    v.push(format!("-{}", "9".repeat(5000)).into_bytes());
    v.push(format!("0.{}1", "0".repeat(2000)).into_bytes());
    v.push("[".repeat(20_000).into_bytes());
    v.push("{\"value\":".repeat(20_000).into_bytes());
    v.push(vec![0xff, 0xfe, 0x00]);
    v.push(b"1\0".to_vec());
    v.push(vec![b'1'; 65_536]);
    v
}

/// Sparkplug B NCMD payloads that are not commands the node takes: malformed protobufs and
/// metrics with NaN and infinite values.
fn commands(rng: &mut Rng) -> Vec<Vec<u8>> {
    let nan_float = [
        0x12, 0x0e, 0x0a, 0x05, b'l', b'e', b'v', b'e', b'l', 0x20, 0x09, 0x65, 0x00, 0x00, 0xc0,
        0x7f,
    ];
    let inf_double = [
        0x12, 0x12, 0x0a, 0x05, b'l', b'e', b'v', b'e', b'l', 0x20, 0x0a, 0x69, 0, 0, 0, 0, 0, 0,
        0xf0, 0x7f,
    ];
    let mut v = vec![
        nan_float.to_vec(),
        inf_double.to_vec(),
        vec![0x12, 0xff, 0xff, 0xff, 0xff, 0x0f],
        vec![
            0x08, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01,
        ],
        vec![0x12, 0x05, 0x0a, 0x03],
        vec![0x0f],
        Vec::new(),
    ];
    for _ in 0..100 {
        let n = rng.below(40) as usize;
        v.push((0..n).map(|_| rng.next() as u8).collect());
    }
    v
}

/// One record of the file mqtt_flood.py publishes.
fn record(out: &mut Vec<u8>, topic: &str, flags: u8, payload: &[u8]) {
    out.extend_from_slice(&(topic.len() as u16).to_be_bytes());
    out.extend_from_slice(topic.as_bytes());
    out.push(flags);
    out.extend_from_slice(&(payload.len() as u32).to_be_bytes());
    out.extend_from_slice(payload);
}

/// A payload of `n` copies of `byte`, made by the script.
fn repeated(out: &mut Vec<u8>, topic: &str, n: u32, byte: u8) {
    out.extend_from_slice(&(topic.len() as u16).to_be_bytes());
    out.extend_from_slice(topic.as_bytes());
    out.push(8 | 1);
    out.extend_from_slice(&n.to_be_bytes());
    out.push(byte);
}

/// `(topic, point type)` of every subscribed point of the flooded PLC.
const POINTS: &[(&str, &str)] = &[
    ("b", "u1"),
    ("c", "u8"),
    ("w", "u16"),
    ("d", "u32"),
    ("s8", "i8"),
    ("s16", "i16"),
    ("s32", "i32"),
    ("level", "f32"),
];

/// Whether `value`, as the module published it, is a finite value a point of type `ty`
/// holds.
fn holds(ty: &str, value: &str) -> bool {
    if ty == "f32" {
        return value.parse::<f32>().is_ok_and(f32::is_finite);
    }
    let Ok(v) = value.parse::<i64>() else {
        return false;
    };
    let bits: u32 = ty[1..].parse().unwrap();
    if ty.starts_with('u') {
        (0..1i64 << bits).contains(&v)
    } else {
        (-(1i64 << (bits - 1))..1i64 << (bits - 1)).contains(&v)
    }
}

/// (received, rejected) in a module's status line.
fn counts(line: &str) -> (u64, u64) {
    let count = |what: &str| -> u64 {
        let before = line.split(&format!(" {what}")).next().unwrap();
        before.rsplit(' ').next().unwrap().parse().unwrap()
    };
    (count("received"), count("rejected"))
}

/// (VmRSS, VmHWM) of a process, in KiB.
fn memory(pid: u32) -> (u64, u64) {
    let text = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let field = |name: &str| -> u64 {
        let line = text.lines().find(|l| l.starts_with(name)).unwrap();
        line.split_whitespace().nth(1).unwrap().parse().unwrap()
    };
    (field("VmRSS:"), field("VmHWM:"))
}

fn flood(broker: &Broker, file: &Path) {
    let out = Process::new(python())
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/mqtt_flood.py"))
        .arg(broker.port.to_string())
        .arg(file)
        .output()
        .expect("python with paho-mqtt (scripts/test-all.sh installs it into target/py)");
    assert!(out.status.success(), "mqtt_flood.py: {out:?}");
}

#[test]
fn a_flood_of_arbitrary_payloads_never_stops_the_plc_nor_makes_a_value_non_finite() {
    let dir = tempfile::tempdir().unwrap();
    let broker = Broker::start();
    std::fs::write(dir.path().join("main.st"), HALF).unwrap();
    let mut conf = String::from("[PLC]\nmodule mqtt mqtt\nmodule spb mqtt\nmodule logic iec\n");
    for (p, ty) in POINTS {
        conf += &format!("point {p} \"a {ty} from the broker\" mqtt {ty}\n");
    }
    let published: Vec<&str> = POINTS.iter().map(|p| p.0).chain(["half"]).collect();
    conf += "point half \"level / 2\" logic f32\npoint down \"broker away\" mqtt\n\
             [mqtt]\nbroker = 127.0.0.1:1\ntopic_prefix = out\nstale = down\n";
    conf += &format!("publish {}\n", published.join(" "));
    for (p, _) in POINTS {
        conf += &format!("subscribe in/{p} {p}\n");
    }
    conf += "[spb]\nbroker = 127.0.0.1:1\nsparkplug = fuzz/node\npublish level half\n\
             [logic]\nprogram = main.st\npou = main\nscan_period = T#10ms\n";
    let path = dir.path().join("plc.conf");
    std::fs::write(&path, conf).unwrap();
    let log = dir.path().join("plc.log");
    let id = format!("flood-{}", std::process::id());
    let plc = run(&path, &id, &log, &broker, &["mqtt", "spb"]);
    let pid = plc.id();
    wait_until("both modules up", || {
        module_line(&id, "mqtt").contains(" up;") && module_line(&id, "spb").contains(" up;")
    });
    // Everything the PLC publishes during the flood, as a third party sees it.
    let seen_path = dir.path().join("seen.txt");
    let watcher = Killed(Some(
        Process::new("mosquitto_sub")
            .args(["-h", "127.0.0.1", "-p", &broker.port.to_string()])
            .args(["-t", "out/#", "-v"])
            .stdout(std::fs::File::create(&seen_path).unwrap())
            .stderr(Stdio::null())
            .spawn()
            .unwrap(),
    ));

    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let specials = specials();
    let round = |rng: &mut Rng, out: &mut Vec<u8>| {
        for (p, _) in POINTS {
            let topic = format!("in/{p}");
            for s in &specials {
                // QoS 0 to 2, one in eight retained.
                let retain = if rng.below(8) == 0 { 4 } else { 0 };
                record(out, &topic, rng.below(3) as u8 | retain, s);
            }
            for _ in 0..150 {
                let payload = match rng.below(3) {
                    0 => (0..rng.below(48)).map(|_| rng.next() as u8).collect(),
                    _ => spelling(rng),
                };
                record(out, &topic, rng.below(3) as u8, &payload);
            }
            repeated(out, &topic, 70_000, b'7');
        }
        for c in commands(rng) {
            record(out, "spBv1.0/fuzz/NCMD/node", 1, &c);
        }
    };
    // A first round warms the allocators up; memory is measured around the next ones, which
    // also carry payloads of 1 and 32 MiB (a relay that held one would show it).
    let mut warm = Vec::new();
    round(&mut rng, &mut warm);
    std::fs::write(dir.path().join("warm.bin"), &warm).unwrap();
    flood(&broker, &dir.path().join("warm.bin"));
    let scans_before = scans(&id, "logic");
    let (rss_before, hwm_before) = memory(pid);
    let mut rest = Vec::new();
    for _ in 0..3 {
        round(&mut rng, &mut rest);
    }
    for (p, _) in POINTS {
        repeated(&mut rest, &format!("in/{p}"), 1 << 20, b'1');
    }
    std::fs::write(dir.path().join("rest.bin"), &rest).unwrap();
    flood(&broker, &dir.path().join("rest.bin"));

    // Good values last: once the module has published them, it has seen the whole flood.
    let finals = [
        ("b", "1"),
        ("c", "200"),
        ("w", "60000"),
        ("d", "4000000000"),
        ("s8", "-100"),
        ("s16", "-30000"),
        ("s32", "-2000000000"),
        ("level", "2.5"),
    ];
    for (p, v) in finals {
        publish(&broker, &format!("in/{p}"), v.as_bytes(), false);
    }
    let mut want: Vec<String> = finals
        .iter()
        .map(|(p, v)| format!("out/{p} {v}"))
        .chain(["out/half 1.25".to_string()])
        .collect();
    want.sort();
    let start = Instant::now();
    while retained(&broker, "out/#") != want {
        assert!(
            start.elapsed() < PATIENCE,
            "the final values not published: {:?}\n{}",
            retained(&broker, "out/#"),
            status(&id)
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    // Two payloads of 32 MiB on their own (a broker drops messages to a client that lags
    // far behind, so not in the flood): both reach the module, which holds neither.
    let (received, rejected) = counts(&module_line(&id, "mqtt"));
    let huge = vec![b'5'; 32 << 20];
    publish(&broker, "in/level", &huge, false);
    publish(&broker, "in/c", &huge, false);
    publish(&broker, "in/c", b"201", false);
    wait_until("c = 201", || retained(&broker, "out/c") == ["out/c 201"]);
    assert_eq!(
        counts(&module_line(&id, "mqtt")),
        (received + 3, rejected + 2)
    );
    let (rss_after, hwm_after) = memory(pid);
    let scans_after = scans(&id, "logic");
    drop(watcher);

    // The PLC kept scanning, its modules up, the link never lost.
    assert!(
        scans_after > scans_before,
        "{scans_before} -> {scans_after}"
    );
    for m in ["mqtt", "spb"] {
        let line = module_line(&id, m);
        assert!(
            line.contains(" up;") && line.contains(" 0 outages"),
            "{m}: {line}"
        );
    }
    // Memory: payloads of 1 and 32 MiB went by; the module held none of them.
    assert!(
        hwm_after < hwm_before + 48 * 1024 && rss_after < rss_before + 32 * 1024,
        "VmRSS {rss_before} -> {rss_after} KiB, VmHWM {hwm_before} -> {hwm_after} KiB"
    );
    // Every value the PLC published during the flood was finite and within its point.
    let seen = std::fs::read_to_string(&seen_path).unwrap();
    let mut values = 0;
    for line in seen.lines() {
        let (topic, value) = line.split_once(' ').unwrap_or((line, ""));
        let point = topic.strip_prefix("out/").unwrap();
        let ty = POINTS.iter().find(|p| p.0 == point).map_or("f32", |p| p.1);
        assert!(holds(ty, value), "{topic} = `{value}` published");
        values += 1;
    }
    assert!(values > 100, "only {values} values published:\n{seen}");
    assert!(seen.contains("out/c 201"), "{seen}");
    let (ok, report) = stop(&id, &log, plc);
    assert!(ok, "{report}");
    assert!(!report.contains("panicked"), "{report}");
    for m in ["mqtt", "spb", "logic"] {
        let row = report
            .lines()
            .find(|l| l.split_whitespace().next() == Some(m))
            .unwrap_or_else(|| panic!("no {m} in:\n{report}"));
        assert!(row.contains("stopped"), "{row}\n{report}");
    }
}
