//! A write cut short at any byte, or any byte of the newest copy damaged, never gives back
//! a mix of two snapshots: the file gives the newest whole snapshot, the older one with a
//! warning when the newest is damaged.

use std::time::SystemTime;

use petriplc_config::PointKind;
use petriplc_retain::file::RetainFile;
use petriplc_retain::{Entry, Identity, Value};
use proptest::prelude::*;

fn entries(v: u32, n: usize) -> Vec<Entry> {
    (0..n)
        .map(|i| Entry {
            name: format!("p{i}"),
            value: Value::Point {
                kind: PointKind::Unsigned,
                bits: 32,
                raw: v,
            },
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    #[test]
    fn torn_or_damaged_newest_copy_falls_back_whole(
        n in 1usize..60,
        cut in 0usize..4096,
        flip in proptest::option::of(0usize..4096),
    ) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.retain");
        let ident = Identity { plc_id: "t".into(), config: "t.conf".into() };
        let (mut f, _) = RetainFile::open(&path).unwrap();
        f.write(&ident, &entries(1, n), SystemTime::now()).unwrap();
        f.write(&ident, &entries(2, n), SystemTime::now()).unwrap();
        let before = std::fs::read(&path).unwrap();
        f.write(&ident, &entries(3, n), SystemTime::now()).unwrap();
        drop(f);
        let after = std::fs::read(&path).unwrap();
        // Snapshot 3 went to slot 1: keep its first `cut` bytes, the rest as before the
        // write (a write that stopped there), then perhaps damage one byte of it.
        let slot = after.len() / 2;
        let mut torn = after.clone();
        torn[slot + cut..2 * slot].copy_from_slice(&before[slot + cut..2 * slot]);
        if let Some(i) = flip {
            torn[slot + i] ^= 0x20;
        }
        std::fs::write(&path, &torn).unwrap();
        let (_, loaded) = RetainFile::open(&path).unwrap();
        let snap = loaded.snapshot.unwrap();
        let values: Vec<u32> = snap.entries.iter().map(|e| match e.value {
            Value::Point { raw, .. } => raw,
            Value::Data { .. } => unreachable!(),
        }).collect();
        prop_assert_eq!(values.len(), n);
        prop_assert!(values.iter().all(|&v| v == values[0]), "a mix: {:?}", values);
        let whole = torn[slot..2 * slot] == after[slot..2 * slot];
        // Cut before the write changed any byte of the older copy's record (header and
        // payload; a flip in the unused rest does not count): that copy is still whole, so
        // the newest whole snapshot (2) comes back with nothing to warn about.
        let len = u32::from_le_bytes(before[slot + 32..slot + 36].try_into().unwrap());
        let record = slot..slot + 40 + len as usize;
        let untouched = torn[record.clone()] == before[record];
        if whole {
            prop_assert_eq!((snap.seq, values[0]), (3, 3));
            prop_assert!(loaded.warnings.is_empty());
        } else if untouched {
            prop_assert_eq!((snap.seq, values[0]), (2, 2));
            prop_assert!(loaded.warnings.is_empty());
        } else {
            prop_assert!(snap.seq == 2 || snap.seq == 3);
            prop_assert_eq!(values[0] as u64, snap.seq);
            if snap.seq == 2 {
                prop_assert!(!loaded.warnings.is_empty());
            }
        }
    }
}

/// Any bytes at the retain file's path — random, zeros, a valid file cut or grown anywhere,
/// a header claiming more than the file holds — open without a panic: a snapshot that is
/// one whole copy, or an error that names the file; never a mix.
fn arbitrary_file() -> impl Strategy<Value = Vec<u8>> {
    let valid = (1usize..40, 1u32..4).prop_map(|(n, writes)| {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.retain");
        let ident = Identity {
            plc_id: "t".into(),
            config: "t.conf".into(),
        };
        let (mut f, _) = RetainFile::open(&path).unwrap();
        for w in 0..writes {
            f.write(&ident, &entries(w, n), SystemTime::now()).unwrap();
        }
        drop(f);
        std::fs::read(&path).unwrap()
    });
    prop_oneof![
        proptest::collection::vec(any::<u8>(), 0..20_000),
        (0usize..20_000).prop_map(|n| vec![0u8; n]),
        (valid.clone(), any::<prop::sample::Index>())
            .prop_map(|(b, i)| b[..i.index(b.len() + 1)].to_vec()),
        (
            valid.clone(),
            proptest::collection::vec(any::<u8>(), 1..5000)
        )
            .prop_map(|(mut b, tail)| {
                b.extend(tail);
                b
            }),
        (valid, any::<prop::sample::Index>(), any::<u8>()).prop_map(|(mut b, i, x)| {
            let i = i.index(b.len());
            b[i] ^= x | 1;
            b
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    #[test]
    fn any_bytes_open_to_a_whole_snapshot_or_an_error(bytes in arbitrary_file()) {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.retain");
        std::fs::write(&path, &bytes).unwrap();
        match RetainFile::open(&path) {
            Ok((mut f, loaded)) => {
                if let Some(snap) = &loaded.snapshot {
                    let values: Vec<u32> = snap.entries.iter().filter_map(|e| match e.value {
                        Value::Point { raw, .. } => Some(raw),
                        Value::Data { .. } => None,
                    }).collect();
                    prop_assert!(values.iter().all(|&v| v == values[0]), "a mix: {:?}", values);
                }
                // And the file can be written again.
                let ident = Identity { plc_id: "t".into(), config: "t.conf".into() };
                prop_assert!(f.write(&ident, &entries(9, 3), SystemTime::now()).is_ok());
            }
            Err(e) => prop_assert!(e.to_string().contains("t.retain"), "{}", e),
        }
    }
}
