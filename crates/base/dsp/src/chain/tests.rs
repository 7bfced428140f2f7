use super::*;

/// Points `a`..`e` (f32, owned), `x` (f32, another module's), `n` (i16, owned), `u` (u32,
/// owned), `b` (bool, owned), `k` (i32, another module's).
struct Table;

impl Points for Table {
    fn slot(&mut self, name: &str, write: bool) -> Result<Slot, String> {
        let (index, ty, owned) = match name {
            "a" => (0, NumType::F32, true),
            "b" => (1, NumType::Unsigned(1), true),
            "c" => (2, NumType::F32, true),
            "d" => (3, NumType::F32, true),
            "e" => (4, NumType::F32, true),
            "x" => (5, NumType::F32, false),
            "n" => (6, NumType::Signed(16), true),
            "u" => (7, NumType::Unsigned(32), true),
            "k" => (8, NumType::Signed(32), false),
            _ => return Err(format!("no point `{name}`")),
        };
        if write && !owned {
            return Err(format!("`{name}` belongs to another module"));
        }
        Ok(Slot { index, ty })
    }
}

fn rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| l.split_whitespace().map(String::from).collect())
        .collect()
}

/// Parses the rows (one per line, without `fblock`) at a 10 ms scan period and renders the
/// result as the descriptions, or as `row N: message` lines.
fn check(text: &str, expect: &str) {
    let got = match Chain::parse(
        &rows(text),
        &mut Table,
        &Context {
            scan_period: Some(0.01),
        },
    ) {
        Ok(c) => c.describe().join("\n"),
        Err(errors) => errors
            .iter()
            .map(|(i, e)| format!("row {}: {e}", i + 1))
            .collect::<Vec<_>>()
            .join("\n"),
    };
    assert_eq!(got, expect, "rows:\n{text}");
}

#[test]
fn every_block_parses() {
    check(
        "typeconv k i32 a f32 a f32 n i32
         add c a 1 x -1
         mult c a 0 x 2.5
         pow c a -1
         pid c d 0.1 0.01 0.005 min_out 0 max_out 100
         ramp a c d2xdt2 1 pos_dxdt 3
         nonlinear a c cutoff_top 7 cutoff_bot 2 deadband_bot 4 deadband_top 5 deadband_out 4 gain 1
         alarm a abs_val b gt 1 u lt 1 c eq 0
         multiplexor c b a 1 x
         hysteresis a b 5 1
         delay a c 3
         source e sine amplitude 2 frequency 0.5",
        "typeconv\nadd\nmult\npow\npid: kp=0.1 ki=0.01 kd=0.005, output 0..100, anti-windup clamp\n\
         ramp\nnonlinear\nalarm\nmultiplexor\nhysteresis\ndelay\nsource",
    );
}

#[test]
fn filters_are_described_with_order_and_coefficients() {
    check(
        "filter a c iir 2 -2 1 0.5 0.25",
        "filter iir: 1 section as given\n  section 1: b = 2 -4 2  a = 1 0.5 0.25",
    );
    check(
        "filter a c butterworth lowpass 1 3 20 5 20",
        // SciPy: buttord(5, 20, 3, 20, fs=100) = (2, 5.005842311399293) and
        // iirdesign(...) = [[0.0201258613751213, 0.0402517227502426, 0.0201258613751213,
        // 1.0, -1.5605156510571976, 0.6410190965576829]]
        "filter butterworth lowpass: order 2 for 3/20 dB at 5 20 Hz (critical 5.005842311399293 Hz), gain 1, 1 section\n  \
         section 1: b = 0.020125861375121297 0.040251722750242594 0.020125861375121297  a = 1 -1.5605156510571978 0.641019096557683",
    );
    check(
        "filter a c fir 0.25 0.5 0.25",
        "filter fir: 3 taps\n  taps: 0.25 0.5 0.25",
    );
}

#[test]
fn bad_rows_say_what_to_fix() {
    check("frobnicate a c", "row 1: unknown block `frobnicate`; the blocks are typeconv, add, mult, pow, pid, filter, ramp, nonlinear, alarm, multiplexor, hysteresis, delay, source");
    check("add c a", "row 1: add takes an output and pairs of input and gain: `fblock add OUT IN GAIN [IN GAIN]...`: OUT = IN·GAIN + ...");
    check("add x a 1", "row 1: `x` belongs to another module");
    check("add c zz 1", "row 1: no point `zz`");
    check("add n a 1", "row 1: `n` is a i16 point, but add writes f32 points: declare it `f32`, or write an f32 point and convert it with `fblock typeconv`");
    check(
        "typeconv a i32 n i32",
        "row 1: typeconv says `a` is i32, but it is declared f32; write f32",
    );
    check("typeconv a f32 b bool", "row 1: typeconv type `bool` for `b` is not i32, u32 or f32: `fblock typeconv IN TYPE OUT TYPE [IN TYPE OUT TYPE]...`, TYPE i32, u32 or f32");
    check("pid a c 1 2 3 4", "row 1: unknown option `4`; this block knows sp, form, max_out, min_out, d_on, d_filter, anti_windup, tt, rate, mode, manual (`fblock pid IN OUT [P [I [D]]] [sp SP] [form parallel|ideal] [max_out U] [min_out L] [d_on error|measurement] [d_filter TF] [anti_windup clamp|backcalc|none] [tt TT] [rate R] [mode MODE manual MANUAL]`)");
    check(
        "pid a c 1 min_out 5 max_out 1",
        "row 1: min_out 5 must be below max_out 1",
    );
    check("pid a c 1 d_on measurement", "row 1: `d_on measurement` needs the measurement: give the setpoint with `sp POINT`, and IN is then the measurement");
    check("pid a c 0 1 anti_windup backcalc", "row 1: `anti_windup backcalc` needs `tt SECONDS` here: without both proportional and integral action there is no Ti to start from");
    check("pid a c 1 mode b", "row 1: `mode` and `manual` go together: `mode POINT` (auto when not 0) and `manual POINT` (the output in manual mode)");
    check("filter a c iir 1 -2 1 0.5", "row 1: `iir` takes C and then four numbers per section (A1 A2 B1 B2), got 4 numbers: `iir C A1 A2 B1 B2 [A1 A2 B1 B2]...` is C·Π(1 + A1·z⁻¹ + A2·z⁻²) / (1 + B1·z⁻¹ + B2·z⁻²)");
    check("filter a c butterworth lowpass 1 .1737 40 500 750", "row 1: F1 = 500 Hz (passband edge) is not below the Nyquist frequency 50 Hz: scan_period 0.01 s samples at 100 Hz; lower F1 or shorten scan_period");
    check("filter a c elliptic lowpass 1 1 40 20 10", "row 1: F2 = 10 Hz (stopband edge) must be above F1 = 20 Hz (passband edge): the frequencies increase, F1 passband edge, F2 stopband edge");
    check("filter a c chebyshev bandstop 1 1 40 10 20 15 30", "row 1: F3 = 15 Hz (upper stopband edge) must be above F2 = 20 Hz (lower stopband edge): the frequencies increase, F1 lower passband edge, F2 lower stopband edge, F3 upper stopband edge, F4 upper passband edge");
    check("filter a c butterworth lowpass 1 40 3 5 20", "row 1: PASS_TOL 40 dB (the most attenuation allowed in the passband) must be below STOP_TOL 3 dB (the least required in the stopband)");
    check("filter a c butterworth lowpass 1 0.1 80 10 10.1", "row 1: the specification needs order 1042, above the limit of 32; widen the transition band or relax the tolerances");
    check("filter a c butterworth lowpass 1 3 20 5", "row 1: a lowpass design takes GAIN PASS_TOL STOP_TOL and 2 frequencies (F1..F2), got 4 cells after the shape: `fblock filter IN OUT iir C A1 A2 B1 B2 [A1 A2 B1 B2]...`, `fblock filter IN OUT TYPE SHAPE GAIN PASS_TOL STOP_TOL F1 F2 [F3 F4]`, `fblock filter IN OUT TYPE SHAPE GAIN order N F1 [F2] [ripple DB] [attenuation DB] [norm phase|delay|mag]`, `fblock filter IN OUT fir B0 B1 ...` or `fblock filter IN OUT fir SHAPE TAPS F1 [F2] [WINDOW]`");
    check(
        "filter a c chebyshev lowpass 1 order 4 10",
        "row 1: a chebyshev filter needs its passband ripple: add `ripple DB`",
    );
    check("filter a c fir highpass 4 10", "row 1: a highpass FIR filter passes the Nyquist frequency, so it needs an odd number of taps (not 4)");
    check("alarm a true_val b gt", "row 1: alarm limits come as OUT COMP LIMIT: `fblock alarm IN true_val|abs_val [hysteresis H] OUT COMP LIMIT [OUT COMP LIMIT]...`, COMP lt le gt ge eq ne");
    check(
        "alarm a true_val b gt 1 b gt 2 b gt 3 b gt 4 b gt 5 b gt 6 b gt 7 b gt 8 b gt 9 b gt 10 b gt 11",
        "row 1: 11 limits; an alarm row holds at most 10: split it into two rows",
    );
    check(
        "alarm a true_val b about 1",
        "row 1: `about` is not a comparison: lt le gt ge eq ne (or less, greater_or_equal, ...)",
    );
    check(
        "multiplexor c b a 5 x 1 e",
        "row 1: the limits must increase: 1 follows 5",
    );
    check(
        "hysteresis a b 1 1",
        "row 1: ON and OFF are both 1: a hysteresis needs a band between them",
    );
    check(
        "delay a c time 0.001",
        "row 1: a delay of 0.001 s is less than half a scan (0.01 s): give at least one scan",
    );
    check("source e noise", "row 1: unknown waveform `noise`: `fblock source OUT sine|square|triangle|step|ramp [amplitude A] [frequency HZ] [offset O] [start SECONDS]`");
    check("add c a 1\nadd c a x\npow c", "row 2: gain of `a` `x` is not a number\nrow 3: pow takes an output, an input and an exponent: `fblock pow OUT IN POWER`");
}

#[test]
fn designed_filters_need_a_scan_period() {
    let e = Chain::parse(
        &rows("filter a c butterworth lowpass 1 3 20 5 20"),
        &mut Table,
        &Context::default(),
    )
    .unwrap_err();
    assert_eq!(e[0].1, "a designed butterworth filter needs the module's sampling rate: set `scan_period` in the module's section (the sampling rate is 1/scan_period)");
    assert!(Chain::parse(
        &rows("filter a c iir 1 0 0 0 0"),
        &mut Table,
        &Context::default()
    )
    .is_ok());
}

/// Values flow through the chain in row order, each block seeing what the earlier ones
/// wrote, and outputs hold what their points can.
#[test]
fn scan_runs_blocks_in_order() {
    let mut chain = Chain::parse(
        &rows(
            "add c a 2 x 1
             mult d c 1 a 0
             typeconv d f32 n i32
             alarm d true_val b gt 100 u lt 0",
        ),
        &mut Table,
        &Context::default(),
    )
    .unwrap();
    let mut v = vec![0.0; 9];
    v[0] = 3.0; // a
    v[5] = 1.5; // x
    chain.scan(&mut v, 0.0);
    // c = 3·2 + 1.5 = 7.5; d = (7.5 + 1)·3 = 25.5; n = 26; b = 0; u = 0
    assert_eq!((v[2], v[3], v[6], v[1], v[7]), (7.5, 25.5, 26.0, 0.0, 0.0));
    v[0] = 1e6;
    chain.scan(&mut v, 0.01);
    // d = (2e6 + 1.5 + 1)·1e6 ≈ 2e12: n saturates at i16's 32767, b sets.
    assert_eq!((v[6], v[1]), (32767.0, 1.0));
    v[0] = f64::NAN;
    chain.scan(&mut v, 0.02);
    // NaN: typeconv gives 0, the alarm sets every output.
    assert_eq!((v[6], v[1], v[7]), (0.0, 1.0, 1.0));
}
