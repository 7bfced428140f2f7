//! petriplc-dsp's blocks as IEC function blocks: an ST program calling `PID` in a closed loop
//! gives, scan by scan, exactly the output of the Rust block fed the same inputs at the same
//! times; the checker refuses wrong parameter types and names.

use petriplc_dsp::block::pid::{AntiWindup, Pid, PidConfig, PidForm, PidInput};
use petriplc_iec::sema::value::Value;
use petriplc_iec::vm::Machine;
use petriplc_iec::{build, check, Natives, Select, Sources};

const PROGRAM: &str = "PROGRAM loop
VAR_INPUT sp : REAL; pv : REAL; man : BOOL; xman : REAL; END_VAR
VAR_OUTPUT u : REAL; END_VAR
VAR ctl : PID; END_VAR
ctl(SP := sp, PV := pv, KP := 2.0, TI := 4.0, TD := 0.5, TF := 0.1, XMIN := 0.0, XMAX := 10.0,
    MANUAL := man, XMAN := xman);
u := ctl.XOUT;
END_PROGRAM
";

#[test]
fn pid_in_st_equals_the_rust_block_scan_by_scan() {
    let mut s = Sources::new();
    s.add_text("loop.st", PROGRAM);
    let engine = build(&s, &Select::Auto, Natives::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .engine;
    let var = |n: &str| engine.lookup(&format!("loop.{n}")).unwrap();
    let mut m = Machine::new(engine.clone());
    let mut pid = Pid::new(PidConfig {
        form: PidForm::Ideal,
        p: 2.0,
        i: 4.0,
        d: 0.5,
        min_out: 0.0,
        max_out: 10.0,
        d_on_measurement: true,
        // The ST literal 0.1 is a REAL (f32).
        d_filter: f64::from(0.1f32),
        anti_windup: AntiWindup::Clamp,
        rate: f64::INFINITY,
    });
    // A first-order plant (time constant 2 s) in closed loop, 10 ms scans; manual mode from
    // 3 s to 4 s, a setpoint step at 6 s that saturates the output.
    let mut pv = 0.0f32;
    let mut previous: Option<i64> = None;
    for k in 0..1000i64 {
        let now = k * 10_000_000;
        let sp: f32 = if k < 600 { 1.5 } else { 8.0 };
        let man = (300..400).contains(&k);
        let xman = 0.75f32;
        m.set(var("sp"), &Value::Real(f64::from(sp))).unwrap();
        m.set(var("pv"), &Value::Real(f64::from(pv))).unwrap();
        m.set(var("man"), &Value::Int(i128::from(man))).unwrap();
        m.set(var("xman"), &Value::Real(f64::from(xman))).unwrap();
        m.scan(now, &mut || true).unwrap();
        let Some(Value::Real(got)) = m.get(var("u")) else {
            panic!("u is not a real")
        };
        let dt = previous.map_or(0.0, |p| (now - p) as f64 * 1e-9);
        previous = Some(now);
        let want = pid.step(
            PidInput {
                sp: f64::from(sp),
                pv: f64::from(pv),
                error_input: false,
                auto: !man,
                manual: f64::from(xman),
            },
            dt,
        );
        assert_eq!(got as f32, want as f32, "scan {k}");
        pv += (0.01 * (f64::from(got as f32) - f64::from(pv)) / 2.0) as f32;
    }
    // The loop did something: it settled near the setpoint before the step.
    assert!(pv > 5.0, "{pv}");
}

fn errors(text: &str) -> String {
    let mut s = Sources::new();
    s.add_text("bad.st", text);
    match check(&s, &Natives::default()) {
        Ok(_) => String::new(),
        Err(e) => e.to_string(),
    }
}

#[test]
fn wrong_parameters_of_a_dsp_block_are_refused() {
    let e = errors(
        "PROGRAM p\nVAR c : PID; b : BOOL; x : REAL; END_VAR\nc(SP := b, PV := x);\nEND_PROGRAM\n",
    );
    assert!(
        e.contains("bad.st:3:9: error[E110]: argument `SP` is BOOL but REAL is needed"),
        "{e}"
    );
    let e = errors(
        "PROGRAM p\nVAR c : PID; x : REAL; END_VAR\nc(SETPOINT := x);\nx := c.OUT;\nEND_PROGRAM\n",
    );
    assert!(
        e.contains("bad.st:3:3: error[E130]: PID has no parameter `SETPOINT`; its parameters are SP, PV, KP"),
        "{e}"
    );
    assert!(
        e.contains("bad.st:4:8: error[E105]: PID has no input or output `OUT`"),
        "{e}"
    );
}

#[test]
fn filter_iir_in_st_equals_the_rust_filter_sample_by_sample() {
    // Two sections (a 4th-order low-pass, MatPLC's row form); the other two unused.
    let (c, s1, s2) = (
        0.25f32,
        [2.0f32, 1.0, -0.5, 0.125],
        [1.0f32, 0.0, -0.75, 0.25],
    );
    let program = format!(
        "PROGRAM f\nVAR_INPUT x : REAL; END_VAR\nVAR_OUTPUT y : REAL; END_VAR\nVAR lp : FILTER_IIR; END_VAR\n\
         lp(X := x, C := {c:?}, A1_1 := {:?}, A2_1 := {:?}, B1_1 := {:?}, B2_1 := {:?},\n\
            A1_2 := {:?}, A2_2 := {:?}, B1_2 := {:?}, B2_2 := {:?});\ny := lp.Y;\nEND_PROGRAM\n",
        s1[0], s1[1], s1[2], s1[3], s2[0], s2[1], s2[2], s2[3]
    );
    let mut s = Sources::new();
    s.add_text("f.st", &program);
    let engine = build(&s, &Select::Auto, Natives::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .engine;
    let var = |n: &str| engine.lookup(&format!("f.{n}")).unwrap();
    let mut m = Machine::new(engine.clone());
    let f = |v: f32| f64::from(v);
    let mut sections = vec![
        [1.0, f(s1[0]), f(s1[1]), 1.0, f(s1[2]), f(s1[3])],
        [1.0, f(s2[0]), f(s2[1]), 1.0, f(s2[2]), f(s2[3])],
    ];
    for v in &mut sections[0][..3] {
        *v *= f(c);
    }
    let mut rust = petriplc_dsp::block::filter::Iir::new(sections, false);
    // Step, impulse, a chirp-like signal and a NaN (held).
    let input = |k: usize| -> f32 {
        match k {
            0..50 => 1.0,
            50 => 5.0,
            77 => f32::NAN,
            _ => ((k * k) as f32 * 0.001).sin(),
        }
    };
    let mut held = 0.0f64;
    for k in 0..400 {
        let x = input(k);
        // Raw: `set` refuses a NaN, which a point or a division can still bring in.
        m.set_slot(var("x").addr, f64::from(x).to_bits());
        m.scan(k as i64 * 1_000_000, &mut || true).unwrap();
        let Some(Value::Real(got)) = m.get(var("y")) else {
            panic!("y is not a real")
        };
        if let Some(y) = rust.step(f64::from(x)) {
            held = y;
        }
        assert_eq!(got as f32, held as f32, "sample {k}");
    }
}

#[test]
fn ramp_and_nonlinear_in_st_equal_the_rust_blocks() {
    let program =
        "PROGRAM r\nVAR_INPUT x : REAL; END_VAR\nVAR_OUTPUT y : REAL; d : REAL; END_VAR\n\
        VAR rp : RAMP; nl : NONLINEAR; END_VAR\n\
        rp(X := x, POS_DXDT := 2.0, NEG_DXDT := 4.0, POS_D2XDT2 := 8.0);\ny := rp.Y;\n\
        nl(X := x, GAIN := 2.0, DB_BOT := -1.0, DB_TOP := 1.0, DB_OUT := 0.5, CUT_TOP := 6.0);\n\
        d := nl.Y;\nEND_PROGRAM\n";
    let mut s = Sources::new();
    s.add_text("r.st", program);
    let engine = build(&s, &Select::Auto, Natives::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .engine;
    let var = |n: &str| engine.lookup(&format!("r.{n}")).unwrap();
    let mut m = Machine::new(engine.clone());
    let mut ramp = petriplc_dsp::block::ramp::Ramp::new(petriplc_dsp::block::ramp::RampConfig {
        pos_dxdt: 2.0,
        neg_dxdt: 4.0,
        pos_d2xdt2: 8.0,
        neg_d2xdt2: f64::INFINITY,
    });
    let nl = petriplc_dsp::block::select::Nonlinear {
        gain: 2.0,
        deadband_bot: -1.0,
        deadband_top: 1.0,
        deadband_out: 0.5,
        cutoff_bot: -f64::from(f32::MAX),
        cutoff_top: 6.0,
    };
    let mut previous = None;
    for k in 0..600i64 {
        let x: f32 = match k {
            0..100 => 0.25,
            100..300 => 5.0,
            _ => -3.0 + (k as f32 * 0.05).sin(),
        };
        let now = k * 5_000_000;
        m.set(var("x"), &Value::Real(f64::from(x))).unwrap();
        m.scan(now, &mut || true).unwrap();
        let (Some(Value::Real(y)), Some(Value::Real(d))) = (m.get(var("y")), m.get(var("d")))
        else {
            panic!("not reals")
        };
        let dt = previous.map_or(0.0, |p: i64| (now - p) as f64 * 1e-9);
        previous = Some(now);
        assert_eq!(
            y as f32,
            ramp.step(f64::from(x), dt) as f32,
            "ramp, scan {k}"
        );
        assert_eq!(
            d as f32,
            nl.step(f64::from(x)) as f32,
            "nonlinear, scan {k}"
        );
    }
}

#[test]
fn filter_design_in_st_equals_the_designed_rust_filter_and_alarm_keeps_its_hysteresis() {
    // An elliptic lowpass, 5 Hz pass / 12 Hz stop, 1 dB / 50 dB, at 100 Hz; and a band-pass.
    let program = "PROGRAM d\nVAR_INPUT x : REAL; END_VAR\nVAR_OUTPUT y : REAL; b : REAL; n : INT; hi : BOOL; END_VAR\n\
        VAR lp : FILTER_DESIGN; bp : FILTER_DESIGN; al : ALARM; END_VAR\n\
        lp(X := x, KIND := 4, FPASS := 5.0, FSTOP := 12.0, GPASS := 1.0, GSTOP := 50.0, GAIN := 2.0, TS := T#10ms);\n\
        y := lp.Y; n := lp.ORDER;\n\
        bp(X := x, KIND := 1, FPASS := 8.0, FPASS2 := 12.0, FSTOP := 4.0, FSTOP2 := 20.0, TS := T#10ms);\n\
        b := bp.Y;\n\
        al(X := x, LIMIT := 0.5, HYST := 0.25);\nhi := al.Q;\nEND_PROGRAM\n";
    let mut s = Sources::new();
    s.add_text("d.st", program);
    let engine = build(&s, &Select::Auto, Natives::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .engine;
    let var = |n: &str| engine.lookup(&format!("d.{n}")).unwrap();
    let mut m = Machine::new(engine.clone());
    use petriplc_dsp::design::{iirdesign, Family};
    let d = iirdesign(&[5.0], &[12.0], 1.0, 50.0, Family::Elliptic, 100.0).unwrap();
    let order = d.order;
    let mut sos = d.sos;
    for c in &mut sos[0][..3] {
        *c *= 2.0;
    }
    let mut lp = petriplc_dsp::block::filter::Iir::new(sos, false);
    let band = iirdesign(
        &[8.0, 12.0],
        &[4.0, 20.0],
        1.0,
        40.0,
        Family::Butterworth,
        100.0,
    )
    .unwrap();
    let mut bp = petriplc_dsp::block::filter::Iir::new(band.sos, false);
    let mut on = false;
    let mut switches = 0;
    for k in 0..500i64 {
        let x = if k == 0 {
            1.0f32
        } else {
            ((k * k) as f32 * 0.0005).sin()
        };
        m.set(var("x"), &Value::Real(f64::from(x))).unwrap();
        m.scan(k * 10_000_000, &mut || true).unwrap();
        let get = |n: &str| match m.get(var(n)) {
            Some(Value::Real(r)) => r,
            Some(Value::Int(i)) => i as f64,
            v => panic!("{n}: {v:?}"),
        };
        let xf = f64::from(x);
        assert_eq!(
            get("y") as f32,
            lp.step(xf).unwrap() as f32,
            "lowpass, scan {k}"
        );
        assert_eq!(
            get("b") as f32,
            bp.step(xf).unwrap() as f32,
            "bandpass, scan {k}"
        );
        assert_eq!(get("n") as usize, order);
        let was = on;
        on = xf > 0.5 || (on && xf > 0.25);
        switches += usize::from(was != on);
        assert_eq!(get("hi") != 0.0, on, "alarm, scan {k}");
    }
    assert!(switches > 4, "{switches}");
}

#[test]
fn an_impossible_design_fails_the_program_with_the_limit() {
    let program = "PROGRAM d\nVAR lp : FILTER_DESIGN; y : REAL; END_VAR\n\
        lp(X := 1.0, FPASS := 5.0, FSTOP := 80.0, TS := T#10ms);\ny := lp.Y;\nEND_PROGRAM\n";
    let mut s = Sources::new();
    s.add_text("d.st", program);
    let engine = build(&s, &Select::Auto, Natives::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .engine;
    let mut m = Machine::new(engine);
    let fault = m.scan(0, &mut || true).unwrap_err().to_string();
    assert!(
        fault.contains("FILTER_DESIGN: ") && fault.contains("Nyquist"),
        "{fault}"
    );
}

#[test]
fn fir_filters_in_st_equal_the_rust_fir_and_hysteresis_switches_at_its_thresholds() {
    use petriplc_dsp::block::filter::Fir;
    use petriplc_dsp::design::{firwin, Band, Window};
    // Explicit taps (5 of the 16), a designed Hamming lowpass (31 taps, 10 Hz at 100 Hz) and a
    // designed Kaiser bandpass (41 taps, 10–20 Hz).
    let b = [0.5f32, -0.25, 0.125, 1.5, -0.75];
    let program = format!(
        "PROGRAM f\nVAR_INPUT x : REAL; END_VAR\n\
         VAR_OUTPUT y : REAL; lo : REAL; bp : REAL; q : BOOL; END_VAR\n\
         VAR ex : FILTER_FIR; lp : FIR_DESIGN; bd : FIR_DESIGN; hy : HYSTERESIS; END_VAR\n\
         ex(X := x, B0 := {:?}, B1 := {:?}, B2 := {:?}, B3 := {:?}, B4 := {:?});\ny := ex.Y;\n\
         lp(X := x, F1 := 10.0, TS := T#10ms);\nlo := lp.Y;\n\
         bd(X := x, SHAPE := 3, TAPS := 41, F1 := 10.0, F2 := 20.0, WINDOW := 7, BETA := 6.0, TS := T#10ms);\n\
         bp := bd.Y;\n\
         hy(X := x, XON := 0.5, XOFF := -0.25);\nq := hy.Q;\nEND_PROGRAM\n",
        b[0], b[1], b[2], b[3], b[4]
    );
    let mut s = Sources::new();
    s.add_text("f.st", &program);
    let engine = build(&s, &Select::Auto, Natives::default())
        .unwrap_or_else(|e| panic!("{e}"))
        .engine;
    let var = |n: &str| engine.lookup(&format!("f.{n}")).unwrap();
    let mut m = Machine::new(engine.clone());
    let mut ex = Fir::new(b.iter().map(|&t| f64::from(t)).collect());
    let mut lp = Fir::new(firwin(31, &[10.0], Window::Hamming, Band::Lowpass, 100.0).unwrap());
    let mut bd = Fir::new(
        firwin(
            41,
            &[10.0, 20.0],
            Window::Kaiser(6.0),
            Band::Bandpass,
            100.0,
        )
        .unwrap(),
    );
    let mut held = [0.0f64; 3];
    let mut on = false;
    let mut switches = 0;
    for k in 0..400usize {
        let x: f32 = match k {
            0 => 1.0,
            1..60 => 0.75,
            90 => f32::NAN,
            _ => ((k * k) as f32 * 0.0007).sin(),
        };
        m.set_slot(var("x").addr, f64::from(x).to_bits());
        m.scan(k as i64 * 10_000_000, &mut || true).unwrap();
        let get = |n: &str| match m.get(var(n)) {
            Some(Value::Real(r)) => r,
            Some(Value::Int(i)) => i as f64,
            v => panic!("{n}: {v:?}"),
        };
        let xf = f64::from(x);
        for (h, f) in held.iter_mut().zip([&mut ex, &mut lp, &mut bd]) {
            if let Some(y) = f.step(xf) {
                *h = y;
            }
        }
        assert_eq!(get("y") as f32, held[0] as f32, "FILTER_FIR, sample {k}");
        assert_eq!(
            get("lo") as f32,
            held[1] as f32,
            "FIR_DESIGN lowpass, sample {k}"
        );
        assert_eq!(
            get("bp") as f32,
            held[2] as f32,
            "FIR_DESIGN bandpass, sample {k}"
        );
        let was = on;
        if xf >= 0.5 {
            on = true;
        } else if xf <= -0.25 {
            on = false;
        }
        switches += usize::from(was != on);
        assert_eq!(get("q") != 0.0, on, "HYSTERESIS, sample {k}");
    }
    assert!(switches > 4, "{switches}");
}

#[test]
fn an_impossible_fir_design_fails_the_program_with_the_reason() {
    for (call, want) in [
        ("F1 := 80.0", "Nyquist"),
        ("SHAPE := 2, TAPS := 30, F1 := 10.0", "odd number of taps"),
        ("F1 := 10.0, WINDOW := 9", "WINDOW = 9"),
        ("F1 := 10.0, TAPS := 65", "TAPS = 65"),
    ] {
        let program = format!(
            "PROGRAM d\nVAR lp : FIR_DESIGN; y : REAL; END_VAR\n\
             lp(X := 1.0, {call}, TS := T#10ms);\ny := lp.Y;\nEND_PROGRAM\n"
        );
        let mut s = Sources::new();
        s.add_text("d.st", &program);
        let engine = build(&s, &Select::Auto, Natives::default())
            .unwrap_or_else(|e| panic!("{e}"))
            .engine;
        let mut m = Machine::new(engine);
        let fault = m.scan(0, &mut || true).unwrap_err().to_string();
        assert!(
            fault.contains("FIR_DESIGN: ") && fault.contains(want),
            "{call}: {fault}"
        );
    }
}
