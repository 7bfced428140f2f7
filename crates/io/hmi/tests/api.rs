//! The hmi module's HTTP API: the page, the event stream, forcing with and without the token,
//! bad requests, the nets' SVG, start-up errors and a clean stop with pages connected. Most
//! tests step the modules in-process (petriplc_runtime::harness) with time passed in; one
//! runs the mixer for real (petriplc-plc) for the module status and the net's moving tokens.

mod common;

use std::io::BufRead;
use std::sync::mpsc;
use std::time::Duration;

use common::*;
use petriplc_runtime::harness::{self, ms};
use serde_json::Value;

/// The logger's rows for `point`, as (time, value).
fn logged(log: &std::path::Path, point: &str) -> Vec<(String, String)> {
    std::fs::read_to_string(log)
        .unwrap()
        .lines()
        .filter_map(|l| {
            let cells: Vec<&str> = l.split(',').collect();
            (cells.get(1) == Some(&point)).then(|| (cells[0].to_string(), cells[2].to_string()))
        })
        .collect()
}

#[test]
fn the_page_and_its_files_are_served() {
    let dir = tempfile::tempdir().unwrap();
    let (mut plc, url) = mixer_harness(&dir.path().join("log.csv"));
    let (status, page) = get(&url);
    assert_eq!(status, 200);
    assert!(page.contains("<title>petriplc HMI</title>"), "{page}");
    assert!(page.contains(r#"<script src="hmi.js">"#));
    let (status, js) = get(&format!("{url}hmi.js"));
    assert_eq!(status, 200);
    assert!(js.contains("new EventSource(\"events\")"));
    assert_eq!(get(&format!("{url}hmi.css")).0, 200);
    let (status, body) = get(&format!("{url}nothing"));
    assert_eq!(status, 404, "{body}");
    // A request naming another host (a rebound DNS name) is refused; loopback names are not.
    let addr = url.trim_start_matches("http://").trim_end_matches('/');
    let port = addr.rsplit(':').next().unwrap();
    let raw = |host: &str| {
        use std::io::{Read, Write};
        let mut s = std::net::TcpStream::connect(addr).unwrap();
        write!(
            s,
            "GET /api/state HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n"
        )
        .unwrap();
        let mut answer = String::new();
        s.read_to_string(&mut answer).unwrap();
        answer
    };
    let answer = raw(&format!("evil.example:{port}"));
    assert!(answer.starts_with("HTTP/1.1 421"), "{answer}");
    assert!(answer.contains("answers requests for"), "{answer}");
    assert!(raw(&format!("localhost:{port}")).starts_with("HTTP/1.1 200"));
    // The status line has the address and the pages, never the token.
    let line = plc.status("hmi");
    assert!(line.ends_with(" — 0 pages connected"), "{line}");
    assert!(!line.contains(TOKEN));
    plc.close();
}

#[test]
fn forcing_needs_the_token_and_every_module_reads_the_forced_value() {
    let dir = tempfile::tempdir().unwrap();
    let log = dir.path().join("log.csv");
    let (mut plc, url) = mixer_harness(&log);
    let (force, unforce) = (format!("{url}api/force"), format!("{url}api/unforce"));
    let mut now = Duration::ZERO;
    plc.tick(now).unwrap();

    // Refused without the token, with a wrong one, and with the token as a plain header.
    let b1_0 = r#"{"point": "B1", "value": 0}"#;
    for token in [
        None,
        Some("wrong-token-123"),
        Some(&TOKEN[..TOKEN.len() - 1]),
    ] {
        let (status, reply) = post(&force, token, b1_0);
        assert_eq!(status, 401, "{reply}");
        assert!(
            reply["error"]
                .as_str()
                .unwrap()
                .contains("Authorization: Bearer"),
            "{reply}"
        );
    }
    let (status, _) = post(&unforce, None, r#"{"point": "B1"}"#);
    assert_eq!(status, 401);
    let refused = agent()
        .post(&force)
        .header("Authorization", TOKEN)
        .send(b1_0)
        .unwrap();
    assert_eq!(refused.status().as_u16(), 401);
    // Nothing was queued: the operator's press at 0.2 s goes through.
    run_to(&mut plc, &mut now, ms(300));
    let state = get_json(&format!("{url}api/state"));
    assert_eq!(point(&state, "B1")["forced"], false, "{state}");
    assert_eq!(point(&state, "B1")["value"], 1, "{state}");
    assert!(logged(&log, "B1").iter().any(|(_, v)| v == "1"));

    // With the token: B1 forced to 0 while the operator presses it, from t = 0.
    let dir2 = tempfile::tempdir().unwrap();
    let log = dir2.path().join("log.csv");
    plc.close();
    let (mut plc, url) = mixer_harness(&log);
    let (force, unforce) = (format!("{url}api/force"), format!("{url}api/unforce"));
    let mut now = Duration::ZERO;
    let (status, reply) = while_scanning(&mut plc, &mut now, Duration::ZERO, || {
        post(&force, Some(TOKEN), b1_0)
    });
    assert_eq!(
        (status, &reply["forced"], &reply["value"]),
        (200, &Value::Bool(true), &Value::from(0)),
        "{reply}"
    );
    run_to(&mut plc, &mut now, ms(1500));
    // The logger and the controller (not B1's owner) read 0: no cycle started.
    let b1 = logged(&log, "B1");
    assert!(!b1.is_empty() && b1.iter().all(|(_, v)| v == "0"), "{b1:?}");
    assert_eq!(
        (plc.value("L1"), plc.value("V1"), plc.value("L2")),
        (1, 0, 0)
    );
    assert_eq!(
        logged(&log, "L1").len(),
        1,
        "L1 changed while B1 was forced to 0"
    );
    let state = get_json(&format!("{url}api/state"));
    assert_eq!(point(&state, "B1")["forced"], true, "{state}");
    assert_eq!(point(&state, "B1")["value"], 0, "{state}");

    // A signed point, through a string and a number.
    let (status, reply) = while_scanning(&mut plc, &mut now, ms(10), || {
        post(&force, Some(TOKEN), r#"{"point": "SP", "value": "-5"}"#)
    });
    assert_eq!(status, 200, "{reply}");
    plc.tick(now).unwrap();
    assert!(
        logged(&log, "SP").iter().any(|(_, v)| v == "-5"),
        "{:?}",
        logged(&log, "SP")
    );

    // Released: the operator's presses go through again and the controller starts a cycle.
    let (status, reply) = while_scanning(&mut plc, &mut now, ms(10), || {
        post(&unforce, Some(TOKEN), r#"{"point": "B1"}"#)
    });
    assert_eq!(
        (status, &reply["forced"]),
        (200, &Value::Bool(false)),
        "{reply}"
    );
    let released = now;
    run_to(&mut plc, &mut now, released + ms(3000));
    assert!(
        logged(&log, "B1").iter().any(|(_, v)| v == "1"),
        "{:?}",
        logged(&log, "B1")
    );
    let l1 = logged(&log, "L1");
    assert!(
        l1.iter().any(|(_, v)| v == "0"),
        "no cycle started after the release: {l1:?}"
    );
    let state = get_json(&format!("{url}api/state"));
    assert_eq!(point(&state, "B1")["forced"], false, "{state}");
    plc.close();
}

#[test]
fn bad_requests_are_refused_with_the_reason_and_change_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (mut plc, url) = mixer_harness(&dir.path().join("log.csv"));
    let force = format!("{url}api/force");
    let mut now = Duration::ZERO;
    plc.tick(now).unwrap();
    for (body, reason) in [
        ("{not json", "the body is not JSON"),
        (r#"{"value": 1}"#, "no `point` in the request"),
        (
            r#"{"point": "B9", "value": 1}"#,
            "no point `B9` in this PLC",
        ),
        (
            r#"{"point": "B1"}"#,
            "point `B1`: no `value` in the request",
        ),
        (
            r#"{"point": "B1", "value": 2}"#,
            "point `B1`: value 2 does not fit type bool (0 to 1)",
        ),
        (
            r#"{"point": "SP", "value": 40000}"#,
            "point `SP`: value 40000 does not fit type i16 (-32768 to 32767)",
        ),
        (
            r#"{"point": "SP", "value": "ten"}"#,
            "point `SP`: value ten is not a whole number",
        ),
        // Issue 27: no point ever holds NaN or an infinity from outside.
        (
            r#"{"point": "T", "value": "NaN"}"#,
            "point `T`: value nan is not a finite number",
        ),
        (
            r#"{"point": "T", "value": "-inf"}"#,
            "point `T`: value -inf is not a finite number",
        ),
        (
            r#"{"point": "T", "value": 1e39}"#,
            "point `T`: value 1e+39 does not fit type f32 (±3.4e38)",
        ),
    ] {
        let (status, reply) = post(&force, Some(TOKEN), body);
        assert_eq!(status, 400, "{body}: {reply}");
        let error = reply["error"].as_str().unwrap();
        assert!(error.starts_with(reason), "{body}: {error}");
    }
    run_to(&mut plc, &mut now, ms(100));
    let state = get_json(&format!("{url}api/state"));
    for p in state["points"].as_array().unwrap() {
        assert_eq!(p["forced"], false, "{p}");
    }
    assert_eq!(point(&state, "SP")["value"], 7);
    assert_eq!(point(&state, "T")["value"], 21.5);
    plc.close();
}

/// Reads server-sent events from `url` on a thread: each snapshot's JSON is sent to the
/// returned channel, then `None` when the stream ends.
fn follow(url: &str) -> mpsc::Receiver<Option<Value>> {
    let (tx, rx) = mpsc::channel();
    let url = format!("{url}events");
    std::thread::spawn(move || {
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .timeout_global(Some(Duration::from_secs(60)))
            .build()
            .into();
        let r = agent.get(&url).call().unwrap();
        assert_eq!(r.status().as_u16(), 200);
        let kind = r.headers()["content-type"].to_str().unwrap().to_string();
        assert!(kind.starts_with("text/event-stream"), "{kind}");
        let reader = std::io::BufReader::new(r.into_body().into_reader());
        let mut event = String::new();
        for line in reader.lines() {
            let Ok(line) = line else { break };
            if let Some(e) = line.strip_prefix("event: ") {
                event = e.to_string();
            } else if let Some(data) = line.strip_prefix("data: ") {
                assert_eq!(event, "snapshot");
                if tx.send(Some(serde_json::from_str(data).unwrap())).is_err() {
                    return;
                }
            }
        }
        let _ = tx.send(None);
    });
    rx
}

#[test]
fn the_event_stream_sends_changes_and_ends_when_the_module_closes() {
    let dir = tempfile::tempdir().unwrap();
    let (mut plc, url) = mixer_harness(&dir.path().join("log.csv"));
    let mut now = Duration::ZERO;
    plc.tick(now).unwrap();
    let events = follow(&url);
    // The first snapshot comes at once, before anything changes.
    let first = events
        .recv_timeout(Duration::from_secs(10))
        .unwrap()
        .expect("the stream ended at once");
    assert_eq!(point(&first, "B1")["value"], 0, "{first}");
    assert_eq!(point(&first, "B1")["kind"], "bool");
    assert_eq!(point(&first, "SP")["kind"], "i16");
    assert_eq!(point(&first, "B1")["owner"], "operator");
    assert_eq!(point(&first, "B1")["description"], "start button");
    assert_eq!(
        plc.status("hmi").split(" — ").nth(1),
        Some("1 page connected")
    );
    // As the PLC runs, B1 is pressed and released; each snapshot is a new version.
    let seen = vec![first];
    let (events, seen) = while_scanning(&mut plc, &mut now, ms(10), move || {
        let mut seen = seen;
        while !(seen.iter().any(|s| point(s, "B1")["value"] == 1)
            && point(seen.last().unwrap(), "B1")["value"] == 0)
        {
            let s = events
                .recv_timeout(Duration::from_secs(20))
                .expect("no snapshot for 20 s")
                .expect("the stream ended");
            seen.push(s);
        }
        (events, seen)
    });
    let versions: Vec<u64> = seen
        .iter()
        .map(|s| s["version"].as_u64().unwrap())
        .collect();
    assert!(versions.windows(2).all(|w| w[0] < w[1]), "{versions:?}");
    // Closing the module ends the open stream.
    plc.close();
    loop {
        match events.recv_timeout(Duration::from_secs(10)) {
            Ok(Some(_)) => continue,
            Ok(None) => break,
            Err(e) => panic!("the event stream did not end when the module closed: {e}"),
        }
    }
}

#[test]
fn the_nets_are_drawn_with_every_place_and_transition() {
    let dir = tempfile::tempdir().unwrap();
    let (mut plc, url) = mixer_harness(&dir.path().join("log.csv"));
    let nets = get_json(&format!("{url}api/nets"));
    let nets = nets.as_array().unwrap();
    assert_eq!(nets.len(), 1);
    assert_eq!(nets[0]["module"], "controller");
    let svg = nets[0]["svg"].as_str().unwrap();
    let (status, alone) = get(&format!("{url}api/nets/controller"));
    assert_eq!((status, alone.as_str()), (200, svg));
    let doc = roxmltree::Document::parse(svg).unwrap_or_else(|e| panic!("{e}: {svg}"));
    let labels = |attr: &str| -> Vec<&str> {
        doc.descendants()
            .filter(|e| e.tag_name().name() == "g")
            .filter_map(|e| e.attribute(attr))
            .collect()
    };
    assert_eq!(
        labels("data-place"),
        ["L1", "A1", "V1", "L2", "V2", "M1", "V3", "L3"]
    );
    assert_eq!(labels("data-transition"), ["B1", "N2", "N3", "N1"]);
    let arcs = doc
        .descendants()
        .filter(|e| e.tag_name().name() == "path" && e.attribute("data-kind").is_some())
        .count();
    assert_eq!(arcs, 16);
    assert_eq!(doc.root_element().attribute("data-layout"), Some("pnml"));
    // The initial marking: one token in L1.
    let l1 = doc
        .descendants()
        .find(|e| e.tag_name().name() == "g" && e.attribute("data-place") == Some("L1"))
        .unwrap();
    assert_eq!(l1.attribute("data-tokens"), Some("1"));
    let (status, body) = get(&format!("{url}api/nets/tank"));
    assert_eq!(status, 404, "{body}");
    assert!(body.contains("nets: controller"), "{body}");
    plc.close();
}

#[test]
fn a_taken_address_and_bad_settings_are_reported_from_init() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = taken.local_addr().unwrap();
    let conf = |hmi: &str| format!("[PLC]\nmodule hmi hmi\npoint X \"x\" hmi\n[hmi]\n{hmi}\n");
    let err = harness::start_err(&conf(&format!("listen = {addr}")), &mixer_dir(), registry);
    let mut next = addr;
    next.set_port(addr.port() + 1);
    assert_eq!(
        err,
        format!(
            "module hmi: cannot listen on {addr}: address already in use; set `listen = \
             HOST:PORT` in [hmi] or run with --set hmi:listen={next}"
        )
    );
    for (setting, expect) in [
        (
            "listen = localhost",
            "module hmi: test.conf:5: `listen = localhost` is not an address and port",
        ),
        (
            "token = short",
            "module hmi: test.conf:5: `token` must be at least 8 printable ASCII",
        ),
        (
            "refresh = 0",
            "module hmi: test.conf:5: `refresh = 0`: write a time from 10 ms to 60 s",
        ),
        (
            "colour = red",
            "module hmi: unknown setting `colour` (test.conf:5) in section [hmi]",
        ),
    ] {
        let err = harness::start_err(&conf(setting), &mixer_dir(), registry);
        assert!(err.starts_with(expect), "{setting}: {err}");
    }
}

#[test]
fn a_running_plc_shows_module_status_and_the_net_marking_changing() {
    let mut run = run_mixer();
    let url = run.url.clone();
    let markings = std::cell::RefCell::new(Vec::<Value>::new());
    let state = wait_for(Duration::from_secs(30), || {
        let s = get_json(&format!("{url}api/state"));
        let m = s["nets"][0]["marking"].clone();
        let mut ms = markings.borrow_mut();
        if m.as_array().is_some_and(|a| !a.is_empty()) && ms.last() != Some(&m) {
            ms.push(m);
        }
        (ms.len() >= 3).then_some(s)
    })
    .unwrap_or_else(|| {
        let state = get_json(&format!("{url}api/state"));
        panic!(
            "the marking did not change: {:?}; {state}",
            markings.borrow()
        )
    });
    let modules: Vec<&str> = state["modules"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(modules, ["operator", "tank", "controller", "hmi"]);
    let controller = &state["modules"][2];
    assert_eq!(controller["state"], "running", "{state}");
    assert!(controller["scans"].as_u64().unwrap() > 0);
    assert_eq!(state["nets"][0]["module"], "controller");
    // Every place, by the labels the SVG uses, in place order.
    let first = markings.borrow()[0].clone();
    let labels: Vec<&str> = first
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p[0].as_str().unwrap())
        .collect();
    assert_eq!(labels, ["L1", "A1", "V1", "L2", "V2", "M1", "V3", "L3"]);
    let hmi = &state["modules"][3];
    assert!(!hmi["detail"].as_str().unwrap().contains(TOKEN));
    let last = run.stop().unwrap();
    assert!(
        last.modules.iter().all(|m| m.state.as_str() != "failed"),
        "{last}"
    );
}
