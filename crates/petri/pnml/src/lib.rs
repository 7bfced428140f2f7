//! ISO/IEC 15909-2 PNML place/transition nets in and out of petriplc's net model: every
//! spelling of special arcs other tools write, petriplc's own `<toolspecific>` data, seed 002's
//! SIPN naming, and graphics kept verbatim so a net read and written back loses nothing.
//!
//! docs/pnml.md describes the format; every problem is reported as a [`Diagnostic`] with a
//! stable code, a file position and the element's id.

pub mod codes;
mod diag;
mod layout;
mod read;
pub mod vocab;
mod write;
mod xml;

use std::path::Path;

use petriplc_net::Net;

pub use codes::CODES;
pub use diag::{Diagnostic, Location, PnmlError};
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

/// The largest file read: [`petriplc_files::PNML`].
pub const MAX_FILE_BYTES: u64 = petriplc_files::PNML.bytes;

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
    petriplc_files::read(path, petriplc_files::PNML).map_err(|e| match e {
        petriplc_files::FileError::Io { source, .. } => source,
        e if matches!(e, petriplc_files::FileError::NotFound { .. }) => {
            std::io::Error::new(std::io::ErrorKind::NotFound, e.reason())
        }
        e => std::io::Error::other(e.reason()),
    })
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
