//! Windowed-sinc FIR design: `scipy.signal.firwin` with the symmetric windows of
//! `scipy.signal.get_window(..., fftbins=False)`.

use std::f64::consts::PI;

use super::{Band, DesignError};

/// A window for [`firwin`] (SciPy's names; `rectangular` is `boxcar`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Window {
    Boxcar,
    Triang,
    Bartlett,
    Hann,
    Hamming,
    Blackman,
    Kaiser(f64),
}

impl Window {
    /// A window by SciPy's name; Kaiser takes its β separately.
    pub fn parse(name: &str) -> Option<Window> {
        Some(match name {
            "boxcar" | "rectangular" | "rect" => Window::Boxcar,
            "triang" | "triangle" => Window::Triang,
            "bartlett" => Window::Bartlett,
            "hann" | "hanning" => Window::Hann,
            "hamming" => Window::Hamming,
            "blackman" => Window::Blackman,
            _ => return None,
        })
    }

    pub fn name(self) -> String {
        match self {
            Window::Boxcar => "boxcar".into(),
            Window::Triang => "triang".into(),
            Window::Bartlett => "bartlett".into(),
            Window::Hann => "hann".into(),
            Window::Hamming => "hamming".into(),
            Window::Blackman => "blackman".into(),
            Window::Kaiser(beta) => format!("kaiser {beta}"),
        }
    }

    /// The `m` symmetric window values.
    pub fn values(self, m: usize) -> Vec<f64> {
        if m <= 1 {
            return vec![1.0; m];
        }
        let cosine = |a: &[f64]| -> Vec<f64> {
            // numpy.linspace(-π, π, m): i·step + start, the last exactly π.
            let step = (2.0 * PI) / (m - 1) as f64;
            (0..m)
                .map(|i| {
                    let fac = if i == m - 1 { PI } else { i as f64 * step - PI };
                    a.iter()
                        .enumerate()
                        .fold(0.0, |w, (k, &ak)| w + ak * (k as f64 * fac).cos())
                })
                .collect()
        };
        match self {
            Window::Boxcar => vec![1.0; m],
            Window::Triang => {
                let half: Vec<f64> = (1..=m.div_ceil(2))
                    .map(|n| {
                        let n = n as f64;
                        if m % 2 == 0 {
                            (2.0 * n - 1.0) / m as f64
                        } else {
                            2.0 * n / (m as f64 + 1.0)
                        }
                    })
                    .collect();
                let mirror = if m % 2 == 0 {
                    half.len()
                } else {
                    half.len() - 1
                };
                let mut w = half.clone();
                w.extend(half[..mirror].iter().rev());
                w
            }
            Window::Bartlett => (0..m)
                .map(|n| {
                    let (n, d) = (n as f64, (m - 1) as f64);
                    if n <= d / 2.0 {
                        2.0 * n / d
                    } else {
                        2.0 - 2.0 * n / d
                    }
                })
                .collect(),
            Window::Hann => cosine(&[0.5, 0.5]),
            Window::Hamming => cosine(&[0.54, 1.0 - 0.54]),
            Window::Blackman => cosine(&[0.42, 0.50, 0.08]),
            Window::Kaiser(beta) => {
                let alpha = (m - 1) as f64 / 2.0;
                (0..m)
                    .map(|n| {
                        let r = (n as f64 - alpha) / alpha;
                        bessel_i0(beta * (1.0 - r * r).max(0.0).sqrt()) / bessel_i0(beta)
                    })
                    .collect()
            }
        }
    }
}

/// The modified Bessel function of the first kind and order zero, by its power series
/// (converges for every argument; the terms are all positive, so it is accurate to rounding).
fn bessel_i0(x: f64) -> f64 {
    let q = x * x / 4.0;
    let mut term = 1.0;
    let mut sum = 1.0;
    for k in 1..500 {
        term *= q / (k * k) as f64;
        sum += term;
        if term <= sum * 1e-17 {
            break;
        }
    }
    sum
}

/// The normalised sinc `sin(πx)/(πx)`.
fn sinc(x: f64) -> f64 {
    let y = PI * if x == 0.0 { 1.0e-20 } else { x };
    y.sin() / y
}

/// `scipy.signal.firwin(numtaps, cutoff, window=window, pass_zero=band, fs=fs)`: the taps of
/// a linear-phase FIR filter, scaled to gain 1 at DC (lowpass, bandstop), Nyquist (highpass)
/// or the passband's centre (bandpass). `cutoff` holds one frequency (lowpass, highpass) or
/// two (bandpass, bandstop) in Hz.
pub fn firwin(
    numtaps: usize,
    cutoff: &[f64],
    window: Window,
    band: Band,
    fs: f64,
) -> Result<Vec<f64>, DesignError> {
    if !(fs.is_finite() && fs > 0.0) {
        return Err(DesignError::Numerical(format!(
            "the sampling rate {fs} Hz must be a positive number"
        )));
    }
    if numtaps == 0 {
        return Err(DesignError::Edges(
            "a FIR filter needs at least one tap".into(),
        ));
    }
    if cutoff.len() != band.edges() {
        return Err(DesignError::Edges(format!(
            "a {band} FIR filter takes {} cut-off frequenc{}",
            band.edges(),
            if band.edges() == 1 { "y" } else { "ies" }
        )));
    }
    let nyq = 0.5 * fs;
    for (i, &c) in cutoff.iter().enumerate() {
        if !(c > 0.0 && c < nyq) {
            return Err(DesignError::OutsideNyquist {
                what: format!("cut-off frequency {}", i + 1),
                value: c,
                nyquist: nyq,
                fs,
            });
        }
    }
    if cutoff.len() == 2 && cutoff[0] >= cutoff[1] {
        return Err(DesignError::Edges(format!(
            "the cut-off frequencies {} Hz and {} Hz must increase",
            cutoff[0], cutoff[1]
        )));
    }
    let pass_zero = matches!(band, Band::Lowpass | Band::Bandstop);
    let pass_nyquist = (cutoff.len() % 2 == 0) == pass_zero;
    if pass_nyquist && numtaps % 2 == 0 {
        return Err(DesignError::Edges(format!(
            "a {band} FIR filter passes the Nyquist frequency, so it needs an odd number of taps \
             (not {numtaps})"
        )));
    }
    let mut edges: Vec<f64> = Vec::new();
    if pass_zero {
        edges.push(0.0);
    }
    edges.extend(cutoff.iter().map(|&c| c / nyq));
    if pass_nyquist {
        edges.push(1.0);
    }
    let alpha = 0.5 * (numtaps as f64 - 1.0);
    let m: Vec<f64> = (0..numtaps).map(|i| i as f64 - alpha).collect();
    let mut h = vec![0.0; numtaps];
    for pair in edges.chunks(2) {
        let (left, right) = (pair[0], pair[1]);
        for (hi, &mi) in h.iter_mut().zip(&m) {
            *hi += right * sinc(right * mi);
            *hi -= left * sinc(left * mi);
        }
    }
    for (hi, wi) in h.iter_mut().zip(window.values(numtaps)) {
        *hi *= wi;
    }
    let (left, right) = (edges[0], edges[1]);
    let scale_frequency = if left == 0.0 {
        0.0
    } else if right == 1.0 {
        1.0
    } else {
        0.5 * (left + right)
    };
    let s: f64 = h
        .iter()
        .zip(&m)
        .map(|(hi, mi)| hi * (PI * mi * scale_frequency).cos())
        .sum();
    for hi in &mut h {
        *hi /= s;
    }
    Ok(h)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn windows_are_symmetric_with_scipy_shapes() {
        assert_eq!(Window::Triang.values(4), vec![0.25, 0.75, 0.75, 0.25]);
        assert_eq!(
            Window::Triang.values(5),
            vec![1.0 / 3.0, 2.0 / 3.0, 1.0, 2.0 / 3.0, 1.0 / 3.0]
        );
        assert_eq!(Window::Bartlett.values(5), vec![0.0, 0.5, 1.0, 0.5, 0.0]);
        let h = Window::Hann.values(5);
        assert!((h[0]).abs() < 1e-16 && (h[2] - 1.0).abs() < 1e-16 && (h[1] - 0.5).abs() < 1e-15);
        assert!((bessel_i0(1.0) - 1.266_065_877_752_008_4).abs() < 1e-15);
    }
}
