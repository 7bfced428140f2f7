//! TwinCAT's and CODESYS's dynamic memory (`__NEW`, `__DELETE`) as the VM keeps it: a region
//! of fixed size after the program's variables, in the same memory (so the VM, machine code
//! and the lockstep tests see one state), whose objects are reached only through checked
//! handles (docs/iec.md, "Dynamic memory").
//!
//! The region holds a header (the epoch, two search positions, the count of live objects),
//! a table of [`ENTRIES`] objects, an owner map (for each data slot, the object holding it)
//! and [`DATA`] slots of data. A handle of a heap object names its table entry and the
//! entry's generation, never its address: `__DELETE` bumps the generation, so every copy of
//! the pointer is stale from then on and a dereference is a fault, not a read of whatever
//! is allocated there next. A deleted object's slots are reused only after the program
//! instance that deleted it has returned (the epoch): a method still running on an object it
//! deleted (`__DELETE(THIS)`) writes slots nobody else holds.

use crate::ext::OpFault;
use crate::handle::{HEAP_BIT, SUB_BIT};
use petriplc_iec_sema::ops::OpError;

/// Objects alive at once (the table's entries; an index takes 15 bits of a handle).
pub const ENTRIES: u64 = 1 << 15;
/// Slots of data (a BYTE, an INT or a REAL takes one, a STRING one per eight characters).
pub const DATA: u64 = 1 << 18;
const HEADER: u64 = 4;
const ENTRY_SLOTS: u64 = 3;

const INDEX_BITS: u32 = 15;
const GEN_BITS: u32 = 11;

const FREE: u64 = 0;
const LIVE: u64 = 1;
/// Deleted; its slots are reclaimed once the epoch has moved on.
const PENDING: u64 = 2;

/// Where the region lies in memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    pub at: u64,
}

/// An object's table entry, unpacked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Entry {
    start: u64,
    len: u64,
    state: u64,
    gen: u64,
    /// The type id of its elements.
    tag: u64,
    count: u64,
    deleted: u64,
}

/// What a heap handle designates: the first slot of the variable, the byte offset of the
/// access and how many values of the handle's type lie from the first slot on.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Designated {
    pub first: u64,
    pub off: i64,
    pub count: u64,
}

fn fault(what: &'static str, detail: impl Into<String>) -> OpFault {
    OpFault::new(OpError::Domain(what), detail)
}

impl Layout {
    /// Slots the region takes.
    pub const fn slots() -> u64 {
        HEADER + ENTRY_SLOTS * ENTRIES + 2 * DATA
    }
    fn epoch(self) -> usize {
        self.at as usize
    }
    fn rover(self) -> usize {
        self.at as usize + 1
    }
    fn entry_rover(self) -> usize {
        self.at as usize + 2
    }
    fn live_count(self) -> usize {
        self.at as usize + 3
    }
    fn entry_at(self, i: u64) -> usize {
        (self.at + HEADER + ENTRY_SLOTS * i) as usize
    }
    fn owner(self) -> u64 {
        self.at + HEADER + ENTRY_SLOTS * ENTRIES
    }
    /// The first data slot.
    pub fn data(self) -> u64 {
        self.owner() + DATA
    }
    /// Whether slot `addr` is heap data.
    pub fn holds(self, addr: u64) -> bool {
        (self.data()..self.data() + DATA).contains(&addr)
    }

    fn read(self, mem: &[u64], i: u64) -> Entry {
        let at = self.entry_at(i);
        let (a, b) = (mem[at], mem[at + 1]);
        Entry {
            start: a & 0xffff_ffff,
            len: a >> 32,
            state: b & 3,
            gen: (b >> 2) & ((1 << GEN_BITS) - 1),
            tag: (b >> 13) & 0xffff,
            count: b >> 29,
            deleted: mem[at + 2],
        }
    }

    fn write(self, mem: &mut [u64], i: u64, e: Entry) {
        let at = self.entry_at(i);
        mem[at] = e.start | e.len << 32;
        mem[at + 1] = e.state | e.gen << 2 | e.tag << 13 | e.count << 29;
        mem[at + 2] = e.deleted;
    }

    /// A new epoch: the objects deleted before it may be reclaimed. Called before each
    /// program instance runs.
    #[inline]
    pub fn tick(self, mem: &mut [u64]) {
        mem[self.epoch()] = mem[self.epoch()].wrapping_add(1);
    }

    /// Objects alive now.
    pub fn live(self, mem: &[u64]) -> u64 {
        mem[self.live_count()]
    }

    /// Frees a deleted object's slots once its epoch is over (true: the entry is free).
    fn reclaim(self, mem: &mut [u64], i: u64) -> bool {
        let mut e = self.read(mem, i);
        match e.state {
            FREE => true,
            PENDING if e.deleted != mem[self.epoch()] => {
                let o = (self.owner() + e.start) as usize;
                mem[o..o + e.len as usize].fill(0);
                e.state = FREE;
                self.write(mem, i, e);
                true
            }
            _ => false,
        }
    }

    /// A new object of `count` values of type `tag` (`slots` each), every one a copy of the
    /// `slots` at `proto` (the type's initial value): its handle, or NULL (0) when the table
    /// or the data are full, as TwinCAT's `__NEW` answers when memory runs out.
    pub fn new_object(self, mem: &mut [u64], tag: u32, slots: u64, count: u64, proto: u64) -> u64 {
        let Some(len) = slots.checked_mul(count).filter(|n| *n <= DATA) else {
            return 0;
        };
        let Some(i) = self.free_entry(mem) else {
            return 0;
        };
        let Some(start) = self.free_data(mem, len) else {
            return 0;
        };
        let o = (self.owner() + start) as usize;
        mem[o..o + len as usize].fill(i + 1);
        let d = (self.data() + start) as usize;
        for k in 0..count as usize {
            let at = d + k * slots as usize;
            mem.copy_within(proto as usize..(proto + slots) as usize, at);
        }
        let gen = self.read(mem, i).gen;
        self.write(
            mem,
            i,
            Entry {
                start,
                len,
                state: LIVE,
                gen,
                tag: u64::from(tag),
                count,
                deleted: 0,
            },
        );
        mem[self.entry_rover()] = (i + 1) % ENTRIES;
        mem[self.rover()] = start + len;
        mem[self.live_count()] += 1;
        crate::handle::encode(HEAP_BIT | gen << INDEX_BITS | i, tag, 0)
    }

    /// A free table entry, searched from after the last one given (so that an entry comes
    /// back only after the others have been used, which spaces out its generations).
    fn free_entry(self, mem: &mut [u64]) -> Option<u64> {
        let from = mem[self.entry_rover()] % ENTRIES;
        (0..ENTRIES)
            .map(|k| (from + k) % ENTRIES)
            .find(|&i| self.reclaim(mem, i))
    }

    /// `len` free data slots in a row, first fit from after the last object given.
    fn free_data(self, mem: &mut [u64], len: u64) -> Option<u64> {
        let mut x = mem[self.rover()].min(DATA);
        let mut wrapped = false;
        'search: loop {
            if x + len > DATA {
                if wrapped {
                    return None;
                }
                wrapped = true;
                x = 0;
                continue;
            }
            let mut y = x;
            while y < x + len {
                let owner = mem[(self.owner() + y) as usize];
                if owner == 0 {
                    y += 1;
                } else if self.reclaim(mem, owner - 1) {
                    // Its slots are free now: look at this one again.
                } else {
                    let e = self.read(mem, owner - 1);
                    x = e.start + e.len;
                    continue 'search;
                }
            }
            return Some(x);
        }
    }

    /// The live entry a heap handle's base field names, or the fault of a stale one.
    fn entry_of(self, mem: &[u64], base: u64, what: &str) -> Result<(u64, Entry), OpFault> {
        let i = base & ((1 << INDEX_BITS) - 1);
        let gen = (base >> INDEX_BITS) & ((1 << GEN_BITS) - 1);
        let e = self.read(mem, i);
        if e.state != LIVE || e.gen != gen {
            return Err(fault(
                "dangling pointer",
                format!("this {what} designates an object that __DELETE has freed; set it to 0 when deleting it (__DELETE does that to the pointer it is given, not to its copies)"),
            ));
        }
        Ok((i, e))
    }

    /// What the heap handle with base field `base` and offset field `off` designates.
    pub fn designated(
        self,
        mem: &[u64],
        base: u64,
        off: i64,
        what: &str,
    ) -> Result<Designated, OpFault> {
        let (_, e) = self.entry_of(mem, base, what)?;
        let first = self.data() + e.start;
        if base & SUB_BIT != 0 {
            return Ok(Designated {
                first: first + off as u64,
                off: 0,
                count: 1,
            });
        }
        Ok(Designated {
            first,
            off,
            count: e.count,
        })
    }

    /// The handle of the variable of type `ty` at data slot `addr` (`THIS` of an object,
    /// `ADR(p^.x)`): the object's own handle when it is the whole object, else one of a part.
    pub fn handle_at(self, mem: &[u64], addr: u64, ty: u32) -> Result<u64, OpFault> {
        let k = addr - self.data();
        let owner = mem[(self.owner() + k) as usize];
        let dead = || {
            fault(
                "dangling pointer",
                "the address of a part of an object that __DELETE has freed",
            )
        };
        if owner == 0 {
            return Err(dead());
        }
        let i = owner - 1;
        let e = self.read(mem, i);
        if e.state != LIVE {
            return Err(dead());
        }
        let at = k - e.start;
        let base = HEAP_BIT | e.gen << INDEX_BITS | i;
        if at == 0 && u64::from(ty) == e.tag {
            return Ok(crate::handle::encode(base, ty, 0));
        }
        Ok(crate::handle::encode(base | SUB_BIT, ty, at as i64))
    }

    /// `__DELETE`: the object the handle designates is freed (NULL: nothing happens).
    pub fn delete(self, mem: &mut [u64], h: u64, what: &str) -> Result<(), OpFault> {
        if h == 0 {
            return Ok(());
        }
        let (base, _, off) = crate::handle::decode(h);
        if base & HEAP_BIT == 0 {
            return Err(not_made());
        }
        let (i, mut e) = self.entry_of(mem, base, what)?;
        if off != 0 {
            return Err(fault(
                "invalid pointer",
                "__DELETE of a pointer into an object: give it the pointer __NEW returned",
            ));
        }
        e.state = PENDING;
        e.gen = (e.gen + 1) & ((1 << GEN_BITS) - 1);
        e.deleted = mem[self.epoch()];
        self.write(mem, i, e);
        mem[self.live_count()] -= 1;
        Ok(())
    }

    /// TwinCAT's `F_CheckMemoryArea`: 2 (Dynamic) for a live heap object, 1 (Static) for any
    /// other variable, 0 (Unknown) for NULL or a stale pointer.
    pub fn area(self, mem: &[u64], h: u64) -> u64 {
        if h == 0 {
            return 0;
        }
        let (base, _, _) = crate::handle::decode(h);
        if base & HEAP_BIT == 0 {
            return 1;
        }
        match self.entry_of(mem, base, "pointer") {
            Ok(_) => 2,
            Err(_) => 0,
        }
    }
}

/// `__DELETE` in a program that has no `__NEW`: only NULL may be deleted.
pub fn delete_static(h: u64) -> Result<(), OpFault> {
    if h == 0 {
        return Ok(());
    }
    Err(not_made())
}

fn not_made() -> OpFault {
    fault(
        "invalid pointer",
        "__DELETE of a pointer that __NEW did not give (the address of a variable): only objects made by __NEW are deleted",
    )
}

/// The memory area of a handle in a program without dynamic memory.
pub fn area_static(h: u64) -> u64 {
    u64::from(h != 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn region() -> (Layout, Vec<u64>) {
        // One prototype slot holding 7 before the region.
        let mut mem = vec![0u64; 1 + Layout::slots() as usize];
        mem[0] = 7;
        (Layout { at: 1 }, mem)
    }

    #[test]
    fn an_object_is_its_prototype_and_dies_with_delete() {
        let (h, mut mem) = region();
        let p = h.new_object(&mut mem, 3, 1, 4, 0);
        assert_ne!(p, 0);
        let (base, tag, _) = crate::handle::decode(p);
        assert_eq!(tag, 3);
        let d = h.designated(&mem, base, 0, "pointer").unwrap();
        assert_eq!(d.count, 4);
        assert_eq!(&mem[d.first as usize..d.first as usize + 4], &[7, 7, 7, 7]);
        assert_eq!(h.live(&mem), 1);
        assert_eq!(h.area(&mem, p), 2);
        h.delete(&mut mem, p, "pointer").unwrap();
        assert!(h.designated(&mem, base, 0, "pointer").is_err(), "stale");
        assert!(h.delete(&mut mem, p, "pointer").is_err(), "deleted twice");
        assert_eq!(h.area(&mem, p), 0);
    }

    #[test]
    fn deleted_slots_are_reused_only_in_a_later_epoch() {
        let (h, mut mem) = region();
        let a = h.new_object(&mut mem, 3, 1, DATA, 0);
        assert_ne!(a, 0, "the whole data");
        assert_eq!(h.new_object(&mut mem, 3, 1, 1, 0), 0, "full: NULL");
        h.delete(&mut mem, a, "pointer").unwrap();
        assert_eq!(h.new_object(&mut mem, 3, 1, 1, 0), 0, "same epoch");
        h.tick(&mut mem);
        let b = h.new_object(&mut mem, 3, 1, 1, 0);
        assert_ne!(b, 0);
        let (ba, _, _) = crate::handle::decode(a);
        assert!(
            h.designated(&mem, ba, 0, "p").is_err(),
            "the old handle stays stale"
        );
    }

    #[test]
    fn a_part_has_its_own_handle_and_the_whole_its_own() {
        let (h, mut mem) = region();
        let p = h.new_object(&mut mem, 5, 3, 1, 0);
        let (base, _, _) = crate::handle::decode(p);
        let first = h.designated(&mem, base, 0, "p").unwrap().first;
        assert_eq!(h.handle_at(&mem, first, 5).unwrap(), p);
        let part = h.handle_at(&mem, first + 2, 9).unwrap();
        let (pb, pt, po) = crate::handle::decode(part);
        assert_eq!((pt, po), (9, 2));
        let d = h.designated(&mem, pb, po, "p").unwrap();
        assert_eq!(
            (d.first, d.count, d.off),
            (first + 2, 1, 0),
            "one value, the part"
        );
        assert!(h.delete(&mut mem, part, "p").is_err(), "not the object");
        h.delete(&mut mem, p, "p").unwrap();
        assert!(
            h.designated(&mem, pb, po, "p").is_err(),
            "parts die with it"
        );
    }

    #[test]
    fn many_small_objects_fill_the_table_then_null() {
        let (h, mut mem) = region();
        let mut n = 0;
        while h.new_object(&mut mem, 1, 1, 1, 0) != 0 {
            n += 1;
        }
        assert_eq!(n, ENTRIES);
    }
}
