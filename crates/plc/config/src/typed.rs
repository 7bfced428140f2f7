//! Layer 2: sections to a [`PlcConfig`]. The `[PLC]` tables become points, modules and the
//! synchronisation net; each module's section gives its settings; then everything is
//! cross-checked, collecting every problem.
//!
//! A setting nobody reads is an error, wherever it is written: `[PLC]` has three settings,
//! `plc_id`, `retain_file` and `retain_write`; a section (or `X: name = value` line) for a module that is not declared is read
//! by nobody (a module program started by hand must be declared too: the C ABI refuses an
//! undeclared module), so any setting or row in it is an error; module sections are checked
//! by their module kinds, and the runner checks the settings it reads itself.

use std::collections::{BTreeMap, HashSet};

use crate::arrow::parse_arrow;
use crate::error::{self, ConfigError, Diagnostic};
use crate::model::{
    Origin, PlaceDecl, PlcConfig, PointDecl, RetainSettings, RetainWrite, Row, Section, Setting,
    SynchDecl, SynchRule,
};
use crate::point::parse_point;
use crate::raw::RawConfig;

mod checks;
mod modules;
#[cfg(test)]
mod tests;

/// The tables `[PLC]` may hold.
pub const PLC_TABLES: &[&str] = &[
    "point",
    "module",
    "place",
    "transition",
    "arc",
    "synch",
    "synch_start",
];

/// The settings of a module's section that the PLC itself reads.
pub const MODULE_SETTINGS: &[&str] = &[
    "scan_period",
    "location",
    "priority",
    "on_failure",
    "restart_delay",
    "restart_delay_max",
    "restart_limit",
    "watchdog",
    "scan_beg",
    "scan_end",
];

/// The settings `[PLC]` may hold.
pub const PLC_SETTINGS: &[&str] = &["plc_id", "retain_file", "retain_write"];

/// MatPLC's `[PLC]` settings that petriplc has no use for, and why.
const MATPLC_PLC_SETTINGS: &[(&str, &str)] = &[
    (
        "confmap_key",
        "MatPLC's key of its configuration shared memory; petriplc names its shared memory \
         after the plc id",
    ),
    (
        "confmap_size",
        "MatPLC's size of its configuration shared memory; petriplc sizes its shared memory \
         itself",
    ),
];

/// The null transition's name: always present, never in an arc.
const NULL: &str = "NULL";

pub(crate) fn build(raw: RawConfig) -> Result<PlcConfig, ConfigError> {
    let (config, diagnostics) = build_partial(raw);
    if diagnostics.is_empty() {
        Ok(config)
    } else {
        Err(ConfigError { diagnostics })
    }
}

/// The configuration as far as it could be read, and every problem found: a tool that
/// checks more (the modules' own settings) reports its problems with these, at once.
pub(crate) fn build_partial(raw: RawConfig) -> (PlcConfig, Vec<Diagnostic>) {
    let mut b = Builder::default();
    let empty = Section::default();
    let plc = raw.sections.get("PLC").unwrap_or(&empty);
    for row in &plc.rows {
        b.row(row);
    }
    let retain = b.check_plc_settings(plc);
    b.check_points();
    b.check_modules();
    b.check_net();
    let modules = b.module_settings(&raw.sections);
    let config = PlcConfig {
        file: raw.file.clone(),
        plc: first_settings(plc),
        retain,
        points: b.points,
        modules,
        synch: b.synch,
        sections: raw.sections.clone(),
    };
    (config, b.diags)
}

/// A section's settings by name; a repeated setting has the same value (layer 1 checks),
/// so the first is kept.
fn first_settings(section: &Section) -> BTreeMap<String, Setting> {
    let mut map = BTreeMap::new();
    for (k, v) in &section.pairs {
        map.entry(k.clone()).or_insert_with(|| v.clone());
    }
    map
}

/// A module row before its section is read.
struct ModuleRow {
    name: String,
    kind: String,
    args: Vec<String>,
    origin: Origin,
}

/// An arc before its ends are resolved to places and transitions.
struct ArcRow {
    from: String,
    to: String,
    weight: u32,
    origin: Origin,
}

#[derive(Default)]
struct Builder {
    diags: Vec<Diagnostic>,
    points: Vec<PointDecl>,
    modules: Vec<ModuleRow>,
    arcs: Vec<ArcRow>,
    synch: SynchDecl,
    /// Places and transitions in file order, for duplicate checks that name the first.
    nodes: Vec<(String, Origin, &'static str)>,
}

impl Builder {
    fn err(&mut self, origin: &Origin, code: &'static str, message: impl Into<String>) {
        self.diags.push(error::diagnostic(origin, code, message));
    }

    fn row(&mut self, row: &Row) {
        let o = &row.origin;
        let cells = row.cells.as_slice();
        match row.table.as_str() {
            "point" => {
                if let Some(p) = parse_point(cells, o, &mut self.diags) {
                    self.points.push(p);
                }
            }
            "module" => match cells {
                [name, kind, args @ ..] if !name.is_empty() && !kind.is_empty() => {
                    self.modules.push(ModuleRow {
                        name: name.clone(),
                        kind: kind.clone(),
                        args: args.to_vec(),
                        origin: o.clone(),
                    })
                }
                _ => self.err(
                    o,
                    error::MODULE_SHAPE,
                    "a module needs a name and a kind or program: `module NAME KIND-or-PATH \
                     [args]`",
                ),
            },
            "place" => {
                let tokens = match cells {
                    [_] => Some(0),
                    [_, t] => t.parse::<u32>().ok(),
                    _ => None,
                };
                match (cells.first(), tokens) {
                    (Some(name), Some(tokens)) if !name.is_empty() => {
                        self.nodes.push((name.clone(), o.clone(), "place"));
                        self.synch.places.push(PlaceDecl {
                            name: name.clone(),
                            tokens,
                            origin: o.clone(),
                        })
                    }
                    _ => self.err(
                        o,
                        error::PLACE_SHAPE,
                        "a place is `place NAME [TOKENS]` with TOKENS a whole number (0 when \
                         left out)",
                    ),
                }
            }
            "transition" => match cells {
                [name] if !name.is_empty() => {
                    self.nodes.push((name.clone(), o.clone(), "transition"));
                    self.synch.transitions.push((name.clone(), o.clone()))
                }
                _ => self.err(
                    o,
                    error::TRANSITION_SHAPE,
                    "a transition is `transition NAME`, one per row",
                ),
            },
            "arc" => match cells {
                [from, arrow, to] => match parse_arrow(arrow) {
                    Ok(weight) => self.arcs.push(ArcRow {
                        from: from.clone(),
                        to: to.clone(),
                        weight,
                        origin: o.clone(),
                    }),
                    Err(why) => self.err(o, error::BAD_ARROW, why),
                },
                _ => self.err(o, error::ARC_SHAPE, shape_hint("arc", "FROM", "TO", cells)),
            },
            "synch" => match cells {
                [from, arrow, to] => match parse_arrow(arrow) {
                    Ok(0) => self.err(
                        o,
                        error::ZERO_WEIGHT_SYNCH,
                        format!(
                            "`synch {from} {arrow} {to}` has weight 0, which synch does not \
                             allow: use a weight of 1 or more (weight-0 arcs need the \
                             place/transition/arc form)"
                        ),
                    ),
                    Ok(weight) => self.synch.rules.push(SynchRule {
                        from: from.clone(),
                        to: to.clone(),
                        weight,
                        origin: o.clone(),
                    }),
                    Err(why) => self.err(o, error::BAD_ARROW, why),
                },
                _ => self.err(
                    o,
                    error::SYNCH_SHAPE,
                    shape_hint("synch", "MODULE1", "MODULE2", cells),
                ),
            },
            "synch_start" => {
                if cells.is_empty() {
                    self.err(
                        o,
                        error::SYNCH_SHAPE,
                        "`synch_start` needs at least one module: `synch_start MODULE [MODULE ...]`",
                    );
                }
                for m in cells {
                    self.synch.starts.push((m.clone(), o.clone()));
                }
            }
            "point_alias" | "synchpt" => self.err(
                o,
                error::UNSUPPORTED_TABLE,
                format!(
                    "MatPLC's `{}` table is not supported: {}",
                    row.table,
                    if row.table == "point_alias" {
                        "declare separate points instead"
                    } else {
                        "use `scan_beg`/`scan_end` settings of the modules instead"
                    }
                ),
            ),
            other => self.err(
                o,
                error::UNKNOWN_TABLE,
                format!(
                    "`{other}` is not a [PLC] table: the tables are {}; settings are written \
                     `name = value`, and a module's own tables belong in its [module] section",
                    PLC_TABLES.join(", ")
                ),
            ),
        }
    }

    /// `[PLC]` holds `plc_id`, `retain_file`, `retain_write` and nothing else.
    fn check_plc_settings(&mut self, plc: &Section) -> RetainSettings {
        let mut retain = RetainSettings::default();
        let mut seen = HashSet::new();
        for (key, s) in &plc.pairs {
            if !seen.insert(key) {
                continue;
            }
            if key == "retain_file" {
                if s.value.is_empty() {
                    self.err(
                        &s.origin,
                        error::BAD_RETAIN_SETTING,
                        "`retain_file` is empty: give the file that keeps the retentive values \
                         (relative to this configuration file's folder), or remove the line for \
                         the default",
                    );
                } else {
                    retain.file = Some(s.clone());
                }
                continue;
            }
            if key == "retain_write" {
                match s.value.as_str() {
                    "change" => retain.write = RetainWrite::Change,
                    v => match petriplc_net::time::parse_duration(v) {
                        Ok(d) if !d.is_zero() => retain.write = RetainWrite::Every(d),
                        Ok(_) => retain.write = RetainWrite::Change,
                        Err(e) => self.err(
                            &s.origin,
                            error::BAD_RETAIN_SETTING,
                            format!(
                                "`retain_write = {v}`: write `change` (every change, as soon as \
                                 the previous write is done) or the shortest time between two \
                                 writes (e.g. `T#500ms`, the default): {e}"
                            ),
                        ),
                    },
                }
                continue;
            }
            if key == "plc_id" {
                if s.value.is_empty() {
                    self.err(
                        &s.origin,
                        error::BAD_PLC_ID,
                        "`plc_id` is empty: give the PLC's id (letters, digits, `_`, `-`, `.`) \
                         or remove the line",
                    );
                }
                continue;
            }
            let why = MATPLC_PLC_SETTINGS
                .iter()
                .find(|(name, _)| name == key)
                .map(|(_, why)| format!(" ({why})"))
                .unwrap_or_default();
            let module = if MODULE_SETTINGS.contains(&key.as_str()) {
                format!(
                    "; `{key}` is a module's setting: write it in the module's section \
                     ([NAME]) or as `NAME: {key} = {}`",
                    s.value
                )
            } else {
                String::new()
            };
            self.err(
                &s.origin,
                error::UNKNOWN_PLC_SETTING,
                format!(
                    "`{key} = {}` in [PLC]: nothing reads this setting{why}; [PLC] has only \
                     {}{module}",
                    s.value,
                    PLC_SETTINGS.join(", ")
                ),
            );
        }
        retain
    }
}

/// "declared modules: a, b" or "no modules are declared", for messages.
fn declared<'a>(what: &str, names: impl Iterator<Item = &'a str>) -> String {
    let names: Vec<&str> = names.collect();
    if names.is_empty() {
        format!("no {what} are declared")
    } else {
        format!("declared {what}: {}", names.join(", "))
    }
}

fn shape_hint(table: &str, from: &str, to: &str, cells: &[String]) -> String {
    let glued = cells.len() < 3 && cells.iter().any(|c| c.contains('>'));
    format!(
        "`{table}` takes three words, `{table} {from} ARROW {to}` (e.g. `{table} A -> B`){}",
        if glued {
            ": put spaces around the arrow"
        } else {
            ""
        }
    )
}
