//! petriplc-dsp's blocks as native function blocks of the IEC engine, so that ST programs
//! call them like any function block: `PID` (the `pid` block of the `dsp` module).
//!
//! A native block keeps its state in the instance's slots (see `petriplc_iec_vm::native`):
//! each call rebuilds the Rust block from the instance's inputs and state, steps it once and
//! stores the state back, so instances are copied, retained and restored like any other
//! variables. `dt` is the time since the instance's previous call (0 at the first), from
//! the scan time the engine passes in, as the `dsp` module takes it from its measured period.
//!
//! ```text
//! PID  VAR_INPUT  SP, PV : REAL          setpoint and process value
//!                 KP : REAL := 1.0       gain (ideal form: u = KP·(e + 1/TI·∫e + TD·de/dt))
//!                 TI : REAL := 0.0       integral time in s (0: no integral action)
//!                 TD : REAL := 0.0       derivative time in s (on the measurement)
//!                 TF : REAL := 0.0       derivative filter time constant in s
//!                 XMIN, XMAX : REAL      output limits (default: none, ±1e38)
//!                 MANUAL : BOOL          manual mode (bumpless both ways)
//!                 XMAN : REAL            the output in manual mode
//!      VAR_OUTPUT XOUT : REAL            the controller output
//!
//! FILTER_IIR VAR_INPUT X : REAL          the input sample (one call per sampling period)
//!                 C : REAL := 1.0        gain
//!                 A1_1, A2_1, B1_1, B2_1 … A1_4, A2_4, B1_4, B2_4 : REAL
//!                                        up to 4 second-order sections, unused ones 0:
//!                                        C·Π(1 + A1·z⁻¹ + A2·z⁻²)/(1 + B1·z⁻¹ + B2·z⁻²),
//!                                        the dsp module's `fblock filter IN OUT iir …`
//!      VAR_OUTPUT Y : REAL               the output (held while X is not finite)
//!
//! RAMP  VAR_INPUT X : REAL               the target
//!                 POS_DXDT, NEG_DXDT, POS_D2XDT2, NEG_D2XDT2 : REAL := 1e38
//!                                        rate and acceleration limits (≥ 1e38: none)
//!      VAR_OUTPUT Y : REAL
//!
//! FILTER_DESIGN VAR_INPUT X : REAL      the input sample (one call per TS)
//!                 KIND : INT := 1        1 Butterworth, 2 Chebyshev I, 3 Chebyshev II,
//!                                        4 elliptic, 5 Bessel
//!                 FPASS, FSTOP : REAL    passband and stopband edges in Hz (FPASS < FSTOP:
//!                                        lowpass, else highpass)
//!                 FPASS2, FSTOP2 : REAL := 0   second edges: a band filter (bandpass when
//!                                        the passband lies inside the stopband)
//!                 GPASS : REAL := 1.0    most attenuation in the passband, dB
//!                 GSTOP : REAL := 40.0   least attenuation in the stopband, dB
//!                 GAIN : REAL := 1.0
//!                 TS : TIME := T#10ms    the sampling period the filter is designed for
//!      VAR_OUTPUT Y : REAL; ORDER : INT  the output and the order the design chose
//!
//! ALARM VAR_INPUT X : REAL; LIMIT : REAL; HYST : REAL := 0.0
//!                 LOW : BOOL             below the limit (default: above)
//!                 ABSOLUTE : BOOL        compare |X|
//!      VAR_OUTPUT Q : BOOL               with hysteresis: set beyond LIMIT, cleared only
//!                                        back past LIMIT ∓ HYST; NaN sets it
//!
//! FILTER_FIR VAR_INPUT X : REAL         the input sample (one call per sampling period)
//!                 B0 … B15 : REAL := 0.0 the taps: y[n] = Σ Bk·x[n−k] (the dsp module's
//!                                        `fblock filter IN OUT fir B0 B1 …`)
//!      VAR_OUTPUT Y : REAL               the output (held while X is not finite)
//!
//! FIR_DESIGN VAR_INPUT X : REAL
//!                 SHAPE : INT := 1       1 lowpass, 2 highpass, 3 bandpass, 4 bandstop
//!                 TAPS : INT := 31       1 … 64 (odd when the filter passes Nyquist)
//!                 F1, F2 : REAL          cut-offs in Hz at −6 dB (F2 for band shapes only)
//!                 TS : TIME := T#10ms    the sampling period the filter is designed for
//!                 WINDOW : INT := 5      1 boxcar, 2 triang, 3 bartlett, 4 hann, 5 hamming,
//!                                        6 blackman, 7 kaiser with β = BETA
//!                 BETA : REAL := 5.0
//!      VAR_OUTPUT Y : REAL               SciPy's firwin taps run as FILTER_FIR runs them
//!
//! HYSTERESIS VAR_INPUT X, XON, XOFF : REAL  Q set when X reaches XON, cleared when it reaches
//!      VAR_OUTPUT Q : BOOL               XOFF (XON < XOFF: the other way round); NaN holds Q
//!
//! NONLINEAR VAR_INPUT X : REAL; GAIN : REAL := 1.0;
//!                 DB_BOT, DB_TOP, DB_OUT : REAL := 0.0   dead band and its output
//!                 CUT_BOT, CUT_TOP : REAL := ∓3.4e38     cut-offs
//!      VAR_OUTPUT Y : REAL
//! ```

use petriplc_dsp::block::filter::{Fir, Iir};
use petriplc_dsp::block::pid::{AntiWindup, Pid, PidConfig, PidForm, PidInput};
use petriplc_dsp::block::Hysteresis;
use std::sync::Mutex;

use petriplc_dsp::block::alarm::{Alarm, Compare, Limit};
use petriplc_dsp::block::ramp::{Ramp, RampConfig};
use petriplc_dsp::block::select::Nonlinear;
use petriplc_iec_sema::ir::{NativeSig, NativeVar, NativeVarKind};
use petriplc_iec_sema::types::Elem;
use petriplc_iec_sema::value::Value;
use petriplc_iec_vm::native::{NativeCtx, NativeFb, Vars};

fn var(name: &str, ty: Elem, kind: NativeVarKind, init: Value) -> NativeVar {
    NativeVar {
        name: name.to_string(),
        ty,
        kind,
        init,
    }
}

/// Every DSP function block.
pub fn blocks() -> Vec<Box<dyn NativeFb>> {
    vec![
        Box::new(PidFb),
        Box::new(FilterIirFb),
        Box::new(RampFb),
        Box::new(NonlinearFb),
        Box::new(FilterDesignFb::default()),
        Box::new(AlarmFb),
        Box::new(FilterFirFb),
        Box::new(FirDesignFb::default()),
        Box::new(HysteresisFb),
    ]
}

/// `PID`: petriplc-dsp's PID in the ideal form, derivative on the measurement, anti-windup
/// by clamping.
pub struct PidFb;

const PID_INPUTS: usize = 10;
const PID_STATE: usize = PID_INPUTS + 1;

impl NativeFb for PidFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O, State as S};
        let r = |n: &str, k, v: f64| var(n, Elem::Real, k, Value::Real(v));
        let mut vars = vec![
            r("SP", I, 0.0),
            r("PV", I, 0.0),
            r("KP", I, 1.0),
            r("TI", I, 0.0),
            r("TD", I, 0.0),
            r("TF", I, 0.0),
            r("XMIN", I, -1e38),
            r("XMAX", I, 1e38),
            var("MANUAL", Elem::Bool, I, Value::Int(0)),
            r("XMAN", I, 0.0),
            r("XOUT", O, 0.0),
        ];
        for n in ["i", "d", "x", "u", "v", "started", "bad"] {
            vars.push(var(n, Elem::Lreal, S, Value::Real(0.0)));
        }
        vars.push(var("last", Elem::Time, S, Value::Int(0)));
        NativeSig {
            name: "PID".into(),
            vars,
        }
    }

    fn call(&self, slots: &mut [u64], ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let config = PidConfig {
            form: PidForm::Ideal,
            p: v.real(2),
            i: v.real(3),
            d: v.real(4),
            min_out: v.real(6),
            max_out: v.real(7),
            d_on_measurement: true,
            d_filter: v.real(5),
            anti_windup: AntiWindup::Clamp,
            rate: f64::INFINITY,
        };
        let mut pid = Pid::new(config);
        let mut state = [0.0; 7];
        for (k, s) in state.iter_mut().enumerate() {
            *s = v.real(PID_STATE + k);
        }
        pid.set_state(state);
        let last = PID_STATE + 7;
        let dt = if state[5] != 0.0 {
            (ctx.now - v.int(last)) as f64 * 1e-9
        } else {
            0.0
        };
        let out = pid.step(
            PidInput {
                sp: v.real(0),
                pv: v.real(1),
                error_input: false,
                auto: !v.bool(8),
                manual: v.real(9),
            },
            dt,
        );
        v.set_real(PID_INPUTS, out);
        for (k, s) in pid.state().iter().enumerate() {
            v.set_real(PID_STATE + k, *s);
        }
        v.set_int(last, ctx.now);
        Ok(())
    }
}

/// `FILTER_IIR`: petriplc-dsp's IIR filter with explicit coefficients, MatPLC's `iir` form.
pub struct FilterIirFb;

const SECTIONS: usize = 4;
/// X, C, then four coefficients per section.
const IIR_INPUTS: usize = 2 + 4 * SECTIONS;
const IIR_Y: usize = IIR_INPUTS;
const IIR_STATE: usize = IIR_Y + 1;

impl NativeFb for FilterIirFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O, State as S};
        let r = |n: &str, k, v: f64| var(n, Elem::Real, k, Value::Real(v));
        let mut vars = vec![r("X", I, 0.0), r("C", I, 1.0)];
        for k in 1..=SECTIONS {
            for c in ["A1", "A2", "B1", "B2"] {
                vars.push(r(&format!("{c}_{k}"), I, 0.0));
            }
        }
        vars.push(r("Y", O, 0.0));
        for k in 0..2 * SECTIONS {
            vars.push(var(&format!("z{k}"), Elem::Lreal, S, Value::Real(0.0)));
        }
        vars.push(var("started", Elem::Bool, S, Value::Int(0)));
        NativeSig {
            name: "FILTER_IIR".into(),
            vars,
        }
    }

    fn call(&self, slots: &mut [u64], _ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let mut sections: Vec<[f64; 6]> = (0..SECTIONS)
            .map(|k| {
                let c = |i: usize| v.real(2 + 4 * k + i);
                [1.0, c(0), c(1), 1.0, c(2), c(3)]
            })
            .collect();
        let gain = v.real(1);
        for c in &mut sections[0][..3] {
            *c *= gain;
        }
        let mut iir = Iir::new(sections, false);
        let state: Vec<[f64; 2]> = (0..SECTIONS)
            .map(|k| [v.real(IIR_STATE + 2 * k), v.real(IIR_STATE + 2 * k + 1)])
            .collect();
        let started = IIR_STATE + 2 * SECTIONS;
        iir.set_state(&state, v.bool(started));
        if let Some(y) = iir.step(v.real(0)) {
            v.set_real(IIR_Y, y);
        }
        let (state, now_started) = iir.state();
        for (k, z) in state.iter().enumerate() {
            v.set_real(IIR_STATE + 2 * k, z[0]);
            v.set_real(IIR_STATE + 2 * k + 1, z[1]);
        }
        v.set_bool(started, now_started);
        Ok(())
    }
}

/// A limit input: 1e38 and above (REAL cannot spell ∞) is no limit.
fn unlimited(x: f64) -> f64 {
    if x >= 1e38 {
        f64::INFINITY
    } else {
        x
    }
}

/// `RAMP`: petriplc-dsp's rate- and acceleration-limited follower.
pub struct RampFb;

impl NativeFb for RampFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O, State as S};
        let r = |n: &str, k, v: f64| var(n, Elem::Real, k, Value::Real(v));
        let mut vars = vec![
            r("X", I, 0.0),
            r("POS_DXDT", I, 1e38),
            r("NEG_DXDT", I, 1e38),
            r("POS_D2XDT2", I, 1e38),
            r("NEG_D2XDT2", I, 1e38),
            r("Y", O, 0.0),
        ];
        for n in ["x", "v", "started"] {
            vars.push(var(n, Elem::Lreal, S, Value::Real(0.0)));
        }
        vars.push(var("last", Elem::Time, S, Value::Int(0)));
        NativeSig {
            name: "RAMP".into(),
            vars,
        }
    }

    fn call(&self, slots: &mut [u64], ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let mut ramp = Ramp::new(RampConfig {
            pos_dxdt: unlimited(v.real(1)),
            neg_dxdt: unlimited(v.real(2)),
            pos_d2xdt2: unlimited(v.real(3)),
            neg_d2xdt2: unlimited(v.real(4)),
        });
        let state = [v.real(6), v.real(7), v.real(8)];
        ramp.set_state(state);
        let dt = if state[2] != 0.0 {
            (ctx.now - v.int(9)) as f64 * 1e-9
        } else {
            0.0
        };
        let y = ramp.step(v.real(0), dt);
        v.set_real(5, y);
        for (k, s) in ramp.state().iter().enumerate() {
            v.set_real(6 + k, *s);
        }
        v.set_int(9, ctx.now);
        Ok(())
    }
}

/// `NONLINEAR`: petriplc-dsp's dead band and cut-offs (no state).
pub struct NonlinearFb;

impl NativeFb for NonlinearFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O};
        let r = |n: &str, k, v: f64| var(n, Elem::Real, k, Value::Real(v));
        let max = f64::from(f32::MAX);
        NativeSig {
            name: "NONLINEAR".into(),
            vars: vec![
                r("X", I, 0.0),
                r("GAIN", I, 1.0),
                r("DB_BOT", I, 0.0),
                r("DB_TOP", I, 0.0),
                r("DB_OUT", I, 0.0),
                r("CUT_BOT", I, -max),
                r("CUT_TOP", I, max),
                r("Y", O, 0.0),
            ],
        }
    }

    fn call(&self, slots: &mut [u64], _ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let block = Nonlinear {
            gain: v.real(1),
            deadband_bot: v.real(2),
            deadband_top: v.real(3),
            deadband_out: v.real(4),
            cutoff_bot: v.real(5),
            cutoff_top: v.real(6),
        };
        let y = block.step(v.real(0));
        v.set_real(7, y);
        Ok(())
    }
}

/// `FILTER_DESIGN`: a filter designed from its specification as the dsp module's
/// `fblock filter IN OUT TYPE SHAPE …` row is (SciPy's `iirdesign`), run as cascaded
/// sections. The design is made at the first call with a specification and kept (by
/// specification) for the other calls and instances; an impossible specification fails the
/// program with the design's message.
#[derive(Default)]
pub struct FilterDesignFb {
    /// Designs by specification (the inputs' bits): sections, or why there are none.
    designs: Mutex<Vec<([u64; 9], Designed)>>,
}

/// A design's sections, or why there are none.
type Designed = Result<Vec<[f64; 6]>, String>;

/// The most sections a designed filter may have (order 16).
const DESIGN_SECTIONS: usize = 8;
const FD_INPUTS: usize = 10;
const FD_Y: usize = FD_INPUTS;
const FD_ORDER: usize = FD_INPUTS + 1;
const FD_STATE: usize = FD_INPUTS + 2;

impl FilterDesignFb {
    fn design(&self, v: &Vars) -> Result<Vec<[f64; 6]>, String> {
        use petriplc_dsp::design::{iirdesign, BesselNorm, Family};
        let mut key = [0u64; 9];
        for (k, slot) in key.iter_mut().enumerate() {
            *slot = v.0[1 + k];
        }
        let mut cache = self.designs.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, d)) = cache.iter().find(|(k, _)| *k == key) {
            return d.clone();
        }
        let made = (|| {
            let family = match v.int(1) {
                1 => Family::Butterworth,
                2 => Family::Chebyshev1,
                3 => Family::Chebyshev2,
                4 => Family::Elliptic,
                5 => Family::Bessel(BesselNorm::Mag),
                k => {
                    return Err(format!(
                        "FILTER_DESIGN: KIND = {k}; give 1 (Butterworth), 2 (Chebyshev I), 3 \
                         (Chebyshev II), 4 (elliptic) or 5 (Bessel)"
                    ))
                }
            };
            let ts = v.int(9) as f64 * 1e-9;
            if ts <= 0.0 {
                return Err("FILTER_DESIGN: TS must be a positive sampling period".into());
            }
            let (fp2, fs2) = (v.real(4), v.real(5));
            let (wp, ws) = if fp2 == 0.0 && fs2 == 0.0 {
                (vec![v.real(2)], vec![v.real(3)])
            } else {
                (vec![v.real(2), fp2], vec![v.real(3), fs2])
            };
            let d = iirdesign(&wp, &ws, v.real(6), v.real(7), family, 1.0 / ts)
                .map_err(|e| format!("FILTER_DESIGN: {e}"))?;
            if d.sos.len() > DESIGN_SECTIONS {
                return Err(format!(
                    "FILTER_DESIGN: the specification needs order {}, above the {} this block \
                     runs; widen the transition band or loosen the tolerances",
                    d.order,
                    2 * DESIGN_SECTIONS
                ));
            }
            let mut sos = d.sos;
            for c in &mut sos[0][..3] {
                *c *= v.real(8);
            }
            Ok(sos)
        })();
        cache.push((key, made.clone()));
        made
    }
}

impl NativeFb for FilterDesignFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O, State as S};
        let r = |n: &str, k, v: f64| var(n, Elem::Real, k, Value::Real(v));
        let mut vars = vec![
            r("X", I, 0.0),
            var("KIND", Elem::Int, I, Value::Int(1)),
            r("FPASS", I, 0.0),
            r("FSTOP", I, 0.0),
            r("FPASS2", I, 0.0),
            r("FSTOP2", I, 0.0),
            r("GPASS", I, 1.0),
            r("GSTOP", I, 40.0),
            r("GAIN", I, 1.0),
            var("TS", Elem::Time, I, Value::Int(10_000_000)),
            r("Y", O, 0.0),
            var("ORDER", Elem::Int, O, Value::Int(0)),
        ];
        for k in 0..2 * DESIGN_SECTIONS {
            vars.push(var(&format!("z{k}"), Elem::Lreal, S, Value::Real(0.0)));
        }
        vars.push(var("started", Elem::Bool, S, Value::Int(0)));
        NativeSig {
            name: "FILTER_DESIGN".into(),
            vars,
        }
    }

    fn call(&self, slots: &mut [u64], _ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let sos = self.design(&v)?;
        let n = sos.len();
        let mut iir = Iir::new(sos, false);
        let state: Vec<[f64; 2]> = (0..n)
            .map(|k| [v.real(FD_STATE + 2 * k), v.real(FD_STATE + 2 * k + 1)])
            .collect();
        let started = FD_STATE + 2 * DESIGN_SECTIONS;
        iir.set_state(&state, v.bool(started));
        if let Some(y) = iir.step(v.real(0)) {
            v.set_real(FD_Y, y);
        }
        let (state, now_started) = iir.state();
        for (k, z) in state.iter().enumerate() {
            v.set_real(FD_STATE + 2 * k, z[0]);
            v.set_real(FD_STATE + 2 * k + 1, z[1]);
        }
        v.set_bool(started, now_started);
        v.set_int(FD_ORDER, 2 * n as i64);
        Ok(())
    }
}

/// `ALARM`: one limit of petriplc-dsp's `alarm` block, with its hysteresis.
pub struct AlarmFb;

impl NativeFb for AlarmFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O};
        let b = |n: &str, k| var(n, Elem::Bool, k, Value::Int(0));
        NativeSig {
            name: "ALARM".into(),
            vars: vec![
                var("X", Elem::Real, I, Value::Real(0.0)),
                var("LIMIT", Elem::Real, I, Value::Real(0.0)),
                var("HYST", Elem::Real, I, Value::Real(0.0)),
                b("LOW", I),
                b("ABSOLUTE", I),
                b("Q", O),
            ],
        }
    }

    fn call(&self, slots: &mut [u64], _ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let compare = if v.bool(3) { Compare::Lt } else { Compare::Gt };
        let mut alarm = Alarm::new(
            v.bool(4),
            v.real(2),
            vec![Limit {
                compare,
                limit: v.real(1),
            }],
        );
        alarm.states[0] = v.bool(5);
        let q = alarm.step(v.real(0))[0];
        v.set_bool(5, q);
        Ok(())
    }
}

/// One sample of a FIR filter whose past inputs live in the instance: `past[k]` holds
/// x[n−1−k] (0 before the first input). Replaying them through a fresh [`Fir`] refills its
/// ring exactly, so the output is the Rust block's, bit for bit. A non-finite `X` holds `Y`
/// and leaves the past alone, as [`Fir::step`] skips it.
fn fir_step(v: &mut Vars, taps: Vec<f64>, x: usize, y: usize, past: usize, room: usize) {
    let n = taps.len();
    let mut fir = Fir::new(taps);
    for k in (0..n - 1).rev() {
        fir.step(v.real(past + k));
    }
    let input = v.real(x);
    if let Some(out) = fir.step(input) {
        v.set_real(y, out);
        for k in (1..room).rev() {
            let older = v.real(past + k - 1);
            v.set_real(past + k, older);
        }
        v.set_real(past, input);
    }
}

/// `FILTER_FIR`: petriplc-dsp's FIR filter with explicit taps.
pub struct FilterFirFb;

const FIR_TAPS: usize = 16;
const FIR_Y: usize = 1 + FIR_TAPS;
const FIR_PAST: usize = FIR_Y + 1;

impl NativeFb for FilterFirFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O, State as S};
        let r = |n: &str, k, v: f64| var(n, Elem::Real, k, Value::Real(v));
        let mut vars = vec![r("X", I, 0.0)];
        for k in 0..FIR_TAPS {
            vars.push(r(&format!("B{k}"), I, 0.0));
        }
        vars.push(r("Y", O, 0.0));
        for k in 0..FIR_TAPS - 1 {
            vars.push(var(&format!("x{k}"), Elem::Lreal, S, Value::Real(0.0)));
        }
        NativeSig {
            name: "FILTER_FIR".into(),
            vars,
        }
    }

    fn call(&self, slots: &mut [u64], _ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let mut taps: Vec<f64> = (0..FIR_TAPS).map(|k| v.real(1 + k)).collect();
        // Unused trailing taps would only add zeros; the filter is the one the taps given make.
        while taps.len() > 1 && taps[taps.len() - 1] == 0.0 {
            taps.pop();
        }
        fir_step(&mut v, taps, 0, FIR_Y, FIR_PAST, FIR_TAPS - 1);
        Ok(())
    }
}

/// `FIR_DESIGN`: a windowed-sinc FIR filter designed as the dsp module's
/// `fblock filter IN OUT fir SHAPE TAPS F1 [F2] [WINDOW]` row is (SciPy's `firwin`), designed
/// at the first call with a specification and kept, like `FILTER_DESIGN`.
#[derive(Default)]
pub struct FirDesignFb {
    designs: Mutex<Vec<([u64; 7], FirDesigned)>>,
}

/// A design's taps, or why there are none.
type FirDesigned = Result<Vec<f64>, String>;

const FIRD_MAX_TAPS: usize = 64;
const FIRD_Y: usize = 8;
const FIRD_PAST: usize = 9;

impl FirDesignFb {
    fn design(&self, v: &Vars) -> FirDesigned {
        use petriplc_dsp::design::Band;
        use petriplc_dsp::design::{firwin, Window};
        let mut key = [0u64; 7];
        for (k, slot) in key.iter_mut().enumerate() {
            *slot = v.0[1 + k];
        }
        let mut cache = self.designs.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, d)) = cache.iter().find(|(k, _)| *k == key) {
            return d.clone();
        }
        let made = (|| {
            let band = match v.int(1) {
                1 => Band::Lowpass,
                2 => Band::Highpass,
                3 => Band::Bandpass,
                4 => Band::Bandstop,
                k => {
                    return Err(format!(
                        "FIR_DESIGN: SHAPE = {k}; give 1 (lowpass), 2 (highpass), 3 (bandpass) \
                         or 4 (bandstop)"
                    ))
                }
            };
            let taps = v.int(2);
            if !(1..=FIRD_MAX_TAPS as i64).contains(&taps) {
                return Err(format!(
                    "FIR_DESIGN: TAPS = {taps}; give 1 to {FIRD_MAX_TAPS}"
                ));
            }
            let ts = v.int(5) as f64 * 1e-9;
            if ts <= 0.0 {
                return Err("FIR_DESIGN: TS must be a positive sampling period".into());
            }
            let window = match v.int(6) {
                1 => Window::Boxcar,
                2 => Window::Triang,
                3 => Window::Bartlett,
                4 => Window::Hann,
                5 => Window::Hamming,
                6 => Window::Blackman,
                7 => Window::Kaiser(v.real(7)),
                k => {
                    return Err(format!(
                        "FIR_DESIGN: WINDOW = {k}; give 1 (boxcar), 2 (triang), 3 (bartlett), \
                         4 (hann), 5 (hamming), 6 (blackman) or 7 (kaiser, β = BETA)"
                    ))
                }
            };
            let cutoff = [v.real(3), v.real(4)];
            firwin(
                taps as usize,
                &cutoff[..band.edges()],
                window,
                band,
                1.0 / ts,
            )
            .map_err(|e| format!("FIR_DESIGN: {e}"))
        })();
        cache.push((key, made.clone()));
        made
    }
}

impl NativeFb for FirDesignFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O, State as S};
        let r = |n: &str, k, v: f64| var(n, Elem::Real, k, Value::Real(v));
        let mut vars = vec![
            r("X", I, 0.0),
            var("SHAPE", Elem::Int, I, Value::Int(1)),
            var("TAPS", Elem::Int, I, Value::Int(31)),
            r("F1", I, 0.0),
            r("F2", I, 0.0),
            var("TS", Elem::Time, I, Value::Int(10_000_000)),
            var("WINDOW", Elem::Int, I, Value::Int(5)),
            r("BETA", I, 5.0),
            r("Y", O, 0.0),
        ];
        for k in 0..FIRD_MAX_TAPS - 1 {
            vars.push(var(&format!("x{k}"), Elem::Lreal, S, Value::Real(0.0)));
        }
        NativeSig {
            name: "FIR_DESIGN".into(),
            vars,
        }
    }

    fn call(&self, slots: &mut [u64], _ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let taps = self.design(&v)?;
        fir_step(&mut v, taps, 0, FIRD_Y, FIRD_PAST, FIRD_MAX_TAPS - 1);
        Ok(())
    }
}

/// `HYSTERESIS`: petriplc-dsp's two-threshold switch.
pub struct HysteresisFb;

impl NativeFb for HysteresisFb {
    fn signature(&self) -> NativeSig {
        use NativeVarKind::{Input as I, Output as O};
        let r = |n: &str| var(n, Elem::Real, I, Value::Real(0.0));
        NativeSig {
            name: "HYSTERESIS".into(),
            vars: vec![
                r("X"),
                r("XON"),
                r("XOFF"),
                var("Q", Elem::Bool, O, Value::Int(0)),
            ],
        }
    }

    fn call(&self, slots: &mut [u64], _ctx: &NativeCtx) -> Result<(), String> {
        let mut v = Vars(slots);
        let (on, off) = (v.real(1), v.real(2));
        if on == off {
            return Err(format!(
                "HYSTERESIS: XON and XOFF are both {on}; set them apart (the band between \
                 them is the hysteresis)"
            ));
        }
        let mut h = Hysteresis {
            on,
            off,
            state: v.bool(3),
        };
        let q = h.step(v.real(0));
        v.set_bool(3, q);
        Ok(())
    }
}
