//! The loop the vector merges (`avx2.rs`, `avx512.rs`) share: a merge step's blocks in one
//! pass, each saved in the journal just before it is merged.
//!
//! The portable loops make two passes per chunk (save the chunk's owned words, then merge
//! it). Here every [`PIECE`] blocks are saved and then merged before the next ones: the
//! journal's count is bumped from a register once per piece, the lines of `g` just read for
//! the save are still in the L1 cache for the merge, and `g` and `p` are prefetched
//! [`AHEAD`] words on, as the hardware alone fetches those two streams late among the
//! journal's stores (a steady update of 64 k words: 6.2 µs without, 5.1 µs with, AVX-512).
//! The kernels pass closures defined in their `#[target_feature]` functions, which this
//! loop, inlined there, calls: a closure defined outside would be compiled without the
//! feature (the AVX2 merge through the portable loop's closure ran 25 % slower).

use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};

use super::{merge_chunk, Journal, Pattern, BLOCK};

/// Blocks per step of the journal (four are no faster).
const PIECE: usize = 2;

/// How far ahead of the merge the words of `g` and `p` are prefetched (1 KiB; 4 KiB is
/// slower).
const AHEAD: usize = 256;

/// Runs `pattern`'s merge over `g` and `p` (a [`super::Step::Merge`]'s words), whole block
/// by whole block: `save(gb, slot)` writes the journal's `saved` words (`saved` > 0) of the
/// block at `gb` to `slot`; then, the journal counting them, `merge(gb, pb)` merges the block
/// at `gb` with the one at `pb`. `gb` and `pb` are valid for reading and writing BLOCK u32s,
/// `slot` for writing `saved` u32s, and they are the only access to those words during the
/// call. The last block, if cut short, is merged by [`merge_chunk`].
#[inline(always)]
pub(super) fn blocks(
    pattern: &Pattern,
    g: &mut [u32],
    p: &mut [u32],
    journal: &mut Journal<'_>,
    saved: usize,
    mut save: impl FnMut(*const u32, *mut u32),
    mut merge: impl FnMut(*mut u32, *mut u32),
) {
    let whole = g.len() / BLOCK * BLOCK;
    let (g, g_tail) = g.split_at_mut(whole);
    let (p, p_tail) = p.split_at_mut(whole);
    let (gp, pp) = (g.as_mut_ptr(), p.as_mut_ptr());
    let blocks = whole / BLOCK;
    // PIECE blocks per step of the journal, then the few left one by one.
    let mut done = 0;
    for (pieces, per) in [(blocks / PIECE, PIECE), (blocks % PIECE, 1)] {
        let (base, save, merge) = (done, &mut save, &mut merge);
        journal.save_each(
            pieces,
            per * saved,
            // `move`: the pointers and counts by value, in registers across the journal's
            // compiler fences (by reference they are reloaded from the stack each block).
            move |i, slot| {
                let slot = slot.as_mut_ptr();
                for k in 0..per {
                    let w = (base + i * per + k) * BLOCK;
                    save(gp.wrapping_add(w), slot.wrapping_add(k * saved));
                }
            },
            move |i| {
                for k in 0..per {
                    let w = (base + i * per + k) * BLOCK;
                    // SAFETY: prefetches have no effect on memory, any address is allowed.
                    unsafe {
                        _mm_prefetch::<_MM_HINT_T0>(gp.wrapping_add(w + AHEAD).cast());
                        _mm_prefetch::<_MM_HINT_T0>(pp.wrapping_add(w + AHEAD).cast());
                    }
                    merge(gp.wrapping_add(w), pp.wrapping_add(w));
                }
            },
        );
        done += pieces * per;
    }
    if !g_tail.is_empty() {
        merge_chunk(pattern, g_tail, p_tail, journal);
    }
}
