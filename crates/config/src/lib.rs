//! MatPLC-style configuration files for the petriplc soft PLC: `[sections]`, `name = value`
//! settings, the `Section: name = value` shorthand, table rows, `*include FILE` and `#`
//! comments, read into the typed [`PlcConfig`] (points, modules and their settings, the
//! synchronisation net).
//!
//! Reading has two layers: [`read_raw`]/[`parse_raw_str`] turn text into [`Section`]s (what
//! any module's own settings and tables are read from), and [`read_file`]/[`parse_str`] go on
//! to give the `[PLC]` section and the modules' PLC-level settings their meaning. Every
//! problem found is reported, each with its file, line, a stable code and how to fix it; a
//! configuration with any problem is refused as a whole. When layer 1 fails its problems are
//! reported alone, since the lines it could not read would only cause follow-on errors.

mod arrow;
pub mod error;
pub mod model;
mod point;
pub mod raw;
mod typed;

use std::path::Path;

pub use error::{ConfigError, Diagnostic, CODES};
pub use model::*;
pub use point::MAX_WORDS;
pub use raw::{parse_raw_str, read_raw, RawConfig};
pub use typed::{MODULE_SETTINGS, PLC_TABLES};

/// Reads the configuration at `path` and the files it includes (relative to the including
/// file's directory).
pub fn read_file(path: &Path) -> Result<PlcConfig, ConfigError> {
    typed::build(read_raw(path)?)
}

/// Reads `text` as the configuration file `file` (the name used in messages); `*include`s
/// are resolved relative to `include_dir`.
pub fn parse_str(text: &str, file: &str, include_dir: &Path) -> Result<PlcConfig, ConfigError> {
    typed::build(parse_raw_str(text, file, include_dir)?)
}
