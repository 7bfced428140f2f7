//! Reading the files a user names — configurations, programs, nets, timelines, password
//! files — so that a wrong path can never hang or exhaust the machine.
//!
//! A path is read only if it is a regular file; a folder, a pipe (opening one waits for a
//! writer, for ever if none comes), a device (`/dev/zero` would be read without end, a
//! terminal would wait for typing) or a socket is refused before it is opened. What is read is bounded by [`Limit`]: the most a
//! file of that format can sensibly hold, stated once per format, so that a huge file (or a
//! pipe that never ends) is refused with its size instead of being read into memory.
//!
//! The errors name the file and say what is wrong once, in words (`it is a folder`, not
//! `Is a directory (os error 21)` wrapped twice).

use std::fmt;
use std::fs::File;
use std::io::{self, Read};
use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};

/// The largest file of one format: its size and its name for messages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Limit {
    pub bytes: u64,
    /// What such a file is, for messages: `a configuration file`.
    pub what: &'static str,
}

/// MatPLC-style configuration files (each file of an `*include` chain).
pub const CONFIG: Limit = Limit {
    bytes: 16 << 20,
    what: "a configuration file",
};
/// IEC 61131-3 sources: Structured Text, Instruction List, PLCopen XML projects (all of
/// OSCAT's libraries together are about 4 MiB).
pub const IEC_SOURCE: Limit = Limit {
    bytes: 256 << 20,
    what: "a .st, .il or .xml file",
};
/// PNML nets (the largest P/T models of the Model Checking Contest are tens of MiB).
pub const PNML: Limit = Limit {
    bytes: 1 << 30,
    what: "a PNML file",
};
/// Timelines of inputs (CSV).
pub const TIMELINE: Limit = Limit {
    bytes: 512 << 20,
    what: "a timeline",
};
/// Small text files of settings: password files, certificates and keys, display screens.
pub const SMALL: Limit = Limit {
    bytes: 1 << 20,
    what: "a settings file",
};

/// Why a file could not be read.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("cannot read {}: {}", .path.display(), self.reason())]
    NotFound { path: PathBuf },
    #[error("cannot read {}: {}", .path.display(), self.reason())]
    NotAFile {
        path: PathBuf,
        kind: Kind,
        what: &'static str,
    },
    #[error("cannot read {}: {}", .path.display(), self.reason())]
    TooLarge {
        path: PathBuf,
        /// The file's size, or what was read before giving up (it grew while read).
        size_at_least: u64,
        limit: u64,
        what: &'static str,
    },
    #[error("cannot read {}: {}", .path.display(), self.reason())]
    Io {
        path: PathBuf,
        #[source]
        source: io::Error,
    },
}

impl FileError {
    /// What is wrong, without the file's name (for messages that name it already):
    /// `it is a directory; name a PNML file`.
    pub fn reason(&self) -> String {
        match self {
            FileError::NotFound { .. } => "no such file".to_string(),
            FileError::NotAFile { kind, what, .. } => format!("it is {kind}; name {what}"),
            FileError::TooLarge {
                size_at_least,
                limit,
                what,
                ..
            } => format!(
                "it is larger than {} ({}), more than {what} can sensibly be; check the path",
                Size(*limit),
                Size(*size_at_least)
            ),
            FileError::Io { source, .. } => Reason(source).to_string(),
        }
    }

    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            FileError::NotFound { path }
            | FileError::NotAFile { path, .. }
            | FileError::TooLarge { path, .. }
            | FileError::Io { path, .. } => path,
        }
    }
}

/// What a path that is not a file is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Folder,
    Fifo,
    CharDevice,
    BlockDevice,
    Socket,
    Other,
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Kind::Folder => "a directory",
            Kind::Fifo => "a pipe (FIFO), not a regular file",
            Kind::CharDevice => "a device, not a regular file",
            Kind::BlockDevice => "a block device, not a regular file",
            Kind::Socket => "a socket, not a regular file",
            Kind::Other => "not a regular file",
        })
    }
}

/// A byte count for people: `16 MiB`, `812 bytes`.
struct Size(u64);

impl fmt::Display for Size {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = self.0;
        if n >= 1 << 20 && n % (1 << 20) == 0 {
            write!(f, "{} MiB", n >> 20)
        } else if n >= 1 << 20 {
            write!(f, "{:.1} MiB", n as f64 / f64::from(1 << 20))
        } else {
            write!(f, "{n} bytes")
        }
    }
}

/// An I/O error in words, without the `(os error N)` suffix people cannot act on.
struct Reason<'a>(&'a io::Error);

impl fmt::Display for Reason<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0.kind() {
            io::ErrorKind::PermissionDenied => f.write_str("permission denied"),
            io::ErrorKind::InvalidData => f.write_str("it is not text"),
            _ => {
                let text = self.0.to_string();
                let text = match text.find(" (os error") {
                    Some(i) => &text[..i],
                    None => &text,
                };
                f.write_str(&text.to_lowercase())
            }
        }
    }
}

/// Whether `path` may be read: a regular file of at most `limit` bytes. Follows symbolic
/// links.
pub fn check(path: &Path, limit: Limit) -> Result<(), FileError> {
    let meta = std::fs::metadata(path).map_err(|e| error(path, e))?;
    let t = meta.file_type();
    let kind = if t.is_file() {
        return if meta.len() > limit.bytes {
            Err(FileError::TooLarge {
                path: path.to_path_buf(),
                size_at_least: meta.len(),
                limit: limit.bytes,
                what: limit.what,
            })
        } else {
            Ok(())
        };
    } else if t.is_dir() {
        Kind::Folder
    } else if t.is_fifo() {
        Kind::Fifo
    } else if t.is_char_device() {
        Kind::CharDevice
    } else if t.is_block_device() {
        Kind::BlockDevice
    } else if t.is_socket() {
        Kind::Socket
    } else {
        Kind::Other
    };
    Err(FileError::NotAFile {
        path: path.to_path_buf(),
        kind,
        what: limit.what,
    })
}

/// The bytes of the file at `path`, refused unless it is a regular file of at most `limit`
/// bytes.
pub fn read(path: &Path, limit: Limit) -> Result<Vec<u8>, FileError> {
    check(path, limit)?;
    let file = File::open(path).map_err(|e| error(path, e))?;
    let mut bytes = Vec::new();
    // Bounded even if the file grows while it is read.
    file.take(limit.bytes + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| error(path, e))?;
    if bytes.len() as u64 > limit.bytes {
        return Err(FileError::TooLarge {
            path: path.to_path_buf(),
            size_at_least: bytes.len() as u64,
            limit: limit.bytes,
            what: limit.what,
        });
    }
    Ok(bytes)
}

/// [`read`], as UTF-8 text (a leading byte order mark is kept: the caller's parser decides).
pub fn read_to_string(path: &Path, limit: Limit) -> Result<String, FileError> {
    String::from_utf8(read(path, limit)?).map_err(|e| {
        error(
            path,
            io::Error::new(io::ErrorKind::InvalidData, e.utf8_error()),
        )
    })
}

fn error(path: &Path, e: io::Error) -> FileError {
    match e.kind() {
        io::ErrorKind::NotFound => FileError::NotFound {
            path: path.to_path_buf(),
        },
        io::ErrorKind::IsADirectory => FileError::NotAFile {
            path: path.to_path_buf(),
            kind: Kind::Folder,
            what: "a file",
        },
        _ => FileError::Io {
            path: path.to_path_buf(),
            source: e,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check_read(path: &Path, limit: Limit, expect: &str) {
        match read(path, limit) {
            Ok(b) => assert_eq!(format!("{} bytes", b.len()), expect),
            Err(e) => assert_eq!(e.to_string(), expect),
        }
    }

    const TINY: Limit = Limit {
        bytes: 10,
        what: "a tiny file",
    };

    #[test]
    fn only_regular_files_are_read_and_within_their_limit() {
        let dir = tempfile::tempdir().unwrap();
        let f = dir.path().join("a.txt");
        std::fs::write(&f, "0123456789").unwrap();
        check_read(&f, TINY, "10 bytes");
        std::fs::write(&f, "0123456789x").unwrap();
        check_read(
            &f,
            TINY,
            &format!(
                "cannot read {}: it is larger than 10 bytes (11 bytes), more than a tiny file \
                 can sensibly be; check the path",
                f.display()
            ),
        );
        // A pipe is refused before it is opened: opening it would wait for a writer.
        let mut child = std::process::Command::new("sh")
            .args(["-c", "yes"])
            .stdout(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        let fd = format!(
            "/proc/self/fd/{}",
            std::os::fd::AsRawFd::as_raw_fd(child.stdout.as_ref().unwrap())
        );
        let e = read(Path::new(&fd), CONFIG).unwrap_err();
        assert!(
            e.to_string()
                .ends_with("it is a pipe (FIFO), not a regular file; name a configuration file"),
            "{e}"
        );
        child.kill().unwrap();
        child.wait().unwrap();
    }

    #[test]
    fn folders_devices_and_missing_files_are_refused_in_words() {
        let dir = tempfile::tempdir().unwrap();
        check_read(
            dir.path(),
            CONFIG,
            &format!(
                "cannot read {}: it is a directory; name a configuration file",
                dir.path().display()
            ),
        );
        check_read(
            Path::new("/dev/zero"),
            IEC_SOURCE,
            "cannot read /dev/zero: it is a device, not a regular file; name a .st, .il or \
             .xml file",
        );
        check_read(
            &dir.path().join("nope.st"),
            IEC_SOURCE,
            &format!(
                "cannot read {}: no such file",
                dir.path().join("nope.st").display()
            ),
        );
        assert_eq!(Size(16 << 20).to_string(), "16 MiB");
        assert_eq!(Size(3 << 19).to_string(), "1.5 MiB");
    }
}
