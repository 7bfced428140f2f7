//! Who owns a PLC id, decided by the kernel: `petriplc run` holds a write lock on the lock
//! file `/dev/shm/petriplc-ID.lock` (an open-file-description lock, `F_OFD_SETLK`) for its
//! whole life. The kernel drops the lock when the process dies, however it dies, so:
//!
//! - a PLC id is taken exactly when its lock is held, never because a file merely exists;
//! - a `petriplc run` that finds the lock free while objects of that id exist knows the PLC
//!   that made them died without stopping, removes them and starts ([`Owner::acquire`]);
//! - `petriplc status` tells a running PLC from a dead one without touching the lock
//!   (`F_OFD_GETLK`, [`probe`]);
//! - `petriplc stop` signals a process only after proving it is the lock's holder: the lock
//!   file names the holder's pid and start time, which must match a live process whose
//!   pidfd is then used, while the lock is still held ([`running_plc`]).
//!
//! The lock file is removed by its owner when the PLC stops. Removing a lock file is racy in
//! general (a newcomer may have opened the old file just before); [`Owner::acquire`] handles
//! it by checking, once it holds the lock, that the file it locked is still the one at the
//! path, and trying again otherwise.
//!
//! Everything a PLC id owns (the shared memory objects, the status file and its temporary,
//! the lock file) has a fixed name ending differently from the others, so one id's names can
//! never be another id's.

use std::fs::{File, OpenOptions};
use std::io::{self, Read, Seek, Write};
use std::os::fd::AsRawFd;
use std::os::unix::fs::{MetadataExt, OpenOptionsExt};
use std::path::PathBuf;
use std::time::SystemTime;

use nix::errno::Errno;
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::sys::mman::shm_open;
use nix::sys::stat::Mode;

use crate::process::{self, Pidfd};

/// Why an id cannot be taken or looked at.
#[derive(Debug, thiserror::Error)]
pub enum OwnerError {
    #[error("invalid plc id `{plc_id}`: {reason}")]
    BadPlcId { plc_id: String, reason: String },
    #[error(
        "a PLC with id `{plc_id}` is already running{}; stop it with `petriplc stop --plc-id \
         {plc_id}`, or give this PLC another id with --plc-id",
        .pid.map(|p| format!(" (process {p})")).unwrap_or_default()
    )]
    Running { plc_id: String, pid: Option<u32> },
    #[error("{what} {}: {source}", .path.display())]
    Os {
        what: &'static str,
        path: PathBuf,
        #[source]
        source: io::Error,
    },
}

// Kept here too, where callers found it before it moved beside the other naming rules.
pub use crate::shm_name::state_dir;

/// The lock file of PLC `plc_id`.
pub fn lock_path(plc_id: &str) -> PathBuf {
    state_dir().join(format!("petriplc-{plc_id}.lock"))
}

fn check_id(plc_id: &str) -> Result<(), OwnerError> {
    crate::shm_name::object_name(plc_id, "image")
        .map(|_| ())
        .map_err(|reason| OwnerError::BadPlcId {
            plc_id: plc_id.to_string(),
            reason: reason.to_string(),
        })
}

fn os(what: &'static str, path: PathBuf) -> impl FnOnce(io::Error) -> OwnerError {
    move |source| OwnerError::Os { what, path, source }
}

use crate::process::whole_file;

/// Whether some open file description holds a lock on `file` that would conflict with a
/// write lock.
fn is_locked(file: &File) -> io::Result<bool> {
    let mut l = whole_file(libc::F_WRLCK as libc::c_short);
    fcntl(file, FcntlArg::F_OFD_GETLK(&mut l))?;
    Ok(l.l_type != libc::F_UNLCK as libc::c_short)
}

/// What the lock file says of its holder: pid and start time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Holder {
    pid: u32,
    start: u64,
}

fn read_holder(file: &mut File) -> Option<Holder> {
    let mut text = String::new();
    file.seek(io::SeekFrom::Start(0)).ok()?;
    file.read_to_string(&mut text).ok()?;
    let mut words = text.split_whitespace();
    let pid = words.next()?.parse().ok()?;
    let start = words.next()?.parse().ok()?;
    Some(Holder { pid, start })
}

/// What a PLC that died without stopping left behind.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Remains {
    /// Its process, if it got as far as recording it (in its lock file, or its status file).
    pub pid: Option<u32>,
    /// The last sign of life: when its status file (rewritten several times a second) or
    /// its lock file was last written.
    pub last_seen: Option<SystemTime>,
    /// The objects it left (paths under /dev/shm), lock file included.
    pub objects: Vec<PathBuf>,
}

impl Remains {
    /// `the PLC (pid N) exited without stopping at TIME`.
    pub fn describe(&self) -> String {
        let at = self
            .last_seen
            .map(|t| format!(" at {}", rfc3339(t)))
            .unwrap_or_default();
        match self.pid {
            Some(p) => format!("the PLC (pid {p}) exited without stopping{at}"),
            None => format!("a PLC exited without stopping{at}"),
        }
    }

    /// The objects' file names, for messages.
    pub fn object_names(&self) -> String {
        self.objects
            .iter()
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// A time as RFC 3339 in UTC, as the PLC's log writes it (`2025-01-31T12:00:00.123Z`).
pub fn rfc3339(t: SystemTime) -> String {
    let t = time::OffsetDateTime::from(t);
    let t = t
        .replace_nanosecond(t.millisecond() as u32 * 1_000_000)
        .unwrap_or(t);
    t.format(&time::format_description::well_known::Rfc3339)
        .unwrap_or_else(|_| format!("{t}"))
}

/// Everything but the lock file a PLC id may own, as paths: the shared memory objects
/// (`/dev/shm/petriplc-ID-image`, `-synch`, `-watchdog`, where POSIX shared memory lives on Linux), the
/// status file and its temporary.
fn objects(plc_id: &str) -> Vec<(PathBuf, Object)> {
    let shm = |object: &str| crate::shm_name::object_name(plc_id, object).ok();
    let mut out = Vec::new();
    for object in ["image", "synch", "watchdog"] {
        if let Some(name) = shm(object) {
            out.push((PathBuf::from(format!("/dev/shm{name}")), Object::Shm(name)));
        }
    }
    let status = crate::status::path(plc_id);
    out.push((crate::status::tmp_path(&status), Object::File));
    out.push((status, Object::File));
    out
}

#[derive(Clone, Debug)]
enum Object {
    Shm(String),
    File,
}

fn exists(object: &Object, path: &std::path::Path) -> bool {
    match object {
        Object::Shm(name) => shm_open(name.as_str(), OFlag::O_RDONLY, Mode::empty())
            .map(drop)
            .map_or_else(|e| e != Errno::ENOENT, |()| true),
        Object::File => path.symlink_metadata().is_ok(),
    }
}

/// The objects of `plc_id` that exist (lock file excluded).
fn existing(plc_id: &str) -> Vec<(PathBuf, Object)> {
    objects(plc_id)
        .into_iter()
        .filter(|(p, o)| exists(o, p))
        .collect()
}

fn last_seen(plc_id: &str) -> Option<SystemTime> {
    let status = crate::status::path(plc_id);
    [
        status.clone(),
        crate::status::tmp_path(&status),
        lock_path(plc_id),
    ]
    .iter()
    .filter_map(|p| p.metadata().and_then(|m| m.modified()).ok())
    .max()
}

/// The state of a PLC id, as [`probe`] finds it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Probe {
    /// No PLC has this id, and nothing of one is left.
    Absent,
    /// A PLC holds the id. `pid` is its process when the lock file names a live process
    /// started at the time it records (`None` while it is starting up).
    Running { pid: Option<u32> },
    /// No PLC holds the id, but one left these behind.
    Dead(Remains),
}

/// Looks at PLC id `plc_id` without changing anything (no lock is taken).
pub fn probe(plc_id: &str) -> Result<Probe, OwnerError> {
    check_id(plc_id)?;
    let path = lock_path(plc_id);
    let mut file = match File::open(&path) {
        Ok(f) => Some(f),
        Err(e) if e.kind() == io::ErrorKind::NotFound => None,
        Err(e) => return Err(os("cannot open the lock file", path)(e)),
    };
    if let Some(f) = &file {
        if is_locked(f).map_err(os("cannot test the lock on", path.clone()))? {
            let holder = read_holder(file.as_mut().expect("checked"));
            let pid = holder
                .filter(|h| process::start_time(h.pid) == Some(h.start))
                .map(|h| h.pid);
            return Ok(Probe::Running { pid });
        }
    }
    let holder = file.as_mut().and_then(read_holder);
    let mut objects: Vec<PathBuf> = existing(plc_id).into_iter().map(|(p, _)| p).collect();
    // Without a lock file (a PLC of an older petriplc), its status file may still say which
    // process it was: for the message only.
    let pid = holder
        .map(|h| h.pid)
        .or_else(|| crate::status::PlcStatus::read(plc_id).map(|s| s.pid));
    // A lock file that names nobody, with nothing else left, is a PLC that had only just
    // begun (or is beginning right now): there is nothing to report.
    if objects.is_empty() && holder.is_none() {
        return Ok(Probe::Absent);
    }
    if file.is_some() {
        objects.push(path);
    }
    Ok(Probe::Dead(Remains {
        pid,
        last_seen: last_seen(plc_id),
        objects,
    }))
}

/// The ownership of a PLC id, held until dropped (or [`Owner::release`]d).
#[derive(Debug)]
pub struct Owner {
    plc_id: String,
    path: PathBuf,
    file: Option<File>,
    ino: u64,
}

impl Owner {
    /// Takes PLC id `plc_id`, refused while another PLC holds it. If a PLC that died
    /// without stopping left objects behind, they are removed and described in the result
    /// (for the one log line that says so).
    pub fn acquire(plc_id: &str) -> Result<(Owner, Option<Remains>), OwnerError> {
        check_id(plc_id)?;
        let path = lock_path(plc_id);
        let (mut file, ino) = loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .mode(0o644)
                .custom_flags(libc::O_CLOEXEC)
                .open(&path)
                .map_err(os("cannot open the lock file", path.clone()))?;
            let l = whole_file(libc::F_WRLCK as libc::c_short);
            match fcntl(&file, FcntlArg::F_OFD_SETLK(&l)) {
                Ok(_) => {}
                Err(Errno::EAGAIN | Errno::EACCES) => {
                    let pid = read_holder(&mut file)
                        .filter(|h| process::start_time(h.pid) == Some(h.start))
                        .map(|h| h.pid);
                    return Err(OwnerError::Running {
                        plc_id: plc_id.to_string(),
                        pid,
                    });
                }
                Err(e) => return Err(os("cannot lock", path.clone())(e.into())),
            }
            // The previous owner unlinks the file before letting it go: if the file we
            // locked is no longer the one at the path, we locked a file nobody will look
            // at again. Try again with the one there now.
            let ours = file
                .metadata()
                .map_err(os("cannot stat the lock file", path.clone()))?
                .ino();
            match path.metadata() {
                Ok(m) if m.ino() == ours => break (file, ours),
                _ => continue,
            }
        };
        // Who held it last, then at once who holds it now: a death from here on is ours.
        let holder = read_holder(&mut file);
        let last_seen = last_seen(plc_id);
        let me = std::process::id();
        let start = process::start_time(me).unwrap_or(0);
        file.set_len(0)
            .and_then(|()| file.seek(io::SeekFrom::Start(0)).map(drop))
            .and_then(|()| writeln!(file, "{me} {start}"))
            .map_err(os("cannot write the lock file", path.clone()))?;
        let left = existing(plc_id);
        let remains = if left.is_empty() && holder.is_none() {
            None
        } else {
            let mut objects: Vec<PathBuf> = left.iter().map(|(p, _)| p.clone()).collect();
            objects.push(path.clone());
            let remains = Remains {
                pid: holder
                    .map(|h| h.pid)
                    .or_else(|| crate::status::PlcStatus::read(plc_id).map(|s| s.pid)),
                last_seen,
                objects,
            };
            for (p, o) in &left {
                let removed = match o {
                    Object::Shm(name) => crate::shm_name::unlink(name)
                        .map(drop)
                        .map_err(io::Error::from),
                    Object::File => std::fs::remove_file(p).or_else(|e| {
                        if e.kind() == io::ErrorKind::NotFound {
                            Ok(())
                        } else {
                            Err(e)
                        }
                    }),
                };
                removed.map_err(os("cannot remove", p.clone()))?;
            }
            Some(remains)
        };
        Ok((
            Owner {
                plc_id: plc_id.to_string(),
                path,
                file: Some(file),
                ino,
            },
            remains,
        ))
    }

    pub fn plc_id(&self) -> &str {
        &self.plc_id
    }

    /// Gives the id up: removes the lock file, then lets the lock go.
    pub fn release(mut self) {
        self.let_go();
    }

    fn let_go(&mut self) {
        let Some(file) = self.file.take() else { return };
        // Only the file we hold: never one a newer owner made.
        if self.path.metadata().is_ok_and(|m| m.ino() == self.ino) {
            let _ = std::fs::remove_file(&self.path);
        }
        drop(file);
    }
}

impl Drop for Owner {
    fn drop(&mut self) {
        self.let_go();
    }
}

/// The process of the PLC that holds id `plc_id`, proven: the lock is held, the lock file
/// names a pid and start time, a pidfd is opened on that pid, the process behind it started
/// at that time, and the lock is still held with the same words in the file. `Ok(None)`:
/// no PLC holds the id, or its holder cannot be proven (still starting: try again).
pub fn running_plc(plc_id: &str) -> Result<Option<Pidfd>, OwnerError> {
    check_id(plc_id)?;
    let path = lock_path(plc_id);
    let mut file = match File::open(&path) {
        Ok(f) => f,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(os("cannot open the lock file", path)(e)),
    };
    let locked = |f: &File| is_locked(f).map_err(os("cannot test the lock on", path.clone()));
    if !locked(&file)? {
        return Ok(None);
    }
    let Some(holder) = read_holder(&mut file) else {
        return Ok(None);
    };
    let Ok(pidfd) = Pidfd::open(holder.pid) else {
        return Ok(None);
    };
    if process::start_time(holder.pid) != Some(holder.start) {
        return Ok(None);
    }
    if !locked(&file)? || read_holder(&mut file) != Some(holder) {
        return Ok(None);
    }
    // The file at the path must still be the one we looked at (not a newer owner's).
    let same = path
        .metadata()
        .ok()
        .zip(file.metadata().ok())
        .is_some_and(|(a, b)| a.ino() == b.ino());
    Ok(same.then_some(pidfd))
}

/// The raw descriptor of an owner's lock file, so that tests can check it is not inherited.
#[doc(hidden)]
pub fn lock_fd(owner: &Owner) -> Option<i32> {
    owner.file.as_ref().map(|f| f.as_raw_fd())
}
