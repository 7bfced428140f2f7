//! The retain file: two slots of equal size, each able to hold one whole snapshot.
//!
//! ```text
//! file   = slot 0 | slot 1                    (each SLOT bytes, a multiple of 4096)
//! slot   = header payload [unused]
//! header = "PPLCRTN1" seq:u64 written_ns:u64 layout_hash:u64 payload_len:u32 crc:u32
//! payload= str plc_id, str config, u32 count, count × entry
//! entry  = str name, 1 u8 kind u8 bits u32 raw          (a point)
//!                  | 2 str signature u32 len bytes        (a module's data)
//! str    = u16 len, UTF-8 bytes;  every number little-endian
//! ```
//!
//! The CRC (CRC-32C, Castagnoli) covers the header before it and the payload. Snapshot `n`
//! goes to slot `n % 2`, written in place over the older copy and synced (`fdatasync`) before
//! it counts as written: whatever moment a crash or power loss strikes, the other slot still
//! holds a whole snapshot, and a torn or damaged slot fails its CRC. Reading takes the valid
//! slot with the higher sequence number. A slot of zeros is empty (a file just created), not
//! damaged.
//!
//! A snapshot too large for its slot (a module registered more data) makes a new file: both
//! copies written to a temporary file beside it, synced, locked, then renamed over the old
//! one and the folder synced, so that the file at the path is always whole.

use std::fs::{File, OpenOptions};
use std::io::{self, Read, Write};
use std::os::unix::fs::{FileExt, FileTypeExt, MetadataExt, OpenOptionsExt};
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use nix::fcntl::{Flock, FlockArg};

use crate::copies;
pub use crate::record::{decode, encode, show_time};
use crate::record::{MAGIC, PAGE};
use crate::{Entry, Identity, RetainError, Snapshot};

/// The largest snapshot a retain file takes: retained values are counters, totals and
/// recipes, not bulk data; a larger one is refused when written rather than grown without end.
pub const MAX_RECORD: usize = 64 << 20;
/// The largest retain file: two slots for the largest snapshot with room to grow (see
/// [`RetainFile::write`]).
pub const MAX_FILE: u64 = 2 * ((MAX_RECORD as u64 * 3 / 2).div_ceil(PAGE) + 1) * PAGE;

/// An open, locked retain file.
#[derive(Debug)]
pub struct RetainFile {
    path: PathBuf,
    file: Flock<File>,
    slot: u64,
    /// The sequence number of the newest whole snapshot in the file (0: none).
    last_seq: u64,
    /// The newest snapshot's bytes, kept to carry it over when the file grows.
    last_record: Option<Vec<u8>>,
}

/// What reading a retain file found.
#[derive(Debug)]
pub struct Loaded {
    /// The newest whole snapshot, if any.
    pub snapshot: Option<Snapshot>,
    /// What was wrong, one line each for the log: a damaged or lost copy and what was used
    /// instead, a file cut short, or wiped (its values lost).
    pub warnings: Vec<String>,
    /// The file did not exist: it was made now.
    pub created: bool,
}

fn io<'a>(path: &'a Path, what: &'static str) -> impl FnOnce(io::Error) -> RetainError + 'a {
    move |source| RetainError::Io {
        path: path.to_path_buf(),
        what,
        source,
    }
}

impl RetainFile {
    /// Opens (creating it and its folder if need be) and locks the retain file at `path`,
    /// and reads the newest whole snapshot in it. Refused while another process holds the
    /// file, when `path` is not a regular file (a device, a FIFO, a folder), when the file
    /// is larger than any retain file can be, and when neither copy can be read (a file
    /// that is not a retain file, or with both copies damaged).
    ///
    /// A new file is made whole before it takes the name (written beside it, synced, then
    /// renamed), stamped with an empty snapshot 0: a file at the path that holds nothing
    /// was wiped, which [`Loaded::warnings`] says.
    pub fn open(path: &Path) -> Result<(RetainFile, Loaded), RetainError> {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(io(path, "cannot create its folder"))?;
        }
        let mut created = false;
        let file = loop {
            // Checked before opening: opening a FIFO or a terminal can block or do harm.
            if let Ok(m) = std::fs::metadata(path) {
                regular(path, &m)?;
            }
            let file = match OpenOptions::new()
                .read(true)
                .write(true)
                .custom_flags(nix::libc::O_NONBLOCK | nix::libc::O_NOCTTY)
                .open(path)
            {
                Ok(f) => f,
                Err(e) if e.kind() == io::ErrorKind::NotFound => {
                    create(path)?;
                    created = true;
                    continue;
                }
                Err(e) => return Err(io(path, "cannot open it")(e)),
            };
            regular(path, &file.metadata().map_err(io(path, "cannot read it"))?)?;
            let file = match Flock::lock(file, FlockArg::LockExclusiveNonblock) {
                Ok(f) => f,
                Err((_, nix::errno::Errno::EWOULDBLOCK)) => {
                    return Err(RetainError::InUse {
                        path: path.to_path_buf(),
                    })
                }
                Err((_, e)) => return Err(io(path, "cannot lock it")(e.into())),
            };
            // A file renamed over the one we opened (a grown file) is the one to lock.
            let ours = file.metadata().map_err(io(path, "cannot read it"))?.ino();
            match path.metadata() {
                Ok(m) if m.ino() == ours => break file,
                _ => continue,
            }
        };
        let bytes = read_bounded(path, &file)?;
        let unreadable = |why: String| RetainError::Unreadable {
            path: path.to_path_buf(),
            why,
        };
        let copies = copies::find(&path.display().to_string(), &bytes);
        let mut me = RetainFile {
            path: path.to_path_buf(),
            file,
            // A file cut short or added to has no slot size: the next write makes it anew.
            slot: copies.slot.unwrap_or(0),
            last_seq: 0,
            last_record: None,
        };
        let Some((index, snapshot)) = copies.newest() else {
            let damaged = copies.damaged();
            if damaged.is_empty() {
                return Ok((
                    me,
                    Loaded {
                        snapshot: None,
                        warnings: copies.warnings,
                        created,
                    },
                ));
            }
            if copies.slot.is_none() && !bytes.starts_with(MAGIC) {
                return Err(unreadable(format!(
                    "it is not a petriplc retain file ({} bytes, not two slots of whole pages)",
                    bytes.len()
                )));
            }
            let whys: Vec<String> = damaged
                .iter()
                .map(|(i, why)| format!("copy {i}: {why}"))
                .collect();
            return Err(unreadable(format!(
                "no copy is whole ({})",
                whys.join("; ")
            )));
        };
        me.last_seq = snapshot.seq;
        if let copies::Slot::Good(_, record) = &copies.slots[index] {
            me.last_record = Some(record.clone());
        }
        // Snapshot 0 is the stamp of a new file: nothing stored yet.
        let snapshot = (snapshot.seq > 0).then(|| snapshot.clone());
        Ok((
            me,
            Loaded {
                snapshot,
                warnings: copies.warnings,
                created,
            },
        ))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The sequence number of the newest snapshot written (or read at open).
    pub fn last_seq(&self) -> u64 {
        self.last_seq
    }

    /// Writes `entries` as the next snapshot (its sequence number, the newest plus one, is
    /// returned) over the older copy, and syncs it: when this returns, a crash or power loss
    /// gives back these values (or, if the disk lies about syncing, the previous ones).
    pub fn write(
        &mut self,
        identity: &Identity,
        entries: &[Entry],
        written: SystemTime,
    ) -> Result<u64, RetainError> {
        let seq = self.last_seq + 1;
        let record = encode(&Snapshot {
            seq,
            written,
            identity: identity.clone(),
            entries: entries.to_vec(),
        });
        if record.len() > MAX_RECORD {
            return Err(RetainError::TooLarge {
                path: self.path.clone(),
                bytes: record.len(),
                limit: MAX_RECORD,
            });
        }
        let file_len = self
            .file
            .metadata()
            .map_err(io(&self.path, "cannot read it"))?
            .len();
        if record.len() as u64 > self.slot || file_len != 2 * self.slot {
            self.grow(seq, &record)?;
        } else {
            let offset = (seq % 2) * self.slot;
            self.file
                .write_all_at(&record, offset)
                .map_err(io(&self.path, "cannot write it"))?;
            self.file
                .sync_data()
                .map_err(io(&self.path, "cannot sync it"))?;
        }
        self.last_seq = seq;
        self.last_record = Some(record);
        Ok(seq)
    }

    /// Makes a new file with slots big enough for `record` (and room to grow), holding
    /// `record` and the previous snapshot, and puts it in place of the old one atomically.
    fn grow(&mut self, seq: u64, record: &[u8]) -> Result<(), RetainError> {
        let need = record
            .len()
            .max(self.last_record.as_ref().map_or(0, Vec::len)) as u64;
        let slot = (need + need / 2).div_ceil(PAGE).max(1) * PAGE;
        let mut image = vec![0u8; 2 * slot as usize];
        let place = |image: &mut [u8], n: u64, bytes: &[u8]| {
            let at = ((n % 2) * slot) as usize;
            image[at..at + bytes.len()].copy_from_slice(bytes);
        };
        if let Some(last) = &self.last_record {
            place(&mut image, seq - 1, last);
        }
        place(&mut image, seq, record);
        let tmp = tmp_path(&self.path);
        let path = self.path.clone();
        let mut f = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)
            .map_err(io(&path, "cannot create its new copy"))?;
        f.write_all(&image)
            .and_then(|()| f.sync_all())
            .map_err(io(&path, "cannot write its new copy"))?;
        // Locked before it takes the name, so that nobody else can lock it in between.
        let f = Flock::lock(f, FlockArg::LockExclusiveNonblock)
            .map_err(|(_, e)| io(&path, "cannot lock its new copy")(e.into()))?;
        std::fs::rename(&tmp, &path).map_err(io(&path, "cannot replace it"))?;
        sync_dir(&path).map_err(io(&path, "cannot sync its folder"))?;
        self.file = f;
        self.slot = slot;
        Ok(())
    }
}

/// Refuses what is not a regular file: a retain file on a device would be read without end
/// (`/dev/zero`) and a FIFO would block the start.
fn regular(path: &Path, m: &std::fs::Metadata) -> Result<(), RetainError> {
    let t = m.file_type();
    if t.is_file() {
        return Ok(());
    }
    let kind = if t.is_dir() {
        "a folder"
    } else if t.is_fifo() {
        "a FIFO (named pipe)"
    } else if t.is_char_device() {
        "a character device"
    } else if t.is_block_device() {
        "a block device"
    } else if t.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    };
    Err(RetainError::NotAFile {
        path: path.to_path_buf(),
        kind,
    })
}

/// The file's bytes, refused beyond the largest retain file petriplc writes.
fn read_bounded(path: &Path, file: &File) -> Result<Vec<u8>, RetainError> {
    let len = file.metadata().map_err(io(path, "cannot read it"))?.len();
    let too_large = |len: u64| RetainError::Unreadable {
        path: path.to_path_buf(),
        why: format!(
            "it is {len} bytes, larger than any retain file ({MAX_FILE} bytes at most: two \
             copies of at most {MAX_RECORD} bytes of retained values, with room to grow)"
        ),
    };
    if len > MAX_FILE {
        return Err(too_large(len));
    }
    let mut bytes = Vec::with_capacity(len as usize);
    // Bounded even if the file grows while it is read.
    file.take(MAX_FILE + 1)
        .read_to_end(&mut bytes)
        .map_err(io(path, "cannot read it"))?;
    if bytes.len() as u64 > MAX_FILE {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// Makes a new retain file at `path`: two slots of one page, copy 0 the stamp (snapshot 0,
/// no values). It is written and synced under another name, locked, and renamed into place,
/// so the file at `path` is never empty; one left half-made by a kill is made again.
fn create(path: &Path) -> Result<(), RetainError> {
    let new = new_path(path);
    let f = OpenOptions::new()
        .read(true)
        .write(true)
        .create(true)
        .truncate(false)
        .open(&new)
        .map_err(io(path, "cannot create it"))?;
    // Truncated only once locked: another start making the same file waits for us.
    let mut f = match Flock::lock(f, FlockArg::LockExclusiveNonblock) {
        Ok(f) => f,
        Err((_, nix::errno::Errno::EWOULDBLOCK)) => {
            return Err(RetainError::InUse {
                path: path.to_path_buf(),
            })
        }
        Err((_, e)) => return Err(io(path, "cannot lock it")(e.into())),
    };
    if path.exists() {
        // Made by another start while this one waited.
        return Ok(());
    }
    let stamp = encode(&Snapshot {
        seq: 0,
        written: SystemTime::now(),
        identity: Identity::default(),
        entries: Vec::new(),
    });
    let mut image = vec![0u8; 2 * PAGE as usize];
    image[..stamp.len()].copy_from_slice(&stamp);
    f.set_len(0)
        .and_then(|()| f.write_all(&image))
        .and_then(|()| f.sync_all())
        .map_err(io(path, "cannot write it"))?;
    std::fs::rename(&new, path).map_err(io(path, "cannot create it"))?;
    sync_dir(path).map_err(io(path, "cannot sync its folder"))
}

/// The name a new retain file is made under, beside it.
fn new_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".new");
    PathBuf::from(name)
}

/// The temporary file a growing retain file is written to, beside it.
pub fn tmp_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(".tmp");
    PathBuf::from(name)
}

fn sync_dir(path: &Path) -> io::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    File::open(dir)?.sync_all()
}

/// Reads the newest whole snapshot of the file at `path` without locking it (for tools and
/// tests that look at a PLC's file): `Ok(None)` for an empty file.
pub fn peek(path: &Path) -> Result<Loaded, RetainError> {
    if let Ok(m) = std::fs::metadata(path) {
        regular(path, &m)?;
    }
    let file = OpenOptions::new()
        .read(true)
        .custom_flags(nix::libc::O_NONBLOCK | nix::libc::O_NOCTTY)
        .open(path)
        .map_err(io(path, "cannot read it"))?;
    regular(path, &file.metadata().map_err(io(path, "cannot read it"))?)?;
    let bytes = read_bounded(path, &file)?;
    let copies = copies::find(&path.display().to_string(), &bytes);
    let snapshot = copies
        .newest()
        .filter(|(_, s)| s.seq > 0)
        .map(|(_, s)| s.clone());
    Ok(Loaded {
        snapshot,
        warnings: copies.warnings,
        created: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::record::HEADER;
    use crate::Value;
    use petriplc_config::PointKind;
    use std::time::{Duration, UNIX_EPOCH};

    fn point(name: &str, raw: u32) -> Entry {
        Entry {
            name: name.into(),
            value: Value::Point {
                kind: PointKind::Unsigned,
                bits: 32,
                raw,
            },
        }
    }

    fn ident() -> Identity {
        Identity {
            plc_id: "p".into(),
            config: "/etc/plc.conf".into(),
        }
    }

    fn newest(path: &Path) -> (Option<u64>, Option<u32>, Option<String>) {
        let (_, loaded) = RetainFile::open(path).unwrap();
        let snap = loaded.snapshot;
        let raw = snap.as_ref().and_then(|s| match s.entries[0].value {
            Value::Point { raw, .. } => Some(raw),
            _ => None,
        });
        let warning = (!loaded.warnings.is_empty()).then(|| loaded.warnings.join("\n"));
        (snap.map(|s| s.seq), raw, warning)
    }

    #[test]
    fn snapshots_round_trip() {
        let snap = Snapshot {
            seq: 7,
            written: UNIX_EPOCH + Duration::from_millis(1_700_000_000_123),
            identity: ident(),
            entries: vec![
                point("count", 42),
                Entry {
                    name: "iec/main.total".into(),
                    value: Value::Data {
                        signature: "LREAL".into(),
                        bytes: vec![1, 2, 3],
                    },
                },
            ],
        };
        let bytes = encode(&snap);
        assert_eq!(decode(&bytes), Ok((snap, bytes.len())));
        assert_eq!(
            show_time(UNIX_EPOCH + Duration::from_millis(1_700_000_000_123)),
            "2023-11-14T22:13:20.123Z"
        );
    }

    #[test]
    fn writes_alternate_and_the_newest_whole_copy_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub/plc.retain");
        let (mut f, loaded) = RetainFile::open(&path).unwrap();
        assert!(loaded.snapshot.is_none());
        for v in 1..=5 {
            f.write(&ident(), &[point("count", v * 10)], SystemTime::now())
                .unwrap();
        }
        drop(f);
        assert_eq!(newest(&path), (Some(5), Some(50), None));
        assert_eq!(std::fs::metadata(&path).unwrap().len(), 2 * PAGE);
        // Damage the newest copy (slot 5 % 2 = 1): the previous one is used, with a warning.
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[PAGE as usize + HEADER + 3] ^= 0x40;
        std::fs::write(&path, &bytes).unwrap();
        let (seq, raw, warning) = newest(&path);
        assert_eq!((seq, raw), (Some(4), Some(40)));
        let warning = warning.unwrap();
        assert!(
            warning.contains("copy 1 is damaged (checksum mismatch")
                && warning.contains("using the other copy, snapshot 4 of "),
            "{warning}"
        );
        // The next write goes over the damaged copy, and numbering goes on.
        let (mut f, _) = RetainFile::open(&path).unwrap();
        assert_eq!(
            f.write(&ident(), &[point("count", 60)], SystemTime::now())
                .unwrap(),
            5
        );
        drop(f);
        assert_eq!(newest(&path), (Some(5), Some(60), None));
    }

    #[test]
    fn both_copies_damaged_or_another_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plc.retain");
        let (mut f, _) = RetainFile::open(&path).unwrap();
        f.write(&ident(), &[point("a", 1)], SystemTime::now())
            .unwrap();
        f.write(&ident(), &[point("a", 2)], SystemTime::now())
            .unwrap();
        drop(f);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[HEADER] ^= 1;
        bytes[PAGE as usize + 9] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        let e = RetainFile::open(&path).unwrap_err().to_string();
        assert!(
            e.contains("no copy is whole (copy 0: checksum mismatch; copy 1: checksum mismatch)")
                && e.contains("Move it away"),
            "{e}"
        );
        std::fs::write(&path, "hello, world\n").unwrap();
        let e = RetainFile::open(&path).unwrap_err().to_string();
        assert!(
            e.contains("it is not a petriplc retain file (13 bytes"),
            "{e}"
        );
    }

    #[test]
    fn a_file_in_use_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plc.retain");
        let (_held, _) = RetainFile::open(&path).unwrap();
        assert!(matches!(
            RetainFile::open(&path),
            Err(RetainError::InUse { .. })
        ));
    }

    #[test]
    fn a_snapshot_too_big_for_its_slot_grows_the_file_keeping_both_copies() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plc.retain");
        let (mut f, _) = RetainFile::open(&path).unwrap();
        f.write(&ident(), &[point("small", 1)], SystemTime::now())
            .unwrap();
        let big: Vec<Entry> = (0..400)
            .map(|i| point(&format!("point{i:04}"), i))
            .collect();
        f.write(&ident(), &big, SystemTime::now()).unwrap();
        let len = std::fs::metadata(&path).unwrap().len();
        assert!(len > 2 * PAGE && len % (2 * PAGE) == 0, "{len}");
        assert!(!tmp_path(&path).exists());
        // The lock moved to the new file with the name.
        assert!(matches!(
            RetainFile::open(&path),
            Err(RetainError::InUse { .. })
        ));
        drop(f);
        let (mut f, loaded) = RetainFile::open(&path).unwrap();
        assert_eq!(loaded.snapshot.unwrap().entries.len(), 400);
        // Damage the big copy (snapshot 2, slot 0): the small one before it is still there.
        drop(f);
        let mut bytes = std::fs::read(&path).unwrap();
        bytes[100] ^= 1;
        std::fs::write(&path, &bytes).unwrap();
        (f, _) = RetainFile::open(&path).unwrap();
        assert_eq!(f.last_seq(), 1);
    }

    #[test]
    fn a_new_file_is_stamped_so_that_a_wiped_one_is_told_apart() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plc.retain");
        let (f, loaded) = RetainFile::open(&path).unwrap();
        assert!(loaded.created && loaded.snapshot.is_none() && loaded.warnings.is_empty());
        drop(f);
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(bytes.len() as u64, 2 * PAGE);
        assert!(bytes.starts_with(MAGIC));
        assert!(!new_path(&path).exists());
        // Opened again: stamped, never written; nothing to warn about.
        let (f, loaded) = RetainFile::open(&path).unwrap();
        assert!(!loaded.created && loaded.snapshot.is_none() && loaded.warnings.is_empty());
        assert_eq!(f.last_seq(), 0);
        drop(f);
        // What a power cut leaves on some file systems: zeros, or nothing.
        for (bytes, what) in [
            (vec![0u8; 8192], "holds only zeros (8192 bytes)"),
            (Vec::new(), "is empty"),
        ] {
            std::fs::write(&path, bytes).unwrap();
            let (_, loaded) = RetainFile::open(&path).unwrap();
            assert!(loaded.snapshot.is_none() && !loaded.created);
            let w = loaded.warnings.join("\n");
            assert!(w.contains(what) && w.contains("values were lost"), "{w}");
        }
    }

    #[test]
    fn a_half_made_new_file_left_by_a_kill_is_made_again() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plc.retain");
        std::fs::write(new_path(&path), b"PPLCRTN1 half").unwrap();
        let (_, loaded) = RetainFile::open(&path).unwrap();
        assert!(loaded.created && loaded.warnings.is_empty());
        assert!(!new_path(&path).exists());
        assert!(std::fs::read(&path).unwrap().starts_with(MAGIC));
    }

    #[test]
    fn a_file_cut_short_says_which_copy_is_lost_and_is_written_anew() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plc.retain");
        let (mut f, _) = RetainFile::open(&path).unwrap();
        for v in 1..=3 {
            f.write(&ident(), &[point("count", v)], SystemTime::now())
                .unwrap();
        }
        drop(f);
        // Snapshot 3 is in slot 1, snapshot 2 in slot 0: keep only the first page.
        let file = OpenOptions::new().write(true).open(&path).unwrap();
        file.set_len(PAGE).unwrap();
        drop(file);
        let (seq, raw, warning) = newest(&path);
        assert_eq!((seq, raw), (Some(2), Some(2)));
        let w = warning.unwrap();
        assert!(
            w.contains("is 4096 bytes, not two copies of whole pages")
                && w.contains("copy 1 is lost (zeroed or cut off)"),
            "{w}"
        );
        // The next write makes the file regular again, with both copies.
        let (mut f, _) = RetainFile::open(&path).unwrap();
        assert_eq!(
            f.write(&ident(), &[point("count", 9)], SystemTime::now())
                .unwrap(),
            3
        );
        drop(f);
        assert_eq!(std::fs::metadata(&path).unwrap().len() % (2 * PAGE), 0);
        assert_eq!(newest(&path), (Some(3), Some(9), None));
        // A copy zeroed in place is lost too.
        let mut bytes = std::fs::read(&path).unwrap();
        let half = bytes.len() / 2;
        bytes[half..].fill(0);
        std::fs::write(&path, &bytes).unwrap();
        let (seq, _, warning) = newest(&path);
        assert_eq!(seq, Some(2));
        assert!(warning.unwrap().contains("copy 1 is lost"));
    }

    #[test]
    fn only_a_regular_file_of_a_sane_size_is_read() {
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("fifo.retain");
        nix::unistd::mkfifo(&fifo, nix::sys::stat::Mode::S_IRWXU).unwrap();
        for (path, kind) in [
            (Path::new("/dev/full"), "a character device"),
            (Path::new("/dev/zero"), "a character device"),
            (fifo.as_path(), "a FIFO (named pipe)"),
            (dir.path(), "a folder"),
        ] {
            let e = RetainFile::open(path).unwrap_err();
            assert!(matches!(e, RetainError::NotAFile { .. }), "{e}");
            assert!(e.is_bad_input());
            assert!(
                e.to_string()
                    .contains(&format!("is {kind}, not a regular file")),
                "{e}"
            );
            assert!(peek(path).is_err());
        }
        // A sparse file larger than any retain file is refused without reading it.
        let big = dir.path().join("big.retain");
        File::create(&big).unwrap().set_len(MAX_FILE + 1).unwrap();
        let e = RetainFile::open(&big).unwrap_err().to_string();
        assert!(e.contains("larger than any retain file"), "{e}");
    }

    #[test]
    fn a_snapshot_larger_than_the_limit_is_refused_when_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plc.retain");
        let (mut f, _) = RetainFile::open(&path).unwrap();
        let huge = Entry {
            name: "m/blob".into(),
            value: Value::Data {
                signature: "ARRAY".into(),
                bytes: vec![7; MAX_RECORD],
            },
        };
        let e = f.write(&ident(), &[huge], SystemTime::now()).unwrap_err();
        assert!(matches!(e, RetainError::TooLarge { .. }), "{e}");
        assert_eq!(f.last_seq(), 0);
    }
}
