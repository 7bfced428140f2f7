//! `update()`'s merge in AVX2, for x86-64 CPUs without AVX-512: a block (a cache line) is two
//! vectors, and a side of it the merge leaves as it was is not written (see `avx512.rs`).
//! AVX2 has no compress: a sparse pattern's owned words are picked out for the journal one
//! by one, from the line the merge reads next.

use std::arch::x86_64::{
    __m256i, _mm256_and_si256, _mm256_andnot_si256, _mm256_loadu_si256, _mm256_or_si256,
    _mm256_storeu_si256, _mm256_testz_si256, _mm256_xor_si256,
};

use super::{each_step, one_pass, Journal, Pattern, Plan, BLOCK, SPARSE};

const _: () = assert!(BLOCK == 16, "a block is two vectors of 8 u32s");

/// [`super::merge`] for CPUs with AVX2.
#[target_feature(enable = "avx2")]
pub(super) fn merge(plan: &Plan, g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    each_step(plan, g, p, journal, |pattern, g, p, journal| {
        // The owned words as constants, so that picking them out is unrolled.
        match pattern.sparse as usize {
            0 => blocks::<BLOCK>(pattern, g, p, journal),
            1 => blocks::<1>(pattern, g, p, journal),
            2 => blocks::<2>(pattern, g, p, journal),
            3 => blocks::<3>(pattern, g, p, journal),
            4 => blocks::<4>(pattern, g, p, journal),
            5 => blocks::<5>(pattern, g, p, journal),
            6 => blocks::<6>(pattern, g, p, journal),
            7 => blocks::<7>(pattern, g, p, journal),
            _ => blocks::<SPARSE>(pattern, g, p, journal),
        }
    });
}

/// One [`Step::Merge`](super::Step::Merge)'s words, `N` of each block saved (all of a dense
/// pattern's: [`BLOCK`]).
#[target_feature(enable = "avx2")]
fn blocks<const N: usize>(
    pattern: &Pattern,
    g: &mut [u32],
    p: &mut [u32],
    journal: &mut Journal<'_>,
) {
    debug_assert!(N == BLOCK || N == pattern.sparse as usize);
    let owned: [usize; N] = std::array::from_fn(|i| {
        if N == BLOCK {
            i
        } else {
            pattern.owned[i] as usize % BLOCK
        }
    });
    // SAFETY: the mask is BLOCK u32s (unaligned loads throughout).
    let m = [0, 8].map(|h| unsafe { _mm256_loadu_si256(pattern.mask.as_ptr().add(h).cast()) });
    // SAFETY (every load and store below): `one_pass::blocks` hands out pointers to BLOCK
    // u32s of `g` and `p` no one else touches meanwhile; `owned` are offsets in a block.
    let half = |b: *mut u32, h: usize| unsafe { _mm256_loadu_si256(b.add(h).cast::<__m256i>()) };
    one_pass::blocks(
        pattern,
        g,
        p,
        journal,
        N,
        move |gb, slot| {
            for (k, &o) in owned.iter().enumerate() {
                unsafe { *slot.add(k) = *gb.add(o) };
            }
        },
        move |gb, pb| {
            let (g0, g1, p0, p1) = (half(gb, 0), half(gb, 8), half(pb, 0), half(pb, 8));
            let (x0, x1) = (_mm256_xor_si256(g0, p0), _mm256_xor_si256(g1, p1));
            // Equal sides (a steady scan's usual block) need nothing: one test for both.
            let x = _mm256_or_si256(x0, x1);
            if _mm256_testz_si256(x, x) != 0 {
                return;
            }
            // v = g ^ ((g ^ p) & m): the owned bits from p, the others from g; g changes
            // where (g ^ p) & m is not 0, p where (g ^ p) & !m is not.
            let (d0, d1) = (_mm256_and_si256(x0, m[0]), _mm256_and_si256(x1, m[1]));
            let (v0, v1) = (_mm256_xor_si256(g0, d0), _mm256_xor_si256(g1, d1));
            let out = _mm256_or_si256(d0, d1);
            let into =
                _mm256_or_si256(_mm256_andnot_si256(m[0], x0), _mm256_andnot_si256(m[1], x1));
            unsafe {
                if _mm256_testz_si256(out, out) == 0 {
                    _mm256_storeu_si256(gb.cast(), v0);
                    _mm256_storeu_si256(gb.add(8).cast(), v1);
                }
                if _mm256_testz_si256(into, into) == 0 {
                    _mm256_storeu_si256(pb.cast(), v0);
                    _mm256_storeu_si256(pb.add(8).cast(), v1);
                }
            }
        },
    );
}
