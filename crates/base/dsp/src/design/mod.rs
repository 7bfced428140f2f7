//! IIR and FIR filter design, reproducing `scipy.signal` (1.17) closely enough that the
//! second-order sections agree to rounding: the order from the tolerances (`buttord`,
//! `cheb1ord`, `cheb2ord`, `ellipord`, and a search for Bessel), the analog prototypes, the
//! lowpass-to-X transforms, the bilinear transform with prewarping, `zpk2sos`'s pairing, and
//! `firwin` with its windows. Frequencies are in Hz with the sampling rate `fs` given, as
//! SciPy's `fs=` argument.

mod fir;
mod order;
mod proto;
mod sos;
pub mod special;
mod transform;

use std::f64::consts::PI;
use std::fmt;

use num_complex::Complex64;

pub use fir::{firwin, Window};
pub use order::order;
pub use proto::BesselNorm;

/// One second-order section `[b0, b1, b2, a0, a1, a2]` (a row of SciPy's `sos`, `a0 = 1`).
pub type Section = [f64; 6];

/// The highest order designed; a specification that needs more is refused (its filter
/// would be too long for a PLC scan, and the numbers stop meaning much).
pub const MAX_ORDER: usize = 32;

/// A filter as zeros, poles and gain.
#[derive(Clone, Debug, PartialEq)]
pub struct Zpk {
    pub z: Vec<Complex64>,
    pub p: Vec<Complex64>,
    pub k: f64,
}

/// The analog prototype a design starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    Butterworth,
    /// Chebyshev type I: equiripple passband.
    Chebyshev1,
    /// Chebyshev type II (inverse Chebyshev): equiripple stopband.
    Chebyshev2,
    /// Elliptic (Cauer): equiripple in both bands.
    Elliptic,
    Bessel(BesselNorm),
}

impl Family {
    pub fn name(self) -> &'static str {
        match self {
            Family::Butterworth => "butterworth",
            Family::Chebyshev1 => "chebyshev",
            Family::Chebyshev2 => "chebyshev2",
            Family::Elliptic => "elliptic",
            Family::Bessel(_) => "bessel",
        }
    }
}

/// Which frequencies a filter passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Band {
    Lowpass,
    Highpass,
    Bandpass,
    Bandstop,
}

impl Band {
    pub fn name(self) -> &'static str {
        match self {
            Band::Lowpass => "lowpass",
            Band::Highpass => "highpass",
            Band::Bandpass => "bandpass",
            Band::Bandstop => "bandstop",
        }
    }
    /// How many critical frequencies the band takes (1 or 2).
    pub fn edges(self) -> usize {
        match self {
            Band::Lowpass | Band::Highpass => 1,
            Band::Bandpass | Band::Bandstop => 2,
        }
    }
}

impl fmt::Display for Band {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Why a filter cannot be designed; the message says which limit is broken.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DesignError {
    #[error("{what} = {value} Hz must be above 0 and below the Nyquist frequency {nyquist} Hz (half the sampling rate {fs} Hz)")]
    OutsideNyquist {
        what: String,
        value: f64,
        nyquist: f64,
        fs: f64,
    },
    #[error("{0}")]
    Edges(String),
    #[error("{0}")]
    Tolerance(String),
    #[error("the specification needs order {order}, above the limit of {max}; widen the transition band or relax the tolerances", max = MAX_ORDER)]
    OrderTooHigh { order: usize },
    #[error("no Bessel filter up to order {max} meets these tolerances (its attenuation grows slowly: about 3 dB × (f/f₃dB)² at most); widen the transition band, relax the tolerances or choose butterworth", max = MAX_ORDER)]
    BesselUnreachable,
    #[error("order {0} is not between 1 and {max}", max = MAX_ORDER)]
    BadOrder(usize),
    #[error("{0}")]
    Numerical(String),
}

/// A designed IIR filter.
#[derive(Clone, Debug, PartialEq)]
pub struct Design {
    pub family: Family,
    pub band: Band,
    pub order: usize,
    /// The critical frequencies handed to `iirfilter`, in Hz.
    pub wn: Vec<f64>,
    pub sos: Vec<Section>,
}

fn check_frequency(what: &str, value: f64, fs: f64) -> Result<(), DesignError> {
    if value > 0.0 && value < fs / 2.0 {
        Ok(())
    } else {
        Err(DesignError::OutsideNyquist {
            what: what.to_string(),
            value,
            nyquist: fs / 2.0,
            fs,
        })
    }
}

fn check_fs(fs: f64) -> Result<(), DesignError> {
    if fs.is_finite() && fs > 0.0 {
        Ok(())
    } else {
        Err(DesignError::Numerical(format!(
            "the sampling rate {fs} Hz must be a positive number"
        )))
    }
}

/// `scipy.signal.iirdesign(wp, ws, gpass, gstop, ftype=…, output='sos', fs=fs)`: the lowest
/// order meeting the tolerances (see [`order`]) and its sections. `wp` and `ws` hold one edge
/// each (lowpass: `wp < ws`; highpass: `wp > ws`) or two (bandpass: the passband inside the
/// stopband edges; bandstop: the stopband inside the passband edges). A Bessel design uses
/// the −3 dB normalisation whatever `norm` says.
pub fn iirdesign(
    wp: &[f64],
    ws: &[f64],
    gpass: f64,
    gstop: f64,
    family: Family,
    fs: f64,
) -> Result<Design, DesignError> {
    check_fs(fs)?;
    if !(gpass.is_finite() && gpass > 0.0) {
        return Err(DesignError::Tolerance(format!(
            "the passband tolerance {gpass} dB must be above 0"
        )));
    }
    if !(gstop.is_finite() && gstop > 0.0) {
        return Err(DesignError::Tolerance(format!(
            "the stopband tolerance {gstop} dB must be above 0"
        )));
    }
    if gpass >= gstop {
        return Err(DesignError::Tolerance(format!(
            "the passband tolerance {gpass} dB must be below the stopband tolerance {gstop} dB"
        )));
    }
    if wp.len() != ws.len() || !(1..=2).contains(&wp.len()) {
        return Err(DesignError::Edges(
            "give one passband and one stopband edge, or two of each".into(),
        ));
    }
    for (i, &w) in wp.iter().enumerate() {
        check_frequency(&format!("passband edge {}", i + 1), w, fs)?;
    }
    for (i, &w) in ws.iter().enumerate() {
        check_frequency(&format!("stopband edge {}", i + 1), w, fs)?;
    }
    let band = if wp.len() == 1 {
        if wp[0] == ws[0] {
            return Err(DesignError::Edges(format!(
                "the passband and stopband edges are both {} Hz; a filter needs a transition band",
                wp[0]
            )));
        }
        if wp[0] < ws[0] {
            Band::Lowpass
        } else {
            Band::Highpass
        }
    } else if ws[0] < wp[0] && wp[0] < wp[1] && wp[1] < ws[1] {
        Band::Bandpass
    } else if wp[0] < ws[0] && ws[0] < ws[1] && ws[1] < wp[1] {
        Band::Bandstop
    } else {
        return Err(DesignError::Edges(format!(
            "the passband {:?} Hz must lie strictly inside the stopband {:?} Hz (bandpass) or the \
             stopband strictly inside the passband (bandstop)",
            wp, ws
        )));
    };
    let family = match family {
        Family::Bessel(_) => Family::Bessel(BesselNorm::Mag),
        f => f,
    };
    let (n, wn) = order(family, wp, ws, gpass, gstop, fs)?;
    let sos = iirfilter(n, &wn, Some(gpass), Some(gstop), band, family, fs)?;
    Ok(Design {
        family,
        band,
        order: n,
        wn,
        sos,
    })
}

/// `scipy.signal.iirfilter(n, wn, rp, rs, btype, ftype, output='sos', fs=fs)`: `wn` in Hz,
/// one frequency (lowpass, highpass) or two (bandpass, bandstop); `rp` the passband ripple
/// (Chebyshev I, elliptic) and `rs` the stopband attenuation (Chebyshev II, elliptic) in dB.
pub fn iirfilter(
    n: usize,
    wn: &[f64],
    rp: Option<f64>,
    rs: Option<f64>,
    band: Band,
    family: Family,
    fs: f64,
) -> Result<Vec<Section>, DesignError> {
    sos::zpk2sos(&iirfilter_zpk(n, wn, rp, rs, band, family, fs)?)
}

/// [`iirfilter`] as zeros, poles and gain.
pub fn iirfilter_zpk(
    n: usize,
    wn: &[f64],
    rp: Option<f64>,
    rs: Option<f64>,
    band: Band,
    family: Family,
    fs: f64,
) -> Result<Zpk, DesignError> {
    check_fs(fs)?;
    if n == 0 || n > MAX_ORDER {
        return Err(DesignError::BadOrder(n));
    }
    if wn.len() != band.edges() {
        return Err(DesignError::Edges(format!(
            "a {band} filter takes {} critical frequenc{}",
            band.edges(),
            if band.edges() == 1 { "y" } else { "ies" }
        )));
    }
    for (i, &w) in wn.iter().enumerate() {
        check_frequency(&format!("critical frequency {}", i + 1), w, fs)?;
    }
    if wn.len() == 2 && wn[0] >= wn[1] {
        return Err(DesignError::Edges(format!(
            "the critical frequencies {} Hz and {} Hz must increase",
            wn[0], wn[1]
        )));
    }
    let need = |what: &str, v: Option<f64>| -> Result<f64, DesignError> {
        match v {
            Some(v) if v > 0.0 && v.is_finite() => Ok(v),
            _ => Err(DesignError::Tolerance(format!(
                "a {} filter needs its {what} in dB, above 0",
                family.name()
            ))),
        }
    };
    let proto = match family {
        Family::Butterworth => proto::buttap(n),
        Family::Chebyshev1 => proto::cheb1ap(n, need("passband ripple", rp)?),
        Family::Chebyshev2 => proto::cheb2ap(n, need("stopband attenuation", rs)?),
        Family::Elliptic => proto::ellipap(
            n,
            need("passband ripple", rp)?,
            need("stopband attenuation", rs)?,
        )?,
        Family::Bessel(norm) => proto::besselap(n, norm)?,
    };
    // SciPy normalises to Nyquist, then prewarps with fs = 2.
    let warped: Vec<f64> = wn
        .iter()
        .map(|&w| w / (fs / 2.0))
        .map(|w| 2.0 * 2.0 * (PI * w / 2.0).tan())
        .collect();
    let analog = match band {
        Band::Lowpass => proto.lp2lp(warped[0]),
        Band::Highpass => proto.lp2hp(warped[0]),
        Band::Bandpass | Band::Bandstop => {
            let bw = warped[1] - warped[0];
            let wo = (warped[0] * warped[1]).sqrt();
            if band == Band::Bandpass {
                proto.lp2bp(wo, bw)
            } else {
                proto.lp2bs(wo, bw)
            }
        }
    };
    Ok(analog.bilinear(2.0))
}

/// `scipy.signal.zpk2sos(z, p, k)` for a digital filter.
pub fn zpk2sos(zpk: &Zpk) -> Result<Vec<Section>, DesignError> {
    sos::zpk2sos(zpk)
}
