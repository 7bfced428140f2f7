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
pub mod codes;
pub mod error;
pub mod model;
mod point;
pub mod raw;
mod typed;

use std::path::Path;

pub use codes::CODES;
pub use error::{ConfigError, Diagnostic};
pub use model::*;
pub use point::MAX_WORDS;
pub use raw::{parse_raw_str, read_raw, RawConfig};
pub use typed::{MODULE_SETTINGS, PLC_TABLES};

/// Reads the configuration at `path` and the files it includes (relative to the including
/// file's directory).
pub fn read_file(path: &Path) -> Result<PlcConfig, ConfigError> {
    typed::build(read_raw(path)?)
}

/// A setting or a table row given on the command line (`petriplc run --set`):
/// `SECTION:NAME=VALUE` replaces the section's setting of that name, or adds it;
/// `SECTION:TABLE KEY CELL…` replaces the section's row of that table whose first cell is
/// KEY (`--set 'io:device table tcp:127.0.0.1:5022 1 5ms 500ms'`), or adds it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Override {
    pub section: String,
    /// The setting's name, or the row's table.
    pub name: String,
    /// The setting's value (empty for a row).
    pub value: String,
    /// A row's cells, its key first; `None` for a setting.
    pub cells: Option<Vec<String>>,
}

impl std::str::FromStr for Override {
    type Err = String;

    /// `SECTION:NAME=VALUE`, e.g. `hmi:listen=127.0.0.1:8081`, or `SECTION:TABLE KEY CELL…`.
    fn from_str(text: &str) -> Result<Override, String> {
        let bad = || {
            format!(
                "`{text}` is neither SECTION:NAME=VALUE (for example `hmi:listen=127.0.0.1:8081`) \
                 nor SECTION:TABLE KEY CELL… (a row, for example `io:device table \
                 tcp:127.0.0.1:5022 1 5ms 500ms`)"
            )
        };
        let (section, rest) = text.split_once(':').ok_or_else(bad)?;
        let section = section.trim();
        if section.is_empty() || section.contains(char::is_whitespace) {
            return Err(bad());
        }
        match raw::setting_or_row(rest).map_err(|_| bad())? {
            raw::Entry::Pair(name, value) => Ok(Override {
                section: section.to_string(),
                name,
                value: value.trim().to_string(),
                cells: None,
            }),
            raw::Entry::Row(table, cells) if !cells.is_empty() => Ok(Override {
                section: section.to_string(),
                name: table,
                value: String::new(),
                cells: Some(cells),
            }),
            raw::Entry::Row(..) => Err(bad()),
        }
    }
}

impl std::fmt::Display for Override {
    /// As it is written after `--set`, so that it reads back the same.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.cells {
            None => write!(f, "{}:{}={}", self.section, self.name, self.value),
            Some(cells) => {
                write!(f, "{}:{}", self.section, self.name)?;
                for c in cells {
                    if c.is_empty()
                        || c.contains(|ch: char| ch.is_whitespace() || "\"#".contains(ch))
                    {
                        write!(f, " \"{}\"", c.replace('\\', "\\\\").replace('"', "\\\""))?;
                    } else {
                        write!(f, " {c}")?;
                    }
                }
                Ok(())
            }
        }
    }
}

/// [`read_file`], with `overrides` applied to the sections before they are given meaning (so
/// an overridden `scan_period` is checked like one in the file). Messages about an
/// overridden setting point at `--set`.
pub fn read_file_with(path: &Path, overrides: &[Override]) -> Result<PlcConfig, ConfigError> {
    let (config, diagnostics) = read_file_partial(path, overrides)?;
    if diagnostics.is_empty() {
        Ok(config)
    } else {
        Err(ConfigError { diagnostics })
    }
}

/// [`read_file_with`], giving the configuration as far as it could be given meaning with
/// every problem found in it, so that a caller can check the rest (the modules' own
/// settings) and report all at once. `Err` only when the files cannot be read at all.
pub fn read_file_partial(
    path: &Path,
    overrides: &[Override],
) -> Result<(PlcConfig, Vec<Diagnostic>), ConfigError> {
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
        let origin = Origin {
            file: "--set".to_string(),
            line: 0,
        };
        if let Some(cells) = &o.cells {
            let row = Row {
                table: o.name.clone(),
                cells: cells.clone(),
                origin,
            };
            let same = |r: &Row| r.table == row.table && r.cells.first() == row.cells.first();
            match section.rows.iter_mut().find(|r| same(r)) {
                Some(r) => *r = row,
                None => section.rows.push(row),
            }
            continue;
        }
        let setting = Setting {
            value: o.value.clone(),
            origin,
        };
        match section.pairs.iter_mut().find(|(k, _)| *k == o.name) {
            Some((_, s)) => *s = setting,
            None => section.pairs.push((o.name.clone(), setting)),
        }
    }
    Ok(typed::build_partial(raw))
}

/// Reads `text` as the configuration file `file` (the name used in messages); `*include`s
/// are resolved relative to `include_dir`.
pub fn parse_str(text: &str, file: &str, include_dir: &Path) -> Result<PlcConfig, ConfigError> {
    typed::build(parse_raw_str(text, file, include_dir)?)
}
