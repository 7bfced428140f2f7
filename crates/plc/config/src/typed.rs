//! Layer 2: sections to a [`PlcConfig`]. The `[PLC]` tables become points, modules and the
//! synchronisation net; each module's section gives its settings; then everything is
//! cross-checked, collecting every problem.
//!
//! A setting nobody reads is an error, wherever it is written: `[PLC]` has three settings,
//! `plc_id`, `retain_file` and `retain_write`; a section (or `X: name = value` line) for a module that is not declared is read
//! by nobody (a module program started by hand must be declared too: the C ABI refuses an
//! undeclared module), so any setting or row in it is an error; module sections are checked
//! by their module kinds, and the runner checks the settings it reads itself.

use std::collections::{BTreeMap, HashMap, HashSet};

use crate::arrow::parse_arrow;
use crate::error::{self, ConfigError, Diagnostic};
use crate::model::{
    ArcDecl, Location, ModuleDecl, OnFailure, Origin, PlaceDecl, PlcConfig, PointDecl,
    RetainSettings, RetainWrite, Row, Section, Setting, SynchDecl, SynchRule,
};
use crate::point::parse_point;
use crate::raw::RawConfig;

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

    fn check_points(&mut self) {
        let mut first: HashMap<&str, &Origin> = HashMap::new();
        let mut diags = Vec::new();
        for p in &self.points {
            if let Some(o) = first.get(p.name.as_str()) {
                diags.push(
                    error::diagnostic(
                        &p.origin,
                        error::DUPLICATE_POINT,
                        format!(
                            "point {} is declared twice (first at {o}): a point has one owner and \
                         one place, so rename or remove one of them",
                            p.name
                        ),
                    )
                    .with_label(
                        (*o).clone(),
                        format!("point {} first declared here", p.name),
                    ),
                );
            } else {
                first.insert(&p.name, &p.origin);
            }
        }
        let modules: HashSet<&str> = self.modules.iter().map(|m| m.name.as_str()).collect();
        for p in &self.points {
            if !modules.contains(p.owner.as_str()) {
                diags.push(error::diagnostic(
                    &p.origin,
                    error::UNKNOWN_OWNER,
                    format!(
                        "the owner of point {}, `{}`, is not a declared module: add `module {} \
                         KIND-or-PATH` to [PLC] or give the point another owner ({})",
                        p.name,
                        p.owner,
                        p.owner,
                        declared("modules", self.modules.iter().map(|m| m.name.as_str()))
                    ),
                ));
            }
        }
        // Placed points by word, to find shared bits in one pass over each word.
        let mut by_word: BTreeMap<u32, Vec<&PointDecl>> = BTreeMap::new();
        for p in &self.points {
            if let Some((w, _)) = p.at {
                by_word.entry(w).or_default().push(p);
            }
        }
        for (word, points) in by_word {
            for (j, b) in points.iter().enumerate() {
                for a in &points[..j] {
                    if mask(a) & mask(b) != 0 && a.name != b.name {
                        diags.push(
                            error::diagnostic(
                                &b.origin,
                                error::OVERLAPPING_POINTS,
                                format!(
                                "point {} (bits {}) overlaps point {} (bits {}, at {}) in word \
                                 {word}: each bit has one writer, so move one of them",
                                b.name,
                                bit_range(b),
                                a.name,
                                bit_range(a),
                                a.origin
                            ),
                            )
                            .with_label(
                                a.origin.clone(),
                                format!("point {} declared here", a.name),
                            ),
                        );
                    }
                }
            }
        }
        self.diags.extend(diags);
    }

    fn check_modules(&mut self) {
        let mut first: HashMap<&str, &Origin> = HashMap::new();
        let mut diags = Vec::new();
        for m in &self.modules {
            if m.name.eq_ignore_ascii_case("PLC") || m.name == NULL {
                diags.push(error::diagnostic(
                    &m.origin,
                    error::RESERVED_NAME,
                    format!("`{}` is reserved: give the module another name", m.name),
                ));
            }
            if let Some(o) = first.get(m.name.as_str()) {
                diags.push(
                    error::diagnostic(
                        &m.origin,
                        error::DUPLICATE_MODULE,
                        format!(
                            "module {} is declared twice (first at {o}): module names name their \
                         sections, so rename or remove one of them",
                            m.name
                        ),
                    )
                    .with_label(
                        (*o).clone(),
                        format!("module {} first declared here", m.name),
                    ),
                );
            } else {
                first.insert(&m.name, &m.origin);
            }
        }
        let modules: HashSet<&str> = self.modules.iter().map(|m| m.name.as_str()).collect();
        let known = || declared("modules", self.modules.iter().map(|m| m.name.as_str()));
        for r in &self.synch.rules {
            for name in [&r.from, &r.to] {
                if !modules.contains(name.as_str()) {
                    diags.push(error::diagnostic(
                        &r.origin,
                        error::UNKNOWN_SYNCH_MODULE,
                        format!(
                            "`synch` names `{name}`, which is not a declared module: declare it \
                             with `module {name} KIND-or-PATH` or correct the name ({})",
                            known()
                        ),
                    ));
                }
            }
        }
        for (name, o) in &self.synch.starts {
            if !modules.contains(name.as_str()) {
                diags.push(error::diagnostic(
                    o,
                    error::UNKNOWN_SYNCH_MODULE,
                    format!(
                        "`synch_start` names `{name}`, which is not a declared module: declare \
                         it with `module {name} KIND-or-PATH` or correct the name ({})",
                        known()
                    ),
                ));
            }
        }
        self.diags.extend(diags);
    }

    fn check_net(&mut self) {
        let mut diags = Vec::new();
        let mut first: HashMap<&str, (&Origin, &str)> = HashMap::new();
        for (name, o, kind) in &self.nodes {
            if name == NULL {
                diags.push(error::diagnostic(
                    o,
                    error::RESERVED_NAME,
                    format!(
                        "`NULL` is reserved for the null transition: give the {kind} another name"
                    ),
                ));
            } else if let Some((at, was)) = first.get(name.as_str()) {
                diags.push(
                    error::diagnostic(
                        o,
                        error::DUPLICATE_NODE,
                        format!(
                            "`{name}` is already declared as a {was} at {at}: places and \
                         transitions share one set of names, so rename one of them"
                        ),
                    )
                    .with_label((*at).clone(), format!("the {was} `{name}` declared here")),
                );
            } else {
                first.insert(name, (o, *kind));
            }
        }
        let mut arcs = Vec::new();
        for a in &self.arcs {
            let mut kinds = Vec::new();
            for end in [&a.from, &a.to] {
                if end == NULL {
                    diags.push(error::diagnostic(
                        &a.origin,
                        error::UNKNOWN_ARC_END,
                        "an arc cannot touch `NULL` (the null transition never fires anything): \
                         declare a transition and use it",
                    ));
                } else if let Some((_, kind)) = first.get(end.as_str()) {
                    kinds.push(*kind);
                } else {
                    diags.push(error::diagnostic(
                        &a.origin,
                        error::UNKNOWN_ARC_END,
                        format!(
                            "the arc names `{end}`, which is neither a place nor a transition: \
                             declare it with `place {end}` or `transition {end}`"
                        ),
                    ));
                }
            }
            let [from, to] = kinds[..] else { continue };
            if from == to {
                diags.push(error::diagnostic(
                    &a.origin,
                    error::ARC_SAME_KIND,
                    format!(
                        "the arc goes from {from} `{}` to {to} `{}`: an arc joins a place and a \
                         transition",
                        a.from, a.to
                    ),
                ));
            } else if a.weight == 0 && from == "transition" {
                diags.push(error::diagnostic(
                    &a.origin,
                    error::ZERO_WEIGHT_FROM_TRANSITION,
                    format!(
                        "the arc from transition `{}` to place `{}` has weight 0, which only \
                         arcs from a place may have (\"fire only while the place is empty\"): \
                         give it a weight of 1 or more",
                        a.from, a.to
                    ),
                ));
            } else {
                arcs.push(ArcDecl {
                    from: a.from.clone(),
                    to: a.to.clone(),
                    weight: a.weight,
                    origin: a.origin.clone(),
                });
            }
        }
        self.synch.arcs = arcs;
        self.diags.extend(diags);
    }

    fn module_settings(&mut self, sections: &BTreeMap<String, Section>) -> Vec<ModuleDecl> {
        let transitions: HashSet<&str> = self
            .synch
            .transitions
            .iter()
            .map(|(n, _)| n.as_str())
            .collect();
        let mut diags = Vec::new();
        let mut out = Vec::new();
        let empty = Section::default();
        let mut done = HashSet::new();
        for m in &self.modules {
            // A second module of one name is already an error; its settings are the first's.
            if !done.insert(m.name.as_str()) {
                continue;
            }
            let section = sections.get(&m.name).unwrap_or(&empty);
            let settings = first_settings(section);
            let mut decl = ModuleDecl {
                args: m.args.clone(),
                origin: m.origin.clone(),
                ..ModuleDecl::new(m.name.clone(), m.kind.clone())
            };
            // In file order, so the messages come out in the order the lines were written.
            let mut seen = HashSet::new();
            for (key, s) in &section.pairs {
                if !seen.insert(key) {
                    continue;
                }
                let mut bad = |code, msg: String| {
                    diags.push(error::diagnostic(
                        &s.origin,
                        code,
                        format!("`{key} = {}` for module {}: {msg}", s.value, m.name),
                    ))
                };
                let v = s.value.as_str();
                match key.as_str() {
                    "scan_period" => match petriplc_net::time::parse_duration(v) {
                        Ok(d) => decl.scan_period = Some(d),
                        Err(e) => bad(error::BAD_SCAN_PERIOD, e.to_string()),
                    },
                    "location" => match v {
                        "local" => decl.location = Location::Local,
                        "shared" => decl.location = Location::Shared,
                        "isolate" => decl.location = Location::Isolate,
                        _ => bad(
                            error::BAD_LOCATION,
                            "write `local` (the default), `shared` or `isolate`".into(),
                        ),
                    },
                    "priority" => match v.parse::<u8>() {
                        Ok(p @ 1..=99) => decl.priority = Some(p),
                        _ => bad(
                            error::BAD_PRIORITY,
                            "write a real-time priority from 1 to 99, or leave it out for \
                             normal scheduling"
                                .into(),
                        ),
                    },
                    "on_failure" => match v {
                        "stop" => decl.on_failure = OnFailure::Stop,
                        "restart" => decl.on_failure = OnFailure::Restart,
                        "ignore" => decl.on_failure = OnFailure::Ignore,
                        _ => bad(
                            error::BAD_ON_FAILURE,
                            "write `stop` (the default), `restart` or `ignore`".into(),
                        ),
                    },
                    "restart_delay" | "restart_delay_max" => {
                        match petriplc_net::time::parse_duration(v) {
                            Ok(d) if key == "restart_delay" => decl.restart.delay = d,
                            Ok(d) if !d.is_zero() => decl.restart.delay_max = d,
                            Ok(_) => bad(
                                error::BAD_RESTART,
                                "the longest delay between restarts must be longer than 0 \
                                 (e.g. `T#10s`)"
                                    .into(),
                            ),
                            Err(e) => bad(error::BAD_RESTART, e.to_string()),
                        }
                    }
                    "watchdog" => match petriplc_net::time::parse_duration(v) {
                        Ok(d) if !d.is_zero() => decl.watchdog = Some(d),
                        Ok(_) => bad(
                            error::BAD_WATCHDOG,
                            "a watchdog must be longer than 0 (e.g. `T#100ms`); remove the \
                             line for none"
                                .into(),
                        ),
                        Err(e) => bad(error::BAD_WATCHDOG, e.to_string()),
                    },
                    "restart_limit" => match v.parse::<u32>() {
                        Ok(n) => decl.restart.limit = n,
                        Err(_) => bad(
                            error::BAD_RESTART,
                            "write how many restarts in a row are allowed (a whole number; \
                             0 for no limit)"
                                .into(),
                        ),
                    },
                    "scan_beg" | "scan_end" => {
                        let t = if v == NULL {
                            None
                        } else if transitions.contains(v) {
                            Some(v.to_string())
                        } else {
                            bad(
                                error::UNKNOWN_SCAN_TRANSITION,
                                format!(
                                    "`{v}` is not a declared transition: declare it with \
                                     `transition {v}` in [PLC], or write NULL ({})",
                                    declared(
                                        "transitions",
                                        self.synch.transitions.iter().map(|(n, _)| n.as_str())
                                    )
                                ),
                            );
                            None
                        };
                        if key == "scan_beg" {
                            decl.scan_beg = t;
                        } else {
                            decl.scan_end = t;
                        }
                    }
                    _ => {}
                }
            }
            if decl.on_failure != OnFailure::Restart {
                for key in ["restart_delay", "restart_delay_max", "restart_limit"] {
                    if let Some(s) = settings.get(key) {
                        diags.push(error::diagnostic(
                            &s.origin,
                            error::BAD_RESTART,
                            format!(
                                "`{key} = {}` for module {}: nothing reads it, because the \
                                 module's on_failure is not `restart`; set `on_failure = \
                                 restart` or remove the line",
                                s.value, m.name
                            ),
                        ));
                    }
                }
            }
            if decl.restart.delay > decl.restart.delay_max {
                let s = settings
                    .get("restart_delay")
                    .or(settings.get("restart_delay_max"));
                if let Some(s) = s {
                    diags.push(error::diagnostic(
                        &s.origin,
                        error::BAD_RESTART,
                        format!(
                            "module {}: restart_delay ({:?}) is longer than restart_delay_max \
                             ({:?}): the delay starts at restart_delay and doubles up to \
                             restart_delay_max",
                            m.name, decl.restart.delay, decl.restart.delay_max
                        ),
                    ));
                }
            }
            decl.settings = settings;
            out.push(decl);
        }
        let modules: HashSet<&str> = self.modules.iter().map(|m| m.name.as_str()).collect();
        for (name, section) in sections {
            if name == "PLC" || modules.contains(name.as_str()) {
                continue;
            }
            if name.eq_ignore_ascii_case("PLC") {
                let o = section
                    .pairs
                    .iter()
                    .map(|(_, s)| &s.origin)
                    .chain(section.rows.iter().map(|r| &r.origin))
                    .min_by_key(|o| (o.file.clone(), o.line))
                    .cloned()
                    .unwrap_or_default();
                diags.push(error::diagnostic(
                    &o,
                    error::SECTION_CASE,
                    format!("section [{name}] would be ignored: section names are case-sensitive, write [PLC]"),
                ));
                continue;
            }
            let similar = self
                .modules
                .iter()
                .find(|m| m.name.eq_ignore_ascii_case(name))
                .map(|m| format!(" (did you mean {}?)", m.name))
                .unwrap_or_default();
            for (key, s) in &section.pairs {
                diags.push(error::diagnostic(
                    &s.origin,
                    error::UNDECLARED_MODULE_SETTING,
                    format!(
                        "`{key}` is set for `{name}`, but no module {name} is declared{similar}: \
                         add `module {name} KIND-or-PATH` to [PLC], or remove the setting"
                    ),
                ));
            }
            for row in &section.rows {
                diags.push(error::diagnostic(
                    &row.origin,
                    error::UNDECLARED_MODULE_SETTING,
                    format!(
                        "a `{}` row in section [{name}], but no module {name} is declared\
                         {similar}: add `module {name} KIND-or-PATH` to [PLC], or remove the row",
                        row.table
                    ),
                ));
            }
        }
        self.diags.extend(diags);
        out
    }
}

fn mask(p: &PointDecl) -> u64 {
    let bit = p.at.map_or(0, |(_, b)| b);
    ((1u64 << p.bits) - 1) << bit
}

fn bit_range(p: &PointDecl) -> String {
    let bit = p.at.map_or(0, |(_, b)| b);
    if p.bits == 1 {
        format!("{bit}")
    } else {
        format!("{bit}-{}", u32::from(bit) + u32::from(p.bits) - 1)
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

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    /// Reads `input` as `t.conf` and renders the typed configuration (one line per point,
    /// module, place, transition, arc, rule and start) or the diagnostics.
    fn check(input: &str, expect: &str) {
        let got = match crate::parse_str(input, "t.conf", Path::new("/nonexistent-dir")) {
            Ok(c) => render(&c),
            Err(e) => e.to_string(),
        };
        assert_eq!(got.trim_end(), expect.trim(), "input:\n{input}");
    }

    fn render(c: &PlcConfig) -> String {
        let mut out = String::new();
        for (k, v) in &c.plc {
            out.push_str(&format!("plc {k}={}\n", v.value));
        }
        if c.retain != RetainSettings::default() {
            out.push_str(&format!(
                "retain {:?} {:?}\n",
                c.retain.file.as_ref().map(|s| &s.value),
                c.retain.write
            ));
        }
        for p in &c.points {
            let at = p.at.map_or("-".into(), |(w, b)| format!("{w}.{b}"));
            out.push_str(&format!(
                "point {} {} {at} {:?}{} {:?}\n",
                p.name, p.owner, p.kind, p.bits, p.init
            ));
        }
        for m in &c.modules {
            if let Some(w) = m.watchdog {
                out.push_str(&format!("watchdog {} {w:?}\n", m.name));
            }
            out.push_str(&format!(
                "module {} {} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}\n",
                m.name,
                m.kind,
                m.args,
                m.scan_period,
                m.location,
                m.priority,
                m.on_failure,
                m.scan_beg,
                m.scan_end,
                m.settings.keys().collect::<Vec<_>>()
            ));
        }
        let s = &c.synch;
        for p in &s.places {
            out.push_str(&format!("place {} {}\n", p.name, p.tokens));
        }
        for (t, _) in &s.transitions {
            out.push_str(&format!("transition {t}\n"));
        }
        for a in &s.arcs {
            out.push_str(&format!("arc {} -{}-> {}\n", a.from, a.weight, a.to));
        }
        for r in &s.rules {
            out.push_str(&format!("synch {} -{}-> {}\n", r.from, r.weight, r.to));
        }
        for (m, _) in &s.starts {
            out.push_str(&format!("start {m}\n"));
        }
        out
    }

    #[test]
    fn modules_and_their_settings() {
        check(
            "[PLC]\nplc_id = 7\nmodule a petrinet x.pnml -v\nmodule b \"/usr/bin/my prog\"\n\
             a: scan_period = T#10ms\n[a]\nlocation = shared\npriority = 50\non_failure = restart\n\
             own = thing\n[b]\nscan_period = 0.25\nlocation = isolate\non_failure = ignore\n",
            r#"plc plc_id=7
module a petrinet ["x.pnml", "-v"] Some(10ms) Shared Some(50) Restart None None ["location", "on_failure", "own", "priority", "scan_period"]
module b /usr/bin/my prog [] Some(250ms) Isolate None Ignore None None ["location", "on_failure", "scan_period"]"#,
        );
    }

    #[test]
    fn module_setting_errors() {
        check(
            "[PLC]\nmodule a x\nmodule\nmodule a y\nmodule NULL z\nmodule plc z\n[a]\n\
             scan_period = fast\nlocation = remote\npriority = 0\non_failure = retry\n\
             scan_beg = T9\nscan_end = NULL\n[ghost]\nscan_period = 1\nown = 1\n[A]\npriority = 5\n\
             [Plc]\nx = 1\n",
            "t.conf:3: error[C030]: a module needs a name and a kind or program: `module NAME KIND-or-PATH [args]`
t.conf:4: error[C031]: module a is declared twice (first at t.conf:2): module names name their sections, so rename or remove one of them
t.conf:2: note: module a first declared here
t.conf:5: error[C032]: `NULL` is reserved: give the module another name
t.conf:6: error[C032]: `plc` is reserved: give the module another name
t.conf:8: error[C034]: `scan_period = fast` for module a: `fast` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)
t.conf:9: error[C035]: `location = remote` for module a: write `local` (the default), `shared` or `isolate`
t.conf:10: error[C036]: `priority = 0` for module a: write a real-time priority from 1 to 99, or leave it out for normal scheduling
t.conf:11: error[C037]: `on_failure = retry` for module a: write `stop` (the default), `restart` or `ignore`
t.conf:12: error[C038]: `scan_beg = T9` for module a: `T9` is not a declared transition: declare it with `transition T9` in [PLC], or write NULL (no transitions are declared)
t.conf:18: error[C033]: `priority` is set for `A`, but no module A is declared (did you mean a?): add `module A KIND-or-PATH` to [PLC], or remove the setting
t.conf:20: error[C039]: section [Plc] would be ignored: section names are case-sensitive, write [PLC]
t.conf:15: error[C033]: `scan_period` is set for `ghost`, but no module ghost is declared: add `module ghost KIND-or-PATH` to [PLC], or remove the setting
t.conf:16: error[C033]: `own` is set for `ghost`, but no module ghost is declared: add `module ghost KIND-or-PATH` to [PLC], or remove the setting",
        );
    }

    #[test]
    fn a_setting_nobody_reads_is_an_error() {
        // A module started by hand must be declared too, so nobody reads [Kbd].
        check(
            "[PLC]\nplc_id = line2\nmodule a x\nconfmap_key = 20\nscan_period = 1\nflavour = 3\n\
             [Kbd]\nkey 38 left\nquiet = 1\n",
            "t.conf:4: error[C012]: `confmap_key = 20` in [PLC]: nothing reads this setting (MatPLC's key of its configuration shared memory; petriplc names its shared memory after the plc id); [PLC] has only plc_id, retain_file, retain_write
t.conf:5: error[C012]: `scan_period = 1` in [PLC]: nothing reads this setting; [PLC] has only plc_id, retain_file, retain_write; `scan_period` is a module's setting: write it in the module's section ([NAME]) or as `NAME: scan_period = 1`
t.conf:6: error[C012]: `flavour = 3` in [PLC]: nothing reads this setting; [PLC] has only plc_id, retain_file, retain_write
t.conf:9: error[C033]: `quiet` is set for `Kbd`, but no module Kbd is declared: add `module Kbd KIND-or-PATH` to [PLC], or remove the setting
t.conf:8: error[C033]: a `key` row in section [Kbd], but no module Kbd is declared: add `module Kbd KIND-or-PATH` to [PLC], or remove the row",
        );
        check("[PLC]\nplc_id =\n", "t.conf:2: error[C013]: `plc_id` is empty: give the PLC's id (letters, digits, `_`, `-`, `.`) or remove the line");
    }

    #[test]
    fn retain_and_watchdog_settings() {
        check(
            "[PLC]\nretain_file = state/plc.retain\nretain_write = change\nmodule a x\n\
             [a]\nwatchdog = T#50ms\n",
            r#"plc retain_file=state/plc.retain
plc retain_write=change
retain Some("state/plc.retain") Change
watchdog a 50ms
module a x [] None Local None Stop None None ["watchdog"]"#,
        );
        check(
            "[PLC]\nretain_write = 0.2\nmodule a x\n",
            r#"plc retain_write=0.2
retain None Every(200ms)
module a x [] None Local None Stop None None []"#,
        );
        check(
            "[PLC]\nretain_file =\nretain_write = often\nmodule a x\nmodule b y\n\
             [a]\nwatchdog = 0\n[b]\nwatchdog = soon\n",
            "t.conf:2: error[C061]: `retain_file` is empty: give the file that keeps the retentive values (relative to this configuration file's folder), or remove the line for the default
t.conf:3: error[C061]: `retain_write = often`: write `change` (every change, as soon as the previous write is done) or the shortest time between two writes (e.g. `T#500ms`, the default): `often` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)
t.conf:7: error[C060]: `watchdog = 0` for module a: a watchdog must be longer than 0 (e.g. `T#100ms`); remove the line for none
t.conf:9: error[C060]: `watchdog = soon` for module b: `soon` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)",
        );
    }

    #[test]
    fn restart_settings() {
        check(
            "[PLC]\nmodule a x\n[a]\non_failure = restart\nrestart_delay = T#50ms\n\
             restart_delay_max = 2\nrestart_limit = 0\n",
            r#"module a x [] None Local None Restart None None ["on_failure", "restart_delay", "restart_delay_max", "restart_limit"]"#,
        );
        check(
            "[PLC]\nmodule a x\nmodule b y\nmodule c z\n[a]\non_failure = restart\n\
             restart_delay = soon\nrestart_delay_max = 0\nrestart_limit = -1\n\
             [b]\nrestart_limit = 3\n[c]\non_failure = restart\nrestart_delay = 20\n",
            "t.conf:7: error[C029]: `restart_delay = soon` for module a: `soon` is not a duration: write a number with a unit (`30s`, `500ms`, `1m30s`), plain seconds (`1.5`) or an IEC literal (`T#1m30s`)
t.conf:8: error[C029]: `restart_delay_max = 0` for module a: the longest delay between restarts must be longer than 0 (e.g. `T#10s`)
t.conf:9: error[C029]: `restart_limit = -1` for module a: write how many restarts in a row are allowed (a whole number; 0 for no limit)
t.conf:11: error[C029]: `restart_limit = 3` for module b: nothing reads it, because the module's on_failure is not `restart`; set `on_failure = restart` or remove the line
t.conf:14: error[C029]: module c: restart_delay (20s) is longer than restart_delay_max (10s): the delay starts at restart_delay and doubles up to restart_delay_max",
        );
    }

    #[test]
    fn points_against_modules() {
        check(
            "[PLC]\nmodule m x\npoint a \"A\" m at 0.0 4\npoint b \"B\" m at 0.3\npoint c \"C\" m at 1\n\
             point d \"D\" m at 1.31\npoint a \"A again\" m\npoint e \"E\" nobody\npoint f \"F\" m at 0.4 28\n",
            "t.conf:7: error[C021]: point a is declared twice (first at t.conf:3): a point has one owner and one place, so rename or remove one of them
t.conf:3: note: point a first declared here
t.conf:8: error[C022]: the owner of point e, `nobody`, is not a declared module: add `module nobody KIND-or-PATH` to [PLC] or give the point another owner (declared modules: m)
t.conf:4: error[C028]: point b (bits 3) overlaps point a (bits 0-3, at t.conf:3) in word 0: each bit has one writer, so move one of them
t.conf:3: note: point a declared here
t.conf:6: error[C028]: point d (bits 31) overlaps point c (bits 0-31, at t.conf:5) in word 1: each bit has one writer, so move one of them
t.conf:5: note: point c declared here",
        );
        check(
            "[PLC]\nmodule m x\npoint a \"A\" m at 0.0 4\npoint b \"B\" m at 0.4 28\npoint c \"\" m\npoint d \"\" m\n",
            "point a m 0.0 Unsigned4 Unsigned(0)\npoint b m 0.4 Unsigned28 Unsigned(0)\n\
             point c m - Unsigned1 Unsigned(0)\npoint d m - Unsigned1 Unsigned(0)\nmodule m x [] None Local None Stop None None []",
        );
    }

    #[test]
    fn tables() {
        check(
            "[PLC]\npoint_alias x \"\" y\nsynchpt a\nlog a b\nPoint a \"\" m\n",
            "t.conf:2: error[C011]: MatPLC's `point_alias` table is not supported: declare separate points instead
t.conf:3: error[C011]: MatPLC's `synchpt` table is not supported: use `scan_beg`/`scan_end` settings of the modules instead
t.conf:4: error[C010]: `log` is not a [PLC] table: the tables are point, module, place, transition, arc, synch, synch_start; settings are written `name = value`, and a module's own tables belong in its [module] section
t.conf:5: error[C010]: `Point` is not a [PLC] table: the tables are point, module, place, transition, arc, synch, synch_start; settings are written `name = value`, and a module's own tables belong in its [module] section",
        );
    }

    #[test]
    fn advanced_synchronisation_net() {
        check(
            "[PLC]\nmodule a x\nplace P 2\nplace Q\ntransition Tb\ntransition Te\n\
             arc P --2--> Tb\narc Te -> Q\narc Q -0-> Te\n[a]\nscan_beg = Tb\nscan_end = Te\n",
            "module a x [] None Local None Stop Some(\"Tb\") Some(\"Te\") [\"scan_beg\", \"scan_end\"]
place P 2
place Q 0
transition Tb
transition Te
arc P -2-> Tb
arc Te -1-> Q
arc Q -0-> Te",
        );
    }

    #[test]
    fn net_errors() {
        check(
            "[PLC]\nplace P x\nplace\nplace A 1 2\ntransition\ntransition T U\ntransition NULL\n\
             place P2\ntransition T\ntransition P2\nplace T\narc P -> T\narc P\narc P->T\n\
             arc P => T\narc X -> T\narc NULL -> P2\narc P2 -> P2\narc T -0-> P2\n",
            "t.conf:2: error[C040]: a place is `place NAME [TOKENS]` with TOKENS a whole number (0 when left out)
t.conf:3: error[C040]: a place is `place NAME [TOKENS]` with TOKENS a whole number (0 when left out)
t.conf:4: error[C040]: a place is `place NAME [TOKENS]` with TOKENS a whole number (0 when left out)
t.conf:5: error[C041]: a transition is `transition NAME`, one per row
t.conf:6: error[C041]: a transition is `transition NAME`, one per row
t.conf:13: error[C043]: `arc` takes three words, `arc FROM ARROW TO` (e.g. `arc A -> B`)
t.conf:14: error[C043]: `arc` takes three words, `arc FROM ARROW TO` (e.g. `arc A -> B`): put spaces around the arrow
t.conf:15: error[C044]: `=>` is not an arrow: write `->` for weight 1 or `-N->` for weight N
t.conf:7: error[C032]: `NULL` is reserved for the null transition: give the transition another name
t.conf:10: error[C042]: `P2` is already declared as a place at t.conf:8: places and transitions share one set of names, so rename one of them
t.conf:8: note: the place `P2` declared here
t.conf:11: error[C042]: `T` is already declared as a transition at t.conf:9: places and transitions share one set of names, so rename one of them
t.conf:9: note: the transition `T` declared here
t.conf:12: error[C045]: the arc names `P`, which is neither a place nor a transition: declare it with `place P` or `transition P`
t.conf:16: error[C045]: the arc names `X`, which is neither a place nor a transition: declare it with `place X` or `transition X`
t.conf:17: error[C045]: an arc cannot touch `NULL` (the null transition never fires anything): declare a transition and use it
t.conf:18: error[C046]: the arc goes from place `P2` to place `P2`: an arc joins a place and a transition
t.conf:19: error[C047]: the arc from transition `T` to place `P2` has weight 0, which only arcs from a place may have (\"fire only while the place is empty\"): give it a weight of 1 or more",
        );
    }

    #[test]
    fn simple_synchronisation() {
        check(
            "[PLC]\nmodule a x\nmodule b y\nsynch a -> b\nsynch b -(3)-> a\nsynch_start a b\n",
            "module a x [] None Local None Stop None None []
module b y [] None Local None Stop None None []
synch a -1-> b
synch b -3-> a
start a
start b",
        );
        check(
            "[PLC]\nmodule a x\nsynch a --0--> a\nsynch a -> c\nsynch a\nsynch_start\nsynch_start a z\n\
             synch a <- a\n",
            "t.conf:3: error[C051]: `synch a --0--> a` has weight 0, which synch does not allow: use a weight of 1 or more (weight-0 arcs need the place/transition/arc form)
t.conf:5: error[C050]: `synch` takes three words, `synch MODULE1 ARROW MODULE2` (e.g. `synch A -> B`)
t.conf:6: error[C050]: `synch_start` needs at least one module: `synch_start MODULE [MODULE ...]`
t.conf:8: error[C044]: `<-` is not an arrow (arrows point from left to right: swap the two names): write `->` for weight 1 or `-N->` for weight N
t.conf:4: error[C052]: `synch` names `c`, which is not a declared module: declare it with `module c KIND-or-PATH` or correct the name (declared modules: a)
t.conf:7: error[C052]: `synch_start` names `z`, which is not a declared module: declare it with `module z KIND-or-PATH` or correct the name (declared modules: a)",
        );
    }

    #[test]
    fn empty_configuration_is_valid() {
        check("", "");
        check("# nothing\n", "");
    }
}
