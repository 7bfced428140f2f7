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

/// A setting given on the command line (`petriplc run --set SECTION:NAME=VALUE`): it replaces
/// the section's setting of that name, or adds it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Override {
    pub section: String,
    pub name: String,
    pub value: String,
}

impl std::str::FromStr for Override {
    type Err = String;

    /// `SECTION:NAME=VALUE`, e.g. `hmi:listen=127.0.0.1:8081`.
    fn from_str(text: &str) -> Result<Override, String> {
        let bad = || {
            format!("`{text}` is not SECTION:NAME=VALUE (for example `hmi:listen=127.0.0.1:8081`)")
        };
        let (section, rest) = text.split_once(':').ok_or_else(bad)?;
        let (name, value) = rest.split_once('=').ok_or_else(bad)?;
        let (section, name) = (section.trim(), name.trim());
        let word = |w: &str| !w.is_empty() && !w.contains(char::is_whitespace);
        if !word(section) || !word(name) {
            return Err(bad());
        }
        Ok(Override {
            section: section.to_string(),
            name: name.to_string(),
            value: value.trim().to_string(),
        })
    }
}

/// [`read_file`], with `overrides` applied to the sections before they are given meaning (so
/// an overridden `scan_period` is checked like one in the file). Messages about an
/// overridden setting point at `--set`.
pub fn read_file_with(path: &Path, overrides: &[Override]) -> Result<PlcConfig, ConfigError> {
    let mut raw = read_raw(path)?;
    for o in overrides {
        let section = raw
            .sections
            .entry(o.section.clone())
            .or_insert_with(|| Section {
                name: o.section.clone(),
                pairs: Vec::new(),
                rows: Vec::new(),
            });
        let setting = Setting {
            value: o.value.clone(),
            origin: Origin {
                file: "--set".to_string(),
                line: 0,
            },
        };
        match section.pairs.iter_mut().find(|(k, _)| *k == o.name) {
            Some((_, s)) => *s = setting,
            None => section.pairs.push((o.name.clone(), setting)),
        }
    }
    typed::build(raw)
}

/// Reads `text` as the configuration file `file` (the name used in messages); `*include`s
/// are resolved relative to `include_dir`.
pub fn parse_str(text: &str, file: &str, include_dir: &Path) -> Result<PlcConfig, ConfigError> {
    typed::build(parse_raw_str(text, file, include_dir)?)
}
