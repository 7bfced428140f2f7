//! Hostile requests to the hmi module's API: arbitrary bodies, with and without the token, to
//! both endpoints, against the mixer stepped in-process. A test binary of its own, so that the
//! memory it measures is its own.

mod common;

use std::time::Duration;

use common::*;
use petriplc_runtime::harness::ms;

/// The resident memory of this process, in KiB.
fn rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .unwrap()
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .unwrap()
}

/// Any body, token or not, to either endpoint: the answer is a success or a refusal with a
/// reason, never a server error; the PLC keeps scanning, no point ever holds a value that is
/// not finite, and memory stays bounded.
#[test]
fn arbitrary_requests_never_break_the_plc() {
    use proptest::prelude::*;
    use proptest::test_runner::{Config, TestRunner};
    let dir = tempfile::tempdir().unwrap();
    let (mut plc, url) = mixer_harness(&dir.path().join("log.csv"));
    let mut now = Duration::ZERO;
    plc.tick(now).unwrap();
    let value = prop_oneof![
        any::<f64>().prop_map(|f| serde_json::json!(f)),
        any::<i64>().prop_map(|i| serde_json::json!(i)),
        any::<bool>().prop_map(|b| serde_json::json!(b)),
        "(?i)(nan|-?inf(inity)?|1e39|-1e400|0x10|[0-9]{1,60}|.{0,80})"
            .prop_map(|s| serde_json::json!(s)),
        Just(serde_json::json!(null)),
        Just(serde_json::json!([1, 2])),
    ];
    let name = prop_oneof![
        Just("T".to_string()),
        Just("SP".to_string()),
        Just("B1".to_string()),
        Just("L1".to_string()),
        ".{0,20}"
    ];
    let body = prop_oneof![
        (name, value).prop_map(|(p, v)| serde_json::json!({"point": p, "value": v}).to_string()),
        ".{0,200}",
        proptest::collection::vec(any::<u8>(), 0..300)
            .prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ];
    let mut round = |cases: u32| {
        while_scanning(&mut plc, &mut now, ms(10), || {
            let mut runner = TestRunner::new(Config {
                cases,
                failure_persistence: None,
                ..Config::default()
            });
            let url = url.clone();
            runner
                .run(
                    &(body.clone(), any::<bool>(), any::<bool>()),
                    |(body, token, release)| {
                        let path = if release { "api/unforce" } else { "api/force" };
                        let (status, reply) =
                            post(&format!("{url}{path}"), token.then_some(TOKEN), &body);
                        prop_assert!(
                            [200, 202, 400, 401].contains(&status),
                            "{body}: {status} {reply}"
                        );
                        let state = get_json(&format!("{url}api/state"));
                        let t = &point(&state, "T")["value"];
                        prop_assert!(t.as_f64().is_some_and(f64::is_finite), "T = {t}");
                        Ok(())
                    },
                )
                .err()
        })
    };
    // A first round warms up (the server's buffers, the client's connections); the second,
    // four times larger, must not need more memory: nothing is kept per request.
    let failures = round(100);
    assert!(failures.is_none(), "{failures:?}");
    let before = rss_kib();
    let failures = round(400);
    assert!(failures.is_none(), "{failures:?}");
    let grown = rss_kib().saturating_sub(before);
    assert!(
        grown < 16 * 1024,
        "memory grew by {grown} KiB over 400 requests"
    );
    let until = now + ms(50);
    run_to(&mut plc, &mut now, until);
    plc.close();
}
