//! `update()`'s merge in AVX-512: a block (a cache line) is one vector, its owned words go to
//! the journal by one compress and one store, and a side of it the merge leaves as it was is
//! not written.
//!
//! Leaving unchanged lines unwritten matters: in a steady scan most words do not change, so
//! the update reads the two images and writes almost nothing (a line of the global image
//! left clean also stays shared with the other modules' cores). Written by hand because
//! the compiler's own AVX-512 code for the portable loops gathers word by word (several
//! times slower).

// The intrinsics are stable from Rust 1.89, after the workspace's 1.86: this module is built
// only where build.rs found them stable.
#![allow(clippy::incompatible_msrv)]

use std::arch::x86_64::{
    __m512i, _mm256_storeu_si256, _mm512_castsi512_si128, _mm512_castsi512_si256,
    _mm512_cmpneq_epi32_mask, _mm512_loadu_si512, _mm512_mask_storeu_epi32,
    _mm512_maskz_compress_epi32, _mm512_storeu_si512, _mm512_ternarylogic_epi32, _mm_storeu_si128,
    _mm_storeu_si32, _mm_storeu_si64,
};

use super::{each_step, one_pass, Journal, Pattern, Plan, BLOCK};

const _: () = assert!(BLOCK == 16, "a block is one vector of 16 u32s");

/// [`super::merge`] for CPUs with AVX-512F.
#[target_feature(enable = "avx512f")]
pub(super) fn merge(plan: &Plan, g: &mut [u32], p: &mut [u32], journal: &mut Journal<'_>) {
    each_step(plan, g, p, journal, |pattern, g, p, journal| {
        // The store of a block's saved words as wide as their count, where a store of that
        // width exists: a masked store costs more.
        match pattern.lanes().count_ones() {
            1 => blocks::<1>(pattern, g, p, journal),
            2 => blocks::<2>(pattern, g, p, journal),
            4 => blocks::<4>(pattern, g, p, journal),
            8 => blocks::<8>(pattern, g, p, journal),
            16 => blocks::<16>(pattern, g, p, journal),
            _ => blocks::<0>(pattern, g, p, journal),
        }
    });
}

/// One [`Step::Merge`](super::Step::Merge)'s words: `N` words saved per block (0: as many as
/// the pattern's lanes, by a masked store).
#[target_feature(enable = "avx512f")]
fn blocks<const N: usize>(
    pattern: &Pattern,
    g: &mut [u32],
    p: &mut [u32],
    journal: &mut Journal<'_>,
) {
    // The journal's lanes, packed to the front of a block's save.
    let lanes = pattern.lanes() as u16;
    let saved = lanes.count_ones() as usize;
    debug_assert!(N == 0 || N == saved);
    let first = ((1u32 << saved) - 1) as u16;
    // SAFETY: the mask is BLOCK u32s (unaligned loads throughout).
    let m = unsafe { _mm512_loadu_si512(pattern.mask.as_ptr().cast()) };
    // SAFETY (every load and store below): `one_pass::blocks` hands out pointers to BLOCK
    // u32s of `g` and `p` no one else touches meanwhile, and slots of `saved` u32s; each
    // store into a slot writes exactly that many.
    one_pass::blocks(
        pattern,
        g,
        p,
        journal,
        saved,
        move |gb, slot| {
            let owned =
                _mm512_maskz_compress_epi32(lanes, unsafe { _mm512_loadu_si512(gb.cast()) });
            unsafe { store_saved::<N>(slot, owned, first) };
        },
        move |gb, pb| {
            let (gv, pv) =
                unsafe { (_mm512_loadu_si512(gb.cast()), _mm512_loadu_si512(pb.cast())) };
            // Equal sides (a steady scan's usual block) need nothing: one test for both.
            if _mm512_cmpneq_epi32_mask(gv, pv) != 0 {
                // Bitwise m ? p : g.
                let v = _mm512_ternarylogic_epi32::<0xCA>(m, pv, gv);
                if _mm512_cmpneq_epi32_mask(v, gv) != 0 {
                    unsafe { _mm512_storeu_si512(gb.cast(), v) };
                }
                if _mm512_cmpneq_epi32_mask(v, pv) != 0 {
                    unsafe { _mm512_storeu_si512(pb.cast(), v) };
                }
            }
        },
    );
}

/// Stores the first `N` u32s of `v` at `to` (`N` = 0: as many as `first` has bits).
///
/// # Safety
/// `to` must be valid for writing that many u32s.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn store_saved<const N: usize>(to: *mut u32, v: __m512i, first: u16) {
    // SAFETY: each store writes N u32s (or `first`'s), as the caller allows.
    unsafe {
        match N {
            1 => _mm_storeu_si32(to.cast(), _mm512_castsi512_si128(v)),
            2 => _mm_storeu_si64(to.cast(), _mm512_castsi512_si128(v)),
            4 => _mm_storeu_si128(to.cast(), _mm512_castsi512_si128(v)),
            8 => _mm256_storeu_si256(to.cast(), _mm512_castsi512_si256(v)),
            16 => _mm512_storeu_si512(to.cast(), v),
            _ => _mm512_mask_storeu_epi32(to.cast(), first, v),
        }
    }
}
