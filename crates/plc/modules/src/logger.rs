//! `logger`: writes point values to a CSV file as `time,point,value` rows, every point at
//! the first scan and then each change (an f32 point as the shortest decimal that reads back
//! as the same f32, without exponent: `20.5`, `-0.001`; `NaN`, `inf`, `-inf`), flushed at the end of every scan that wrote a row so
//! that a crash keeps the log up to the last scan.
//!
//! ```text
//! [log]
//! file = out/mixer-log.csv  # relative to the configuration file; created (with its folders) or truncated
//! points = B1 V1 V2 V3      # default: every point of the configuration
//! log N1                    # rows add points too
//! plot = out/mixer.svg      # optional: a trend of the f32 points, drawn when the PLC stops
//! title = mixer levels      # the trend's title (default: the log file's name)
//! ```

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use petriplc_config::{ModuleDecl, PointValue};
use petriplc_net::time::format_seconds;
use petriplc_runtime::image::Handle;
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};
use petriplc_sim::{write_trend_svg, Series};

use crate::common::{self, error};

const KIND: &str = "logger";

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Logger::new(decl)?))
}

/// The `logger` module.
pub struct Logger {
    name: String,
    file: String,
    points: Vec<String>,
    plot: Option<String>,
    title: Option<String>,
    run: Option<Run>,
}

/// The most samples a trend keeps per point (about 5 MB for ten points): beyond, the plot
/// shows the start of the run and says so.
const PLOT_SAMPLES: usize = 65_536;

struct Run {
    out: BufWriter<File>,
    path: PathBuf,
    /// Per point: its handle, name and the raw bits last logged (`None` before the first
    /// scan). Raw bits, so that a float point's change is never missed by a comparison.
    points: Vec<(Handle, String, Option<u32>)>,
    rows: u64,
    /// With `plot`: the f32 points' samples (index into `points`, series).
    trend: Vec<(usize, Series)>,
    plot: Option<PathBuf>,
    last: f64,
}

impl Logger {
    /// Checks the settings; the file is created by `init`.
    pub fn new(decl: &ModuleDecl) -> Result<Logger, ModuleError> {
        common::check_decl(decl, KIND, &["file", "points", "plot", "title"])?;
        Ok(Logger {
            name: decl.name.clone(),
            file: common::require(decl, "file")?.to_string(),
            points: common::setting(decl, "points")
                .map(|v| v.split_whitespace().map(String::from).collect())
                .unwrap_or_default(),
            plot: common::setting(decl, "plot").map(String::from),
            title: common::setting(decl, "title").map(String::from),
            run: None,
        })
    }

    fn write_error(&self, e: &std::io::Error) -> ModuleError {
        error(
            &self.name,
            format!("cannot write log file `{}`: {e}", self.file),
        )
    }
}

impl Module for Logger {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let mut names = self.points.clone();
        for row in common::rows(ctx, KIND, &["log"])? {
            names.extend(row.cells.iter().cloned());
        }
        if names.is_empty() {
            names = ctx
                .map
                .layout()
                .points()
                .map(|(_, s)| s.name.clone())
                .collect();
        }
        let mut points = Vec::with_capacity(names.len());
        let mut problems = Vec::new();
        for n in names {
            if points.iter().any(|(_, p, _)| *p == n) {
                continue;
            }
            match ctx.map.handle(&n) {
                Ok(h) => points.push((h, n, None)),
                Err(e) => problems.push(format!(
                    "cannot log `{n}`: {e}; fix the name in `points` or the `log` rows of [{}]",
                    self.name
                )),
            }
        }
        if !problems.is_empty() {
            let sep = format!("\nmodule {}: ", self.name);
            return Err(error(&self.name, problems.join(&sep)));
        }
        let path = ctx.path(&self.file);
        let plot = match &self.plot {
            None => None,
            Some(p) => {
                let p = ctx.path(p);
                make_folder(&self.name, &p, "plot")?;
                // Created now (and drawn at close), so a bad path stops the PLC at start.
                File::create(&p).map_err(|e| {
                    error(
                        &self.name,
                        format!("cannot create plot `{}`: {e}", p.display()),
                    )
                })?;
                Some(p)
            }
        };
        let trend = if plot.is_some() {
            points
                .iter()
                .enumerate()
                .filter(|(_, (h, _, _))| h.kind() == petriplc_config::PointKind::Float)
                .map(|(i, (_, name, _))| {
                    (
                        i,
                        Series {
                            name: name.clone(),
                            samples: Vec::new(),
                        },
                    )
                })
                .collect()
        } else {
            Vec::new()
        };
        make_folder(&self.name, &path, "log file")?;
        let file = File::create(&path).map_err(|e| {
            error(
                &self.name,
                format!("cannot create log file `{}`: {e}", path.display()),
            )
        })?;
        let mut out = BufWriter::new(file);
        writeln!(out, "time,point,value").map_err(|e| self.write_error(&e))?;
        self.run = Some(Run {
            out,
            path,
            points,
            rows: 0,
            trend,
            plot,
            last: 0.0,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        let mut time: Option<String> = None;
        let mut result = Ok(());
        let t = ctx.now.as_secs_f64();
        run.last = t;
        for (i, (h, name, last)) in run.points.iter_mut().enumerate() {
            let raw = ctx.map.get_u32(h);
            if *last == Some(raw) {
                continue;
            }
            *last = Some(raw);
            if let Some((_, s)) = run.trend.iter_mut().find(|(j, _)| *j == i) {
                if s.samples.len() < PLOT_SAMPLES {
                    s.samples.push((t, f64::from(f32::from_bits(raw))));
                }
            }
            let t = time.get_or_insert_with(|| format_seconds(ctx.now));
            let value = match ctx.map.get(h) {
                PointValue::Unsigned(v) => v.to_string(),
                PointValue::Signed(v) => v.to_string(),
                PointValue::Float(v) => v.to_string(),
            };
            result = writeln!(run.out, "{t},{name},{value}");
            if result.is_err() {
                break;
            }
            run.rows += 1;
        }
        // A scan that changed nothing leaves nothing buffered: no need to flush it.
        if result.is_ok() && time.is_some() {
            result = run.out.flush();
        }
        match result {
            Ok(()) => Ok(Control::Continue),
            Err(e) => Err(self.write_error(&e)),
        }
    }

    fn close(&mut self) {
        if let Some(run) = &mut self.run {
            // `close` cannot report; every row was already flushed at the end of its scan.
            let _ = run.out.flush();
            if let Some(path) = &run.plot {
                let full = run
                    .trend
                    .iter()
                    .any(|(_, s)| s.samples.len() >= PLOT_SAMPLES);
                let name = self.title.clone().unwrap_or_else(|| {
                    Path::new(&self.file)
                        .file_name()
                        .map_or(self.file.clone(), |f| f.to_string_lossy().into_owned())
                });
                let title = format!(
                    "{name}{}",
                    if full {
                        " (the start: too many samples)"
                    } else {
                        ""
                    }
                );
                let series: Vec<Series> = run.trend.iter().map(|(_, s)| s.clone()).collect();
                if let Err(e) = write_trend_svg(&title, &series, run.last, path) {
                    log::error!("module {}: {e}", self.name);
                }
            }
        }
    }

    fn default_scan_period(&self) -> Option<std::time::Duration> {
        Some(crate::common::DEFAULT_PERIOD)
    }

    fn status(&self) -> String {
        self.run.as_ref().map_or_else(String::new, |r| {
            format!(
                "{} row{} to {}",
                r.rows,
                if r.rows == 1 { "" } else { "s" },
                r.path.display()
            )
        })
    }
}

/// Creates the missing folders of `file` (as every `--out` does), or says which one cannot be
/// made and why.
fn make_folder(module: &str, file: &Path, what: &str) -> Result<(), ModuleError> {
    match file.parent().filter(|d| !d.as_os_str().is_empty()) {
        Some(dir) if !dir.is_dir() => std::fs::create_dir_all(dir).map_err(|e| {
            error(
                module,
                format!(
                    "cannot create the folder `{}` for the {what} `{}`: {e}",
                    dir.display(),
                    file.display()
                ),
            )
        }),
        _ => Ok(()),
    }
}
