//! One copy of a retain file as bytes: the header (magic, sequence number, time written,
//! layout hash, length, CRC-32C) and the payload of entries, written and read back. The
//! layout is drawn in [`crate::file`]; this is the format both the file and the search for
//! its copies ([`crate::copies`]) read.

use std::time::{Duration, SystemTime, UNIX_EPOCH};

use crc::{Crc, CRC_32_ISCSI};
use petriplc_config::PointKind;

use crate::{Entry, Identity, Snapshot, Value};

pub(crate) const MAGIC: &[u8; 8] = b"PPLCRTN1";
pub(crate) const HEADER: usize = 40;
pub(crate) const PAGE: u64 = 4096;
const CRC: Crc<u32> = Crc::<u32>::new(&CRC_32_ISCSI);

/// `2026-01-31 12:00:00.123 UTC`-like text without a time crate: seconds since the epoch
/// are enough for messages that a person compares with the log.
pub fn show_time(t: SystemTime) -> String {
    let d = t.duration_since(UNIX_EPOCH).unwrap_or(Duration::ZERO);
    let secs = d.as_secs();
    let (days, rest) = (secs / 86_400, secs % 86_400);
    let (y, m, day) = petriplc_calendar::civil_from_days(days as i64);
    format!(
        "{y:04}-{m:02}-{day:02}T{:02}:{:02}:{:02}.{:03}Z",
        rest / 3600,
        rest / 60 % 60,
        rest % 60,
        d.subsec_millis()
    )
}

/// One snapshot as the bytes of a slot.
pub fn encode(s: &Snapshot) -> Vec<u8> {
    let mut p = Vec::new();
    put_str(&mut p, &s.identity.plc_id);
    put_str(&mut p, &s.identity.config);
    p.extend_from_slice(&(s.entries.len() as u32).to_le_bytes());
    for e in &s.entries {
        put_str(&mut p, &e.name);
        match &e.value {
            Value::Point { kind, bits, raw } => {
                p.push(1);
                p.push(match kind {
                    PointKind::Unsigned => b'u',
                    PointKind::Signed => b'i',
                    PointKind::Float => b'f',
                });
                p.push(*bits);
                p.extend_from_slice(&raw.to_le_bytes());
            }
            Value::Data { signature, bytes } => {
                p.push(2);
                put_str(&mut p, signature);
                p.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
                p.extend_from_slice(bytes);
            }
        }
    }
    let ns = s
        .written
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    let mut out = Vec::with_capacity(HEADER + p.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&s.seq.to_le_bytes());
    out.extend_from_slice(&ns.to_le_bytes());
    out.extend_from_slice(&s.layout_hash().to_le_bytes());
    out.extend_from_slice(&(p.len() as u32).to_le_bytes());
    let mut digest = CRC.digest();
    digest.update(&out);
    digest.update(&p);
    out.extend_from_slice(&digest.finalize().to_le_bytes());
    out.extend_from_slice(&p);
    out
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    // Names and signatures are short; a longer one is cut at a character boundary.
    let mut end = s.len().min(u16::MAX as usize);
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    out.extend_from_slice(&(end as u16).to_le_bytes());
    out.extend_from_slice(&s.as_bytes()[..end]);
}

/// The snapshot at the start of `bytes` and its length, or why it is not a whole one.
pub fn decode(bytes: &[u8]) -> Result<(Snapshot, usize), String> {
    if bytes.len() < HEADER {
        return Err("too short for a header".into());
    }
    if &bytes[..8] != MAGIC {
        return Err("no retain-file header".into());
    }
    let u64_at = |i: usize| u64::from_le_bytes(bytes[i..i + 8].try_into().expect("8 bytes"));
    let u32_at = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().expect("4 bytes"));
    let seq = u64_at(8);
    let ns = u64_at(16);
    let hash = u64_at(24);
    let len = u32_at(32) as usize;
    let crc = u32_at(36);
    let end = HEADER
        .checked_add(len)
        .filter(|&e| e <= bytes.len())
        .ok_or("its length runs past the slot")?;
    let mut digest = CRC.digest();
    digest.update(&bytes[..36]);
    digest.update(&bytes[HEADER..end]);
    if digest.finalize() != crc {
        return Err("checksum mismatch".into());
    }
    let mut r = Reader {
        bytes: &bytes[HEADER..end],
        at: 0,
    };
    let bad = || "malformed contents under a good checksum".to_string();
    let plc_id = r.str().ok_or_else(bad)?;
    let config = r.str().ok_or_else(bad)?;
    let count = r.u32().ok_or_else(bad)?;
    let mut entries = Vec::new();
    for _ in 0..count {
        let name = r.str().ok_or_else(bad)?;
        let value = match r.u8().ok_or_else(bad)? {
            1 => {
                let kind = match r.u8().ok_or_else(bad)? {
                    b'u' => PointKind::Unsigned,
                    b'i' => PointKind::Signed,
                    b'f' => PointKind::Float,
                    _ => return Err(bad()),
                };
                let bits = r.u8().ok_or_else(bad)?;
                let raw = r.u32().ok_or_else(bad)?;
                Value::Point { kind, bits, raw }
            }
            2 => {
                let signature = r.str().ok_or_else(bad)?;
                let n = r.u32().ok_or_else(bad)? as usize;
                let bytes = r.take(n).ok_or_else(bad)?.to_vec();
                Value::Data { signature, bytes }
            }
            _ => return Err(bad()),
        };
        entries.push(Entry { name, value });
    }
    if r.at != r.bytes.len() {
        return Err(bad());
    }
    let snap = Snapshot {
        seq,
        written: UNIX_EPOCH + Duration::from_nanos(ns),
        identity: Identity { plc_id, config },
        entries,
    };
    if snap.layout_hash() != hash {
        return Err(bad());
    }
    Ok((snap, end))
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        let s = self.bytes.get(self.at..self.at.checked_add(n)?)?;
        self.at += n;
        Some(s)
    }
    fn u8(&mut self) -> Option<u8> {
        Some(self.take(1)?[0])
    }
    fn u32(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes(self.take(4)?.try_into().ok()?))
    }
    fn str(&mut self) -> Option<String> {
        let n = u16::from_le_bytes(self.take(2)?.try_into().ok()?) as usize;
        String::from_utf8(self.take(n)?.to_vec()).ok()
    }
}
