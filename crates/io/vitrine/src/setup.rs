//! The vitrine's section read and checked: settings (`background`, `pulse`, `points`) and
//! the `show`, `graph` and `key` rows, resolved to point handles; every problem is reported
//! at once with the row's file:line and how to fix it.

use std::time::Duration;

use petriplc_config::{ModuleDecl, PointKind, PointValue, Row};
use petriplc_modules::common::{self, error};
use petriplc_runtime::image::{Handle, ModuleMap};
use petriplc_runtime::module::{InitContext, ModuleError};

use crate::keys::{parse_key, Action, Binding};

pub(crate) const KIND: &str = "vitrine";

/// The settings a vitrine section may have (besides the runner's).
pub(crate) const SETTINGS: &[&str] = &["background", "pulse", "points"];

/// The tables a vitrine section may have.
pub(crate) const TABLES: &[&str] = &["show", "graph", "key"];

/// How long a `pulse` key holds its point true unless `pulse = ...` says otherwise.
pub(crate) const DEFAULT_PULSE: Duration = Duration::from_millis(300);

/// What the declaration alone says (checked by the factory).
#[derive(Clone, Debug)]
pub(crate) struct Settings {
    pub background: Option<String>,
    pub pulse: Duration,
    /// `points = A B C`: the points table shows these, in this order (default: all).
    pub points: Option<Vec<String>>,
}

impl Settings {
    pub fn parse(decl: &ModuleDecl) -> Result<Settings, ModuleError> {
        common::check_decl(decl, KIND, SETTINGS)?;
        let at = |name: &str| {
            decl.settings
                .get(name)
                .filter(|s| !s.origin.file.is_empty())
                .map_or_else(String::new, |s| format!("{}: ", s.origin))
        };
        let pulse = match common::setting(decl, "pulse") {
            None => DEFAULT_PULSE,
            Some(v) => match petriplc_net::time::parse_duration(v) {
                Ok(d) if !d.is_zero() => d,
                Ok(_) => {
                    return Err(error(
                        &decl.name,
                        format!(
                            "{}`pulse = {v}`: a pulse must last some time; write e.g. \
                             `pulse = 300ms`",
                            at("pulse")
                        ),
                    ))
                }
                Err(e) => return Err(error(&decl.name, format!("{}`pulse`: {e}", at("pulse")))),
            },
        };
        let background = common::setting(decl, "background")
            .filter(|v| !v.is_empty())
            .map(String::from);
        let points = common::setting(decl, "points")
            .map(|v| v.split_whitespace().map(String::from).collect::<Vec<_>>());
        if points.as_ref().is_some_and(Vec::is_empty) {
            return Err(error(
                &decl.name,
                format!(
                    "{}`points` is empty; name the points to list (`points = B1 V1`) or \
                     remove the setting to list every point",
                    at("points")
                ),
            ));
        }
        Ok(Settings {
            background,
            pulse,
            points,
        })
    }
}

/// MatPLC's `show` data types: how a field reads its point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DataType {
    Bool,
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
}

impl DataType {
    pub(crate) const NAMES: &'static str = "bool, i8, u8, i16, u16, i32, u32, f32";

    fn parse(s: &str) -> Option<DataType> {
        Some(match s {
            "bool" => DataType::Bool,
            "i8" => DataType::I8,
            "u8" => DataType::U8,
            "i16" => DataType::I16,
            "u16" => DataType::U16,
            "i32" => DataType::I32,
            "u32" => DataType::U32,
            "f32" => DataType::F32,
            _ => return None,
        })
    }
}

/// `show POINT ROW COL [TYPE] [ON [OFF]]`
#[derive(Clone, Debug)]
pub(crate) struct ShowField {
    pub handle: Handle,
    pub row: u16,
    pub col: u16,
    pub ty: DataType,
    pub on: String,
    pub off: String,
}

/// `graph POINT [MIN MAX]`
#[derive(Clone, Debug)]
pub(crate) struct GraphSpec {
    pub point: String,
    pub handle: Handle,
    pub range: Option<(f64, f64)>,
}

/// Everything the rows say, resolved.
pub(crate) struct Rows {
    pub show: Vec<ShowField>,
    pub graphs: Vec<GraphSpec>,
    pub keys: Vec<Binding>,
}

/// Rows and columns beyond this are surely a mistake (and would only be clipped).
const MAX_POS: u16 = 999;

pub(crate) fn rows(ctx: &InitContext<'_>) -> Result<Rows, ModuleError> {
    let module = ctx.decl.name.as_str();
    let mut problems = Vec::new();
    let mut out = Rows {
        show: Vec::new(),
        graphs: Vec::new(),
        keys: Vec::new(),
    };
    for row in common::rows(ctx, KIND, TABLES)? {
        let result = match row.table.as_str() {
            "show" => show_row(ctx.map, row).map(|f| out.show.push(f)),
            "graph" => graph_row(ctx.map, row).map(|g| out.graphs.push(g)),
            _ => {
                key_row(ctx.map, row).and_then(|b| match out.keys.iter().find(|k| k.key == b.key) {
                    Some(k) => Err(format!(
                        "key `{}` is bound twice (also at {}); letters match either case, so \
                         keep one `key` row per key",
                        b.written, k.origin
                    )),
                    None => {
                        out.keys.push(b);
                        Ok(())
                    }
                })
            }
        };
        if let Err(e) = result {
            problems.push(format!("{}: {e}", row.origin));
        }
    }
    if problems.is_empty() {
        Ok(out)
    } else {
        Err(error(
            module,
            problems.join(&format!("\nmodule {module}: ")),
        ))
    }
}

fn handle(map: &ModuleMap, point: &str, row: &str) -> Result<Handle, String> {
    map.handle(point)
        .map_err(|e| format!("`{row}`: {e}; declare the point in [PLC] or fix the name"))
}

fn show_row(map: &ModuleMap, row: &Row) -> Result<ShowField, String> {
    const FORM: &str = "a show row is `show POINT ROW COL [TYPE] [ON [OFF]]`";
    let c = &row.cells;
    if c.len() < 3 {
        return Err(format!("{FORM} (got `show {}`)", c.join(" ")));
    }
    let handle = handle(map, &c[0], "show")?;
    let pos = |what: &str, v: &str| {
        v.parse::<u16>()
            .ok()
            .filter(|&n| n <= MAX_POS)
            .ok_or_else(|| {
                format!("{FORM}: {what} `{v}` is not a whole number from 0 to {MAX_POS}")
            })
    };
    let (row_no, col) = (pos("ROW", &c[1])?, pos("COL", &c[2])?);
    let mut rest = &c[3..];
    let ty = match rest.first().and_then(|t| DataType::parse(t)) {
        Some(t) => {
            rest = &rest[1..];
            t
        }
        None => DataType::Bool,
    };
    if ty != DataType::Bool && !rest.is_empty() {
        return Err(format!(
            "{FORM}: ON and OFF strings are for bool fields; a {} field shows the number \
             (remove `{}`)",
            c[3],
            rest.join(" ")
        ));
    }
    let (on, off) = match rest {
        [] => ("1".to_string(), "0".to_string()),
        // Only ON: the field disappears while the point is off.
        [on] => (on.clone(), " ".repeat(on.chars().count())),
        [on, off] => (on.clone(), off.clone()),
        _ => {
            return Err(format!(
                "{FORM}: `{}` is one cell too many (TYPE is one of {}; quote strings with \
                 spaces)",
                rest[2..].join(" "),
                DataType::NAMES
            ))
        }
    };
    Ok(ShowField {
        handle,
        row: row_no,
        col,
        ty,
        on,
        off,
    })
}

fn graph_row(map: &ModuleMap, row: &Row) -> Result<GraphSpec, String> {
    const FORM: &str = "a graph row is `graph POINT [MIN MAX]`";
    let c = &row.cells;
    let range = match c.as_slice() {
        [_] => None,
        [_, lo, hi] => {
            let num = |v: &str| {
                v.parse::<f64>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| format!("{FORM}: `{v}` is not a number"))
            };
            let (lo, hi) = (num(lo)?, num(hi)?);
            if lo >= hi {
                return Err(format!(
                    "{FORM}: MIN ({lo}) must be below MAX ({hi}); swap them"
                ));
            }
            Some((lo, hi))
        }
        _ => return Err(format!("{FORM} (got `graph {}`)", c.join(" "))),
    };
    let handle = handle(map, &c[0], "graph")?;
    Ok(GraphSpec {
        point: c[0].clone(),
        handle,
        range,
    })
}

fn key_row(map: &ModuleMap, row: &Row) -> Result<Binding, String> {
    const FORM: &str = "a key row is `key KEY POINT [pulse|toggle|set VALUE]`";
    let c = &row.cells;
    if c.len() < 2 {
        return Err(format!("{FORM} (got `key {}`)", c.join(" ")));
    }
    let key = parse_key(&c[0])?;
    let handle = handle(map, &c[1], "key")?;
    let point = c[1].as_str();
    let boolean = handle.kind() == PointKind::Unsigned && handle.bits() == 1;
    let what = point_kind(&handle);
    let action = match &c[2..] {
        [] if boolean => Action::Pulse,
        [] => {
            return Err(format!(
                "`{point}` is {what}: say what the key writes with `key {} {point} set VALUE`",
                c[0]
            ))
        }
        [a] if a == "pulse" || a == "toggle" => {
            if !boolean {
                return Err(format!(
                    "`{a}` is for bool (1-bit) points and `{point}` is {what}: use `set VALUE`"
                ));
            }
            if a == "pulse" {
                Action::Pulse
            } else {
                Action::Toggle
            }
        }
        [a, v] if a == "set" => {
            Action::Set(parse_value(&handle, v).map_err(|why| format!("`set {v}`: {why}"))?)
        }
        _ => {
            return Err(format!(
                "{FORM}: `{}` is not an action (pulse, toggle or set VALUE)",
                c[2..].join(" ")
            ))
        }
    };
    Ok(Binding {
        written: c[0].clone(),
        key,
        point: point.to_string(),
        owned: map.owns(&handle),
        handle,
        action,
        origin: row.origin.clone(),
    })
}

/// `a bool point`, `a 16-bit signed point`, for messages.
pub(crate) fn point_kind(h: &Handle) -> String {
    match (h.kind(), h.bits()) {
        (PointKind::Unsigned, 1) => "a bool point".to_string(),
        (PointKind::Float, _) => "a float point".to_string(),
        (k, b) => format!("a {b}-bit {} point", common::kind_name(k)),
    }
}

/// A value written as text, checked against the point it is for.
fn parse_value(h: &Handle, v: &str) -> Result<PointValue, String> {
    let what = point_kind(h);
    match h.kind() {
        PointKind::Unsigned if h.bits() == 1 => match v.to_ascii_lowercase().as_str() {
            "1" | "true" | "on" | "yes" => Ok(PointValue::Unsigned(1)),
            "0" | "false" | "off" | "no" => Ok(PointValue::Unsigned(0)),
            _ => Err(format!("{what} takes 1 or 0 (or on/off, true/false)")),
        },
        PointKind::Float => v
            .parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .map(PointValue::Float)
            .ok_or_else(|| format!("{what} takes a number such as 2.5")),
        kind => match v.parse::<i64>() {
            Ok(n) if common::fits(h, n) => Ok(match kind {
                PointKind::Signed => PointValue::Signed(n as i32),
                _ => PointValue::Unsigned(n as u32),
            }),
            Ok(_) => Err(format!("{v} does not fit {what}")),
            Err(_) => Err(format!("{what} takes a whole number")),
        },
    }
}
