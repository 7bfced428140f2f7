//! Unit tests of `module.rs`.

use proptest::prelude::*;

use super::super::shm::TestJournal;
use super::{merge_with, plan, Simd, CHUNK};

/// Runs `merge` with the plan of `mask` on global words `g0` and private words `p0`, and
/// compares it with the definition: owned bits from the private words, every other bit
/// from the global ones, in both. Then undoes it from its journal, as the next locker
/// would after a death: the global words must be `g0` again.
fn check(mask: &[u32], g0: &[u32], p0: &[u32]) {
    let want: Vec<u32> = (0..mask.len())
        .map(|i| (g0[i] & !mask[i]) | (p0[i] & mask[i]))
        .collect();
    let plan = plan(mask);
    // Every merge this CPU can run.
    for simd in [Simd::Portable, Simd::Avx2, Simd::Avx512] {
        if !simd.available() {
            continue;
        }
        let (mut g, mut p) = (g0.to_vec(), p0.to_vec());
        let mut journal = TestJournal::new(mask.len());
        {
            let mut j = journal.journal();
            j.open(&plan.spans);
            merge_with(simd, &plan, &mut g, &mut p, &mut j);
        }
        assert_eq!(g, want, "global words, {simd:?}, mask {mask:x?}");
        assert_eq!(p, want, "private words, {simd:?}, mask {mask:x?}");
        let changed = (0..g.len()).filter(|&i| g[i] != g0[i]).count();
        assert!(journal.saved() >= changed, "saved fewer words than changed");
        journal.undo(&mut g, None);
        assert_eq!(g, g0, "undone from the journal, {simd:?}, mask {mask:x?}");
    }
}

fn check_mask(mask: &[u32]) {
    let g0: Vec<u32> = (0..mask.len() as u32)
        .map(|i| i.wrapping_mul(0x9E37_79B9))
        .collect();
    let p0: Vec<u32> = (0..mask.len() as u32)
        .map(|i| !i.wrapping_mul(0x85EB_CA6B))
        .collect();
    check(mask, &g0, &p0);
}

#[test]
fn every_shape_of_ownership_merges_as_the_masks_say() {
    check_mask(&[]);
    check_mask(&[0; 5]);
    check_mask(&[u32::MAX; 20]);
    check_mask(&[u32::MAX]);
    check_mask(&[0x10]);
    // Interleaved single words, a long run, a short run, partial words at the ends.
    let mut mask: Vec<u32> = (0..64)
        .map(|i| if i % 4 == 1 { u32::MAX } else { 0 })
        .collect();
    mask.extend([u32::MAX; 9]);
    mask.extend([0, u32::MAX, u32::MAX, 0x0000_FF00, 0x8000_0001]);
    check_mask(&mask);
    check_mask(&[0x0F, u32::MAX, 0xF0]);
    // Dense patterns, and one pattern over more than a journal chunk.
    let dense: Vec<u32> = (0..40).map(|i| if i % 8 == 0 { 0 } else { 7 }).collect();
    check_mask(&dense);
    let long: Vec<u32> = (0..1000).map(|i| if i % 4 == 1 { !0 } else { 0 }).collect();
    check_mask(&long);
    // Every kind of step over several journal chunks, the image ending inside a block.
    let mut chunks: Vec<u32> = (0..2 * CHUNK + 40)
        .map(|i| if i % 4 == 1 { !0 } else { 0 })
        .collect();
    chunks.extend(vec![u32::MAX; CHUNK + 3]);
    chunks.extend((0..CHUNK + 100).map(|i| if i % 3 == 0 { 0 } else { 0xF0 }));
    chunks.extend(vec![0; CHUNK]);
    chunks.extend((0..CHUNK + 7).map(|i| if i % 16 == 5 { 0x8000_0000 } else { 0 }));
    check_mask(&chunks);
}

/// A mask in runs: nobody's, the module's, a partial word repeated, every `k`-th word.
fn masks() -> impl Strategy<Value = Vec<u32>> {
    // Every k-th word for k up to 17: one to eight owned words in a block.
    let run = (0u8..4, 1usize..80, any::<u32>(), 1usize..18).prop_map(|(kind, len, bits, k)| {
        (0..len)
            .map(|i| match kind {
                0 => 0,
                1 => u32::MAX,
                2 => bits,
                _ if i % k == 0 => u32::MAX,
                _ => 0,
            })
            .collect::<Vec<u32>>()
    });
    prop::collection::vec(run, 0..12).prop_map(|runs| runs.concat())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    #[test]
    fn the_plan_merges_and_journals_any_ownership_as_word_by_word(
        (mask, g0, p0) in masks().prop_flat_map(|m| {
            let n = m.len();
            (
                Just(m),
                prop::collection::vec(any::<u32>(), n),
                prop::collection::vec(any::<u32>(), n),
            )
        })
    ) {
        check(&mask, &g0, &p0);
    }
}
