//! The `dsp` module run scan by scan through the PLC harness (a real process image), fed by
//! a `timeline` module with decimal values, against references in Python: SciPy's `sosfilt`
//! and `lfilter` for the filters (step, impulse and chirp), a discrete PID closing the loop
//! around the `thermal` plant module, and each other block's documented behaviour including
//! NaN, infinities and out-of-range conversions (tests/dsp_reference.py).

mod harness;
#[path = "../../../base/dsp/tests/support/mod.rs"]
mod support;

use std::path::Path;
use std::time::Duration;

use harness::{start, start_err, Plc};
use petriplc_config::PointValue;
use serde_json::{json, Value};
use support::{ask_script, floats, nums};

const REFERENCE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/dsp_reference.py");

fn reference(requests: &[Value]) -> Vec<Value> {
    ask_script(REFERENCE, requests)
}

/// `time,COL...` rows at every scan of `period_ms`, the values as f32 decimals.
fn timeline(columns: &[(&str, &[f32])], period_ms: u64) -> String {
    let mut s = String::from("time");
    for (name, _) in columns {
        s += &format!(",{name}");
    }
    s.push('\n');
    let n = columns.iter().map(|c| c.1.len()).max().unwrap_or(0);
    for k in 0..n {
        let ms = k as u64 * period_ms;
        s += &format!("{}.{:03}", ms / 1000, ms % 1000);
        for (_, values) in columns {
            match values.get(k) {
                Some(v) => s += &format!(",{v}"),
                None => s.push(','),
            }
        }
        s.push('\n');
    }
    s
}

fn value(plc: &Plc, point: &str) -> f64 {
    match plc.get(point) {
        PointValue::Float(v) => f64::from(v),
        PointValue::Signed(v) => f64::from(v),
        PointValue::Unsigned(v) => f64::from(v),
    }
}

/// Runs `scans` scans `period_ms` apart and records `points` after each: one vector per
/// point.
fn run(plc: &mut Plc, scans: usize, period_ms: u64, points: &[&str]) -> Vec<Vec<f64>> {
    let mut rec = vec![Vec::with_capacity(scans); points.len()];
    for k in 0..scans {
        plc.tick(Duration::from_millis(k as u64 * period_ms))
            .unwrap();
        for (r, p) in rec.iter_mut().zip(points) {
            r.push(value(plc, p));
        }
    }
    rec
}

fn start_in(dir: &Path, config: &str, files: &[(&str, String)]) -> Plc {
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    start(config, dir).unwrap_or_else(|e| panic!("{e}"))
}

/// `|got − expect| ≤ tol · max(1, peak |expect|)` everywhere (NaN only where NaN); with
/// `tol = 0`, the same f32 (what the points hold: the JSON numbers read back may be an `f64`
/// unit in the last place off, which rounding to f32 undoes).
fn assert_close(name: &str, got: &[f64], expect: &[f64], tol: f64) {
    assert_eq!(got.len(), expect.len(), "{name}");
    let peak = expect
        .iter()
        .filter(|v| v.is_finite())
        .fold(1.0f64, |m, v| m.max(v.abs()));
    for (k, (g, e)) in got.iter().zip(expect).enumerate() {
        let ok =
            (g.is_nan() && e.is_nan()) || *g as f32 == *e as f32 || (g - e).abs() <= tol * peak;
        assert!(ok, "{name}: scan {k}: {g} where the reference has {e}");
    }
}

const FILTERS: &str = "
[PLC]
module feed timeline
module dsp dsp
point x \"input\" feed f32
point y1 \"\" dsp f32
point y2 \"\" dsp f32
point y3 \"\" dsp f32
point y4 \"\" dsp f32
point y5 \"\" dsp f32
point y6 \"\" dsp f32
point y7 \"\" dsp f32
point y8 \"\" dsp f32
point y9 \"\" dsp f32
[feed]
file = x.csv
[dsp]
scan_period = 0.001
fblock filter x y1 butterworth lowpass 1 1 40 100 150
fblock filter x y2 chebyshev highpass 2.5 0.5 30 100 150
fblock filter x y3 elliptic bandpass 1 0.5 40 50 100 150 200
fblock filter x y4 bessel bandstop 1 3 10 50 200 300 450
fblock filter x y5 chebyshev2 bandstop 1 1 40 100 180 220 300
fblock filter x y6 butterworth lowpass 0.5 order 4 50 steady
fblock filter x y7 iir 0.5 -2 1 0.2 0.3 2 1 -0.1 0.05
fblock filter x y8 fir lowpass 31 100 kaiser 5
fblock filter x y9 fir 0.25 0.5 0.25
";

/// What each output's filter is in SciPy's terms: (design, gain, steady).
fn filter_designs(bessel: (usize, Vec<f64>)) -> Vec<(Value, f64, bool)> {
    let fs = 1000.0;
    vec![
        (
            json!({"iirdesign": {"wp": [100.0], "ws": [150.0], "gpass": 1.0, "gstop": 40.0, "ftype": "butter", "fs": fs}}),
            1.0,
            false,
        ),
        (
            json!({"iirdesign": {"wp": [150.0], "ws": [100.0], "gpass": 0.5, "gstop": 30.0, "ftype": "cheby1", "fs": fs}}),
            2.5,
            false,
        ),
        (
            json!({"iirdesign": {"wp": [100.0, 150.0], "ws": [50.0, 200.0], "gpass": 0.5, "gstop": 40.0, "ftype": "ellip", "fs": fs}}),
            1.0,
            false,
        ),
        (
            json!({"iirfilter": {"n": bessel.0, "wn": bessel.1, "btype": "bandstop", "ftype": "bessel_mag", "fs": fs}}),
            1.0,
            false,
        ),
        (
            json!({"iirdesign": {"wp": [100.0, 300.0], "ws": [180.0, 220.0], "gpass": 1.0, "gstop": 40.0, "ftype": "cheby2", "fs": fs}}),
            1.0,
            false,
        ),
        (
            json!({"iirfilter": {"n": 4, "wn": [50.0], "btype": "lowpass", "ftype": "butter", "fs": fs}}),
            0.5,
            true,
        ),
        (
            json!({"sos": [[1.0, -2.0, 1.0, 1.0, 0.2, 0.3], [1.0, 2.0, 1.0, 1.0, -0.1, 0.05]]}),
            0.5,
            false,
        ),
        (
            json!({"firwin": {"numtaps": 31, "cutoff": [100.0], "window": ["kaiser", 5.0], "pass_zero": "lowpass", "fs": fs}}),
            1.0,
            false,
        ),
        (json!({"fir": [0.25, 0.5, 0.25]}), 1.0, false),
    ]
}

/// The order and critical frequencies the status shows for the Bessel filter.
fn bessel_from_status(status: &str) -> (usize, Vec<f64>) {
    let line = status
        .lines()
        .find(|l| l.starts_with("filter bessel"))
        .unwrap_or_else(|| panic!("no bessel filter in the status:\n{status}"));
    let order = line
        .split("order ")
        .nth(1)
        .and_then(|r| r.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    let critical: Vec<f64> = line
        .split("(critical ")
        .nth(1)
        .and_then(|r| r.split(" Hz").next())
        .unwrap()
        .split_whitespace()
        .map(|v| v.parse().unwrap())
        .collect();
    (order, critical)
}

#[test]
fn filters_equal_scipy_sosfilt_on_step_impulse_and_chirp() {
    let n = 300;
    let step = vec![1.0f32; n];
    let mut impulse = vec![0.0f32; n];
    impulse[0] = 1.0;
    // A linear chirp from 1 Hz to 450 Hz over the run, sampled at 1 kHz.
    let chirp: Vec<f32> = (0..n)
        .map(|k| {
            let t = k as f64 / 1000.0;
            let span = n as f64 / 1000.0;
            let phase = 2.0 * std::f64::consts::PI * (t + (450.0 - 1.0) / (2.0 * span) * t * t);
            phase.sin() as f32
        })
        .collect();
    let outputs = ["y1", "y2", "y3", "y4", "y5", "y6", "y7", "y8", "y9"];
    let mut requests = Vec::new();
    let mut got = Vec::new();
    let mut names = Vec::new();
    for (signal, xs) in [("step", &step), ("impulse", &impulse), ("chirp", &chirp)] {
        let dir = tempfile::tempdir().unwrap();
        let csv = timeline(&[("x", xs)], 1);
        let mut plc = start_in(dir.path(), FILTERS, &[("x.csv", csv)]);
        let mut points = vec!["x"];
        points.extend(outputs);
        let rec = run(&mut plc, n, 1, &points);
        let status = plc.status("dsp");
        assert!(status.starts_with("9 blocks, "), "{status}");
        for ((design, gain, steady), (i, out)) in filter_designs(bessel_from_status(&status))
            .into_iter()
            .zip(outputs.iter().enumerate())
        {
            requests.push(json!({"op": "filter", "design": design, "gain": gain,
                                 "steady": steady, "x": nums(&rec[0])}));
            got.push(rec[i + 1].clone());
            names.push(format!("{signal} through {out}"));
        }
    }
    let answers = reference(&requests);
    for ((name, got), answer) in names.iter().zip(&got).zip(&answers) {
        assert_close(name, got, &floats(&answer["y"]), 1e-6);
    }
}

/// The oven loop: setpoint from a timeline, the `thermal` plant, the PID in a dsp module.
fn oven_config(pid: &str) -> String {
    format!(
        "[PLC]
module ops timeline
module oven plant
module ctl dsp
point setpoint \"\" ops f32
point auto \"\" ops
point manual \"\" ops f32
point temp \"vessel temperature\" oven f32
point heater \"heater power %\" ctl f32
[ops]
file = ops.csv
[oven]
plant = thermal
gain = 2
time_constant = 20
dead_time = 2
ambient = 20
[ctl]
scan_period = 0.1
fblock pid temp heater {pid}
"
    )
}

/// Runs the oven for `scans` scans of 100 ms with the operator's columns: the points
/// recorded (setpoint, temp, heater, auto, manual) and the reference loop's request with the
/// same PID settings.
fn oven_run(
    pid_row: &str,
    pid: Value,
    ops: &[(&str, &[f32])],
    scans: usize,
) -> (Vec<Vec<f64>>, Value) {
    let dir = tempfile::tempdir().unwrap();
    let mut plc = start_in(
        dir.path(),
        &oven_config(pid_row),
        &[("ops.csv", timeline(ops, 100))],
    );
    let rec = run(
        &mut plc,
        scans,
        100,
        &["setpoint", "temp", "heater", "auto", "manual"],
    );
    let times: Vec<u64> = (0..scans as u64).map(|k| k * 100_000_000).collect();
    let has_mode = ops.iter().any(|c| c.0 == "auto");
    let request = json!({
        "op": "pid_loop", "pid": pid,
        "plant": {"gain": 2.0, "time_constant": 20.0, "dead_time": 2.0, "ambient": 20.0},
        "times_ns": times, "sp": nums(&rec[0]),
        "mode": if has_mode { nums(&rec[3]) } else { Value::Null },
        "manual": if has_mode { nums(&rec[4]) } else { Value::Null },
    });
    (rec, request)
}

/// Each run's temperature and heater output equal the reference loop's, every scan (one
/// Python run for all: starting it costs more than the loops).
fn check_ovens(runs: &[(Vec<Vec<f64>>, Value)]) {
    let requests: Vec<Value> = runs.iter().map(|r| r.1.clone()).collect();
    for ((rec, _), answer) in runs.iter().zip(reference(&requests)) {
        assert_close("temperature", &rec[1], &floats(&answer["temp"]), 1e-6);
        assert_close("heater", &rec[2], &floats(&answer["heater"]), 1e-6);
    }
}

fn steps(n: usize, changes: &[(usize, f32)]) -> Vec<f32> {
    let mut v = vec![0.0; n];
    for (i, &(from, x)) in changes.iter().enumerate() {
        let to = changes.get(i + 1).map_or(n, |c| c.0);
        v[from..to].fill(x);
    }
    v
}

/// Setpoint steps 20 → 150 → 100 °C on the first-order-plus-dead-time vessel, parallel
/// and ideal forms with derivative on the measurement through a filter: the loop settles,
/// and every scan equals the Python reference.
#[test]
fn pid_closes_the_loop_around_the_thermal_plant_as_the_reference() {
    let sp = steps(1200, &[(0, 20.0), (10, 150.0), (600, 100.0)]);
    let parallel = oven_run(
        "2 0.2 2 sp setpoint min_out 0 max_out 100 d_filter 0.5",
        json!({"p": 2.0, "i": 0.2, "d": 2.0, "min_out": 0.0, "max_out": 100.0, "d_filter": 0.5}),
        &[("setpoint", &sp)],
        1200,
    );
    let temp = &parallel.0[1];
    // Settled within 1 °C of each setpoint before the next change.
    assert!((temp[590] - 150.0).abs() < 1.0, "{}", temp[590]);
    assert!(temp[..600].iter().all(|&t| t < 152.0), "overshoot");
    assert!((temp[1199] - 100.0).abs() < 1.0, "{}", temp[1199]);
    let ideal = oven_run(
        "2 10 1 sp setpoint form ideal min_out 0 max_out 100 d_filter 0.2 anti_windup backcalc",
        json!({"form": "ideal", "p": 2.0, "i": 10.0, "d": 1.0, "min_out": 0.0, "max_out": 100.0,
               "d_filter": 0.2, "anti_windup": "backcalc", "tt": (10.0f64 * 1.0).sqrt()}),
        &[("setpoint", &sp)],
        1200,
    );
    check_ovens(&[parallel, ideal]);
}

/// A setpoint the heater cannot reach (300 °C, at most 220) for a minute, then 100 °C.
/// Without anti-windup the integral grows the whole minute and holds the heater at 100 %
/// long after the drop, overshooting; clamping and back-calculation let go at once.
#[test]
fn anti_windup_with_a_saturating_heater() {
    let sp = steps(1500, &[(0, 300.0), (600, 100.0)]);
    let mut results = Vec::new();
    let mut runs = Vec::new();
    for (aw, extra) in [
        ("none", json!({})),
        ("clamp", json!({})),
        ("backcalc", json!({"tt": 5.0})),
    ] {
        let row = format!(
            "2 0.1 0 sp setpoint min_out 0 max_out 100 anti_windup {aw}{}",
            if aw == "backcalc" { " tt 5" } else { "" }
        );
        let mut pid = json!({"p": 2.0, "i": 0.1, "d": 0.0, "min_out": 0.0, "max_out": 100.0,
                             "anti_windup": aw});
        if let Some(tt) = extra.get("tt") {
            pid["tt"] = tt.clone();
        }
        let (rec, request) = oven_run(&row, pid, &[("setpoint", &sp)], 1500);
        let heater = &rec[2];
        assert!(
            heater[100..600].iter().all(|&u| u == 100.0),
            "{aw}: saturated"
        );
        let held = heater[600..].iter().take_while(|&&u| u == 100.0).count();
        // The temperature half a minute after the drop to 100 °C.
        results.push((aw, held, rec[1][900]));
        runs.push((rec, request));
    }
    check_ovens(&runs);
    let (none, clamp, back) = (results[0], results[1], results[2]);
    assert!(none.1 > 200, "{results:?}");
    assert!(clamp.1 < 20 && back.1 < 20, "{results:?}");
    assert!(
        none.2 > 200.0 && clamp.2 < 130.0 && back.2 < 130.0,
        "{results:?}"
    );
}

/// Auto, then manual at 40 s (manual output 30 %), then auto again at 70 s, with the
/// output rate limited to 5 %/s: the output never moves more than 0.5 % in a 100 ms scan,
/// walks to the manual value, and returns to auto where it was. Without a rate limit the
/// return to auto is still bumpless: the integral tracked the manual output.
#[test]
fn bumpless_manual_auto_transfer() {
    let n = 1000;
    let sp = steps(n, &[(0, 120.0)]);
    let auto = steps(n, &[(0, 1.0), (400, 0.0), (700, 1.0)]);
    let manual = steps(n, &[(0, 30.0)]);
    let ops: [(&str, &[f32]); 3] = [("setpoint", &sp), ("auto", &auto), ("manual", &manual)];
    let base = json!({"p": 2.0, "i": 0.1, "d": 0.0, "min_out": 0.0, "max_out": 100.0});
    let limited = oven_run(
        "2 0.1 0 sp setpoint min_out 0 max_out 100 rate 5 mode auto manual manual",
        {
            let mut p = base.clone();
            p["rate"] = json!(5.0);
            p
        },
        &ops,
        n,
    );
    let heater = &limited.0[2];
    let biggest = heater
        .windows(2)
        .map(|w| (w[1] - w[0]).abs())
        .fold(0.0f64, f64::max);
    assert!(biggest <= 0.5 + 1e-5, "a step of {biggest} %");
    assert!(
        (heater[699] - 30.0).abs() < 1e-5,
        "manual output reached: {}",
        heater[699]
    );

    let free = oven_run(
        "2 0.1 0 sp setpoint min_out 0 max_out 100 mode auto manual manual",
        base,
        &ops,
        n,
    );
    let heater = &free.0[2];
    assert_eq!(heater[699], 30.0);
    assert!(
        (heater[700] - heater[699]).abs() < 0.5,
        "{} → {}",
        heater[699],
        heater[700]
    );
    check_ovens(&[limited, free]);
}

const BLOCKS: &str = "
[PLC]
module feed timeline
module dsp dsp
point x \"\" feed f32
point y \"\" feed f32
point z \"\" feed f32
point c \"\" feed f32
point noisy \"\" feed f32
point i \"\" dsp i32
point u \"\" dsp u32
point s \"\" dsp i16
point b \"\" dsp
point a \"\" dsp f32
point m \"\" dsp f32
point p2 \"\" dsp f32
point pinv \"\" dsp f32
point psqrt \"\" dsp f32
point nl \"\" dsp f32
point rp \"\" dsp f32
point mx \"\" dsp f32
point al1 \"\" dsp
point al2 \"\" dsp f32
point al3 \"\" dsp u8
point raw \"\" dsp
point t \"\" dsp f32
[feed]
file = in.csv
non_finite = accept
[dsp]
scan_period = 0.1
out_time_pt = t
fblock typeconv x f32 i i32 x f32 u u32 x f32 s i32 x f32 b u32
fblock add a x 2 y -0.5
fblock mult m x 1 y 0.25
fblock pow p2 x 2
fblock pow pinv x -1
fblock pow psqrt x 0.5
fblock nonlinear x nl cutoff_top 7 cutoff_bot 2 deadband_bot 4 deadband_top 5 deadband_out 4 gain 1
fblock ramp x rp pos_dxdt 20 neg_dxdt 40 d2xdt2 100
fblock multiplexor mx c x 1 y 2 z
fblock alarm noisy true_val hysteresis 0.5 al1 gt 10 al2 lt 5 al3 eq 7
fblock alarm noisy true_val raw gt 10
";

/// A deterministic noise in [−1, 1].
fn noise(k: usize) -> f32 {
    let h = (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) >> 40;
    (h as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
}

#[test]
fn blocks_equal_their_reference_with_nan_infinities_and_range_edges() {
    let special = [
        0.0f32,
        1.5,
        -2.5,
        2.5,
        -0.4999,
        65536.7,
        3e9,
        -3e9,
        5e9,
        1e30,
        -1e30,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        4.5,
        7.0,
        6.0,
        0.5,
        -7.0,
        3.0,
    ];
    let n = 240;
    let x: Vec<f32> = (0..n)
        .map(|k| {
            if k < 120 {
                special[k % special.len()]
            } else {
                (k as f32 - 120.0) / 10.0 - 3.0
            }
        })
        .collect();
    let y: Vec<f32> = (0..n).map(|k| noise(k + 1000) * 50.0).collect();
    let z: Vec<f32> = (0..n).map(|k| k as f32).collect();
    let c: Vec<f32> = (0..n)
        .map(|k| match k % 7 {
            0 => f32::NAN,
            r => r as f32 * 0.5,
        })
        .collect();
    // A slow ramp through the limits at 5, 7 and 10 with noise of ±0.4.
    let noisy: Vec<f32> = (0..n)
        .map(|k| 3.0 + 9.0 * k as f32 / n as f32 + 0.4 * noise(k))
        .collect();
    let dir = tempfile::tempdir().unwrap();
    let csv = timeline(
        &[
            ("x", &x),
            ("y", &y),
            ("z", &z),
            ("c", &c),
            ("noisy", &noisy),
        ],
        100,
    );
    let mut plc = start_in(dir.path(), BLOCKS, &[("in.csv", csv)]);
    let names = [
        "x", "y", "z", "c", "noisy", "i", "u", "s", "b", "a", "m", "p2", "pinv", "psqrt", "nl",
        "rp", "mx", "al1", "al2", "al3", "raw", "t",
    ];
    let rec = run(&mut plc, n, 100, &names);
    let col = |name: &str| &rec[names.iter().position(|n| *n == name).unwrap()];
    let (xs, ys, zs, cs, ns) = (col("x"), col("y"), col("z"), col("c"), col("noisy"));
    let times: Vec<f64> = (0..n)
        .map(|k| Duration::from_millis(k as u64 * 100).as_secs_f64())
        .collect();
    let block = |kind: &str, params: Value, extra: Value| {
        let mut r = json!({"op": "block", "kind": kind, "params": params, "x": nums(xs)});
        if let (Some(r), Some(e)) = (r.as_object_mut(), extra.as_object()) {
            r.extend(e.clone());
        }
        r
    };
    let requests = vec![
        block("typeconv", json!({"bits": 32, "signed": true}), json!({})),
        block("typeconv", json!({"bits": 32, "signed": false}), json!({})),
        block("typeconv", json!({"bits": 16, "signed": true}), json!({})),
        block("typeconv", json!({"bits": 1, "signed": false}), json!({})),
        block(
            "add",
            json!({"gains": [2.0, -0.5]}),
            json!({"inputs": [nums(xs), nums(ys)]}),
        ),
        block(
            "mult",
            json!({"offsets": [1.0, 0.25]}),
            json!({"inputs": [nums(xs), nums(ys)]}),
        ),
        block("pow", json!({"exponent": 2.0}), json!({})),
        block("pow", json!({"exponent": -1.0}), json!({})),
        block("pow", json!({"exponent": 0.5}), json!({})),
        block(
            "nonlinear",
            json!({"cutoff_top": 7.0, "cutoff_bot": 2.0, "deadband_bot": 4.0, "deadband_top": 5.0,
                   "deadband_out": 4.0, "gain": 1.0}),
            json!({}),
        ),
        block(
            "ramp",
            json!({"pos_dxdt": 20.0, "neg_dxdt": 40.0, "pos_d2xdt2": 100.0, "neg_d2xdt2": 100.0}),
            json!({"t": times}),
        ),
        block(
            "multiplexor",
            json!({"limits": [1.0, 2.0]}),
            json!({"control": nums(cs), "inputs": [nums(xs), nums(ys), nums(zs)]}),
        ),
        json!({"op": "block", "kind": "alarm", "x": nums(ns),
               "params": {"hysteresis": 0.5, "limits": [["gt", 10.0], ["lt", 5.0], ["eq", 7.0]]}}),
        json!({"op": "block", "kind": "alarm", "x": nums(ns),
               "params": {"limits": [["gt", 10.0]]}}),
    ];
    let answers = reference(&requests);
    let y = |i: usize| floats(&answers[i]["y"]);
    let checks: [(&str, Vec<f64>); 12] = [
        ("i", y(0)),
        ("u", y(1)),
        ("s", y(2)),
        ("b", y(3)),
        ("a", y(4)),
        ("m", y(5)),
        ("p2", y(6)),
        ("pinv", y(7)),
        ("psqrt", y(8)),
        ("nl", y(9)),
        ("rp", y(10)),
        ("mx", y(11)),
    ];
    for (name, expect) in &checks {
        assert_close(name, col(name), expect, 0.0);
    }
    let alarms: Vec<Vec<f64>> = answers[12]["y"]
        .as_array()
        .unwrap()
        .iter()
        .map(floats)
        .collect();
    for (j, name) in ["al1", "al2", "al3"].iter().enumerate() {
        let expect: Vec<f64> = alarms.iter().map(|a| a[j]).collect();
        assert_close(name, col(name), &expect, 0.0);
    }
    let raw: Vec<f64> = answers[13]["y"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| floats(a)[0])
        .collect();
    assert_close("raw", col("raw"), &raw, 0.0);
    // The noisy ramp crosses 10 once: with hysteresis the alarm sets once and stays; without,
    // it chatters.
    let changes = |v: &[f64]| v.windows(2).filter(|w| w[0] != w[1]).count();
    assert_eq!(changes(col("al1")), 1);
    assert!(changes(col("raw")) >= 5, "{}", changes(col("raw")));
    // Conversions at the edges: saturated, NaN to 0, halves away from zero.
    let at = |k: usize| (col("i")[k], col("u")[k], col("s")[k], col("b")[k]);
    assert_eq!(at(3), (3.0, 3.0, 3.0, 1.0)); // 2.5
    assert_eq!(at(2), (-3.0, 0.0, -3.0, 0.0)); // −2.5
    assert_eq!(at(6), (2147483647.0, 3e9, 32767.0, 1.0)); // 3e9
    assert_eq!(at(11), (0.0, 0.0, 0.0, 0.0)); // NaN
    assert_eq!(at(13), (-2147483648.0, 0.0, -32768.0, 0.0)); // −∞
    assert!((col("t")[n - 1] - 23.9).abs() < 1e-5, "out_time_pt");
}

#[test]
fn bad_rows_are_reported_with_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let conf = "[PLC]
module dsp dsp
module other timeline
point a \"\" dsp f32
point o \"\" other f32
point n \"\" dsp i16
[other]
file = none.csv
[dsp]
fblock add a o 1
fblock add o a 1
fblock add n a 1
fblock filter a a butterworth lowpass 1 1 40 10 20
fblock wobble a
fblock add a q 1
";
    let got = start_err(conf, dir.path());
    assert_eq!(
        got,
        "module dsp: test.conf:11: fblock add: `o` is owned by module `other`, and only its owner may write a point: declare `point o \"...\" dsp`, or write another point
module dsp: test.conf:12: fblock add: `n` is a i16 point, but add writes f32 points: declare it `f32`, or write an f32 point and convert it with `fblock typeconv`
module dsp: test.conf:13: fblock filter: a designed butterworth filter needs the module's sampling rate: set `scan_period` in the module's section (the sampling rate is 1/scan_period)
module dsp: test.conf:14: fblock wobble: unknown block `wobble`; the blocks are typeconv, add, mult, pow, pid, filter, ramp, nonlinear, alarm, multiplexor, hysteresis, delay, source
module dsp: test.conf:15: fblock add: no point named `q`; did you mean `a`, `n`, `o`? (or declare `point q \"...\" OWNER f32` in [PLC])"
    );
    let conf = "[PLC]\nmodule dsp dsp\npoint a \"\" dsp f32\n[dsp]\nscan_period = 0.05\n\
                fblock filter a a butterworth highpass 1 .1737 40 500 750\n";
    assert_eq!(
        start_err(conf, dir.path()),
        "module dsp: test.conf:6: fblock filter: F1 = 500 Hz (stopband edge) is not below the Nyquist frequency 10 Hz: scan_period 0.05 s samples at 20 Hz; lower F1 or shorten scan_period"
    );
    let conf = "[PLC]\nmodule dsp dsp\npoint a \"\" dsp f32\n[dsp]\nout_time_pt = a\nmap a b\n";
    assert_eq!(
        start_err(conf, dir.path()),
        "module dsp: test.conf:6: a dsp module reads only fblock rows, not `map`"
    );
    let conf = "[PLC]\nmodule dsp dsp\npoint a \"\" dsp\n[dsp]\nout_time_pt = a\n";
    assert_eq!(
        start_err(conf, dir.path()),
        "module dsp: out_time_pt = a must be an f32 point of this module: declare `point a \"...\" dsp f32`"
    );
}

#[test]
fn thermal_plant_settings_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let conf = |settings: &str| {
        format!(
            "[PLC]\nmodule oven plant\npoint temp \"\" oven f32\npoint heater \"\" oven f32\n\
             [oven]\nplant = thermal\n{settings}\n"
        )
    };
    assert!(start(
        &conf("gain = 1.5\ntime_constant = 30\ndead_time = 0"),
        dir.path()
    )
    .is_ok());
    let cases = [
        (
            "time_constant = 0",
            "module oven: `time_constant = 0` must be above 0",
        ),
        (
            "dead_time = -1",
            "module oven: `dead_time = -1` must be from 0 to 3600 s",
        ),
        ("gain = hot", "module oven: `gain = hot` is not a number"),
    ];
    for (settings, expect) in cases {
        assert_eq!(start_err(&conf(settings), dir.path()), expect);
    }
    let tank = "[PLC]\nmodule t plant\n[t]\nplant = tank\ngain = 2\n";
    assert_eq!(
        start_err(tank, dir.path()),
        "module t: `gain` is a setting of `plant = thermal`, not of this plant"
    );
    // The vessel's temperature as an f32 point, starting at `initial`.
    let mut plc = start(&conf("initial = 55.5"), dir.path()).unwrap();
    plc.tick(Duration::ZERO).unwrap();
    assert_eq!(value(&plc, "temp"), 55.5);
    assert!(
        plc.status("oven").starts_with("thermal 55.50 °C"),
        "{}",
        plc.status("oven")
    );
}

/// A timeline drives f32 points with decimal values and a logger writes them back as
/// decimals; whole-number points refuse decimals at start.
#[test]
fn timeline_and_logger_carry_f32_points() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("in.csv"),
        "time,x,n\n0,20.5,1\n0.1,-1e-3,2\n0.2,nan,\n",
    )
    .unwrap();
    let conf = "[PLC]\nmodule feed timeline\nmodule log logger\npoint x \"\" feed f32\n\
                point n \"\" feed i8\n[feed]\nfile = in.csv\nnon_finite = accept\n\
                [log]\nfile = log.csv\n\
                plot = trend.svg\n";
    let mut plc = start(conf, dir.path()).unwrap();
    for k in 0..3 {
        plc.tick(Duration::from_millis(100 * k)).unwrap();
    }
    plc.close();
    let log = std::fs::read_to_string(dir.path().join("log.csv")).unwrap();
    assert_eq!(
        log,
        "time,point,value\n0,x,20.5\n0,n,1\n0.1,x,-0.001\n0.1,n,2\n0.2,x,NaN\n"
    );
    // The trend: the f32 point only, with its legend.
    let svg = std::fs::read_to_string(dir.path().join("trend.svg")).unwrap();
    assert!(svg.contains(">\nx\n<") && !svg.contains(">\nn\n<"), "{svg}");
    std::fs::write(dir.path().join("in.csv"), "time,x,n\n0,1,1.5\n").unwrap();
    assert_eq!(
        start_err(conf, dir.path()),
        "module feed: timeline `in.csv` sets `n` to 1.5 at t=0s, but point `n` is signed (8 bits), which holds whole numbers: declare it f32, or write a whole number"
    );
}
