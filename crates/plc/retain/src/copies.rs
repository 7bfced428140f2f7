//! Finding a retain file's two copies in its bytes: the regular layout (two slots of whole
//! pages), a file cut short or added to by something other than petriplc, and a wiped one.
//!
//! Every file petriplc creates holds, from its first byte on disk, a stamp in copy 0: a
//! snapshot numbered 0 with no values (see [`crate::file::RetainFile::open`]). So a file at
//! the path that holds no copy at all — empty, or all zeros, as some file systems leave a
//! file after a power cut — was wiped, and its values are lost: that is said, never taken
//! for "nothing stored yet". A file whose length is not two slots of whole pages was cut
//! short or added to; its copies are looked for where they can be, and what is missing is
//! said.

use crate::record::{decode, show_time, HEADER, MAGIC, PAGE};
use crate::Snapshot;

/// One copy as found.
pub(crate) enum Slot {
    /// All zeros, or not there at all.
    Empty,
    /// A whole snapshot and its bytes.
    Good(Snapshot, Vec<u8>),
    /// Something that is not a whole snapshot, and why.
    Damaged(String),
}

/// What a retain file's bytes hold.
pub(crate) struct Copies {
    pub slots: [Slot; 2],
    /// The size of a slot when the file has the regular layout; `None` when it was cut short
    /// or added to (the next write then makes the file anew).
    pub slot: Option<u64>,
    /// What was wrong, one line each, for the log: a damaged or lost copy, a file cut short
    /// or wiped.
    pub warnings: Vec<String>,
}

impl Copies {
    /// The newest whole copy: its index and snapshot.
    pub fn newest(&self) -> Option<(usize, &Snapshot)> {
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, s)| match s {
                Slot::Good(snap, _) => Some((i, snap)),
                _ => None,
            })
            .max_by_key(|(_, s)| s.seq)
    }

    /// Every damaged copy and why.
    pub fn damaged(&self) -> Vec<(usize, &str)> {
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, s)| match s {
                Slot::Damaged(why) => Some((i, why.as_str())),
                _ => None,
            })
            .collect()
    }
}

/// The copy whose bytes start at `bytes` (to the end of the file: a record is read by its
/// own length, so that a file cut inside a slot's padding loses nothing).
pub(crate) fn decode_slot(bytes: Option<&[u8]>) -> Slot {
    let Some(bytes) = bytes else {
        return Slot::Empty;
    };
    if bytes.iter().take(HEADER).all(|&b| b == 0) {
        return Slot::Empty;
    }
    if bytes.len() < HEADER {
        return Slot::Damaged("cut off inside its header".into());
    }
    match decode(bytes) {
        Ok((snap, len)) => Slot::Good(snap, bytes[..len].to_vec()),
        Err(why) => Slot::Damaged(why),
    }
}

/// Finds the copies in the bytes of the file at `path` (`path` for messages).
pub(crate) fn find(path: &str, bytes: &[u8]) -> Copies {
    let len = bytes.len() as u64;
    let mut warnings = Vec::new();
    if bytes.iter().all(|&b| b == 0) {
        let what = if bytes.is_empty() {
            "is empty".to_string()
        } else {
            format!("holds only zeros ({len} bytes)")
        };
        warnings.push(format!(
            "retain file {path} {what}: no copy of the retained values is left (a power cut \
             leaves a file so on some file systems, or it was wiped). petriplc stamps every \
             retain file it creates, so values were lost: every retentive point and module \
             value starts from its init value"
        ));
        return Copies {
            slots: [Slot::Empty, Slot::Empty],
            slot: Some((len / 2).max(PAGE)),
            warnings,
        };
    }
    let first = decode_slot(Some(bytes));
    let first_len = match &first {
        Slot::Good(_, record) => record.len() as u64,
        _ => 0,
    };
    // Two slots of whole pages, each holding its copy: the layout petriplc writes.
    let regular = len % (2 * PAGE) == 0 && first_len <= len / 2;
    let (second, slot) = if regular {
        let slot = len / 2;
        (decode_slot(bytes.get(slot as usize..)), Some(slot))
    } else {
        warnings.push(format!(
            "retain file {path} is {len} bytes, not two copies of whole pages: it was cut \
             short or added to by something other than petriplc (it will be written anew)"
        ));
        (search(bytes, first_len.max(PAGE)), None)
    };
    let mut copies = Copies {
        slots: [first, second],
        slot,
        warnings,
    };
    let newest = copies.newest().map(|(i, s)| (i, s.seq, s.written));
    if let Some((index, seq, written)) = newest {
        let damaged: Vec<(usize, String)> = copies
            .damaged()
            .into_iter()
            .map(|(i, why)| (i, why.to_string()))
            .collect();
        for (i, why) in damaged {
            copies.warnings.push(format!(
                "retain file {path}: copy {i} is damaged ({why}: a write cut short by a crash \
                 or power loss, or a failing disk); using the other copy, snapshot {seq} of {}",
                show_time(written)
            ));
        }
        // Snapshot 1 has only the stamp (no values) beside it, and files of earlier
        // versions had nothing: only from snapshot 2 on does a missing copy mean lost values.
        let other = 1 - index;
        if seq >= 2 && matches!(copies.slots[other], Slot::Empty) {
            copies.warnings.push(format!(
                "retain file {path}: copy {other} is lost (zeroed or cut off), so a crash \
                 during the next write could lose snapshot {seq}; it is written again at the \
                 next change"
            ));
        }
    }
    copies
}

/// The second copy of a file whose layout is not regular: the first page-aligned record
/// after `from` that is whole, else the first damaged one, else none.
fn search(bytes: &[u8], from: u64) -> Slot {
    let mut damaged = None;
    let mut at = from.div_ceil(PAGE) * PAGE;
    while (at as usize) < bytes.len() {
        let rest = &bytes[at as usize..];
        if rest.starts_with(MAGIC) {
            match decode_slot(Some(rest)) {
                good @ Slot::Good(..) => return good,
                other => damaged = damaged.or(Some(other)),
            }
        }
        at += PAGE;
    }
    damaged.unwrap_or(Slot::Empty)
}
