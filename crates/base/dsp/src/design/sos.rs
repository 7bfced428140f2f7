//! Zeros, poles and gain to second-order sections, pairing as `scipy.signal.zpk2sos` does for
//! a digital filter (`pairing='nearest'`): the poles closest to the unit circle go last, each
//! with the zeros nearest to it, and the gain goes into the first section.

use std::cmp::Ordering;

use num_complex::Complex64 as C;

use super::{DesignError, Section, Zpk};

fn cmp(a: f64, b: f64) -> Ordering {
    a.partial_cmp(&b).unwrap_or(Ordering::Equal)
}

fn is_real(v: C) -> bool {
    v.im == 0.0
}

/// Splits roots into one of each complex-conjugate pair (positive imaginary part, averaged
/// with its partner) and the real ones, both sorted by real part (SciPy's `_cplxreal`).
fn cplxreal(z: &[C]) -> Result<(Vec<C>, Vec<f64>), DesignError> {
    if z.is_empty() {
        return Ok((Vec::new(), Vec::new()));
    }
    let tol = 100.0 * f64::EPSILON;
    let mut z = z.to_vec();
    // numpy.lexsort((|imag|, real)) is stable: by real part, then by |imaginary part|.
    z.sort_by(|a, b| cmp(a.re, b.re).then(cmp(a.im.abs(), b.im.abs())));
    let real = |v: &C| v.im.abs() <= tol * v.norm();
    let zr: Vec<f64> = z.iter().filter(|v| real(v)).map(|v| v.re).collect();
    if zr.len() == z.len() {
        return Ok((Vec::new(), zr));
    }
    let rest: Vec<C> = z.into_iter().filter(|v| !real(v)).collect();
    let mut zp: Vec<C> = rest.iter().copied().filter(|v| v.im > 0.0).collect();
    let mut zn: Vec<C> = rest.iter().copied().filter(|v| v.im < 0.0).collect();
    let unmatched = || DesignError::Numerical("a complex root has no conjugate".into());
    if zp.len() != zn.len() {
        return Err(unmatched());
    }
    // Runs of (nearly) equal real parts are sorted by |imaginary part|, so that partners line
    // up.
    let mut start = 0;
    while start < zp.len() {
        let mut stop = start;
        while stop + 1 < zp.len() && zp[stop + 1].re - zp[stop].re <= tol * zp[stop].norm() {
            stop += 1;
        }
        if stop > start {
            zp[start..=stop].sort_by(|a, b| cmp(a.im.abs(), b.im.abs()));
            zn[start..=stop].sort_by(|a, b| cmp(a.im.abs(), b.im.abs()));
        }
        start = stop + 1;
    }
    if zp
        .iter()
        .zip(&zn)
        .any(|(p, n)| (p - n.conj()).norm() > tol * n.norm())
    {
        return Err(unmatched());
    }
    let zc = zp
        .iter()
        .zip(&zn)
        .map(|(p, n)| (p + n.conj()) / 2.0)
        .collect();
    Ok((zc, zr))
}

/// The index of the root nearest to `to` among the real ones, the complex ones or all (the
/// first of equals).
fn nearest(from: &[C], to: C, which: Which) -> Option<usize> {
    from.iter()
        .enumerate()
        .filter(|(_, v)| match which {
            Which::Real => is_real(**v),
            Which::Complex => !is_real(**v),
            Which::Any => true,
        })
        .min_by(|a, b| cmp((a.1 - to).norm(), (b.1 - to).norm()))
        .map(|(i, _)| i)
}

#[derive(Clone, Copy)]
enum Which {
    Real,
    Complex,
    Any,
}

/// The pole closest to the unit circle (the first of equals).
fn worst(p: &[C]) -> usize {
    p.iter()
        .enumerate()
        .min_by(|a, b| cmp((1.0 - a.1.norm()).abs(), (1.0 - b.1.norm()).abs()))
        .map_or(0, |(i, _)| i)
}

/// The real coefficients of the monic polynomial with roots `r`: `[1]`, `[1, −r0]` or
/// `[1, −(r0 + r1), r0·r1]`.
fn poly(r: &[C]) -> Vec<f64> {
    match r {
        [] => vec![1.0],
        [a] => vec![1.0, -a.re],
        [a, b] => {
            // numpy.convolve([1, −a], [1, −b]).
            let c1 = -*b + -*a;
            let c2 = *a * *b;
            vec![1.0, c1.re, c2.re]
        }
        _ => unreachable!("a section has at most two roots"),
    }
}

/// One section from up to two zeros and two poles (SciPy's `_single_zpksos` with k = 1).
fn section(z: &[C], p: &[C]) -> Section {
    let mut s = [0.0; 6];
    let b = poly(z);
    let a = poly(p);
    s[3 - b.len()..3].copy_from_slice(&b);
    s[6 - a.len()..6].copy_from_slice(&a);
    s
}

/// Removes and returns the root of `v` nearest to `to` of the kind asked for.
fn pick(v: &mut Vec<C>, to: C, which: Which) -> Result<C, DesignError> {
    let i = nearest(v, to, which)
        .ok_or_else(|| DesignError::Numerical("poles and zeros could not be paired".into()))?;
    Ok(v.remove(i))
}

/// `scipy.signal.zpk2sos(z, p, k)` for a digital filter.
pub fn zpk2sos(zpk: &Zpk) -> Result<Vec<Section>, DesignError> {
    let (mut z, mut p, k) = (zpk.z.clone(), zpk.p.clone(), zpk.k);
    if z.is_empty() && p.is_empty() {
        return Ok(vec![[k, 0.0, 0.0, 1.0, 0.0, 0.0]]);
    }
    // As many poles as zeros (the extra ones at the origin), and an even number of both.
    while p.len() < z.len() {
        p.push(C::new(0.0, 0.0));
    }
    while z.len() < p.len() {
        z.push(C::new(0.0, 0.0));
    }
    let n_sections = p.len().div_ceil(2);
    if p.len() % 2 == 1 {
        p.push(C::new(0.0, 0.0));
        z.push(C::new(0.0, 0.0));
    }
    let (zc, zr) = cplxreal(&z)?;
    let mut z: Vec<C> = zc
        .into_iter()
        .chain(zr.into_iter().map(|r| C::new(r, 0.0)))
        .collect();
    let (pc, pr) = cplxreal(&p)?;
    let mut p: Vec<C> = pc
        .into_iter()
        .chain(pr.into_iter().map(|r| C::new(r, 0.0)))
        .collect();

    let mut sos = vec![[0.0; 6]; n_sections];
    let internal = || DesignError::Numerical("poles and zeros could not be paired".into());
    for si in (0..n_sections).rev() {
        let p1 = p.remove(worst(&p));
        let reals_left = p.iter().filter(|v| is_real(**v)).count();
        if is_real(p1) && reals_left == 0 {
            // The last real pole: with the nearest real zero, as a first-order section padded
            // with a pole and a zero at the origin.
            let z1 = pick(&mut z, p1, Which::Real)?;
            sos[si] = section(&[z1, C::new(0.0, 0.0)], &[p1, C::new(0.0, 0.0)]);
        } else if p.len() + 1 == z.len()
            && !is_real(p1)
            && reals_left == 1
            && z.iter().filter(|v| is_real(**v)).count() == 1
        {
            // One real pole and one real zero left, and as many poles as zeros to pair: this
            // complex pole must take a complex zero.
            let z1 = pick(&mut z, p1, Which::Complex)?;
            sos[si] = section(&[z1, z1.conj()], &[p1, p1.conj()]);
        } else {
            let p2 = if is_real(p1) {
                let reals: Vec<usize> = (0..p.len()).filter(|&i| is_real(p[i])).collect();
                let values: Vec<C> = reals.iter().map(|&i| p[i]).collect();
                p.remove(reals[worst(&values)])
            } else {
                p1.conj()
            };
            if z.is_empty() {
                sos[si] = section(&[], &[p1, p2]);
            } else {
                let z1 = pick(&mut z, p1, Which::Any)?;
                if !is_real(z1) {
                    sos[si] = section(&[z1, z1.conj()], &[p1, p2]);
                } else if z.is_empty() {
                    sos[si] = section(&[z1], &[p1, p2]);
                } else {
                    let z2 = pick(&mut z, p1, Which::Real)?;
                    sos[si] = section(&[z1, z2], &[p1, p2]);
                }
            }
        }
    }
    if !p.is_empty() || !z.is_empty() {
        return Err(internal());
    }
    for c in &mut sos[0][..3] {
        *c *= k;
    }
    Ok(sos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cplxreal_pairs_and_sorts() {
        let z = [
            C::new(1.0, 2.0),
            C::new(3.0, 0.0),
            C::new(1.0, -2.0),
            C::new(-1.0, 0.0),
        ];
        let (zc, zr) = cplxreal(&z).unwrap();
        assert_eq!(zc, vec![C::new(1.0, 2.0)]);
        assert_eq!(zr, vec![-1.0, 3.0]);
        assert!(cplxreal(&[C::new(1.0, 2.0)]).is_err());
    }

    #[test]
    fn gain_only_and_first_order() {
        let s = zpk2sos(&Zpk {
            z: vec![],
            p: vec![],
            k: 2.0,
        })
        .unwrap();
        assert_eq!(s, vec![[2.0, 0.0, 0.0, 1.0, 0.0, 0.0]]);
        // scipy.signal.zpk2sos([-1], [0.5], 0.25) == [[0.25, 0.25, 0, 1, -0.5, 0]]
        let s = zpk2sos(&Zpk {
            z: vec![C::new(-1.0, 0.0)],
            p: vec![C::new(0.5, 0.0)],
            k: 0.25,
        })
        .unwrap();
        assert_eq!(s, vec![[0.25, 0.25, 0.0, 1.0, -0.5, 0.0]]);
    }
}
