//! `dsp`: MatPLC's dsp module. The `fblock` rows of the section are function blocks run in
//! row order every scan (petriplc-dsp's `Chain`), reading and writing plc points: every point
//! a row names is read at the start of the scan, and the points the blocks write (which the
//! module must own) are written at its end. Designed filters sample at 1/`scan_period`.
//!
//! ```text
//! [heater]
//! scan_period = 0.1
//! out_time_pt = t                     # the module's time in s (an f32 point), every scan
//! fblock pid temp heat 2 0.05 0 sp setpoint min_out 0 max_out 100
//! fblock filter raw smooth butterworth lowpass 1 1 30 0.5 2
//! ```

use std::time::Duration;

use petriplc_config::{ModuleDecl, PointKind, Row};
use petriplc_dsp::block::NumType;
use petriplc_dsp::chain::{Chain, Context, Points, Slot};
use petriplc_runtime::image::{Handle, ModuleMap};
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};

use crate::common::{self, error};

const KIND: &str = "dsp";

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(DspModule::new(decl)?))
}

/// The `dsp` module.
pub struct DspModule {
    name: String,
    out_time_pt: Option<String>,
    scan_period: Option<Duration>,
    run: Option<Run>,
}

/// A point the chain uses: its handle, what it holds, and whether a block writes it.
struct Bound {
    handle: Handle,
    ty: NumType,
    written: bool,
}

struct Run {
    chain: Chain,
    points: Vec<Bound>,
    values: Vec<f64>,
    time: Option<Handle>,
    /// The blocks and filters, fixed at start.
    summary: String,
    last_t: f64,
}

impl DspModule {
    /// Checks the settings; the rows are read by `init`, where the points are known.
    pub fn new(decl: &ModuleDecl) -> Result<DspModule, ModuleError> {
        common::check_decl(decl, KIND, &["out_time_pt"])?;
        Ok(DspModule {
            name: decl.name.clone(),
            out_time_pt: common::setting(decl, "out_time_pt").map(String::from),
            scan_period: decl.scan_period.filter(|p| !p.is_zero()),
            run: None,
        })
    }
}

/// The chain's view of the module's map: each point once, by name.
struct MapPoints<'a> {
    map: &'a ModuleMap,
    module: &'a str,
    names: Vec<String>,
    bound: Vec<Bound>,
}

fn num_type(h: &Handle) -> NumType {
    match h.kind() {
        PointKind::Float => NumType::F32,
        PointKind::Signed => NumType::Signed(h.bits()),
        PointKind::Unsigned => NumType::Unsigned(h.bits()),
    }
}

impl Points for MapPoints<'_> {
    fn slot(&mut self, name: &str, write: bool) -> Result<Slot, String> {
        let handle = self.map.handle(name).map_err(|e| {
            let owner = if write { self.module } else { "OWNER" };
            format!("{e} (or declare `point {name} \"...\" {owner} f32` in [PLC])")
        })?;
        if write && !self.map.owns(&handle) {
            let owner = &self.map.layout().slot(handle.id()).owner;
            return Err(format!(
                "`{name}` is owned by module `{owner}`, and only its owner may write a point: \
                 declare `point {name} \"...\" {}`, or write another point",
                self.module
            ));
        }
        if write && self.map.layout().slot(handle.id()).retain {
            return Err(format!(
                "`{name}` is retentive (`retain`), but the blocks compute it at every scan \
                 from state that starts afresh, so its stored value would be overwritten at the \
                 first scan; drop `retain` from point `{name}`"
            ));
        }
        let index = match self.names.iter().position(|n| n == name) {
            Some(i) => i,
            None => {
                self.names.push(name.to_string());
                self.bound.push(Bound {
                    ty: num_type(&handle),
                    handle,
                    written: false,
                });
                self.names.len() - 1
            }
        };
        self.bound[index].written |= write;
        Ok(Slot {
            index,
            ty: self.bound[index].ty,
        })
    }
}

fn read(map: &ModuleMap, p: &Bound) -> f64 {
    match p.ty {
        NumType::F32 => f64::from(map.get_f32(&p.handle)),
        NumType::Signed(_) => f64::from(map.get_i32(&p.handle)),
        NumType::Unsigned(_) => f64::from(map.get_u32(&p.handle)),
    }
}

/// Writes a value the chain already made fit the point (`petriplc_dsp::block::convert`).
fn write(map: &mut ModuleMap, p: &Bound, v: f64) -> Result<(), String> {
    let r = match p.ty {
        NumType::F32 => map.set_f32(&p.handle, v as f32),
        NumType::Signed(_) => map.set_i32(&p.handle, v as i32),
        NumType::Unsigned(_) => map.set_u32(&p.handle, v as u32),
    };
    r.map_err(|e| e.to_string())
}

impl Module for DspModule {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let rows: Vec<&Row> = common::rows(ctx, KIND, &["fblock"])?;
        let cells: Vec<Vec<String>> = rows.iter().map(|r| r.cells.clone()).collect();
        let mut points = MapPoints {
            map: ctx.map,
            module: &self.name,
            names: Vec::new(),
            bound: Vec::new(),
        };
        let context = Context {
            scan_period: self.scan_period.map(|p| p.as_secs_f64()),
        };
        let chain = Chain::parse(&cells, &mut points, &context).map_err(|errors| {
            let lines: Vec<String> = errors
                .iter()
                .map(|(i, e)| {
                    let r = rows[*i];
                    let kind = r.cells.first().map_or("", String::as_str);
                    format!("{}: fblock {kind}: {e}", r.origin)
                })
                .collect();
            error(&self.name, lines.join(&format!("\nmodule {}: ", self.name)))
        })?;
        let bound = points.bound;
        let time = match &self.out_time_pt {
            None => None,
            Some(name) => {
                let h = ctx.map.handle(name).map_err(|e| {
                    error(
                        &self.name,
                        format!(
                            "out_time_pt: {e}; declare `point {name} \"...\" {} f32` in [PLC]",
                            self.name
                        ),
                    )
                })?;
                if !ctx.map.owns(&h) || h.kind() != PointKind::Float {
                    return Err(error(
                        &self.name,
                        format!(
                            "out_time_pt = {name} must be an f32 point of this module: declare \
                             `point {name} \"...\" {} f32`",
                            self.name
                        ),
                    ));
                }
                Some(h)
            }
        };
        let filters = chain.filters();
        for line in &filters {
            log::debug!("module {}: {line}", self.name);
        }
        let mut summary = format!(
            "{} block{}, {} second-order section{}",
            chain.len(),
            if chain.len() == 1 { "" } else { "s" },
            chain.sections(),
            if chain.sections() == 1 { "" } else { "s" }
        );
        for line in filters {
            summary.push('\n');
            summary.push_str(&line);
        }
        self.run = Some(Run {
            values: vec![0.0; bound.len()],
            points: bound,
            chain,
            time,
            summary,
            last_t: 0.0,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        for (v, p) in run.values.iter_mut().zip(&run.points) {
            *v = read(ctx.map, p);
        }
        let t = ctx.now.as_secs_f64();
        run.last_t = t;
        run.chain.scan(&mut run.values, t);
        for (&v, p) in run.values.iter().zip(&run.points) {
            if p.written {
                write(ctx.map, p, v).map_err(|e| error(&self.name, e))?;
            }
        }
        if let Some(h) = &run.time {
            ctx.map
                .set_f32(h, t as f32)
                .map_err(|e| error(&self.name, e.to_string()))?;
        }
        Ok(Control::Continue)
    }

    fn default_scan_period(&self) -> Option<Duration> {
        Some(common::DEFAULT_PERIOD)
    }

    fn status(&self) -> String {
        self.run.as_ref().map_or_else(String::new, |r| {
            let bad = r.chain.bad_inputs();
            let held = if bad == 0 {
                String::new()
            } else {
                format!(", {bad} PID steps held on inputs that were not numbers")
            };
            match r.summary.split_once('\n') {
                Some((first, rest)) => format!("{first}, t={:.1} s{held}\n{rest}", r.last_t),
                None => format!("{}, t={:.1} s{held}", r.summary, r.last_t),
            }
        })
    }
}
