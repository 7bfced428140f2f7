//! `update()`'s merge in AVX-512: the partly owned blocks one 64-byte vector (a cache line)
//! at a time, in one pass.
//!
//! The portable loops make two passes per chunk (save the chunk's owned words in the
//! journal, then merge it) and pick the owned words out one by one. Here every two blocks
//! are saved and then merged before the next two: a block's owned words go to the journal
//! by one compress and one store, and the journal's count is bumped from a register.
//! A side whose words the merge leaves as they are is not written, so that its cache lines
//! stay clean: in a steady scan most words do not change, and a global line left clean
//! stays shared with the other modules' cores. Written by hand because the compiler's own
//! AVX-512 code for the portable loops gathers word by word (several times slower).

// The intrinsics are stable from Rust 1.89, after the workspace's 1.86: this module is built
// only where build.rs found them stable.
#![allow(clippy::incompatible_msrv)]

use std::arch::x86_64::{
    __m512i, _mm256_storeu_si256, _mm512_castsi512_si128, _mm512_castsi512_si256,
    _mm512_cmpneq_epi32_mask, _mm512_loadu_si512, _mm512_mask_storeu_epi32,
    _mm512_maskz_compress_epi32, _mm512_storeu_si512, _mm512_ternarylogic_epi32, _mm_prefetch,
    _mm_storeu_si128, _mm_storeu_si32, _mm_storeu_si64, _MM_HINT_T0,
};

use super::{each_step, merge_chunk, Journal, Pattern, Plan, BLOCK};

/// Blocks per step of the journal.
const PIECE: usize = 2;

/// How far ahead of the merge the words of `g` and `p` are prefetched.
const AHEAD: usize = 256;

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

/// One [`Step::Merge`]'s words: `N` words saved per block (0: as many as the pattern's
/// lanes, by a masked store).
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
    let whole = g.len() / BLOCK * BLOCK;
    let (g, g_tail) = g.split_at_mut(whole);
    let (p, p_tail) = p.split_at_mut(whole);
    let (gp, pp) = (g.as_mut_ptr(), p.as_mut_ptr());
    // SAFETY (every load and store below): block `b` of `g` and of `p` is the BLOCK u32s
    // at `b * BLOCK`, for b < whole / BLOCK, the blocks `save_each` hands out; a save's
    // slot is `saved` u32s and each store writes exactly that many. The two pointers are
    // the only access to `g` and `p` until they go out of use.
    let block = |b: usize| unsafe { _mm512_loadu_si512(gp.add(b * BLOCK).cast()) };
    let merge = |b: usize| {
        let gv = block(b);
        let pv = unsafe { _mm512_loadu_si512(pp.add(b * BLOCK).cast()) };
        // Bitwise m ? p : g.
        let v = _mm512_ternarylogic_epi32::<0xCA>(m, pv, gv);
        if _mm512_cmpneq_epi32_mask(v, gv) != 0 {
            unsafe { _mm512_storeu_si512(gp.add(b * BLOCK).cast(), v) };
        }
        if _mm512_cmpneq_epi32_mask(v, pv) != 0 {
            unsafe { _mm512_storeu_si512(pp.add(b * BLOCK).cast(), v) };
        }
    };
    let blocks = whole / BLOCK;
    // PIECE blocks per step of the journal (each step bumps its count), then the few
    // blocks left one by one.
    let steps = [(blocks / PIECE, PIECE), (blocks % PIECE, 1)];
    let mut done = 0;
    for (pieces, per) in steps {
        let base = done;
        journal.save_each(
            pieces,
            per * saved,
            |i, slot| {
                for k in 0..per {
                    let owned = _mm512_maskz_compress_epi32(lanes, block(base + i * per + k));
                    unsafe { store_saved::<N>(slot.as_mut_ptr().add(k * saved), owned, first) };
                }
            },
            |i| {
                for k in 0..per {
                    let b = base + i * per + k;
                    // The lines AHEAD words on: the loads of g and p are two streams
                    // among the journal's stores, which the hardware alone prefetches
                    // too late (a steady update takes 6.2 µs without, 5.1 µs with).
                    _mm_prefetch::<_MM_HINT_T0>(gp.wrapping_add(b * BLOCK + AHEAD).cast());
                    _mm_prefetch::<_MM_HINT_T0>(pp.wrapping_add(b * BLOCK + AHEAD).cast());
                    merge(b);
                }
            },
        );
        done += pieces * per;
    }
    // The image's last block, cut short.
    if !g_tail.is_empty() {
        merge_chunk(pattern, g_tail, p_tail, journal);
    }
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
