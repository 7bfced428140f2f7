//! Packed markings: each place gets a bit field just wide enough for the tokens seen so far, so
//! a state is one to a few `u64` words, hashed and compared as words and fired by adding one
//! precomputed word per transition.
//!
//! Widths start small (from the initial marking) and grow when a successor does not fit
//! ([`Layout::widen`]); a static bound (capacity, or the token count of a conservative net)
//! caps them. Places no transition changes (input places, self-loops only) take no bits.

use petriplc_net::{Net, PlaceId, TransitionArcs};

/// Set in word 0 of every stored key, so that an all-zero word 0 marks an empty hash slot.
pub(crate) const MARK: u64 = 1 << 63;

/// Where one place's tokens sit in a key. `max == 0` means the place is constant and not
/// stored at all (its value is the initial marking's).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Field {
    pub word: u32,
    pub shift: u32,
    pub max: u32,
}

/// The encoding of markings as keys of `words` words.
#[derive(Clone, Debug)]
pub(crate) struct Layout {
    pub words: usize,
    pub fields: Vec<Field>,
    /// Bits per place (0 for constant places).
    pub bits: Vec<u32>,
    /// Places that are stored, in field order.
    pub var: Vec<u32>,
    /// A decoded marking with the constant places filled in and 0 elsewhere.
    pub base: Vec<u32>,
    /// The most bits a place can ever need (its static bound).
    cap_bits: Vec<u32>,
}

/// First-fit decreasing placement: (place, word) for every stored place, and the bits left in
/// each word (word 0 keeps its top bit for MARK).
fn first_fit(bits: &[u32]) -> (Vec<(u32, usize)>, Vec<u32>) {
    let mut var: Vec<u32> = (0..bits.len() as u32)
        .filter(|&i| bits[i as usize] > 0)
        .collect();
    var.sort_by_key(|&i| (std::cmp::Reverse(bits[i as usize]), i));
    let mut room: Vec<u32> = vec![63];
    let placed = var
        .iter()
        .map(|&i| {
            let b = bits[i as usize];
            let w = match room.iter().position(|&r| r >= b) {
                Some(w) => w,
                None => {
                    room.push(64);
                    room.len() - 1
                }
            };
            room[w] -= b;
            (i, w)
        })
        .collect();
    (placed, room)
}

/// Hands the bits the last word leaves unused to the fields, always to the narrowest one
/// (water-filling), where a place seen with at most one token counts two bits wider (it is
/// likely a safe place): free headroom that saves later widenings, each of which re-encodes
/// every state. Skipped for very large nets, where repacking for every trial would cost too
/// much.
fn spare(mut bits: Vec<u32>, cap_bits: &[u32], seen: &[u64]) -> Vec<u32> {
    if bits.len() > 512 {
        return bits;
    }
    let words = first_fit(&bits).1.len();
    let mut open: Vec<bool> = bits
        .iter()
        .zip(cap_bits)
        .map(|(&b, &c)| b > 0 && b < c.min(32))
        .collect();
    while let Some(i) = (0..bits.len())
        .filter(|&i| open[i])
        .min_by_key(|&i| (bits[i] + if seen[i] <= 1 { 2 } else { 0 }, i))
    {
        bits[i] += 1;
        if first_fit(&bits).1.len() > words {
            bits[i] -= 1;
            open[i] = false;
        } else if bits[i] >= cap_bits[i].min(32) {
            open[i] = false;
        }
    }
    bits
}

/// Bits needed to write `v`.
pub(crate) fn bits_for(v: u64) -> u32 {
    64 - v.leading_zeros()
}

impl Layout {
    /// The first layout for `net`: each changing place gets room for its initial tokens (one
    /// bit at least).
    pub fn new(net: &Net) -> Layout {
        let m0 = net.initial_marking().0;
        let n = m0.len();
        let mut constant = vec![true; n];
        // Conservative (every transition puts back as many tokens as it takes): no place can
        // ever hold more than the initial total.
        let mut conservative = true;
        for t in net.transition_ids() {
            let a = net.arcs_of(t);
            let (c, p): (u64, u64) = (
                a.consume.iter().map(|&(_, w)| u64::from(w)).sum(),
                a.produce.iter().map(|&(_, w)| u64::from(w)).sum(),
            );
            conservative &= c == p;
            for &(q, _) in a.consume.iter().chain(&a.produce) {
                if net.incidence(q, t) != 0 {
                    constant[q.index()] = false;
                }
            }
        }
        let total: u64 = m0.iter().map(|&v| u64::from(v)).sum();
        let cap_bits: Vec<u32> = net
            .place_ids()
            .map(|p| {
                let mut b = 32;
                if let Some(c) = net.bound(p) {
                    b = b.min(bits_for(u64::from(c)));
                }
                if conservative {
                    b = b.min(bits_for(total));
                }
                b.max(1)
            })
            .collect();
        let bits: Vec<u32> = (0..n)
            .map(|i| {
                if constant[i] {
                    0
                } else {
                    bits_for(u64::from(m0[i]).max(1)).min(cap_bits[i])
                }
            })
            .collect();
        let base = (0..n)
            .map(|i| if constant[i] { m0[i] } else { 0 })
            .collect();
        let seen: Vec<u64> = m0.iter().map(|&v| u64::from(v)).collect();
        Layout::pack(spare(bits, &cap_bits, &seen), base, cap_bits)
    }

    /// A layout for states whose places hold at most `most[p]` tokens: each field just fits
    /// its maximum, with one bit more when that maximum fills it (it is likely to grow), then
    /// the spare bits of the last word go to the fields most likely to grow. Fields may shrink
    /// (spare bits handed out earlier are taken back), so `most` must cover every state that
    /// will be re-encoded.
    pub fn widen(&self, most: &[u64]) -> Layout {
        let bits = self
            .bits
            .iter()
            .enumerate()
            .map(|(i, &b)| {
                if b == 0 {
                    return 0;
                }
                let v = most[i].max(1);
                let mut b = bits_for(v);
                if b >= 2 && v == (1u64 << b) - 1 {
                    b += 1;
                }
                b.min(self.cap_bits[i].max(bits_for(v))).min(32)
            })
            .collect();
        Layout::pack(
            spare(bits, &self.cap_bits, most),
            self.base.clone(),
            self.cap_bits.clone(),
        )
    }

    /// First-fit decreasing: wide fields first, each into the first word with room. No field
    /// straddles two words, so that firing is one wrapping add per word.
    fn pack(bits: Vec<u32>, base: Vec<u32>, cap_bits: Vec<u32>) -> Layout {
        let (var, room) = first_fit(&bits);
        let mut fields = vec![
            Field {
                word: 0,
                shift: 0,
                max: 0
            };
            bits.len()
        ];
        let mut left: Vec<u32> = room.iter().map(|_| 0).collect();
        left[0] = 63;
        for l in left.iter_mut().skip(1) {
            *l = 64;
        }
        for &(i, w) in &var {
            let b = bits[i as usize];
            let used = if w == 0 { 63 } else { 64 } - left[w];
            left[w] -= b;
            fields[i as usize] = Field {
                word: w as u32,
                shift: used,
                max: (((1u64) << b) - 1) as u32,
            };
        }
        let var = var.iter().map(|&(i, _)| i).collect();
        Layout {
            words: room.len(),
            fields,
            bits,
            var,
            base,
            cap_bits,
        }
    }

    /// Writes the key of marking `m` into `out` (`words` long).
    pub fn encode(&self, m: &[u32], out: &mut [u64]) {
        out.fill(0);
        out[0] = MARK;
        for &i in &self.var {
            let f = self.fields[i as usize];
            out[f.word as usize] |= u64::from(m[i as usize]) << f.shift;
        }
    }

    /// Whether every place of `m` fits its field.
    #[cfg(test)]
    pub fn fits(&self, m: &[u32]) -> bool {
        self.var
            .iter()
            .all(|&i| m[i as usize] <= self.fields[i as usize].max)
    }

    /// Reads a key into `m`, which must start as a copy of [`Layout::base`] (constant places
    /// are never written).
    #[inline]
    pub fn decode(&self, key: &[u64], m: &mut [u32]) {
        for &i in &self.var {
            let f = self.fields[i as usize];
            m[i as usize] = ((key[f.word as usize] >> f.shift) & u64::from(f.max)) as u32;
        }
    }

    /// The words to add to a key to fire a transition with these arcs. Valid whenever the
    /// transition is enabled and its successor fits the layout: then no field borrows or
    /// carries, so the wrapping sum per word is exact.
    pub fn delta(&self, arcs: &TransitionArcs) -> Vec<u64> {
        let mut d = vec![0u64; self.words];
        let mut add = |p: PlaceId, w: u32, sign: bool| {
            let f = self.fields[p.index()];
            if f.max == 0 {
                return;
            }
            let v = u64::from(w) << f.shift;
            let slot = &mut d[f.word as usize];
            *slot = if sign {
                slot.wrapping_add(v)
            } else {
                slot.wrapping_sub(v)
            };
        };
        for &(p, w) in &arcs.produce {
            add(p, w, true);
        }
        for &(p, w) in &arcs.consume {
            add(p, w, false);
        }
        d
    }
}

/// Hash of a key: a multiply-xor chain over the words and a final avalanche, so that both the
/// top bits (shard) and the low bits (slot) are well mixed.
#[inline]
pub(crate) fn hash(key: &[u64]) -> u64 {
    let mut h: u64 = 0x243F_6A88_85A3_08D3;
    for &w in key {
        h = (h ^ w).wrapping_mul(0x9E37_79B9_7F4A_7C15);
        h ^= h >> 32;
    }
    h ^= h >> 33;
    h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    h ^= h >> 33;
    h = h.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
    h ^ (h >> 33)
}

/// The number of words in a key, fixed at compile time for the common small sizes so that the
/// hot loops unroll, or known only at run time.
pub(crate) trait Stride: Copy + Send + Sync {
    fn k(self) -> usize;
}

#[derive(Clone, Copy)]
pub(crate) struct Fixed<const K: usize>;

impl<const K: usize> Stride for Fixed<K> {
    #[inline(always)]
    fn k(self) -> usize {
        K
    }
}

#[derive(Clone, Copy)]
pub(crate) struct Dyn(pub usize);

impl Stride for Dyn {
    #[inline(always)]
    fn k(self) -> usize {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testnet::parse;

    /// Lays out a net, then round-trips and fires its initial marking.
    fn check(net_text: &str, expect: &str) {
        let net = parse(net_text);
        let l = Layout::new(&net);
        let m0 = net.initial_marking().0;
        let mut key = vec![0; l.words];
        l.encode(&m0, &mut key);
        let mut back = l.base.clone();
        l.decode(&key, &mut back);
        assert_eq!(back, m0);
        let mut fired = Vec::new();
        for t in net.transition_ids() {
            if net.is_enabled(&net.initial_marking(), t) {
                let mut m = net.initial_marking();
                net.fire(&mut m, t).unwrap();
                if l.fits(&m.0) {
                    let d = l.delta(net.arcs_of(t));
                    let k2: Vec<u64> = key
                        .iter()
                        .zip(&d)
                        .map(|(a, b)| a.wrapping_add(*b))
                        .collect();
                    let mut got = l.base.clone();
                    l.decode(&k2, &mut got);
                    assert_eq!(got, m.0);
                    fired.push(net.transition_label(t).to_string());
                }
            }
        }
        let got = format!("words {} bits {:?} fired {:?}", l.words, l.bits, fired);
        assert_eq!(got, expect);
    }

    #[test]
    fn constant_places_take_no_bits_and_spare_bits_are_handed_out() {
        // `c` is only read (constant), `i` is an input place: neither takes bits. The word's
        // 63 bits go to `a` and `b`, the one seen with 3 tokens first.
        check(
            "a=3 b c=1 i? ; t: a -> b*2 ?c ; u: b -> a !i",
            "words 1 bits [32, 31, 0, 0] fired [\"t\"]",
        );
    }

    #[test]
    fn capacity_and_conservation_cap_widths() {
        // Conservative with 2 tokens: no place needs more than 2 bits; c's capacity is 1.
        check(
            "a=2 b c<1 ; t: a -> b ; u: b -> c",
            "words 1 bits [2, 2, 1] fired [\"t\"]",
        );
    }

    #[test]
    fn widening_fits_the_most_seen_and_doubles_full_fields() {
        let net = parse("a=1 b ; t: a -> b*2");
        let l = Layout::new(&net);
        let w = l.widen(&[1, 40]);
        assert_eq!(w.words, 1);
        assert!(w.fields[1].max >= 40);
        let mut key = vec![0; w.words];
        w.encode(&[1, 40], &mut key);
        let mut m = w.base.clone();
        w.decode(&key, &mut m);
        assert_eq!(m, vec![1, 40]);
    }

    #[test]
    fn many_places_spill_into_more_words() {
        let places: Vec<String> = (0..40).map(|i| format!("p{i}=3")).collect();
        let trs: Vec<String> = (0..39)
            .map(|i| format!("t{i}: p{i} -> p{}", i + 1))
            .collect();
        let net = parse(&format!("{} ; {}", places.join(" "), trs.join(" ; ")));
        let l = Layout::new(&net);
        // 40 changing places of 2 bits at least: two words, every field within one word.
        assert_eq!(l.words, 2);
        assert!(l.bits.iter().all(|&b| b >= 2));
        let mut most = vec![3u64; 40];
        most[1] = u64::from(u32::MAX);
        let wide = l.widen(&most);
        assert_eq!(wide.bits[1], 32);
        assert!(wide
            .fields
            .iter()
            .zip(&wide.bits)
            .all(|(f, &b)| f.shift + b <= if f.word == 0 { 63 } else { 64 }));
    }
}
