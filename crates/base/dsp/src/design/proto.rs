//! Analog lowpass prototypes (cut-off 1 rad/s) as zeros, poles and gain, computed the way
//! `scipy.signal`'s `buttap`, `cheb1ap`, `cheb2ap`, `ellipap` and `besselap` compute them.

use std::f64::consts::PI;

use num_complex::Complex64 as C;

use super::special::{ellipj, ellipk, ellipkm1};
use super::{DesignError, Zpk};

/// SciPy's threshold below which an elliptic zero or pole's part is taken as zero.
const EPSILON: f64 = 2e-16;

/// `10^x − 1` without cancellation for small `x`.
pub(crate) fn pow10m1(x: f64) -> f64 {
    (std::f64::consts::LN_10 * x).exp_m1()
}

/// `-N+1, -N+3, …, N-1`.
fn odd_steps(n: usize) -> impl Iterator<Item = f64> {
    let n = n as i64;
    (0..n).map(move |i| (-n + 1 + 2 * i) as f64)
}

fn prod(values: &[C]) -> C {
    values.iter().fold(C::new(1.0, 0.0), |acc, &v| acc * v)
}

/// Butterworth: poles evenly on the left unit half-circle, the middle one exactly real.
pub fn buttap(n: usize) -> Zpk {
    let p = odd_steps(n)
        .map(|m| -C::new(0.0, PI * m / (2.0 * n as f64)).exp())
        .collect();
    Zpk {
        z: Vec::new(),
        p,
        k: 1.0,
    }
}

/// Chebyshev type I with `rp` dB of passband ripple; an even order has −`rp` dB at DC.
pub fn cheb1ap(n: usize, rp: f64) -> Zpk {
    if n == 0 {
        return Zpk {
            z: Vec::new(),
            p: Vec::new(),
            k: 10f64.powf(-rp / 20.0),
        };
    }
    let eps = (10f64.powf(0.1 * rp) - 1.0).sqrt();
    let mu = 1.0 / n as f64 * (1.0 / eps).asinh();
    let p: Vec<C> = odd_steps(n)
        .map(|m| {
            let theta = PI * m / (2.0 * n as f64);
            -C::new(mu, theta).sinh()
        })
        .collect();
    let minus: Vec<C> = p.iter().map(|&v| -v).collect();
    let mut k = prod(&minus).re;
    if n % 2 == 0 {
        k /= (1.0 + eps * eps).sqrt();
    }
    Zpk {
        z: Vec::new(),
        p,
        k,
    }
}

/// Chebyshev type II with `rs` dB of stopband attenuation.
pub fn cheb2ap(n: usize, rs: f64) -> Zpk {
    if n == 0 {
        return Zpk {
            z: Vec::new(),
            p: Vec::new(),
            k: 1.0,
        };
    }
    let de = 1.0 / (10f64.powf(0.1 * rs) - 1.0).sqrt();
    let mu = (1.0 / de).asinh() / n as f64;
    let nn = n as i64;
    let m: Vec<f64> = if n % 2 == 1 {
        (0..nn)
            .map(|i| -nn + 1 + 2 * i)
            .filter(|&m| m != 0)
            .map(|m| m as f64)
            .collect()
    } else {
        odd_steps(n).collect()
    };
    let z: Vec<C> = m
        .iter()
        .map(|&m| C::new(0.0, 1.0) / (m * PI / (2.0 * n as f64)).sin())
        .collect();
    let p: Vec<C> = odd_steps(n)
        .map(|m1| {
            let theta1 = PI * m1 / (2.0 * n as f64);
            -C::new(1.0, 0.0) / C::new(mu, theta1).sinh()
        })
        .collect();
    let minus_p: Vec<C> = p.iter().map(|&v| -v).collect();
    let minus_z: Vec<C> = z.iter().map(|&v| -v).collect();
    let k = (prod(&minus_p) / prod(&minus_z)).re;
    Zpk { z, p, k }
}

/// The degree equation of elliptic filters: the modulus `m` of order `n` for `m1`, by its
/// nome series (seven terms, as SciPy's `_ellipdeg`).
fn ellipdeg(n: usize, m1: f64) -> f64 {
    const MMAX: i32 = 7;
    let k1 = ellipk(m1);
    let k1p = ellipkm1(m1);
    let q1 = (-PI * k1p / k1).exp();
    let q = q1.powf(1.0 / n as f64);
    let num: f64 = (0..=MMAX).map(|m| q.powf(f64::from(m * (m + 1)))).sum();
    let den = 1.0
        + 2.0
            * (1..=MMAX + 1)
                .map(|m| q.powf(f64::from(m * m)))
                .sum::<f64>();
    16.0 * q * (num / den).powi(4)
}

/// The imaginary part of the inverse of `sn` at the purely imaginary `i·w` for parameter `m`,
/// by the Landen recursion (SciPy's `_arc_jac_sc1` through `_arc_jac_sn`). With a purely
/// imaginary argument every step stays purely imaginary, so only imaginary parts are kept.
fn arc_jac_sc1(w: f64, m: f64) -> Result<f64, DesignError> {
    let complement = |kx: f64| ((1.0 - kx) * (1.0 + kx)).powf(0.5);
    let k = m.powf(0.5);
    if k > 1.0 || k.is_nan() {
        return Err(DesignError::Numerical("elliptic modulus above 1".into()));
    }
    if k == 1.0 {
        // arctanh(i·w) = i·atan(w).
        return Ok(w.atan());
    }
    let mut ks = vec![k];
    while *ks.last().unwrap_or(&0.0) != 0.0 {
        let kp = complement(ks[ks.len() - 1]);
        ks.push((1.0 - kp) / (1.0 + kp));
        if ks.len() > 11 {
            return Err(DesignError::Numerical(
                "the Landen transformation does not converge".into(),
            ));
        }
    }
    let big_k = ks[1..].iter().map(|&k| 1.0 + k).product::<f64>() * PI / 2.0;
    let mut wn = w;
    for pair in ks.windows(2) {
        let (kn, knext) = (pair[0], pair[1]);
        // _complement(kn·i·wn): (1 − i·x)(1 + i·x) = 1 + x², a real number.
        let x = kn * wn;
        let comp = (1.0 + x * x).powf(0.5);
        wn = 2.0 * wn / ((1.0 + knext) * (1.0 + comp));
    }
    // arcsin(i·y) = i·asinh(y).
    Ok(big_k * (2.0 / PI * wn.asinh()))
}

/// Elliptic (Cauer) with `rp` dB of passband ripple and `rs` dB of stopband attenuation; an
/// even order has −`rp` dB at DC.
pub fn ellipap(n: usize, rp: f64, rs: f64) -> Result<Zpk, DesignError> {
    if n == 0 {
        return Ok(Zpk {
            z: Vec::new(),
            p: Vec::new(),
            k: 10f64.powf(-rp / 20.0),
        });
    }
    if n == 1 {
        let p = -(1.0 / pow10m1(0.1 * rp)).sqrt();
        return Ok(Zpk {
            z: Vec::new(),
            p: vec![C::new(p, 0.0)],
            k: -p,
        });
    }
    let eps_sq = pow10m1(0.1 * rp);
    let eps = eps_sq.sqrt();
    let ck1_sq = eps_sq / pow10m1(0.1 * rs);
    if ck1_sq == 0.0 {
        return Err(DesignError::Numerical(
            "the passband and stopband tolerances are too far apart for an elliptic design".into(),
        ));
    }
    let val0 = ellipk(ck1_sq);
    let m = ellipdeg(n, ck1_sq);
    let capk = ellipk(m);
    let js: Vec<f64> = ((1 - n % 2)..n).step_by(2).map(|j| j as f64).collect();
    let jac: Vec<_> = js.iter().map(|&j| ellipj(j * capk / n as f64, m)).collect();
    let mut z: Vec<C> = jac
        .iter()
        .filter(|j| j.sn.abs() > EPSILON)
        .map(|j| C::new(0.0, 1.0 / (m.sqrt() * j.sn)))
        .collect();
    let conj: Vec<C> = z.iter().map(|v| v.conj()).collect();
    z.extend(conj);

    let r = arc_jac_sc1(1.0 / eps, ck1_sq)?;
    let v0 = capk * r / (n as f64 * val0);
    let jv = ellipj(v0, 1.0 - m);
    let (sv, cv, dv) = (jv.sn, jv.cn, jv.dn);
    let mut p: Vec<C> = jac
        .iter()
        .map(|j| {
            let num = C::new(j.cn * j.dn * sv * cv, j.sn * dv);
            -num / (1.0 - (j.dn * sv).powf(2.0))
        })
        .collect();
    if n % 2 == 1 {
        let norm = p.iter().map(|v| (v * v.conj()).re).sum::<f64>().sqrt();
        let newp: Vec<C> = p
            .iter()
            .filter(|v| v.im.abs() > EPSILON * norm)
            .map(|v| v.conj())
            .collect();
        p.extend(newp);
    } else {
        let conj: Vec<C> = p.iter().map(|v| v.conj()).collect();
        p.extend(conj);
    }
    let minus_p: Vec<C> = p.iter().map(|&v| -v).collect();
    let minus_z: Vec<C> = z.iter().map(|&v| -v).collect();
    let mut k = (prod(&minus_p) / prod(&minus_z)).re;
    if n % 2 == 0 {
        k /= (1.0 + eps_sq).sqrt();
    }
    Ok(Zpk { z, p, k })
}

/// How a Bessel prototype is normalised (SciPy's `norm`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BesselNorm {
    /// The phase response's midpoint at 1 rad/s; high-frequency asymptote as Butterworth's.
    Phase,
    /// Group delay 1 s at DC.
    Delay,
    /// −3 dB at 1 rad/s.
    Mag,
}

impl BesselNorm {
    pub fn as_str(self) -> &'static str {
        match self {
            BesselNorm::Phase => "phase",
            BesselNorm::Delay => "delay",
            BesselNorm::Mag => "mag",
        }
    }
}

/// The starting points of Campos and Calderón for the zeros of the Bessel polynomial.
fn campos_zeros(n: usize) -> Vec<C> {
    if n == 1 {
        return vec![C::new(-1.0, 0.0)];
    }
    let nf = n as f64;
    // numpy.polynomial.polynomial.polyval: coefficients in increasing degree.
    let polyval = |x: f64, c: &[f64]| c.iter().rev().fold(0.0, |acc, &ci| acc * x + ci);
    let s = polyval(nf, &[0.0, 0.0, 2.0, 0.0, -3.0, 1.0]);
    let b3 = polyval(nf, &[16.0, -8.0]) / s;
    let b2 = polyval(nf, &[-24.0, -12.0, 12.0]) / s;
    let b1 = polyval(nf, &[8.0, 24.0, -12.0, -2.0]) / s;
    let b0 = polyval(nf, &[0.0, -6.0, 0.0, 5.0, -1.0]) / s;
    let r = polyval(nf, &[0.0, 0.0, 2.0, 1.0]);
    let a1 = polyval(nf, &[-6.0, -6.0]) / r;
    let a2 = 6.0 / r;
    (1..=n)
        .map(|k| {
            let k = k as f64;
            C::new(polyval(k, &[0.0, a1, a2]), polyval(k, &[b0, b1, b2, b3]))
        })
        .collect()
}

/// A double-double number `hi + lo`: about 32 significant digits, enough to evaluate the
/// Bessel polynomial near its zeros without the cancellation that limits `f64` to about
/// 1e-10 there for orders above 12.
#[derive(Clone, Copy, Debug)]
struct Dd {
    hi: f64,
    lo: f64,
}

impl Dd {
    fn new(v: f64) -> Dd {
        Dd { hi: v, lo: 0.0 }
    }
    fn quick(hi: f64, lo: f64) -> Dd {
        let s = hi + lo;
        Dd {
            hi: s,
            lo: lo - (s - hi),
        }
    }
    fn add(self, o: Dd) -> Dd {
        let s = self.hi + o.hi;
        let bb = s - self.hi;
        let e = (self.hi - (s - bb)) + (o.hi - bb);
        Dd::quick(s, e + self.lo + o.lo)
    }
    fn neg(self) -> Dd {
        Dd {
            hi: -self.hi,
            lo: -self.lo,
        }
    }
    fn mul(self, b: f64) -> Dd {
        let p = self.hi * b;
        let e = self.hi.mul_add(b, -p);
        Dd::quick(p, e + self.lo * b)
    }
}

/// A complex double-double.
#[derive(Clone, Copy, Debug)]
struct Cd {
    re: Dd,
    im: Dd,
}

impl Cd {
    fn new(v: C) -> Cd {
        Cd {
            re: Dd::new(v.re),
            im: Dd::new(v.im),
        }
    }
    fn add(self, o: Cd) -> Cd {
        Cd {
            re: self.re.add(o.re),
            im: self.im.add(o.im),
        }
    }
    /// Times a complex `f64`.
    fn mul(self, x: C) -> Cd {
        Cd {
            re: self.re.mul(x.re).add(self.im.mul(x.im).neg()),
            im: self.re.mul(x.im).add(self.im.mul(x.re)),
        }
    }
    fn scale(self, c: f64) -> Cd {
        Cd {
            re: self.re.mul(c),
            im: self.im.mul(c),
        }
    }
    fn round(self) -> C {
        C::new(self.re.hi + self.re.lo, self.im.hi + self.im.lo)
    }
}

/// The ordinary Bessel polynomial `y_n(x)` and its derivative, by the three-term recurrence
/// `y_k = (2k − 1)·x·y_{k−1} + y_{k−2}` in double-double arithmetic.
fn bessel_y(n: usize, x: C) -> (C, C) {
    let one = Cd::new(C::new(1.0, 0.0));
    let (mut y0, mut y1) = (one, Cd::new(x).add(one));
    let (mut d0, mut d1) = (Cd::new(C::new(0.0, 0.0)), one);
    if n == 0 {
        return (y0.round(), d0.round());
    }
    for k in 2..=n {
        let c = (2 * k - 1) as f64;
        let y2 = y1.mul(x).scale(c).add(y0);
        let d2 = y1.add(d1.mul(x)).scale(c).add(d0);
        (y0, y1, d0, d1) = (y1, y2, d1, d2);
    }
    (y1.round(), d1.round())
}

/// The zeros of `y_n`, by Aberth's simultaneous iteration from Campos' starting points and a
/// Newton polish of each, then averaged with their conjugates so that they are exactly
/// symmetric (as SciPy's `_bessel_zeros`, which iterates on `kve(n + ½, 1/x)`, a function
/// with the same zeros).
fn bessel_zeros(n: usize) -> Result<Vec<C>, DesignError> {
    let mut x = campos_zeros(n);
    let mut converged = false;
    for _ in 0..50 {
        let alpha: Vec<C> = x
            .iter()
            .map(|&xi| {
                let (f, fp) = bessel_y(n, xi);
                -f / fp
            })
            .collect();
        let beta: Vec<C> = (0..n)
            .map(|k| {
                (0..n)
                    .filter(|&j| j != k)
                    .map(|j| C::new(1.0, 0.0) / (x[k] - x[j]))
                    .sum()
            })
            .collect();
        for k in 0..n {
            x[k] += alpha[k] / (C::new(1.0, 0.0) + alpha[k] * beta[k]);
        }
        if x.iter().any(|v| !v.re.is_finite() || !v.im.is_finite()) {
            return Err(DesignError::Numerical(
                "the Bessel polynomial's zeros could not be found".into(),
            ));
        }
        if alpha.iter().all(|a| a.norm() <= 1e-15) {
            converged = true;
            break;
        }
    }
    if !converged && n > 1 {
        // Aberth stalls at rounding level for larger orders; the Newton polish below decides.
    }
    for xi in &mut x {
        for _ in 0..50 {
            let (f, fp) = bessel_y(n, *xi);
            if f == C::new(0.0, 0.0) || fp == C::new(0.0, 0.0) {
                break;
            }
            let next = *xi - f / fp;
            let done = (next - *xi).norm() <= 1e-15;
            *xi = next;
            if done {
                break;
            }
        }
    }
    let sym: Vec<C> = (0..n).map(|k| (x[k] + x[n - 1 - k].conj()) / 2.0).collect();
    let sum: C = sym.iter().sum();
    if (sum + 1.0).norm() > 1e-14 {
        return Err(DesignError::Numerical(
            "the Bessel polynomial's zeros are inaccurate".into(),
        ));
    }
    Ok(sym)
}

/// `(2n)! / (n! 2^n)`, the constant term of the reverse Bessel polynomial.
fn bessel_a_last(n: usize) -> f64 {
    (1..=n).map(|k| (n + k) as f64 / 2.0).product()
}

/// The secant method of `scipy.optimize.newton` without a derivative (tolerance 1.48e-8).
fn secant(f: impl Fn(f64) -> f64, x0: f64) -> Result<f64, DesignError> {
    let tol = 1.48e-8;
    let eps = 1e-4;
    let mut p0 = x0;
    let mut p1 = x0 * (1.0 + eps);
    p1 += if p1 >= 0.0 { eps } else { -eps };
    let mut q0 = f(p0);
    let mut q1 = f(p1);
    if q1.abs() < q0.abs() {
        std::mem::swap(&mut p0, &mut p1);
        std::mem::swap(&mut q0, &mut q1);
    }
    for _ in 0..50 {
        if q1 == q0 {
            return Ok((p1 + p0) / 2.0);
        }
        let p = if q1.abs() > q0.abs() {
            (-q0 / q1 * p1 + p0) / (1.0 - q0 / q1)
        } else {
            (-q1 / q0 * p0 + p1) / (1.0 - q1 / q0)
        };
        if (p - p1).abs() <= tol {
            return Ok(p);
        }
        p0 = p1;
        q0 = q1;
        p1 = p;
        q1 = f(p1);
    }
    Err(DesignError::Numerical(
        "the Bessel filter's −3 dB frequency could not be found".into(),
    ))
}

/// Bessel–Thomson: maximally flat group delay.
pub fn besselap(n: usize, norm: BesselNorm) -> Result<Zpk, DesignError> {
    if n == 0 {
        return Ok(Zpk {
            z: Vec::new(),
            p: Vec::new(),
            k: 1.0,
        });
    }
    let mut p: Vec<C> = bessel_zeros(n)?
        .into_iter()
        .map(|x| C::new(1.0, 0.0) / x)
        .collect();
    let a_last = bessel_a_last(n);
    let k = match norm {
        BesselNorm::Delay => a_last,
        BesselNorm::Mag => {
            let g = |w: f64| {
                let den: C = p.iter().map(|&pi| C::new(0.0, w) - pi).product();
                (C::new(a_last, 0.0) / den).norm()
            };
            let factor = secant(|w| g(w) - 1.0 / 2f64.sqrt(), 1.5)?;
            for pi in &mut p {
                *pi /= factor;
            }
            factor.powf(-(n as f64)) * a_last
        }
        BesselNorm::Phase => {
            let scale = 10f64.powf(-a_last.log10() / n as f64);
            for pi in &mut p {
                *pi *= scale;
            }
            1.0
        }
    };
    Ok(Zpk {
        z: Vec::new(),
        p,
        k,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bessel_constants() {
        assert_eq!(bessel_a_last(1), 1.0);
        assert_eq!(bessel_a_last(3), 15.0);
        assert_eq!(bessel_a_last(5), 945.0);
    }

    #[test]
    fn campos_zeros_are_conjugate_symmetric() {
        let x = campos_zeros(5);
        for k in 0..5 {
            assert!((x[k] - x[4 - k].conj()).norm() < 1e-12);
        }
    }
}
