//! SciPy as the reference: runs tests/scipy_reference.py (in this folder's parent) with the
//! Python of target/py, where scripts/test-all.sh installs the pinned SciPy
//! (`PETRIPLC_PYTHON` overrides).

#![allow(dead_code)]

use std::io::{BufRead, BufReader, Write};
use std::path::PathBuf;
use std::process::{Child, ChildStdout, Command, Stdio};
use std::sync::Mutex;

use serde_json::Value;

/// The SciPy version scripts/test-all.sh pins.
pub const SCIPY: &str = "1.17.1";

pub fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("PETRIPLC_PYTHON") {
        return PathBuf::from(p);
    }
    let p = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../../target/py/bin/python"
    ));
    if p.exists() {
        return p;
    }
    panic!(
        "no Python with SciPy: run scripts/test-all.sh, which installs scipy=={SCIPY} into \
         target/py, or set PETRIPLC_PYTHON"
    );
}

/// SciPy's answers to `requests` (see scipy_reference.py), one per request.
pub fn ask(requests: &[Value]) -> Vec<Value> {
    ask_script(
        concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../dsp/tests/scipy_reference.py"
        ),
        requests,
    )
}

/// The answers of a reference script that reads one JSON list of requests per line on
/// stdin and prints one line `{"scipy": VERSION, "answers": [...]}` for each. The script
/// runs once per test process and serves every test in it (importing SciPy takes seconds).
pub fn ask_script(script: &str, requests: &[Value]) -> Vec<Value> {
    static SERVERS: Mutex<Vec<(String, Child, BufReader<ChildStdout>)>> = Mutex::new(Vec::new());
    let mut servers = SERVERS.lock().unwrap_or_else(|e| e.into_inner());
    if !servers.iter().any(|s| s.0 == script) {
        let mut child = Command::new(python())
            .arg(script)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .unwrap_or_else(|e| panic!("cannot run {}: {e}", python().display()));
        let out = BufReader::new(child.stdout.take().unwrap());
        servers.push((script.to_string(), child, out));
    }
    let server = servers.iter_mut().find(|s| s.0 == script).unwrap();
    let mut line = serde_json::to_string(&Value::Array(requests.to_vec())).unwrap();
    line.push('\n');
    let stdin = server.1.stdin.as_mut().unwrap();
    stdin.write_all(line.as_bytes()).unwrap();
    stdin.flush().unwrap();
    let mut reply = String::new();
    server.2.read_line(&mut reply).unwrap();
    assert!(
        !reply.is_empty(),
        "{script} ended without answering (its error is above)"
    );
    let v: Value = serde_json::from_str(&reply).unwrap();
    assert_eq!(
        v["scipy"], SCIPY,
        "the reference must be scipy {SCIPY}; run scripts/test-all.sh"
    );
    let answers = v["answers"].as_array().unwrap().clone();
    assert_eq!(answers.len(), requests.len());
    answers
}

/// A number as JSON: NaN and infinities, which JSON lacks, as the strings "nan", "inf"
/// and "-inf" (the reference scripts read them back).
pub fn num(x: f64) -> Value {
    if x.is_finite() {
        Value::from(x)
    } else if x.is_nan() {
        Value::from("nan")
    } else if x > 0.0 {
        Value::from("inf")
    } else {
        Value::from("-inf")
    }
}

/// A list of numbers as JSON (see [`num`]).
pub fn nums(xs: &[f64]) -> Value {
    Value::Array(xs.iter().map(|&x| num(x)).collect())
}

/// A JSON number, or "nan"/"inf"/"-inf", or null (NaN).
pub fn float(x: &Value) -> f64 {
    match x {
        Value::String(s) => s.parse().unwrap_or_else(|_| panic!("not a number: {s}")),
        _ => x.as_f64().unwrap_or(f64::NAN),
    }
}

/// A JSON array of numbers as a vector.
pub fn floats(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array: {v}"))
        .iter()
        .map(float)
        .collect()
}

/// A JSON array of sections.
pub fn sections(v: &Value) -> Vec<[f64; 6]> {
    v.as_array()
        .unwrap_or_else(|| panic!("not an array of sections: {v}"))
        .iter()
        .map(|row| {
            let r = floats(row);
            [r[0], r[1], r[2], r[3], r[4], r[5]]
        })
        .collect()
}

/// The largest difference between two sections, relative to the largest coefficient of the
/// same numerator or denominator.
fn section_error(g: &[f64; 6], e: &[f64; 6]) -> f64 {
    let mut worst: f64 = 0.0;
    for half in [0..3, 3..6] {
        let scale = e[half.clone()].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        for i in half {
            let d = (g[i] - e[i]).abs() / scale.max(f64::MIN_POSITIVE);
            worst = worst.max(if d.is_nan() { f64::INFINITY } else { d });
        }
    }
    worst
}

/// How far a section's poles are from the unit circle: the key zpk2sos orders sections by
/// (the pole closest to the circle goes last).
fn circle_distance(s: &[f64; 6]) -> f64 {
    let (a1, a2) = (s[4] / s[3], s[5] / s[3]);
    let disc = a1 * a1 - 4.0 * a2;
    if disc < 0.0 {
        (1.0 - a2.sqrt()).abs()
    } else {
        let r = disc.sqrt();
        [(-a1 + r) / 2.0, (-a1 - r) / 2.0]
            .iter()
            .map(|p| (1.0 - p.abs()).abs())
            .fold(f64::INFINITY, f64::min)
    }
}

/// The largest difference between two cascades (see `section_error`); `None` when the
/// section counts differ. Sections whose poles are equally far from the unit circle (to
/// 1e-10) are compared as a set: zpk2sos orders them by rounding noise (mirror-image poles
/// of a band filter centred on a quarter of the sampling rate, for instance).
pub fn sos_error(got: &[[f64; 6]], expect: &[[f64; 6]]) -> Option<f64> {
    if got.len() != expect.len() {
        return None;
    }
    let mut worst: f64 = 0.0;
    let mut start = 0;
    while start < expect.len() {
        let key = circle_distance(&expect[start]);
        let mut end = start + 1;
        while end < expect.len() && (circle_distance(&expect[end]) - key).abs() <= 1e-10 {
            end += 1;
        }
        let mut unused: Vec<usize> = (start..end).collect();
        for g in &got[start..end] {
            let (pos, err) = unused
                .iter()
                .enumerate()
                .map(|(pos, &j)| (pos, section_error(g, &expect[j])))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap();
            unused.remove(pos);
            worst = worst.max(err);
        }
        start = end;
    }
    Some(worst)
}
