//! The lowest order that meets a tolerance specification, and the critical frequencies that
//! go with it: SciPy's `buttord`, `cheb1ord`, `cheb2ord` and `ellipord` step by step
//! (including the bounded Brent minimisation `fminbound` that places a band-stop filter's
//! passband edges), and a search for Bessel filters, which have no closed-form order.

use std::f64::consts::PI;

use super::proto::{besselap, pow10m1, BesselNorm};
use super::special::{ellipk, ellipkm1};
use super::{Band, DesignError, Family, MAX_ORDER};

/// Which order formula `band_stop_obj` evaluates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Formula {
    Butter,
    Cheby,
    Ellip,
}

impl Family {
    fn formula(self) -> Formula {
        match self {
            Family::Butterworth | Family::Bessel(_) => Formula::Butter,
            Family::Chebyshev1 | Family::Chebyshev2 => Formula::Cheby,
            Family::Elliptic => Formula::Ellip,
        }
    }
}

/// The order (not rounded) a stopband-to-passband ratio `nat` needs with `formula`.
fn order_for(formula: Formula, nat: f64, gpass: f64, gstop: f64) -> f64 {
    match formula {
        Formula::Butter => {
            let gs = 10f64.powf(0.1 * gstop.abs());
            let gp = 10f64.powf(0.1 * gpass.abs());
            ((gs - 1.0) / (gp - 1.0)).log10() / (2.0 * nat.log10())
        }
        Formula::Cheby => {
            let gs = 10f64.powf(0.1 * gstop.abs());
            let gp = 10f64.powf(0.1 * gpass.abs());
            ((gs - 1.0) / (gp - 1.0)).sqrt().acosh() / nat.acosh()
        }
        Formula::Ellip => {
            let gs = 10f64.powf(0.1 * gstop);
            let gp = 10f64.powf(0.1 * gpass);
            let arg1 = ((gp - 1.0) / (gs - 1.0)).sqrt();
            let arg0 = 1.0 / nat;
            let d0 = [ellipk(arg0 * arg0), ellipk(1.0 - arg0 * arg0)];
            let d1 = [ellipk(arg1 * arg1), ellipk(1.0 - arg1 * arg1)];
            d0[0] * d1[1] / (d0[1] * d1[0])
        }
    }
}

/// The ratio of the band-stop transform for passband edges `p` and stopband edges `s`.
fn stop_nat(p: [f64; 2], s: [f64; 2]) -> [f64; 2] {
    s.map(|s| s * (p[0] - p[1]) / (s * s - p[0] * p[1]))
}

fn min_abs(v: [f64; 2]) -> f64 {
    v[0].abs().min(v[1].abs())
}

/// SciPy's `band_stop_obj`: the order needed when passband edge `ind` moves to `wp`.
fn band_stop_obj(
    wp: f64,
    ind: usize,
    passb: [f64; 2],
    stopb: [f64; 2],
    gpass: f64,
    gstop: f64,
    formula: Formula,
) -> f64 {
    let mut p = passb;
    p[ind] = wp;
    order_for(formula, min_abs(stop_nat(p, stopb)), gpass, gstop)
}

/// `scipy.optimize.fminbound(f, x1, x2)` (xtol 1e-5, 500 evaluations): Brent's bounded
/// minimisation by golden sections and parabolic steps, followed step for step so that it
/// stops at the same point.
pub(crate) fn fminbound(f: impl Fn(f64) -> f64, x1: f64, x2: f64) -> f64 {
    let xatol = 1e-5;
    let maxfun = 500;
    let sqrt_eps = 2.2e-16f64.sqrt();
    let golden_mean = 0.5 * (3.0 - 5f64.sqrt());
    let (mut a, mut b) = (x1, x2);
    let mut fulc = a + golden_mean * (b - a);
    let (mut nfc, mut xf) = (fulc, fulc);
    let mut rat: f64 = 0.0;
    let mut e: f64 = 0.0;
    let mut fx = f(xf);
    let mut num = 1;
    let (mut ffulc, mut fnfc) = (fx, fx);
    let mut xm = 0.5 * (a + b);
    let mut tol1 = sqrt_eps * xf.abs() + xatol / 3.0;
    let mut tol2 = 2.0 * tol1;
    let sign = |v: f64| {
        if v > 0.0 {
            1.0
        } else if v < 0.0 {
            -1.0
        } else {
            0.0
        }
    };
    while (xf - xm).abs() > tol2 - 0.5 * (b - a) {
        let mut golden = true;
        if e.abs() > tol1 {
            golden = false;
            let mut r = (xf - nfc) * (fx - ffulc);
            let mut q = (xf - fulc) * (fx - fnfc);
            let mut p = (xf - fulc) * q - (xf - nfc) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            r = e;
            e = rat;
            if p.abs() < (0.5 * q * r).abs() && p > q * (a - xf) && p < q * (b - xf) {
                rat = (p + 0.0) / q;
                let x = xf + rat;
                if (x - a) < tol2 || (b - x) < tol2 {
                    let si = sign(xm - xf) + if xm - xf == 0.0 { 1.0 } else { 0.0 };
                    rat = tol1 * si;
                }
            } else {
                golden = true;
            }
        }
        if golden {
            e = if xf >= xm { a - xf } else { b - xf };
            rat = golden_mean * e;
        }
        let si = sign(rat) + if rat == 0.0 { 1.0 } else { 0.0 };
        let x = xf + si * rat.abs().max(tol1);
        let fu = f(x);
        num += 1;
        if fu <= fx {
            if x >= xf {
                a = xf;
            } else {
                b = xf;
            }
            fulc = nfc;
            ffulc = fnfc;
            nfc = xf;
            fnfc = fx;
            xf = x;
            fx = fu;
        } else {
            if x < xf {
                a = x;
            } else {
                b = x;
            }
            if fu <= fnfc || nfc == xf {
                fulc = nfc;
                ffulc = fnfc;
                nfc = x;
                fnfc = fu;
            } else if fu <= ffulc || fulc == xf || fulc == nfc {
                fulc = x;
                ffulc = fu;
            }
        }
        xm = 0.5 * (a + b);
        tol1 = sqrt_eps * xf.abs() + xatol / 3.0;
        tol2 = 2.0 * tol1;
        if num >= maxfun {
            break;
        }
    }
    xf
}

/// Band edges normalised to Nyquist (SciPy's `_validate_wp_ws` with `fs`), prewarped for the
/// bilinear transform (`_pre_warp`).
#[derive(Clone, Debug)]
struct Edges {
    passb: Vec<f64>,
    stopb: Vec<f64>,
    band: Band,
}

fn edges(wp: &[f64], ws: &[f64], fs: f64) -> Edges {
    let norm = |v: &[f64]| -> Vec<f64> { v.iter().map(|&w| 2.0 * w / fs).collect() };
    let (wp, ws) = (norm(wp), norm(ws));
    let band = match (wp.len(), wp[0] >= ws[0]) {
        (1, false) => Band::Lowpass,
        (1, true) => Band::Highpass,
        (_, false) => Band::Bandstop,
        (_, true) => Band::Bandpass,
    };
    let warp = |v: &[f64]| -> Vec<f64> { v.iter().map(|&w| (PI * w / 2.0).tan()).collect() };
    Edges {
        passb: warp(&wp),
        stopb: warp(&ws),
        band,
    }
}

/// SciPy's `_find_nat_freq`: the stopband-to-passband ratio of the equivalent lowpass, and the
/// passband edges (moved by `fminbound` for a band-stop filter).
fn nat_freq(e: &Edges, gpass: f64, gstop: f64, formula: Formula) -> (f64, Vec<f64>) {
    match e.band {
        Band::Lowpass => (min_abs([e.stopb[0] / e.passb[0]; 2]), e.passb.clone()),
        Band::Highpass => (min_abs([e.passb[0] / e.stopb[0]; 2]), e.passb.clone()),
        Band::Bandstop => {
            let passb = [e.passb[0], e.passb[1]];
            let stopb = [e.stopb[0], e.stopb[1]];
            let obj = |ind: usize| {
                move |wp: f64| band_stop_obj(wp, ind, passb, stopb, gpass, gstop, formula)
            };
            let wp0 = fminbound(obj(0), passb[0], stopb[0] - 1e-12);
            let wp1 = fminbound(obj(1), stopb[1] + 1e-12, passb[1]);
            let p = [wp0, wp1];
            (min_abs(stop_nat(p, stopb)), p.to_vec())
        }
        Band::Bandpass => {
            let p = &e.passb;
            let nat = e
                .stopb
                .iter()
                .map(|&s| (s * s - p[0] * p[1]) / (s * (p[0] - p[1])))
                .fold(f64::INFINITY, |m, v| m.min(v.abs()));
            (nat, e.passb.clone())
        }
    }
}

/// Back from prewarped, Nyquist-normalised frequencies to Hz (SciPy's `_postprocess_wn`).
fn postprocess(wn: &[f64], fs: f64) -> Vec<f64> {
    wn.iter()
        .map(|&w| w.atan() * 2.0 / PI)
        .map(|w| w * fs / 2.0)
        .collect()
}

/// The critical frequencies (prewarped) of a filter whose prototype meets the passband
/// tolerance exactly at `1 / w0` rad/s (SciPy's `buttord` after its order).
fn natural(band: Band, passb: &[f64], w0: f64) -> Vec<f64> {
    match band {
        Band::Lowpass => vec![w0 * passb[0]],
        Band::Highpass => vec![passb[0] / w0],
        Band::Bandstop => {
            let d = passb[1] - passb[0];
            let discr = (d * d + 4.0 * w0 * w0 * passb[0] * passb[1]).sqrt();
            let mut wn = [
                ((d + discr) / (2.0 * w0)).abs(),
                ((d - discr) / (2.0 * w0)).abs(),
            ];
            wn.sort_by(f64::total_cmp);
            wn.to_vec()
        }
        Band::Bandpass => {
            let d = passb[1] - passb[0];
            let mut wn = [-w0, w0]
                .map(|w| -w * d / 2.0 + (w * w / 4.0 * (d * d) + passb[0] * passb[1]).sqrt())
                .map(f64::abs);
            wn.sort_by(f64::total_cmp);
            wn.to_vec()
        }
    }
}

/// A rounded-up order, refused when it is not a usable number.
fn ceil_order(n: f64) -> Result<usize, DesignError> {
    let n = n.ceil();
    if !n.is_finite() || n < 1.0 {
        return Err(DesignError::Numerical(format!(
            "the order formula gives {n}; check the tolerances and band edges"
        )));
    }
    if n > MAX_ORDER as f64 {
        return Err(DesignError::OrderTooHigh {
            order: if n < 1e9 { n as usize } else { usize::MAX },
        });
    }
    Ok(n as usize)
}

/// The attenuation in dB of a Bessel prototype (−3 dB at 1 rad/s) at `w` rad/s.
fn bessel_attenuation(p: &[num_complex::Complex64], k: f64, w: f64) -> f64 {
    let den: num_complex::Complex64 = p
        .iter()
        .map(|&pi| num_complex::Complex64::new(0.0, w) - pi)
        .product();
    -20.0 * (k / den.norm()).log10()
}

/// The frequency at which an increasing function first reaches `target`, by bisection to
/// the last bit.
fn bisect(f: impl Fn(f64) -> f64, target: f64) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while f(hi) < target && hi < 1e6 {
        lo = hi;
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if f(mid) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// The order and critical frequencies (Hz) for a tolerance specification: `wp` and `ws` are
/// the passband and stopband edges in Hz (one each, or two for band filters), `gpass` the
/// most attenuation allowed in the passband and `gstop` the least required in the stopband,
/// in dB. Butterworth, Chebyshev and elliptic follow SciPy's `*ord` functions; a Bessel
/// filter (`norm` must be `Mag`) gets the lowest order whose −3 dB-normalised prototype,
/// placed so that the passband edge is attenuated exactly `gpass`, attenuates the nearest
/// stopband edge at least `gstop`.
pub fn order(
    family: Family,
    wp: &[f64],
    ws: &[f64],
    gpass: f64,
    gstop: f64,
    fs: f64,
) -> Result<(usize, Vec<f64>), DesignError> {
    let e = edges(wp, ws, fs);
    let (nat, passb) = nat_freq(&e, gpass, gstop, family.formula());
    match family {
        Family::Butterworth => {
            let n = ceil_order(order_for(Formula::Butter, nat, gpass, gstop))?;
            let gp = 10f64.powf(0.1 * gpass.abs());
            let w0 = (gp - 1.0).powf(-1.0 / (2.0 * n as f64));
            Ok((n, postprocess(&natural(e.band, &passb, w0), fs)))
        }
        Family::Chebyshev1 => {
            let n = ceil_order(order_for(Formula::Cheby, nat, gpass, gstop))?;
            Ok((n, postprocess(&passb, fs)))
        }
        Family::Chebyshev2 => {
            let n = ceil_order(order_for(Formula::Cheby, nat, gpass, gstop))?;
            Ok((
                n,
                postprocess(&cheb2_natural(&e, &passb, n, gpass, gstop), fs),
            ))
        }
        Family::Elliptic => {
            let arg1_sq = pow10m1(0.1 * gpass) / pow10m1(0.1 * gstop);
            let arg0 = 1.0 / nat;
            let d0 = [ellipk(arg0 * arg0), ellipkm1(arg0 * arg0)];
            let d1 = [ellipk(arg1_sq), ellipkm1(arg1_sq)];
            let n = ceil_order(d0[0] * d1[1] / (d0[1] * d1[0]))?;
            Ok((n, postprocess(&passb, fs)))
        }
        Family::Bessel(norm) => {
            if norm != BesselNorm::Mag {
                return Err(DesignError::Numerical(
                    "a Bessel order search needs the −3 dB (mag) normalisation".into(),
                ));
            }
            for n in 1..=MAX_ORDER {
                let proto = besselap(n, BesselNorm::Mag)?;
                let att = |w: f64| bessel_attenuation(&proto.p, proto.k, w);
                let w_pass = bisect(att, gpass);
                if att(w_pass * nat) >= gstop {
                    return Ok((n, postprocess(&natural(e.band, &passb, 1.0 / w_pass), fs)));
                }
            }
            Err(DesignError::BesselUnreachable)
        }
    }
}

/// SciPy's `cheb2ord` after its order: the frequencies where the stopband attenuation starts.
fn cheb2_natural(e: &Edges, passb: &[f64], n: usize, gpass: f64, gstop: f64) -> Vec<f64> {
    let gs = 10f64.powf(0.1 * gstop.abs());
    let gp = 10f64.powf(0.1 * gpass.abs());
    let v_pass_stop = ((gs - 1.0) / (gp - 1.0)).sqrt().acosh();
    let new_freq = 1.0 / (1.0 / n as f64 * v_pass_stop).cosh();
    match e.band {
        Band::Lowpass => vec![passb[0] / new_freq],
        Band::Highpass => vec![passb[0] * new_freq],
        Band::Bandstop => {
            let d = passb[1] - passb[0];
            let nat0 = new_freq / 2.0 * (passb[0] - passb[1])
                + (new_freq * new_freq * (d * d) / 4.0 + passb[1] * passb[0]).sqrt();
            vec![nat0, passb[1] * passb[0] / nat0]
        }
        Band::Bandpass => {
            let d = passb[1] - passb[0];
            let nat0 = 1.0 / (2.0 * new_freq) * (passb[0] - passb[1])
                + ((d * d) / (4.0 * (new_freq * new_freq)) + passb[1] * passb[0]).sqrt();
            vec![nat0, passb[0] * passb[1] / nat0]
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fminbound_finds_a_parabola_minimum() {
        let x = fminbound(|x| (x - 0.3) * (x - 0.3), 0.0, 1.0);
        assert!((x - 0.3).abs() < 1e-5, "{x}");
    }
}
