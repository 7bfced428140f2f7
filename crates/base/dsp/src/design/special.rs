//! The special functions elliptic filter design needs, with SciPy's conventions: the complete
//! elliptic integral of the first kind `K(m)` (parameter `m = k²`), `K(1 − p)` without the
//! cancellation of forming `1 − p`, and the Jacobian elliptic functions `sn`, `cn`, `dn`.
//!
//! `K` is computed with the arithmetic-geometric mean, `K(m) = π / (2·AGM(1, √(1 − m)))`, which
//! is accurate to a few units in the last place; the Jacobian functions with the descending
//! Landen (AGM) recurrence and the small-`m` and `m`-near-1 expansions Cephes (and so SciPy)
//! uses, so that both agree to rounding on the values filter design asks for.

use std::f64::consts::{FRAC_PI_2, PI};

/// The arithmetic-geometric mean of two positive numbers.
fn agm(mut a: f64, mut b: f64) -> f64 {
    for _ in 0..64 {
        let next_a = 0.5 * (a + b);
        if (a - b).abs() <= 4.0 * f64::EPSILON * a || next_a == a {
            return next_a;
        }
        b = (a * b).sqrt();
        a = next_a;
    }
    a
}

/// `K(1 − p)` from `p` (SciPy's `ellipkm1`; Cephes' `ellpk`): ∞ at `p = 0`, NaN below 0.
pub fn ellipkm1(p: f64) -> f64 {
    if p.is_nan() || p < 0.0 {
        return f64::NAN;
    }
    if p == 0.0 {
        return f64::INFINITY;
    }
    if p.is_infinite() {
        return 0.0;
    }
    PI / (2.0 * agm(1.0, p.sqrt()))
}

/// The complete elliptic integral of the first kind `K(m)` (SciPy's `ellipk`).
pub fn ellipk(m: f64) -> f64 {
    ellipkm1(1.0 - m)
}

/// `sn`, `cn`, `dn` and the amplitude `φ` of `u` for parameter `m`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Jacobi {
    pub sn: f64,
    pub cn: f64,
    pub dn: f64,
    pub ph: f64,
}

/// The Jacobian elliptic functions of real `u` and `0 ≤ m ≤ 1` (SciPy's `ellipj`); NaN outside.
pub fn ellipj(u: f64, m: f64) -> Jacobi {
    const MACHEP: f64 = 1.110_223_024_625_156_5e-16;
    if m.is_nan() || u.is_nan() || !(0.0..=1.0).contains(&m) {
        return Jacobi {
            sn: f64::NAN,
            cn: f64::NAN,
            dn: f64::NAN,
            ph: f64::NAN,
        };
    }
    if m < 1e-9 {
        // First-order expansion in m around the circular functions.
        let (t, b) = (u.sin(), u.cos());
        let ai = 0.25 * m * (u - t * b);
        return Jacobi {
            sn: t - ai * b,
            cn: b + ai * t,
            dn: 1.0 - 0.5 * m * t * t,
            ph: u - ai,
        };
    }
    if m >= 0.999_999_999_9 {
        // First-order expansion in 1 − m around the hyperbolic functions.
        let ai = 0.25 * (1.0 - m);
        let b = u.cosh();
        let t = u.tanh();
        let phi = 1.0 / b;
        let twon = b * u.sinh();
        let sn = t + ai * (twon - u) / (b * b);
        let ph = 2.0 * u.exp().atan() - FRAC_PI_2 + ai * (twon - u) / b;
        let ai = ai * t * phi;
        return Jacobi {
            sn,
            cn: phi - ai * (twon - u),
            dn: phi + ai * (twon + u),
            ph,
        };
    }
    // Descending Landen transformation: the AGM of 1 and √(1 − m), remembering each step.
    let mut a = [0.0f64; 9];
    let mut c = [0.0f64; 9];
    a[0] = 1.0;
    let mut b = (1.0 - m).sqrt();
    c[0] = m.sqrt();
    let mut twon = 1.0;
    let mut i = 0;
    while (c[i] / a[i]).abs() > MACHEP {
        if i > 7 {
            break;
        }
        let ai = a[i];
        i += 1;
        c[i] = 0.5 * (ai - b);
        let t = (ai * b).sqrt();
        a[i] = 0.5 * (ai + b);
        b = t;
        twon *= 2.0;
    }
    // Back up the recurrence to the amplitude.
    let mut phi = twon * a[i] * u;
    loop {
        let t = c[i] * phi.sin() / a[i];
        b = phi;
        phi = 0.5 * (t.asin() + phi);
        i -= 1;
        if i == 0 {
            break;
        }
    }
    let t = phi.cos();
    Jacobi {
        sn: phi.sin(),
        cn: t,
        dn: t / (phi - b).cos(),
        ph: phi,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `got` equals `expect` to `rel` relative (or both are NaN, or equal infinities).
    fn check(got: f64, expect: f64, rel: f64) {
        let ok = (got.is_nan() && expect.is_nan())
            || got == expect
            || (got - expect).abs() <= rel * expect.abs();
        assert!(ok, "got {got:e}, expected {expect:e}");
    }

    /// Values printed by scipy.special 1.17.1 (`ellipk`, `ellipkm1`, `ellipj`).
    #[test]
    fn agrees_with_scipy() {
        check(ellipk(0.0), FRAC_PI_2, 1e-15);
        check(ellipk(0.5), 1.854_074_677_301_371_9, 1e-15);
        check(ellipk(0.99), 3.695_637_362_989_874_7, 1e-15);
        check(ellipk(1.0), f64::INFINITY, 0.0);
        check(ellipkm1(1e-12), 15.201_804_919_087_715, 1e-15);
        check(ellipkm1(-1.0), f64::NAN, 0.0);
        let j = ellipj(0.7, 0.3);
        check(j.sn, 0.632_304_776_310_864_6, 1e-15);
        check(j.cn, 0.774_719_736_326_929_8, 1e-15);
        check(j.dn, 0.938_113_639_681_430_4, 1e-15);
        check(j.ph, 0.684_524_593_661_293_9, 1e-15);
        let j = ellipj(1.3, 1e-10);
        check(j.sn, 0.963_558_185_410_223, 1e-15);
        let j = ellipj(1.3, 1.0 - 1e-11);
        check(j.sn, 0.861_723_159_314_624, 1e-12);
        check(ellipj(1.0, 1.5).sn, f64::NAN, 0.0);
    }
}
