//! What several modules share (this crate's and the Modbus, vitrine and HMI crates'): checking a section's settings and rows, loading a net,
//! binding named signals to points, and converting between signal values and points.

use std::collections::HashMap;
use std::error::Error;
use std::path::Path;
use std::time::Duration;

use petriplc_config::{ModuleDecl, PlcConfig, PointKind, Row, MODULE_SETTINGS};
use petriplc_net::time::format_seconds;
use petriplc_net::{Evolution, Net, ScanOptions, SignalType, StepRule};
use petriplc_pnml::{Naming, ReadOptions};
use petriplc_runtime::image::{Handle, ImageError, ModuleMap};
use petriplc_runtime::module::{InitContext, ModuleError};

/// The scan period of a built-in module with no `scan_period` outside the synchronisation
/// net: a common PLC scan, rather than as fast as the CPU allows.
pub const DEFAULT_PERIOD: Duration = Duration::from_millis(10);

/// An error prefixed with the module's name, so that the runner can print it as is.
pub fn error(module: &str, message: impl std::fmt::Display) -> ModuleError {
    ModuleError::new(format!("module {module}: {message}"))
}

/// An error with every cause in its source chain (I/O errors hide the OS reason there).
pub fn chain(e: &dyn Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}

/// Refuses arguments and settings the kind does not know: a misspelt setting would otherwise
/// be silently replaced by its default.
pub fn check_decl(decl: &ModuleDecl, kind: &str, known: &[&str]) -> Result<(), ModuleError> {
    if !decl.args.is_empty() {
        return Err(error(
            &decl.name,
            format!(
                "a {kind} module takes no arguments (got `{}`); put its settings in section [{}]",
                decl.args.join(" "),
                decl.name
            ),
        ));
    }
    let unknown: Vec<String> = decl
        .settings
        .iter()
        .filter(|(k, _)| !known.contains(&k.as_str()) && !MODULE_SETTINGS.contains(&k.as_str()))
        .map(|(k, s)| {
            let at = if s.origin.file.is_empty() {
                String::new()
            } else {
                format!(" ({})", s.origin)
            };
            format!("`{k}`{at}")
        })
        .collect();
    if unknown.is_empty() {
        return Ok(());
    }
    Err(error(
        &decl.name,
        format!(
            "unknown setting{} {} in section [{}]; a {kind} module knows {}",
            if unknown.len() == 1 { "" } else { "s" },
            unknown.join(", "),
            decl.name,
            known.join(", ")
        ),
    ))
}

pub fn setting<'a>(decl: &'a ModuleDecl, name: &str) -> Option<&'a str> {
    decl.settings.get(name).map(|s| s.value.trim())
}

/// Like `InitContext::require`, for factories, which see only the declaration.
pub fn require<'a>(decl: &'a ModuleDecl, name: &str) -> Result<&'a str, ModuleError> {
    match setting(decl, name) {
        Some(v) if !v.is_empty() => Ok(v),
        _ => Err(error(
            &decl.name,
            format!(
                "no `{name}` setting; add `{name} = ...` to section [{}]",
                decl.name
            ),
        )),
    }
}

/// A yes/no setting; absent is `false`.
pub fn flag(decl: &ModuleDecl, name: &str) -> Result<bool, ModuleError> {
    match setting(decl, name).map(str::to_ascii_lowercase).as_deref() {
        None | Some("no" | "false" | "off" | "0") => Ok(false),
        Some("yes" | "true" | "on" | "1") => Ok(true),
        Some(other) => Err(error(
            &decl.name,
            format!("`{name} = {other}`: write `{name} = yes` or `{name} = no`"),
        )),
    }
}

/// The rows of the module's section, refusing tables the kind does not read.
pub fn rows<'a>(
    ctx: &'a InitContext<'_>,
    kind: &str,
    tables: &[&str],
) -> Result<Vec<&'a Row>, ModuleError> {
    let rows = module_rows(ctx.config, &ctx.decl.name);
    if let Some(row) = rows.iter().find(|r| !tables.contains(&r.table.as_str())) {
        let reads = if tables.is_empty() {
            "no table rows".to_string()
        } else {
            format!("only {} rows", tables.join(", "))
        };
        return Err(error(
            &ctx.decl.name,
            format!(
                "{}: a {kind} module reads {reads}, not `{}`",
                row.origin, row.table
            ),
        ));
    }
    Ok(rows)
}

/// Every row of `module`'s section but the runner's (`safe POINT VALUE`, the values written
/// on a failure), for modules that check the tables themselves.
pub fn module_rows<'a>(config: &'a PlcConfig, module: &str) -> Vec<&'a Row> {
    config
        .sections
        .get(module)
        .map_or_else(Vec::new, |section| {
            section
                .rows
                .iter()
                .filter(|r| !RUNNER_TABLES.contains(&r.table.as_str()))
                .collect()
        })
}

/// Table rows of a module's section that the runner reads, whatever the kind.
pub const RUNNER_TABLES: &[&str] = &["safe"];

/// Where a net comes from and how it is scanned, as the settings say.
#[derive(Clone, Debug)]
pub struct NetSettings {
    pub file: String,
    pub naming: Naming,
    pub step: Option<StepRule>,
    pub evolve: Option<Evolution>,
    pub max_passes: Option<u32>,
}

/// The settings [`NetSettings::parse`] reads (besides `net`).
pub const NET_OPTIONS: &[&str] = &["names", "step", "evolve", "max_passes"];

impl NetSettings {
    pub fn parse(decl: &ModuleDecl, file: &str) -> Result<NetSettings, ModuleError> {
        let bad = |name: &str, value: &str, allowed: &str| {
            error(
                &decl.name,
                format!("`{name} = {value}` is not valid; use {allowed}"),
            )
        };
        let naming = match setting(decl, "names") {
            None | Some("plain") => Naming::Plain,
            Some("sipn") => Naming::Sipn,
            Some(v) => return Err(bad("names", v, "`plain` or `sipn`")),
        };
        let step = setting(decl, "step")
            .map(|v| {
                StepRule::parse(v).ok_or_else(|| bad("step", v, "`maximal-step` or `sequential`"))
            })
            .transpose()?;
        let evolve = setting(decl, "evolve")
            .map(|v| {
                Evolution::parse(v).ok_or_else(|| bad("evolve", v, "`one-pass` or `until-stable`"))
            })
            .transpose()?;
        let max_passes = setting(decl, "max_passes")
            .map(|v| match v.parse::<u32>() {
                Ok(n) if n > 0 => Ok(n),
                _ => Err(bad("max_passes", v, "a whole number of 1 or more")),
            })
            .transpose()?;
        Ok(NetSettings {
            file: file.to_string(),
            naming,
            step,
            evolve,
            max_passes,
        })
    }

    /// The net's own choices, overridden by the settings.
    pub fn options(&self, net: &Net) -> ScanOptions {
        let mut o = ScanOptions::of(net);
        o.step = self.step.unwrap_or(o.step);
        o.evolve = self.evolve.unwrap_or(o.evolve);
        o.max_passes = self.max_passes.unwrap_or(o.max_passes);
        o
    }

    /// Reads the net. It is leaked: a `Scanner` borrows its net, and a module that owned both
    /// would borrow from itself; a module lives as long as the PLC, so one net per module
    /// start is all that is ever kept.
    pub fn load(&self, module: &str, base_dir: &Path) -> Result<&'static Net, ModuleError> {
        let path = base_dir.join(&self.file);
        let doc = petriplc_pnml::read_file(
            &path,
            &ReadOptions {
                naming: self.naming,
            },
        )
        .map_err(|e| error(module, format!("net `{}`: {}", self.file, chain(&e))))?;
        Ok(Box::leak(Box::new(doc.net)))
    }
}

/// A named signal of a net or plant; `Int` for a Rust plant, whose signals carry plain values.
#[derive(Clone, Debug)]
pub struct Port {
    pub name: String,
    pub ty: SignalType,
    /// A real quantity in fixed point, `scale` units per 1 (`Plant::scale`): it may be bound
    /// to an f32 point, which then holds the real value.
    pub scale: Option<f64>,
}

/// A signal bound to its point.
#[derive(Clone, Debug)]
pub struct Bound {
    pub signal: String,
    pub point: String,
    pub handle: Handle,
    pub ty: SignalType,
    pub scale: Option<f64>,
}

impl Bound {
    /// A bool signal sees any non-zero point as 1; an int signal sees the point's value (a
    /// fixed-point signal bound to an f32 point: the value times the scale, rounded).
    pub fn read(&self, map: &ModuleMap) -> i64 {
        if let (Some(scale), PointKind::Float) = (self.scale, self.handle.kind()) {
            let v = (f64::from(map.get_f32(&self.handle)) * scale).round();
            // NaN reads as 0; ±∞ saturate.
            return v as i64;
        }
        match self.ty {
            SignalType::Bool => i64::from(map.get_bool(&self.handle)),
            SignalType::Int => match self.handle.kind() {
                PointKind::Signed => i64::from(map.get_i32(&self.handle)),
                // Floats are refused when binding.
                _ => i64::from(map.get_u32(&self.handle)),
            },
        }
    }

    pub fn write(&self, map: &mut ModuleMap, value: i64) -> Result<(), String> {
        if let (Some(scale), PointKind::Float) = (self.scale, self.handle.kind()) {
            return map
                .set_f32(&self.handle, (value as f64 / scale) as f32)
                .map_err(|e| e.to_string());
        }
        match self.ty {
            SignalType::Bool => map
                .set_bool(&self.handle, value != 0)
                .map_err(|e| e.to_string()),
            SignalType::Int => write_int(map, &self.handle, &self.point, value),
        }
    }
}

/// Writes an integer to an unsigned or signed point, or converted to a float point.
pub fn write_int(map: &mut ModuleMap, h: &Handle, point: &str, value: i64) -> Result<(), String> {
    let result = match h.kind() {
        PointKind::Unsigned => match u32::try_from(value) {
            Ok(v) => map.set_u32(h, v),
            Err(_) => return Err(does_not_fit(point, h, value)),
        },
        PointKind::Signed => match i32::try_from(value) {
            Ok(v) => map.set_i32(h, v),
            Err(_) => return Err(does_not_fit(point, h, value)),
        },
        PointKind::Float => map.set_f32(h, value as f32),
    };
    result.map_err(|e| e.to_string())
}

/// Whether `value` can be written to the point without an error.
pub fn fits(h: &Handle, value: i64) -> bool {
    let bits = u32::from(h.bits());
    match h.kind() {
        PointKind::Unsigned => (0..=(1i64 << bits) - 1).contains(&value),
        PointKind::Signed => {
            let half = 1i64 << (bits - 1);
            (-half..half).contains(&value)
        }
        PointKind::Float => true,
    }
}

fn does_not_fit(point: &str, h: &Handle, value: i64) -> String {
    ImageError::OutOfRange {
        point: point.to_string(),
        kind: kind_name(h.kind()),
        bits: h.bits(),
        value: value.to_string(),
    }
    .to_string()
}

pub fn kind_name(kind: PointKind) -> &'static str {
    match kind {
        PointKind::Unsigned => "unsigned",
        PointKind::Signed => "signed",
        PointKind::Float => "float",
    }
}

/// Binds every input to a point of the same name (any owner) and every output to a point of
/// the same name owned by this module; `map SIGNAL POINT` rows of the module's section bind
/// a signal to another point. Every problem is reported at once, one per line.
pub fn bind(
    ctx: &InitContext<'_>,
    kind: &str,
    what: &str,
    inputs: &[Port],
    outputs: &[Port],
) -> Result<(Vec<Bound>, Vec<Bound>), ModuleError> {
    let module = ctx.decl.name.as_str();
    let mut problems: Vec<String> = Vec::new();
    let mut renames: HashMap<&str, &str> = HashMap::new();
    let signals: Vec<&str> = inputs
        .iter()
        .chain(outputs)
        .map(|p| p.name.as_str())
        .collect();
    for row in rows(ctx, kind, &["map"])? {
        match row.cells.as_slice() {
            [signal, point] if !signals.contains(&signal.as_str()) => problems.push(format!(
                "{}: `map {signal} {point}`: {what} has no signal `{signal}` (its signals: {})",
                row.origin,
                signals.join(", ")
            )),
            [signal, point] => {
                if renames.insert(signal, point).is_some() {
                    problems.push(format!(
                        "{}: signal `{signal}` is mapped twice; keep one `map {signal} POINT` row",
                        row.origin
                    ));
                }
            }
            _ => problems.push(format!(
                "{}: a map row is `map SIGNAL POINT`, with one signal and one point",
                row.origin
            )),
        }
    }

    let mut bind_one = |port: &Port, output: bool| -> Option<Bound> {
        let point = renames
            .get(port.name.as_str())
            .copied()
            .unwrap_or(&port.name);
        let dir = if output { "output" } else { "input" };
        let mapped = if point == port.name {
            String::new()
        } else {
            format!(" (mapped to point `{point}`)")
        };
        let handle = match ctx.map.handle(point) {
            Ok(h) => h,
            Err(e) => {
                let owner = if output { module } else { "OWNER" };
                let who = if output {
                    String::new()
                } else {
                    " with the module that drives it as OWNER".to_string()
                };
                problems.push(format!(
                    "{dir} signal `{}` of {what} needs a point{mapped}: {e}; declare \
                     `point {point} \"...\" {owner}` in [PLC]{who}, or bind the signal to \
                     another point with a row `map {} POINT` in [{module}]",
                    port.name, port.name
                ));
                return None;
            }
        };
        if handle.kind() == PointKind::Float && port.scale.is_none() {
            problems.push(format!(
                "{dir} signal `{}` of {what} is bound to point `{point}`, a float point; \
                 {} signals carry whole numbers: declare `{point}` as `u` or `i`",
                port.name, port.ty
            ));
            return None;
        }
        if output && !ctx.map.owns(&handle) {
            let owner = ctx.map.layout().slot(handle.id()).owner.clone();
            problems.push(format!(
                "output signal `{}` of {what} drives point `{point}`{}, but `{point}` is owned \
                 by module `{owner}`; only its owner may write a point: declare \
                 `point {point} \"...\" {module}` (and let `{owner}` read it), or bind the \
                 signal to a point of this module with `map {} POINT` in [{module}]",
                port.name,
                if mapped.is_empty() { "" } else { " (mapped)" },
                port.name
            ));
            return None;
        }
        if output && ctx.map.layout().slot(handle.id()).retain {
            problems.push(format!(
                "output signal `{}` of {what} drives point `{point}`{}, which is retentive \
                 (`retain`): the module computes it at every scan from state that starts \
                 afresh (a net's marking, a model's state), so its stored value would be \
                 overwritten at the first scan; drop `retain` from point `{point}`",
                port.name,
                if mapped.is_empty() { "" } else { " (mapped)" },
            ));
            return None;
        }
        Some(Bound {
            signal: port.name.clone(),
            point: point.to_string(),
            handle,
            ty: port.ty,
            scale: port.scale,
        })
    };
    let ins: Vec<Bound> = inputs.iter().filter_map(|p| bind_one(p, false)).collect();
    let outs: Vec<Bound> = outputs.iter().filter_map(|p| bind_one(p, true)).collect();
    if problems.is_empty() {
        Ok((ins, outs))
    } else {
        Err(error(
            module,
            problems.join(&format!("\nmodule {module}: ")),
        ))
    }
}

/// `at t=1.5s` for scan-time errors, to the millisecond: the PLC's clock counts
/// nanoseconds, which say nothing to a person reading the log.
pub fn at(now: Duration) -> String {
    let ms = (now.as_nanos() + 500_000) / 1_000_000;
    let rounded = Duration::from_millis(u64::try_from(ms).unwrap_or(u64::MAX));
    format!("at t={}s", format_seconds(rounded))
}
