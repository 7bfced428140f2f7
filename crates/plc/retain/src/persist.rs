//! The persistence thread: keeps the retain file up to date off the scan path.
//!
//! It asks its source for a snapshot (the runner copies the retentive points out of the
//! process image under its lock, as of the last committed scans, and the modules' committed
//! data) and writes it when it differs from the last one written, at most as often as the
//! write policy allows: `change` writes as soon as the previous write is done (the values
//! are looked at every millisecond); a duration `T` writes at most once per `T`, a change
//! being written at most `T` + 10 ms after the last write. A write is acknowledged once it
//! is synced; the last acknowledged snapshot is published ([`Persister::acknowledged`]).
//! Scans never wait for the disk: the only thing they share with this thread is the image
//! lock, held for the copy of a few words.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant, SystemTime};

use petriplc_config::RetainWrite;

use crate::file::RetainFile;
use crate::{Entry, Identity};

/// Fills the snapshot: every retained value as of one committed scan, in a fixed order.
pub type Source = Box<dyn FnMut(&mut Vec<Entry>) + Send>;

/// A snapshot that is in the file: its number, when it was taken, its values.
#[derive(Clone, Debug, PartialEq)]
pub struct Ack {
    pub seq: u64,
    pub written: SystemTime,
    pub entries: Vec<Entry>,
}

struct Shared {
    stop: AtomicBool,
    ack: Mutex<Option<Ack>>,
}

/// The running persistence thread of one retain file.
pub struct Persister {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<RetainFile>>,
}

impl Persister {
    /// Starts writing snapshots of `source` to `file` under `policy`. `restored` is the
    /// snapshot the file gave back at start (the first acknowledged one).
    pub fn start(
        file: RetainFile,
        identity: Identity,
        policy: RetainWrite,
        restored: Option<Ack>,
        source: Source,
    ) -> std::io::Result<Persister> {
        let shared = Arc::new(Shared {
            stop: AtomicBool::new(false),
            ack: Mutex::new(restored.clone()),
        });
        let s = Arc::clone(&shared);
        let thread = std::thread::Builder::new()
            .name("retain".into())
            .spawn(move || run(file, identity, policy, restored, source, &s))?;
        Ok(Persister {
            shared,
            thread: Some(thread),
        })
    }

    /// The last snapshot known to be in the file.
    pub fn acknowledged(&self) -> Option<Ack> {
        self.shared
            .ack
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }

    /// Writes a last snapshot (if anything changed) and ends the thread; returns the file,
    /// still locked, and what it holds.
    pub fn stop(mut self) -> Option<(RetainFile, Option<Ack>)> {
        self.finish().map(|f| (f, self.acknowledged()))
    }

    fn finish(&mut self) -> Option<RetainFile> {
        self.shared.stop.store(true, Ordering::Release);
        let t = self.thread.take()?;
        t.thread().unpark();
        t.join().ok()
    }
}

impl Drop for Persister {
    fn drop(&mut self) {
        self.finish();
    }
}

/// How long to sleep between looks at the values.
fn poll(policy: RetainWrite) -> Duration {
    match policy {
        RetainWrite::Change => Duration::from_millis(1),
        RetainWrite::Every(d) => d.clamp(Duration::from_millis(1), Duration::from_millis(10)),
    }
}

fn run(
    mut file: RetainFile,
    identity: Identity,
    policy: RetainWrite,
    restored: Option<Ack>,
    mut source: Source,
    shared: &Shared,
) -> RetainFile {
    let mut current: Vec<Entry> = Vec::new();
    let mut written: Option<Vec<Entry>> = restored.map(|a| a.entries);
    let mut last_write: Option<Instant> = None;
    // Errors are said once, and again when the file works again.
    let mut failing = false;
    loop {
        let stopping = shared.stop.load(Ordering::Acquire);
        let due = match (policy, last_write) {
            (RetainWrite::Every(d), Some(t)) => t.elapsed() >= d,
            _ => true,
        };
        if due || stopping {
            current.clear();
            source(&mut current);
            // An empty snapshot is worth writing only over one that was not empty.
            let unchanged = match &written {
                Some(w) => *w == current,
                None => current.is_empty(),
            };
            if !unchanged {
                let at = SystemTime::now();
                match file.write(&identity, &current, at) {
                    Ok(seq) => {
                        if failing {
                            log::info!("retain file {}: written again", file.path().display());
                            failing = false;
                        }
                        *shared.ack.lock().unwrap_or_else(PoisonError::into_inner) = Some(Ack {
                            seq,
                            written: at,
                            entries: current.clone(),
                        });
                        log::debug!(
                            "retain file {}: snapshot {seq} written",
                            file.path().display()
                        );
                        written = Some(current.clone());
                        last_write = Some(Instant::now());
                    }
                    Err(e) => {
                        if !failing {
                            log::error!(
                                "{e}; the retentive values are kept in memory and written \
                                 again as soon as the file can be written"
                            );
                            failing = true;
                        }
                        // Not at the pace of `change`: a failing disk gets a rest.
                        last_write = Some(Instant::now());
                        if stopping {
                            return file;
                        }
                        std::thread::park_timeout(Duration::from_millis(100));
                        continue;
                    }
                }
            }
        }
        if stopping {
            return file;
        }
        std::thread::park_timeout(poll(policy));
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::AtomicU32;

    use petriplc_config::PointKind;

    use super::*;
    use crate::file::peek;
    use crate::Value;

    fn entry(raw: u32) -> Entry {
        Entry {
            name: "count".into(),
            value: Value::Point {
                kind: PointKind::Unsigned,
                bits: 32,
                raw,
            },
        }
    }

    #[test]
    fn changes_are_written_and_acknowledged_and_the_last_one_at_stop() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.retain");
        let (file, _) = RetainFile::open(&path).unwrap();
        let value = Arc::new(AtomicU32::new(1));
        let v = Arc::clone(&value);
        let p = Persister::start(
            file,
            Identity::default(),
            RetainWrite::Every(Duration::from_secs(3600)),
            None,
            Box::new(move |out| out.push(entry(v.load(Ordering::Relaxed)))),
        )
        .unwrap();
        // The first snapshot is due at once.
        while p.acknowledged().is_none() {
            std::thread::sleep(Duration::from_millis(1));
        }
        assert_eq!(p.acknowledged().unwrap().entries, vec![entry(1)]);
        // A change within the hour waits; stopping writes it.
        value.store(2, Ordering::Relaxed);
        let (_, ack) = p.stop().unwrap();
        let ack = ack.unwrap();
        assert_eq!((ack.seq, &ack.entries), (2, &vec![entry(2)]));
        let on_disk = peek(&path).unwrap().snapshot.unwrap();
        assert_eq!((on_disk.seq, on_disk.entries), (2, vec![entry(2)]));
    }

    #[test]
    fn nothing_is_written_while_nothing_changes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.retain");
        let (file, _) = RetainFile::open(&path).unwrap();
        let restored = Ack {
            seq: 0,
            written: SystemTime::UNIX_EPOCH,
            entries: vec![entry(5)],
        };
        let calls = Arc::new(AtomicU32::new(0));
        let c = Arc::clone(&calls);
        let p = Persister::start(
            file,
            Identity::default(),
            RetainWrite::Change,
            Some(restored.clone()),
            Box::new(move |out| {
                c.fetch_add(1, Ordering::Relaxed);
                out.push(entry(5))
            }),
        )
        .unwrap();
        while calls.load(Ordering::Relaxed) < 5 {
            std::thread::sleep(Duration::from_millis(1));
        }
        let (f, ack) = p.stop().unwrap();
        assert_eq!((f.last_seq(), ack), (0, Some(restored)));
        assert!(peek(&path).unwrap().snapshot.is_none());
    }
}
