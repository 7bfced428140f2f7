//! `timeline`: drives points from a timeline CSV (petriplc-sim's format: `time,A,B,...`,
//! each value holding until a later row changes it); every column drives the point of the
//! same name, which this module must own. A column driving an f32 point takes decimal values
//! (`20.5`, `-1e-3`); the others take whole numbers and TRUE/FALSE. NaN and infinities are
//! refused, as at every boundary of the PLC, unless `non_finite = accept` (for tests of how
//! a program copes with them). Before a column's first row its point keeps its init value
//! (restored at each restart with `repeat`). Every value is checked against its point at
//! `init`.
//!
//! ```text
//! [buttons]
//! file = press-b1.csv       # relative to the configuration file
//! repeat = yes              # start again 1 s after the last row (default: no)
//! non_finite = refuse       # or accept: `nan`, `inf` drive f32 points (default: refuse)
//! ```

use std::time::Duration;

use petriplc_config::{ModuleDecl, PointKind, PointValue};
use petriplc_net::time::format_seconds;
use petriplc_runtime::image::Handle;
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};
use petriplc_sim::{NonFinite, Timeline};

use crate::common::{self, at, chain, error, fits, kind_name, write_int};

const KIND: &str = "timeline";

/// With `repeat`, the time from the last row to the restart: the last row's values are
/// then seen for a while, as `petriplc sim` runs one second past the last row.
const REPEAT_GAP: Duration = Duration::from_secs(1);

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(TimelineModule::new(decl)?))
}

/// The `timeline` module.
pub struct TimelineModule {
    name: String,
    file: String,
    repeat: bool,
    non_finite: NonFinite,
    run: Option<Run>,
}

struct Run {
    timeline: Timeline,
    /// Per column: the point, and its value before the timeline first set it (restored at
    /// each repeat before the column's first row).
    columns: Vec<(Handle, String, PointValue)>,
    /// The length of one round with `repeat`.
    period: Option<Duration>,
    last: Duration,
}

impl TimelineModule {
    /// Checks the settings; the file is read by `init`.
    pub fn new(decl: &ModuleDecl) -> Result<TimelineModule, ModuleError> {
        common::check_decl(decl, KIND, &["file", "repeat", "non_finite"])?;
        let non_finite = match common::setting(decl, "non_finite") {
            None | Some("refuse") => NonFinite::Refuse,
            Some("accept") => NonFinite::Accept,
            Some(other) => {
                return Err(error(
                    &decl.name,
                    format!(
                        "`non_finite = {other}`: write `refuse` (the default: NaN and \
                         infinities in the file are errors) or `accept` (they are driven into \
                         f32 points, to test how the PLC copes with them)"
                    ),
                ))
            }
        };
        Ok(TimelineModule {
            name: decl.name.clone(),
            file: common::require(decl, "file")?.to_string(),
            repeat: common::flag(decl, "repeat")?,
            non_finite,
            run: None,
        })
    }
}

/// Seconds to the hundredth, for status lines: `0.23`, `1.4`, `0`.
fn seconds(d: Duration) -> String {
    format!("{}", (d.as_secs_f64() * 100.0).round() / 100.0)
}

impl Module for TimelineModule {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        common::rows(ctx, KIND, &[])?;
        let timeline = Timeline::read_file_decimal(ctx.path(&self.file), self.non_finite)
            .map_err(|e| error(&self.name, chain(&e)))?;
        let module = self.name.as_str();
        let mut problems = Vec::new();
        let mut columns = Vec::new();
        for (i, col) in timeline.columns().iter().enumerate() {
            let h = match ctx.map.handle(col) {
                Ok(h) => h,
                Err(e) => {
                    problems.push(format!(
                        "timeline `{}` column `{col}`: {e}; declare `point {col} \"...\" \
                         {module}` in [PLC], or drop the column",
                        self.file
                    ));
                    continue;
                }
            };
            if !ctx.map.owns(&h) {
                let owner = &ctx.map.layout().slot(h.id()).owner;
                problems.push(format!(
                    "timeline `{}` column `{col}` drives point `{col}`, which is owned by \
                     module `{owner}`; a timeline drives only its own points: declare \
                     `point {col} \"...\" {module}`, or drop the column",
                    self.file
                ));
                continue;
            }
            // Checked now, so a bad cell stops the PLC before it starts, not minutes in.
            let decimals = timeline.decimal_changes(i).unwrap_or_default();
            let whole = |v: f64| v.is_finite() && v.fract() == 0.0;
            // In f32 a value beyond its range would become an infinity: refused like one.
            if h.kind() == PointKind::Float && self.non_finite == NonFinite::Refuse {
                if let Some(&(t, v)) = decimals.iter().find(|&&(_, v)| (v as f32).is_infinite()) {
                    problems.push(format!(
                        "timeline `{}` sets `{col}` to {v:?} at t={}s, beyond the range of point \
                         `{col}` (f32: ±3.4e38); write a smaller number",
                        self.file,
                        format_seconds(t),
                    ));
                    continue;
                }
            }
            if h.kind() != PointKind::Float {
                if let Some(&(t, v)) = decimals.iter().find(|&&(_, v)| !whole(v)) {
                    problems.push(format!(
                        "timeline `{}` sets `{col}` to {v} at t={}s, but point `{col}` is {} \
                         ({} bits), which holds whole numbers: declare it f32, or write a \
                         whole number",
                        self.file,
                        format_seconds(t),
                        kind_name(h.kind()),
                        h.bits()
                    ));
                    continue;
                }
            }
            if let Some(&(t, v)) = timeline
                .changes(i)
                .iter()
                .filter(|_| h.kind() != PointKind::Float)
                .find(|&&(_, v)| !fits(&h, v))
            {
                problems.push(format!(
                    "timeline `{}` sets `{col}` to {v} at t={}s, which point `{col}` ({}, {} \
                     bits) cannot hold",
                    self.file,
                    format_seconds(t),
                    kind_name(h.kind()),
                    h.bits()
                ));
                continue;
            }
            columns.push((h, col.clone(), ctx.map.get(&h)));
        }
        if !problems.is_empty() {
            return Err(error(
                module,
                problems.join(&format!("\nmodule {module}: ")),
            ));
        }
        self.run = Some(Run {
            period: self.repeat.then(|| timeline.end() + REPEAT_GAP),
            timeline,
            columns,
            last: Duration::ZERO,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        let t = match run.period {
            Some(p) => {
                let nanos = ctx.now.as_nanos() % p.as_nanos();
                Duration::from_nanos(u64::try_from(nanos).unwrap_or(u64::MAX))
            }
            None => ctx.now,
        };
        run.last = t;
        for (i, (h, col, initial)) in run.columns.iter().enumerate() {
            let result = if h.kind() == PointKind::Float {
                match run.timeline.decimal_at(i, t) {
                    Some(v) => ctx.map.set_f32(h, v as f32).map_err(|e| e.to_string()),
                    None => ctx.map.set(h, *initial).map_err(|e| e.to_string()),
                }
            } else {
                match run.timeline.value_at(i, t) {
                    Some(v) => write_int(ctx.map, h, col, v),
                    None => ctx.map.set(h, *initial).map_err(|e| e.to_string()),
                }
            };
            result
                .map_err(|e| error(&self.name, format!("{}: column `{col}`: {e}", at(ctx.now))))?;
        }
        Ok(Control::Continue)
    }

    fn default_scan_period(&self) -> Option<std::time::Duration> {
        Some(crate::common::DEFAULT_PERIOD)
    }

    fn status(&self) -> String {
        self.run.as_ref().map_or_else(String::new, |r| {
            let file = &self.file;
            let (t, end) = (seconds(r.last), seconds(r.timeline.end()));
            match r.period {
                // The position within the repeated cycle (rows, then the gap before the next).
                Some(p) => format!("{file}: {t} s into a {} s cycle", seconds(p)),
                None if r.last < r.timeline.end() => format!("{file}: {t} s of {end} s"),
                None => format!("{file}: ended at {end} s; its last values hold"),
            }
        })
    }
}
