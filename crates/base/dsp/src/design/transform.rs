//! Frequency transformations of a lowpass prototype and the bilinear transform, on zeros,
//! poles and gain (SciPy's `lp2lp_zpk`, `lp2hp_zpk`, `lp2bp_zpk`, `lp2bs_zpk`, `bilinear_zpk`).

use num_complex::Complex64 as C;

use super::Zpk;

/// The principal complex square root (the C99 `csqrt` formulation, accurate for every input).
pub(crate) fn csqrt(v: C) -> C {
    if v.re == 0.0 && v.im == 0.0 {
        return C::new(0.0, v.im);
    }
    let t = ((v.re.abs() + v.re.hypot(v.im)) * 0.5).sqrt();
    if v.re >= 0.0 {
        C::new(t, v.im / (2.0 * t))
    } else {
        C::new(v.im.abs() / (2.0 * t), t.copysign(v.im))
    }
}

fn prod(values: impl Iterator<Item = C>) -> C {
    values.fold(C::new(1.0, 0.0), |acc, v| acc * v)
}

impl Zpk {
    /// Poles minus zeros: the zeros at infinity.
    fn degree(&self) -> usize {
        self.p.len().saturating_sub(self.z.len())
    }

    /// Lowpass with cut-off `wo` rad/s.
    pub fn lp2lp(&self, wo: f64) -> Zpk {
        let degree = self.degree();
        Zpk {
            z: self.z.iter().map(|&z| z * wo).collect(),
            p: self.p.iter().map(|&p| p * wo).collect(),
            k: self.k * wo.powf(degree as f64),
        }
    }

    /// Highpass with cut-off `wo` rad/s: the zeros at infinity move to the origin.
    pub fn lp2hp(&self, wo: f64) -> Zpk {
        let degree = self.degree();
        let mut z: Vec<C> = self.z.iter().map(|&z| C::new(wo, 0.0) / z).collect();
        let p: Vec<C> = self.p.iter().map(|&p| C::new(wo, 0.0) / p).collect();
        z.extend(std::iter::repeat_n(C::new(0.0, 0.0), degree));
        let k = self.k * (prod(self.z.iter().map(|&z| -z)) / prod(self.p.iter().map(|&p| -p))).re;
        Zpk { z, p, k }
    }

    /// Each root `r` of the scaled prototype becomes `r ± √(r² − wo²)`.
    fn split(roots: &[C], wo: f64) -> Vec<C> {
        let shifted: Vec<C> = roots.iter().map(|&r| csqrt(r * r - wo * wo)).collect();
        let plus = roots.iter().zip(&shifted).map(|(&r, &s)| r + s);
        let minus = roots.iter().zip(&shifted).map(|(&r, &s)| r - s);
        plus.chain(minus).collect()
    }

    /// Bandpass centred on `wo` rad/s, `bw` rad/s wide: half the zeros at infinity move to
    /// the origin.
    pub fn lp2bp(&self, wo: f64, bw: f64) -> Zpk {
        let degree = self.degree();
        let z_lp: Vec<C> = self.z.iter().map(|&z| z * bw / 2.0).collect();
        let p_lp: Vec<C> = self.p.iter().map(|&p| p * bw / 2.0).collect();
        let mut z = Zpk::split(&z_lp, wo);
        z.extend(std::iter::repeat_n(C::new(0.0, 0.0), degree));
        Zpk {
            z,
            p: Zpk::split(&p_lp, wo),
            k: self.k * bw.powf(degree as f64),
        }
    }

    /// Bandstop centred on `wo` rad/s, `bw` rad/s wide: the zeros at infinity move to ±j·wo.
    pub fn lp2bs(&self, wo: f64, bw: f64) -> Zpk {
        let degree = self.degree();
        let z_hp: Vec<C> = self.z.iter().map(|&z| C::new(bw / 2.0, 0.0) / z).collect();
        let p_hp: Vec<C> = self.p.iter().map(|&p| C::new(bw / 2.0, 0.0) / p).collect();
        let mut z = Zpk::split(&z_hp, wo);
        z.extend(std::iter::repeat_n(C::new(0.0, wo), degree));
        z.extend(std::iter::repeat_n(C::new(0.0, -wo), degree));
        let k = self.k * (prod(self.z.iter().map(|&z| -z)) / prod(self.p.iter().map(|&p| -p))).re;
        Zpk {
            z,
            p: Zpk::split(&p_hp, wo),
            k,
        }
    }

    /// The digital filter of the bilinear transform at sampling rate `fs`: zeros at infinity
    /// move to Nyquist (−1).
    pub fn bilinear(&self, fs: f64) -> Zpk {
        let degree = self.degree();
        let fs2 = 2.0 * fs;
        let map = |r: C| (fs2 + r) / (fs2 - r);
        let mut z: Vec<C> = self.z.iter().map(|&r| map(r)).collect();
        z.extend(std::iter::repeat_n(C::new(-1.0, 0.0), degree));
        let k = self.k
            * (prod(self.z.iter().map(|&r| fs2 - r)) / prod(self.p.iter().map(|&r| fs2 - r))).re;
        Zpk {
            z,
            p: self.p.iter().map(|&r| map(r)).collect(),
            k,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csqrt_matches_the_principal_root() {
        let check = |v: C, expect: C| {
            let got = csqrt(v);
            assert!(
                (got - expect).norm() < 1e-15,
                "sqrt({v}) = {got}, not {expect}"
            );
        };
        check(C::new(4.0, 0.0), C::new(2.0, 0.0));
        check(C::new(-4.0, 0.0), C::new(0.0, 2.0));
        check(C::new(-4.0, -0.0), C::new(0.0, -2.0));
        check(C::new(0.0, 2.0), C::new(1.0, 1.0));
        check(C::new(3.0, -4.0), C::new(2.0, -1.0));
    }
}
