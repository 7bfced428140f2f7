//! One shard of the state set: an open-addressing hash table whose slots hold the packed keys
//! themselves (one memory access decides most look-ups), plus the order in which states were
//! inserted, which is the exploration's queue and numbering.

use crate::layout::{hash, Stride};

/// Number of hash shards (a power of two: the top bits of a hash pick one).
pub(crate) const SHARDS: usize = 64;

/// The shard of a state with hash `h`.
#[inline]
pub(crate) fn shard_of(h: u64) -> usize {
    (h >> 58) as usize
}

/// Slots are grown when this fraction (×1/8) is full: linear probing stays short below it.
const MAX_LOAD_EIGHTHS: usize = 6;

pub(crate) struct Shard {
    /// `cap × k` words; a slot whose word 0 is 0 is empty (stored keys carry `MARK`).
    keys: Vec<u64>,
    mask: usize,
    /// The slot of each state, by local number (insertion order).
    pub order: Vec<u32>,
}

impl Shard {
    pub fn new(k: usize, cap: usize) -> Shard {
        let cap = cap.next_power_of_two().max(16);
        Shard {
            keys: vec![0; cap * k],
            mask: cap - 1,
            order: Vec::new(),
        }
    }

    pub fn len(&self) -> usize {
        self.order.len()
    }

    pub fn capacity(&self) -> usize {
        self.mask + 1
    }

    /// The key of local state `i`.
    #[inline]
    pub fn key<S: Stride>(&self, s: S, i: usize) -> &[u64] {
        let k = s.k();
        let slot = self.order[i] as usize;
        &self.keys[slot * k..slot * k + k]
    }

    /// Reads the first slot `h` probes, to start its cache miss early (the value is unused).
    #[inline]
    pub fn touch<S: Stride>(&self, s: S, h: u64) -> u64 {
        self.keys[(h as usize & self.mask) * s.k()]
    }

    /// The slot holding `key`, if it is stored.
    #[inline]
    pub fn find<S: Stride>(&self, s: S, key: &[u64], h: u64) -> Option<usize> {
        let k = s.k();
        let mut i = h as usize & self.mask;
        loop {
            let slot = &self.keys[i * k..i * k + k];
            if slot[0] == 0 {
                return None;
            }
            if (0..k).all(|j| slot[j] == key[j]) {
                return Some(i);
            }
            i = (i + 1) & self.mask;
        }
    }

    /// Inserts `key` (hash `h`) unless present; true when it is new.
    #[inline]
    pub fn insert<S: Stride>(&mut self, s: S, key: &[u64], h: u64) -> bool {
        if (self.order.len() + 1) * 8 > self.capacity() * MAX_LOAD_EIGHTHS {
            self.grow(s);
        }
        let k = s.k();
        let mut i = h as usize & self.mask;
        loop {
            let slot = &mut self.keys[i * k..i * k + k];
            if slot[0] == 0 {
                slot.copy_from_slice(&key[..k]);
                self.order.push(i as u32);
                return true;
            }
            if (0..k).all(|j| slot[j] == key[j]) {
                return false;
            }
            i = (i + 1) & self.mask;
        }
    }

    /// Doubles the table, keeping every state's local number.
    fn grow<S: Stride>(&mut self, s: S) {
        let k = s.k();
        let cap = self.capacity() * 2;
        assert!(cap <= 1 << 32, "a shard outgrew u32 slot numbers");
        let old = std::mem::replace(&mut self.keys, vec![0; cap * k]);
        self.mask = cap - 1;
        for slot in self.order.iter_mut() {
            let key = &old[*slot as usize * k..*slot as usize * k + k];
            let mut i = hash(key) as usize & self.mask;
            while self.keys[i * k] != 0 {
                i = (i + 1) & self.mask;
            }
            self.keys[i * k..i * k + k].copy_from_slice(key);
            *slot = i as u32;
        }
    }

    /// Bytes held, for reports.
    pub fn bytes(&self) -> usize {
        self.keys.capacity() * 8 + self.order.capacity() * 4
    }

    /// Frees what growth left unused (after exploration).
    pub fn shrink(&mut self) {
        self.order.shrink_to_fit();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::{Dyn, Fixed, MARK};

    /// Inserts keys (word 0 gets MARK) and reports which were new, then the insertion order.
    fn check(keys: &[[u64; 2]], expect: &str) {
        let mut fixed = Shard::new(2, 1);
        let mut dynamic = Shard::new(2, 1);
        let mut got = Vec::new();
        for k in keys {
            let key = [k[0] | MARK, k[1]];
            let h = hash(&key);
            let a = fixed.insert(Fixed::<2>, &key, h);
            let b = dynamic.insert(Dyn(2), &key, h);
            assert_eq!(a, b);
            assert!(fixed.find(Fixed::<2>, &key, h).is_some());
            got.push(if a { "new" } else { "old" });
        }
        let order: Vec<u64> = (0..fixed.len())
            .map(|i| fixed.key(Fixed::<2>, i)[0] & !MARK)
            .collect();
        assert_eq!(format!("{got:?} {order:?}"), expect);
    }

    #[test]
    fn dedups_and_keeps_insertion_order() {
        check(
            &[[3, 0], [1, 0], [3, 0], [0, 0], [1, 1]],
            r#"["new", "new", "old", "new", "new"] [3, 1, 0, 1]"#,
        );
    }

    #[test]
    fn growth_keeps_local_numbers() {
        let keys: Vec<[u64; 2]> = (0..1000).map(|i| [i % 300, i / 300]).collect();
        let mut s = Shard::new(2, 1);
        for k in &keys {
            let key = [k[0] | MARK, k[1]];
            s.insert(Fixed::<2>, &key, hash(&key));
        }
        assert_eq!(s.len(), 1000);
        assert!(s.capacity() >= 1000 * 8 / MAX_LOAD_EIGHTHS);
        for (i, k) in keys.iter().enumerate() {
            assert_eq!(s.key(Fixed::<2>, i), &[k[0] | MARK, k[1]]);
            let missing = [k[0] | MARK, k[1] + 10];
            assert_eq!(s.find(Fixed::<2>, &missing, hash(&missing)), None);
        }
    }
}
