//! Reading one `fblock` row into a block: its cells checked one by one (numbers, keywords,
//! points read or written), filters designed, every problem worded for the row's author.

use crate::block::{
    Add, Alarm, AntiWindup, Compare, Delay, Fir, Hysteresis, Iir, Limit, Mult, Multiplexor,
    Nonlinear, NumType, Pid, PidConfig, PidForm, Pow, Ramp, RampConfig, Source, Wave, MAX_LIMITS,
};
use crate::design::{
    firwin, iirdesign, iirfilter, Band, BesselNorm, Family, Section, Window, MAX_ORDER,
};

use super::{list, Context, Node, Points, Run, Slot, Spec, BLOCKS};

/// One row being read.
pub(super) struct Row<'a> {
    pub cells: &'a [String],
    pub points: &'a mut dyn Points,
    pub ctx: &'a Context,
}

/// A number cell.
fn number(what: &str, cell: &str) -> Result<f64, String> {
    match cell.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(format!("{what} `{cell}` is not a number")),
    }
}

fn positive(what: &str, cell: &str) -> Result<f64, String> {
    let v = number(what, cell)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(format!("{what} `{cell}` must be above 0"))
    }
}

/// `keyword value` pairs: each keyword at most once, and only the known ones.
fn keywords<'c>(
    cells: &'c [String],
    known: &[&str],
    syntax: &str,
) -> Result<Vec<(&'c str, &'c str)>, String> {
    let mut pairs: Vec<(&str, &str)> = Vec::new();
    for kv in cells.chunks(2) {
        let k = kv[0].as_str();
        if !known.contains(&k) {
            return Err(format!(
                "unknown option `{k}`; this block knows {} ({syntax})",
                known.join(", ")
            ));
        }
        let Some(v) = kv.get(1).map(String::as_str) else {
            return Err(format!(
                "`{k}` has no value; write it as `{k} VALUE` ({syntax})"
            ));
        };
        if pairs.iter().any(|(p, _)| *p == k) {
            return Err(format!("`{k}` is given twice; keep one"));
        }
        pairs.push((k, v));
    }
    Ok(pairs)
}

const F_NAMES: [&str; 4] = ["F1", "F2", "F3", "F4"];

impl Row<'_> {
    fn read(&mut self, name: &str) -> Result<Slot, String> {
        self.points.slot(name, false)
    }

    /// An output an analog block writes: an f32 point of this module.
    fn write_f32(&mut self, name: &str, block: &str) -> Result<Slot, String> {
        let s = self.points.slot(name, true)?;
        if s.ty != NumType::F32 {
            return Err(format!(
                "`{name}` is a {} point, but {block} writes f32 points: declare it `f32`, or \
                 write an f32 point and convert it with `fblock typeconv`",
                s.ty.name()
            ));
        }
        Ok(s)
    }

    /// An output a boolean block writes: any point of this module (1/0, or 1.0/0.0).
    fn write_any(&mut self, name: &str) -> Result<Slot, String> {
        self.points.slot(name, true)
    }

    fn scan_period(&self, what: &str) -> Result<f64, String> {
        self.ctx.scan_period.ok_or_else(|| {
            format!(
                "{what} needs the module's sampling rate: set `scan_period` in the module's \
                 section (the sampling rate is 1/scan_period)"
            )
        })
    }

    pub(super) fn node(&mut self) -> Result<Node, String> {
        let Some((kind, args)) = self.cells.split_first() else {
            return Err(format!(
                "an fblock row names a block: {}",
                BLOCKS.join(", ")
            ));
        };
        match kind.as_str() {
            "typeconv" => self.typeconv(args),
            "add" | "mult" => self.weighted(kind, args),
            "pow" => self.pow(args),
            "pid" => self.pid(args),
            "filter" => self.filter(args),
            "ramp" => self.ramp(args),
            "nonlinear" => self.nonlinear(args),
            "alarm" => self.alarm(args),
            "multiplexor" => self.multiplexor(args),
            "hysteresis" => self.hysteresis(args),
            "delay" => self.delay(args),
            "source" => self.source(args),
            other => Err(format!(
                "unknown block `{other}`; the blocks are {}",
                BLOCKS.join(", ")
            )),
        }
    }

    fn typeconv(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str =
            "`fblock typeconv IN TYPE OUT TYPE [IN TYPE OUT TYPE]...`, TYPE i32, u32 or f32";
        if a.is_empty() || a.len() % 4 != 0 {
            return Err(format!(
                "typeconv takes groups of four cells, got {}: {SYNTAX}",
                a.len()
            ));
        }
        let mut pairs = Vec::new();
        for g in a.chunks(4) {
            let i = self.read(&g[0])?;
            let o = self.write_any(&g[2])?;
            for (name, ty, slot) in [(&g[0], &g[1], i), (&g[2], &g[3], o)] {
                let matches = match (ty.as_str(), slot.ty) {
                    ("i32", NumType::Signed(_))
                    | ("u32", NumType::Unsigned(_))
                    | ("f32", NumType::F32) => true,
                    ("i32" | "u32" | "f32", _) => false,
                    _ => {
                        return Err(format!(
                            "typeconv type `{ty}` for `{name}` is not i32, u32 or f32: {SYNTAX}"
                        ))
                    }
                };
                if !matches {
                    let right = match slot.ty {
                        NumType::F32 => "f32",
                        NumType::Signed(_) => "i32",
                        NumType::Unsigned(_) => "u32",
                    };
                    return Err(format!(
                        "typeconv says `{name}` is {ty}, but it is declared {}; write {right}",
                        slot.ty.name()
                    ));
                }
            }
            pairs.push((i, o));
        }
        Ok(Node::TypeConv(pairs))
    }

    fn weighted(&mut self, kind: &str, a: &[String]) -> Result<Node, String> {
        let (param, syntax) = if kind == "add" {
            (
                "gain",
                "`fblock add OUT IN GAIN [IN GAIN]...`: OUT = IN·GAIN + ...",
            )
        } else {
            (
                "offset",
                "`fblock mult OUT IN OFFSET [IN OFFSET]...`: OUT = (IN + OFFSET)·...",
            )
        };
        if a.len() < 3 || a.len() % 2 == 0 {
            return Err(format!(
                "{kind} takes an output and pairs of input and {param}: {syntax}"
            ));
        }
        let out = self.write_f32(&a[0], kind)?;
        let mut ins = Vec::new();
        let mut ks = Vec::new();
        for pair in a[1..].chunks(2) {
            ins.push(self.read(&pair[0])?);
            ks.push(number(&format!("{param} of `{}`", pair[0]), &pair[1])?);
        }
        Ok(if kind == "add" {
            Node::Add {
                out,
                ins,
                block: Add { gains: ks },
            }
        } else {
            Node::Mult {
                out,
                ins,
                block: Mult { offsets: ks },
            }
        })
    }

    fn pow(&mut self, a: &[String]) -> Result<Node, String> {
        let [o, i, p] = a else {
            return Err(
                "pow takes an output, an input and an exponent: `fblock pow OUT IN POWER`".into(),
            );
        };
        Ok(Node::Pow {
            out: self.write_f32(o, "pow")?,
            input: self.read(i)?,
            block: Pow {
                exponent: number("the exponent", p)?,
            },
        })
    }

    fn pid(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str = "`fblock pid IN OUT [P [I [D]]] [sp SP] [form parallel|ideal] \
            [max_out U] [min_out L] [d_on error|measurement] [d_filter TF] \
            [anti_windup clamp|backcalc|none] [tt TT] [rate R] [mode MODE manual MANUAL]`";
        const KEYS: &[&str] = &[
            "sp",
            "form",
            "max_out",
            "min_out",
            "d_on",
            "d_filter",
            "anti_windup",
            "tt",
            "rate",
            "mode",
            "manual",
        ];
        if a.len() < 2 {
            return Err(format!("pid takes an input and an output: {SYNTAX}"));
        }
        let input = self.read(&a[0])?;
        let out = self.write_f32(&a[1], "pid")?;
        let rest = &a[2..];
        let n_gains = rest
            .iter()
            .take(3)
            .take_while(|c| !KEYS.contains(&c.as_str()))
            .count();
        let mut config = PidConfig::default();
        let gains: Vec<f64> = rest[..n_gains]
            .iter()
            .zip(["P", "I", "D"])
            .map(|(c, what)| number(what, c))
            .collect::<Result<_, _>>()?;
        for (slot, g) in [&mut config.p, &mut config.i, &mut config.d]
            .into_iter()
            .zip(&gains)
        {
            *slot = *g;
        }
        let opts = keywords(&rest[n_gains..], KEYS, SYNTAX)?;
        let get = |k: &str| opts.iter().find(|(key, _)| *key == k).map(|(_, v)| *v);
        let sp = get("sp").map(|p| self.read(p)).transpose()?;
        if let Some(f) = get("form") {
            config.form = match f {
                "parallel" => PidForm::Parallel,
                "ideal" => PidForm::Ideal,
                _ => return Err(format!("`form {f}`: write `form parallel` or `form ideal`")),
            };
        }
        if config.form == PidForm::Ideal && (config.i < 0.0 || config.d < 0.0) {
            return Err(
                "in the ideal form I is Ti and D is Td, in seconds: neither may be negative".into(),
            );
        }
        if let Some(v) = get("max_out") {
            config.max_out = number("max_out", v)?;
        }
        if let Some(v) = get("min_out") {
            config.min_out = number("min_out", v)?;
        }
        if config.min_out >= config.max_out {
            return Err(format!(
                "min_out {} must be below max_out {}",
                config.min_out, config.max_out
            ));
        }
        config.d_on_measurement = match get("d_on") {
            None => sp.is_some(),
            Some("error") => false,
            Some("measurement") if sp.is_some() => true,
            Some("measurement") => {
                return Err("`d_on measurement` needs the measurement: give the setpoint with `sp POINT`, and IN is then the measurement".into())
            }
            Some(v) => return Err(format!("`d_on {v}`: write `d_on error` or `d_on measurement`")),
        };
        if let Some(v) = get("d_filter") {
            let tf = number("d_filter", v)?;
            if tf < 0.0 {
                return Err(format!("d_filter `{v}` (seconds) may not be negative"));
            }
            config.d_filter = tf;
        }
        if let Some(v) = get("rate") {
            config.rate = positive("rate", v)?;
        }
        config.anti_windup = match get("anti_windup").unwrap_or("clamp") {
            "clamp" => AntiWindup::Clamp,
            "none" => AntiWindup::None,
            "backcalc" => {
                let tt = match get("tt") {
                    Some(v) => positive("tt", v)?,
                    None => config.default_tracking_time().ok_or(
                        "`anti_windup backcalc` needs `tt SECONDS` here: without both \
                         proportional and integral action there is no Ti to start from",
                    )?,
                };
                AntiWindup::BackCalculation { tt }
            }
            v => return Err(format!("`anti_windup {v}`: write clamp, backcalc or none")),
        };
        if get("tt").is_some() && !matches!(config.anti_windup, AntiWindup::BackCalculation { .. })
        {
            return Err(
                "`tt` is the back-calculation time constant: add `anti_windup backcalc`".into(),
            );
        }
        let mode = match (get("mode"), get("manual")) {
            (None, None) => None,
            (Some(m), Some(man)) => Some((self.read(m)?, self.read(man)?)),
            _ => {
                return Err(
                    "`mode` and `manual` go together: `mode POINT` (auto when not 0) \
                     and `manual POINT` (the output in manual mode)"
                        .into(),
                )
            }
        };
        Ok(Node::Pid {
            input,
            out,
            sp,
            mode,
            block: Box::new(Pid::new(config)),
        })
    }

    fn filter(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str = "`fblock filter IN OUT iir C A1 A2 B1 B2 [A1 A2 B1 B2]...`, \
            `fblock filter IN OUT TYPE SHAPE GAIN PASS_TOL STOP_TOL F1 F2 [F3 F4]`, \
            `fblock filter IN OUT TYPE SHAPE GAIN order N F1 [F2] [ripple DB] [attenuation DB] [norm phase|delay|mag]`, \
            `fblock filter IN OUT fir B0 B1 ...` or `fblock filter IN OUT fir SHAPE TAPS F1 [F2] [WINDOW]`";
        if a.len() < 3 {
            return Err(format!(
                "filter takes an input, an output and a filter: {SYNTAX}"
            ));
        }
        let input = self.read(&a[0])?;
        let out = self.write_f32(&a[1], "filter")?;
        let spec = &a[2..];
        let run = match spec[0].as_str() {
            "iir" => self.iir_coefficients(&spec[1..])?,
            "fir" => self.fir(&spec[1..])?,
            t => {
                let family = match t {
                    "butterworth" => Family::Butterworth,
                    "chebyshev" => Family::Chebyshev1,
                    "chebyshev2" => Family::Chebyshev2,
                    "elliptic" => Family::Elliptic,
                    "bessel" => Family::Bessel(BesselNorm::Mag),
                    _ => {
                        return Err(format!(
                            "unknown filter `{t}`: iir, fir, butterworth, chebyshev, \
                             chebyshev2, elliptic or bessel ({SYNTAX})"
                        ))
                    }
                };
                self.designed(family, &spec[1..], SYNTAX)?
            }
        };
        Ok(Node::Filter {
            input,
            out,
            run: Box::new(run),
        })
    }

    fn iir_coefficients(&mut self, c: &[String]) -> Result<Run, String> {
        let (c, steady) = match c.split_last() {
            Some((last, rest)) if last == "steady" => (rest, true),
            _ => (c, false),
        };
        if c.len() < 5 || (c.len() - 1) % 4 != 0 {
            return Err(format!(
                "`iir` takes C and then four numbers per section (A1 A2 B1 B2), got {} \
                 number{}: `iir C A1 A2 B1 B2 [A1 A2 B1 B2]...` is C·Π(1 + A1·z⁻¹ + A2·z⁻²) / \
                 (1 + B1·z⁻¹ + B2·z⁻²)",
                c.len(),
                if c.len() == 1 { "" } else { "s" }
            ));
        }
        let gain = number("C", &c[0])?;
        let mut sections: Vec<Section> = Vec::new();
        for (k, s) in c[1..].chunks(4).enumerate() {
            let n = |i: usize, what: &str| number(&format!("{what} of section {}", k + 1), &s[i]);
            sections.push([1.0, n(0, "A1")?, n(1, "A2")?, 1.0, n(2, "B1")?, n(3, "B2")?]);
        }
        for v in &mut sections[0][..3] {
            *v *= gain;
        }
        Ok(Run::Iir {
            order: 2 * sections.len(),
            filter: Iir::new(sections, steady),
            spec: Spec::Coefficients,
        })
    }

    fn fir(&mut self, c: &[String]) -> Result<Run, String> {
        let Some(first) = c.first() else {
            return Err("`fir` takes its taps B0 B1 ... or a design: `fir SHAPE TAPS F1 [F2] [WINDOW [BETA]]`".into());
        };
        let band = match first.as_str() {
            "lowpass" => Band::Lowpass,
            "highpass" => Band::Highpass,
            "bandpass" => Band::Bandpass,
            "bandstop" => Band::Bandstop,
            _ => {
                let taps: Vec<f64> = c
                    .iter()
                    .enumerate()
                    .map(|(i, v)| number(&format!("tap B{i}"), v))
                    .collect::<Result<_, _>>()?;
                return Ok(Run::Fir {
                    filter: Fir::new(taps),
                    design: None,
                });
            }
        };
        let syntax = "`fir SHAPE TAPS F1 [F2] [WINDOW [BETA]]`, F2 for bandpass and bandstop, \
            WINDOW hamming (default), hann, blackman, boxcar, triang, bartlett or kaiser BETA";
        let n = band.edges();
        if c.len() < 2 + n {
            return Err(format!(
                "a {band} FIR design needs TAPS and {n} frequenc{}: {syntax}",
                if n == 1 { "y" } else { "ies" }
            ));
        }
        let taps: usize = match c[1].parse() {
            Ok(t) if (1..=4096).contains(&t) => t,
            _ => {
                return Err(format!(
                    "TAPS `{}` must be a whole number from 1 to 4096",
                    c[1]
                ))
            }
        };
        let freqs: Vec<f64> = c[2..2 + n]
            .iter()
            .zip(F_NAMES)
            .map(|(v, f)| positive(f, v))
            .collect::<Result<_, _>>()?;
        let window = match &c[2 + n..] {
            [] => Window::Hamming,
            [w] if w == "kaiser" => {
                return Err("the kaiser window needs its β: `kaiser BETA`".into())
            }
            [w, beta] if w == "kaiser" => Window::Kaiser(number("the kaiser β", beta)?),
            [w] => Window::parse(w).ok_or_else(|| format!("unknown window `{w}`: {syntax}"))?,
            rest => return Err(format!("`{}` is too many cells: {syntax}", rest.join(" "))),
        };
        let period = self.scan_period("a designed FIR filter")?;
        let fs = 1.0 / period;
        self.check_edges(&freqs, &["cut-off"; 4][..n], fs, period)?;
        let h = firwin(taps, &freqs, window, band, fs).map_err(|e| e.to_string())?;
        Ok(Run::Fir {
            filter: Fir::new(h),
            design: Some(format!(
                "firwin {band} {} Hz, {} window, at {fs} Hz",
                list(&freqs),
                window.name()
            )),
        })
    }

    /// Frequencies must be positive, below Nyquist and increasing.
    fn check_edges(&self, f: &[f64], roles: &[&str], fs: f64, period: f64) -> Result<(), String> {
        let nyquist = fs / 2.0;
        for (i, (&v, role)) in f.iter().zip(roles).enumerate() {
            if v >= nyquist {
                return Err(format!(
                    "{} = {v} Hz ({role}) is not below the Nyquist frequency {nyquist} Hz: \
                     scan_period {period} s samples at {fs} Hz; lower {} or shorten scan_period",
                    F_NAMES[i], F_NAMES[i]
                ));
            }
            if i > 0 && v <= f[i - 1] {
                return Err(format!(
                    "{} = {v} Hz ({role}) must be above {} = {} Hz ({}): the frequencies \
                     increase, {}",
                    F_NAMES[i],
                    F_NAMES[i - 1],
                    f[i - 1],
                    roles[i - 1],
                    roles
                        .iter()
                        .zip(F_NAMES)
                        .map(|(r, n)| format!("{n} {r}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
        }
        Ok(())
    }

    fn designed(&mut self, family: Family, c: &[String], syntax: &str) -> Result<Run, String> {
        let (c, steady) = match c.split_last() {
            Some((last, rest)) if last == "steady" => (rest, true),
            _ => (c, false),
        };
        let band = match c.first().map(String::as_str) {
            Some("lowpass") => Band::Lowpass,
            Some("highpass") => Band::Highpass,
            Some("bandpass") => Band::Bandpass,
            Some("bandstop") => Band::Bandstop,
            other => {
                return Err(format!(
                    "the shape `{}` is not lowpass, highpass, bandpass or bandstop: {syntax}",
                    other.unwrap_or("")
                ))
            }
        };
        if c.len() < 2 {
            return Err(format!("the filter's GAIN is missing: {syntax}"));
        }
        let gain = number("GAIN", &c[1])?;
        let period = self.scan_period(&format!("a designed {} filter", family.name()))?;
        let fs = 1.0 / period;
        let rest = &c[2..];
        if rest.first().map(String::as_str) == Some("order") {
            return self.with_order(family, band, gain, &rest[1..], fs, period, steady);
        }
        let n = 2 * band.edges();
        if rest.len() != 2 + n {
            return Err(format!(
                "a {band} design takes GAIN PASS_TOL STOP_TOL and {n} frequencies (F1..F{n}), \
                 got {} cells after the shape: {syntax}",
                c.len() - 1
            ));
        }
        let pass_db = positive("PASS_TOL", &rest[0])?;
        let stop_db = positive("STOP_TOL", &rest[1])?;
        let f: Vec<f64> = rest[2..]
            .iter()
            .zip(F_NAMES)
            .map(|(v, name)| positive(name, v))
            .collect::<Result<_, _>>()?;
        // MatPLC's order of the edges per shape: always increasing.
        let (roles, wp, ws): (&[&str], Vec<f64>, Vec<f64>) = match band {
            Band::Lowpass => (&["passband edge", "stopband edge"], vec![f[0]], vec![f[1]]),
            Band::Highpass => (&["stopband edge", "passband edge"], vec![f[1]], vec![f[0]]),
            Band::Bandpass => (
                &[
                    "lower stopband edge",
                    "lower passband edge",
                    "upper passband edge",
                    "upper stopband edge",
                ],
                vec![f[1], f[2]],
                vec![f[0], f[3]],
            ),
            Band::Bandstop => (
                &[
                    "lower passband edge",
                    "lower stopband edge",
                    "upper stopband edge",
                    "upper passband edge",
                ],
                vec![f[0], f[3]],
                vec![f[1], f[2]],
            ),
        };
        self.check_edges(&f, roles, fs, period)?;
        if pass_db >= stop_db {
            return Err(format!(
                "PASS_TOL {pass_db} dB (the most attenuation allowed in the passband) must be \
                 below STOP_TOL {stop_db} dB (the least required in the stopband)"
            ));
        }
        let d = iirdesign(&wp, &ws, pass_db, stop_db, family, fs).map_err(|e| e.to_string())?;
        let mut sos = d.sos;
        for v in &mut sos[0][..3] {
            *v *= gain;
        }
        Ok(Run::Iir {
            filter: Iir::new(sos, steady),
            order: d.order,
            spec: Spec::Tolerances {
                family: d.family,
                band,
                gain,
                pass_db,
                stop_db,
                edges: f,
                wn: d.wn,
            },
        })
    }

    #[allow(clippy::too_many_arguments)]
    fn with_order(
        &mut self,
        family: Family,
        band: Band,
        gain: f64,
        c: &[String],
        fs: f64,
        period: f64,
        steady: bool,
    ) -> Result<Run, String> {
        let syntax =
            "`TYPE SHAPE GAIN order N F1 [F2] [ripple DB] [attenuation DB] [norm phase|delay|mag]`";
        let order: usize = match c.first().map(|v| v.parse::<usize>()) {
            Some(Ok(n)) if (1..=MAX_ORDER).contains(&n) => n,
            _ => {
                return Err(format!(
                    "`order` takes a whole number from 1 to {MAX_ORDER}: {syntax}"
                ))
            }
        };
        let n = band.edges();
        if c.len() < 1 + n {
            return Err(format!(
                "a {band} filter of given order takes {n} critical frequenc{}: {syntax}",
                if n == 1 { "y" } else { "ies" }
            ));
        }
        let wn: Vec<f64> = c[1..1 + n]
            .iter()
            .zip(F_NAMES)
            .map(|(v, name)| positive(name, v))
            .collect::<Result<_, _>>()?;
        self.check_edges(&wn, &["critical frequency"; 2][..n], fs, period)?;
        let opts = keywords(&c[1 + n..], &["ripple", "attenuation", "norm"], syntax)?;
        let get = |k: &str| opts.iter().find(|(key, _)| *key == k).map(|(_, v)| *v);
        let rp = get("ripple").map(|v| positive("ripple", v)).transpose()?;
        let rs = get("attenuation")
            .map(|v| positive("attenuation", v))
            .transpose()?;
        let family = match (family, get("norm")) {
            (Family::Bessel(_), None | Some("phase")) => Family::Bessel(BesselNorm::Phase),
            (Family::Bessel(_), Some("delay")) => Family::Bessel(BesselNorm::Delay),
            (Family::Bessel(_), Some("mag")) => Family::Bessel(BesselNorm::Mag),
            (Family::Bessel(_), Some(v)) => {
                return Err(format!("`norm {v}`: write phase, delay or mag"))
            }
            (_, Some(_)) => return Err("`norm` applies to bessel filters only".into()),
            (f, None) => f,
        };
        let needs = |f: Family| match f {
            Family::Chebyshev1 => (true, false),
            Family::Chebyshev2 => (false, true),
            Family::Elliptic => (true, true),
            _ => (false, false),
        };
        let (need_rp, need_rs) = needs(family);
        if need_rp && rp.is_none() {
            return Err(format!(
                "a {} filter needs its passband ripple: add `ripple DB`",
                family.name()
            ));
        }
        if need_rs && rs.is_none() {
            return Err(format!(
                "a {} filter needs its stopband attenuation: add `attenuation DB`",
                family.name()
            ));
        }
        if !need_rp && rp.is_some() {
            return Err(format!(
                "`ripple` does not apply to a {} filter",
                family.name()
            ));
        }
        if !need_rs && rs.is_some() {
            return Err(format!(
                "`attenuation` does not apply to a {} filter",
                family.name()
            ));
        }
        let mut sos = iirfilter(order, &wn, rp, rs, band, family, fs).map_err(|e| e.to_string())?;
        for v in &mut sos[0][..3] {
            *v *= gain;
        }
        Ok(Run::Iir {
            filter: Iir::new(sos, steady),
            order,
            spec: Spec::Order {
                family,
                band,
                gain,
                wn,
            },
        })
    }

    fn ramp(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str = "`fblock ramp IN OUT [dxdt R] [pos_dxdt R] [neg_dxdt R] [d2xdt2 A] [pos_d2xdt2 A] [neg_d2xdt2 A]`";
        if a.len() < 2 {
            return Err(format!("ramp takes an input and an output: {SYNTAX}"));
        }
        let input = self.read(&a[0])?;
        let out = self.write_f32(&a[1], "ramp")?;
        let opts = keywords(
            &a[2..],
            &[
                "dxdt",
                "pos_dxdt",
                "neg_dxdt",
                "d2xdt2",
                "pos_d2xdt2",
                "neg_d2xdt2",
            ],
            SYNTAX,
        )?;
        let mut c = RampConfig::default();
        for (k, v) in opts {
            let x = positive(k, v)?;
            match k {
                "dxdt" => {
                    c.pos_dxdt = c.pos_dxdt.min(x);
                    c.neg_dxdt = c.neg_dxdt.min(x);
                }
                "pos_dxdt" => c.pos_dxdt = x,
                "neg_dxdt" => c.neg_dxdt = x,
                "d2xdt2" => {
                    c.pos_d2xdt2 = c.pos_d2xdt2.min(x);
                    c.neg_d2xdt2 = c.neg_d2xdt2.min(x);
                }
                "pos_d2xdt2" => c.pos_d2xdt2 = x,
                _ => c.neg_d2xdt2 = x,
            }
        }
        Ok(Node::Ramp {
            input,
            out,
            block: Ramp::new(c),
        })
    }

    fn nonlinear(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str = "`fblock nonlinear IN OUT [cutoff_top X] [cutoff_bot X] [deadband_top X] [deadband_bot X] [deadband_out X] [gain X]`";
        if a.len() < 2 {
            return Err(format!("nonlinear takes an input and an output: {SYNTAX}"));
        }
        let input = self.read(&a[0])?;
        let out = self.write_f32(&a[1], "nonlinear")?;
        let opts = keywords(
            &a[2..],
            &[
                "cutoff_top",
                "cutoff_bot",
                "deadband_top",
                "deadband_bot",
                "deadband_out",
                "gain",
            ],
            SYNTAX,
        )?;
        let mut n = Nonlinear::default();
        for (k, v) in opts {
            let x = number(k, v)?;
            match k {
                "cutoff_top" => n.cutoff_top = x,
                "cutoff_bot" => n.cutoff_bot = x,
                "deadband_top" => n.deadband_top = x,
                "deadband_bot" => n.deadband_bot = x,
                "deadband_out" => n.deadband_out = x,
                _ => n.gain = x,
            }
        }
        if n.cutoff_bot > n.cutoff_top {
            return Err(format!(
                "cutoff_bot {} is above cutoff_top {}",
                n.cutoff_bot, n.cutoff_top
            ));
        }
        if n.deadband_bot > n.deadband_top {
            return Err(format!(
                "deadband_bot {} is above deadband_top {}",
                n.deadband_bot, n.deadband_top
            ));
        }
        Ok(Node::Nonlinear {
            input,
            out,
            block: n,
        })
    }

    fn alarm(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str = "`fblock alarm IN true_val|abs_val [hysteresis H] OUT COMP LIMIT [OUT COMP LIMIT]...`, COMP lt le gt ge eq ne";
        if a.len() < 2 {
            return Err(format!("alarm takes an input and its limits: {SYNTAX}"));
        }
        let input = self.read(&a[0])?;
        let absolute = match a[1].as_str() {
            "true_val" => false,
            "abs_val" => true,
            v => return Err(format!("`{v}` is neither true_val nor abs_val: {SYNTAX}")),
        };
        // OUT COMP LIMIT triples come in threes, `hysteresis H` in twos: the cell count
        // tells them apart even from a point named `hysteresis`.
        let (hysteresis, triples) =
            if a.len() >= 4 && a[2] == "hysteresis" && (a.len() - 4) % 3 == 0 {
                let h = number("hysteresis", &a[3])?;
                if h < 0.0 {
                    return Err(format!("hysteresis `{}` may not be negative", a[3]));
                }
                (h, &a[4..])
            } else {
                (0.0, &a[2..])
            };
        if triples.is_empty() || triples.len() % 3 != 0 {
            return Err(format!("alarm limits come as OUT COMP LIMIT: {SYNTAX}"));
        }
        if triples.len() / 3 > MAX_LIMITS {
            return Err(format!(
                "{} limits; an alarm row holds at most {MAX_LIMITS}: split it into two rows",
                triples.len() / 3
            ));
        }
        let mut outs = Vec::new();
        let mut limits = Vec::new();
        for t in triples.chunks(3) {
            outs.push(self.write_any(&t[0])?);
            let compare = Compare::parse(&t[1]).ok_or_else(|| {
                format!(
                    "`{}` is not a comparison: lt le gt ge eq ne (or less, greater_or_equal, ...)",
                    t[1]
                )
            })?;
            limits.push(Limit {
                compare,
                limit: number(&format!("the limit of `{}`", t[0]), &t[2])?,
            });
        }
        Ok(Node::Alarm {
            input,
            outs,
            block: Alarm::new(absolute, hysteresis, limits),
        })
    }

    fn multiplexor(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str = "`fblock multiplexor OUT CTRL IN1 [LIMIT1 IN2]...`: IN1 while CTRL < LIMIT1, IN2 from LIMIT1, ...";
        if a.len() < 3 || a.len() % 2 == 0 {
            return Err(format!(
                "multiplexor takes an output, a control and inputs between limits: {SYNTAX}"
            ));
        }
        let out = self.write_f32(&a[0], "multiplexor")?;
        let control = self.read(&a[1])?;
        let mut ins = vec![self.read(&a[2])?];
        let mut limits: Vec<f64> = Vec::new();
        for pair in a[3..].chunks(2) {
            let l = number("the limit", &pair[0])?;
            if let Some(&prev) = limits.last() {
                if l <= prev {
                    return Err(format!("the limits must increase: {l} follows {prev}"));
                }
            }
            limits.push(l);
            ins.push(self.read(&pair[1])?);
        }
        Ok(Node::Multiplexor {
            out,
            control,
            ins,
            block: Multiplexor { limits },
        })
    }

    fn hysteresis(&mut self, a: &[String]) -> Result<Node, String> {
        let [i, o, on, off] = a else {
            return Err(
                "hysteresis takes `fblock hysteresis IN OUT ON OFF`: on at ON, off at OFF".into(),
            );
        };
        let input = self.read(i)?;
        let out = self.write_any(o)?;
        let (on, off) = (number("ON", on)?, number("OFF", off)?);
        if on == off {
            return Err(format!(
                "ON and OFF are both {on}: a hysteresis needs a band between them"
            ));
        }
        Ok(Node::Hysteresis {
            input,
            out,
            block: Hysteresis {
                on,
                off,
                state: false,
            },
        })
    }

    fn delay(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str = "`fblock delay IN OUT SCANS` or `fblock delay IN OUT time SECONDS`";
        let (i, o, n) = match a {
            [i, o, n] => {
                let n: usize = match n.parse() {
                    Ok(n) if (1..=1_000_000).contains(&n) => n,
                    _ => {
                        return Err(format!(
                            "SCANS `{n}` must be a whole number from 1 to 1000000: {SYNTAX}"
                        ))
                    }
                };
                (i, o, n)
            }
            [i, o, t, secs] if t == "time" => {
                let s = positive("the delay", secs)?;
                let period = self.scan_period("a delay given in seconds")?;
                let n = (s / period).round();
                if n < 1.0 {
                    return Err(format!("a delay of {s} s is less than half a scan ({period} s): give at least one scan"));
                }
                if n > 1_000_000.0 {
                    return Err(format!("a delay of {s} s is {n} scans, more than 1000000"));
                }
                (i, o, n as usize)
            }
            _ => {
                return Err(format!(
                    "delay takes an input, an output and how long: {SYNTAX}"
                ))
            }
        };
        Ok(Node::Delay {
            input: self.read(i)?,
            out: self.write_f32(o, "delay")?,
            block: Delay::new(n),
        })
    }

    fn source(&mut self, a: &[String]) -> Result<Node, String> {
        const SYNTAX: &str = "`fblock source OUT sine|square|triangle|step|ramp [amplitude A] [frequency HZ] [offset O] [start SECONDS]`";
        if a.len() < 2 {
            return Err(format!("source takes an output and a waveform: {SYNTAX}"));
        }
        let out = self.write_f32(&a[0], "source")?;
        let wave =
            Wave::parse(&a[1]).ok_or_else(|| format!("unknown waveform `{}`: {SYNTAX}", a[1]))?;
        let opts = keywords(
            &a[2..],
            &["amplitude", "frequency", "offset", "start"],
            SYNTAX,
        )?;
        let mut s = Source {
            wave,
            amplitude: 1.0,
            frequency: 1.0,
            offset: 0.0,
            start: 0.0,
        };
        for (k, v) in opts {
            match k {
                "amplitude" => s.amplitude = number(k, v)?,
                "frequency" => s.frequency = positive(k, v)?,
                "offset" => s.offset = number(k, v)?,
                _ => {
                    s.start = number(k, v)?;
                    if s.start < 0.0 {
                        return Err(format!("start `{v}` (seconds) may not be negative"));
                    }
                }
            }
        }
        Ok(Node::Source { out, block: s })
    }
}
