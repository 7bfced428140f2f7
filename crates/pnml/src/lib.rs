//! ISO/IEC 15909-2 PNML place/transition nets in and out of petriplc's net model: every
//! spelling of special arcs other tools write, petriplc's own `<toolspecific>` data, seed 002's
//! SIPN naming, and graphics kept verbatim so a net read and written back loses nothing.
//!
//! docs/pnml.md describes the format; every problem is reported as a [`Diagnostic`] with a
//! stable code, a file position and the element's id.

mod diag;
mod layout;
mod read;
pub mod vocab;
mod write;
mod xml;

use std::path::Path;

use petriplc_net::Net;

pub use diag::{Diagnostic, PnmlError, CODES};
pub use layout::{Extras, Layout};

/// How names carry meaning.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Naming {
    /// Names are only names.
    #[default]
    Plain,
    /// Seed 002's NetLab convention for SIPN: a place's name is its output signal and a
    /// transition's name its input condition (`!B1` negates); names starting with `default`
    /// are internal. Every place holds at most one token unless it declares a capacity.
    /// Explicit petriplc toolspecific data wins over the convention.
    Sipn,
}

/// Options for reading.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct ReadOptions {
    pub naming: Naming,
}

/// A net as read from a file, with what the model does not hold.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Document {
    pub net: Net,
    pub layout: Layout,
}

/// The largest PNML file read (a net of a million nodes is a few hundred MiB).
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// Reads the one net of a PNML file. Only a regular file of at most [`MAX_FILE_BYTES`] is
/// read: a directory, a device (`/dev/zero` would never end) or a pipe is refused.
pub fn read_file(path: &Path, opts: &ReadOptions) -> Result<Document, PnmlError> {
    let bytes = read_bounded(path).map_err(|source| PnmlError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let source = path.display().to_string();
    match std::str::from_utf8(&bytes) {
        Ok(text) => read_str(text, &source, opts),
        Err(e) => Err(read::not_utf8(&bytes, &e, &source)),
    }
}

fn read_bounded(path: &Path) -> std::io::Result<Vec<u8>> {
    use std::io::{Error, Read};
    let meta = std::fs::metadata(path)?;
    if meta.is_dir() {
        return Err(Error::other("it is a directory; name a PNML file"));
    }
    if !meta.is_file() {
        return Err(Error::other(
            "it is not a regular file (a device or a pipe); name a PNML file",
        ));
    }
    let mut bytes = Vec::new();
    std::fs::File::open(path)?
        .take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(Error::other(format!(
            "it is larger than {} MiB, more than a PNML file petriplc reads",
            MAX_FILE_BYTES >> 20
        )));
    }
    Ok(bytes)
}

/// Reads the one net of a PNML document; `source` names it in diagnostics.
pub fn read_str(text: &str, source: &str, opts: &ReadOptions) -> Result<Document, PnmlError> {
    read::read(text, source, opts)
}

/// Writes `net` as PNML, with the graphics and other tools' data of `layout` when given.
///
/// Reading the result gives back an equal net. Characters XML cannot carry (most control
/// characters) are written as U+FFFD.
pub fn write_string(net: &Net, layout: Option<&Layout>) -> String {
    write::write(net, layout)
}

/// Writes `net` as a PNML file.
pub fn write_file(path: &Path, net: &Net, layout: Option<&Layout>) -> Result<(), PnmlError> {
    std::fs::write(path, write_string(net, layout)).map_err(|source| PnmlError::Write {
        path: path.to_path_buf(),
        source,
    })
}
