//! The process's attachment to a running PLC (the safe half of the C ABI): the module map,
//! the global map, the shared synchronisation marking and the scan period, behind one
//! process-wide lock.
//!
//! Blocking waits (the period, the synchronisation net) run with the lock released, so the
//! module's other threads can still read and write points while the scan loop waits.

use std::os::raw::c_int;
use std::path::Path;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use petriplc_config::{Location, PlcConfig, PointKind};
use petriplc_runtime::image::module::process_threads;
use petriplc_runtime::image::{GlobalMap, Handle, ImageError, Layout, ModuleMap};
use petriplc_runtime::period::{self, Period, ScanStats};
use petriplc_runtime::report::Sender;
use petriplc_runtime::retained::{self, Adopt};
use petriplc_runtime::synch::{ScanRef, SharedSynch, SynchError, SynchNet, TransitionRef};
use petriplc_runtime::watchdog::{ScanClock, ScanClocks, Token};

use crate::args::{self, Target};
use crate::*;

/// A point handle as C sees it (`plc_pt_t`): the point's index + 1 (0 is the invalid
/// handle) and the `plc_init` it came from, so a handle kept across `plc_close` and a new
/// `plc_init` (perhaps of another configuration) is refused rather than misread.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PlcPt {
    pub index: u32,
    pub session: u32,
}

impl PlcPt {
    pub const INVALID: PlcPt = PlcPt {
        index: 0,
        session: 0,
    };
}

struct Plc {
    session: u32,
    map: ModuleMap,
    /// `None` for an isolated module: its proxy process alone maps the global map.
    global: Option<GlobalMap>,
    /// Shared with callers that wait on it with the lock released.
    synch: Arc<SharedSynch>,
    /// The module's scan_beg / scan_end and its scan slot, which tells the PLC whether the
    /// module is inside a scan should it die (`None`: both are NULL).
    scan: Option<ScanRef>,
    scan_period: Option<Duration>,
    /// Started by the first `scan_beg`, so that scan 0 runs at once and t0 is its start.
    period: Option<Period>,
    /// By point index.
    handles: Vec<Handle>,
    /// This process's scans, as the runner's status shows them: each from the period's
    /// wake-up (or `plc_scan_beg`) to the end of `plc_scan_end`.
    stats: ScanStats,
    /// The scan under way: when it began, how late its period woke, periods it missed.
    under_way: Option<(Duration, Duration, u64)>,
    /// To the runner that started this process (`None` when started by hand).
    report: Option<Sender>,
    /// With a watchdog: the module's scan clock, which the runner watches, and the scan
    /// under way on it.
    clock: Option<ScanClock>,
    scan_token: Option<Token>,
}

static STATE: Mutex<Option<Plc>> = Mutex::new(None);
static SESSIONS: AtomicU32 = AtomicU32::new(0);

/// A caught panic poisons the lock; the state it guards is still consistent (every
/// mutation is a single assignment or a `ModuleMap` call that completes or panics before
/// writing), so carry on rather than fail every later call.
fn state() -> MutexGuard<'static, Option<Plc>> {
    STATE.lock().unwrap_or_else(PoisonError::into_inner)
}

fn not_init() -> Error {
    Error::new(
        PLC_ERR_NOT_INIT,
        "the module is not attached to a PLC: call plc_init first",
    )
}

fn with_plc<R>(f: impl FnOnce(&mut Plc) -> Result<R, Error>) -> Result<R, Error> {
    match state().as_mut() {
        Some(plc) => f(plc),
        None => Err(not_init()),
    }
}

/// As [`with_plc`], for the second half of a call that waited with the lock released.
fn with_session<R>(session: u32, f: impl FnOnce(&mut Plc) -> Result<R, Error>) -> Result<R, Error> {
    with_plc(|plc| {
        if plc.session != session {
            return Err(Error::new(
                PLC_ERR_NOT_INIT,
                "plc_close was called while this call waited",
            ));
        }
        f(plc)
    })
}

fn image_error(e: ImageError) -> Error {
    let code = match &e {
        ImageError::UnknownPoint { .. } => PLC_ERR_POINT,
        ImageError::NotOwner { .. } => PLC_ERR_NOT_OWNER,
        ImageError::OutOfRange { .. } | ImageError::WrongKind { .. } => PLC_ERR_VALUE,
        ImageError::UnknownModule { .. } => PLC_ERR_MODULE,
        ImageError::NotRunning { .. } => PLC_ERR_NOT_RUNNING,
        ImageError::LayoutMismatch { .. } | ImageError::BadImage { .. } => PLC_ERR_MISMATCH,
        ImageError::BadPlcId { .. } => PLC_ERR_ARGS,
        ImageError::Os { .. } => PLC_ERR_OS,
        _ => PLC_ERR_CONFIG,
    };
    Error::new(code, e.to_string())
}

fn synch_error(e: SynchError) -> Error {
    let code = match &e {
        SynchError::Config { .. } => PLC_ERR_CONFIG,
        SynchError::BadPlcId { .. } => PLC_ERR_ARGS,
        SynchError::NotRunning { .. } => PLC_ERR_NOT_RUNNING,
        SynchError::Mismatch { .. } => PLC_ERR_MISMATCH,
        _ => PLC_ERR_OS,
    };
    Error::new(code, e.to_string())
}

/// A module process started by hand is the usual way to get here: say both ways to fix it,
/// in the module's terms (`--PLCplc_id`, not the CLI's `--plc-id`).
fn not_running(plc_id: &str, shm: &str) -> Error {
    Error::new(
        PLC_ERR_NOT_RUNNING,
        format!(
            "no PLC with id `{plc_id}` is running (no shared memory `{shm}`): start it with \
             `petriplc run CONFIG` (which starts its modules too), or pass the id of the \
             running PLC with --PLCplc_id=ID"
        ),
    )
}

/// The configuration with the `--set` overrides `petriplc run` passes its program modules
/// in `PETRIPLC_SET`, one per line.
fn read_config(path: &Path) -> Result<PlcConfig, Error> {
    let overrides = std::env::var("PETRIPLC_SET")
        .unwrap_or_default()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(str::parse)
        .collect::<Result<Vec<petriplc_config::Override>, String>>()
        .map_err(|e| Error::new(PLC_ERR_CONFIG, format!("PETRIPLC_SET: {e}")))?;
    petriplc_config::read_file_with(path, &overrides).map_err(|e| {
        Error::new(
            PLC_ERR_CONFIG,
            format!("configuration `{}`:\n{e}", path.display()),
        )
    })
}

fn already_init() -> Error {
    Error::new(
        PLC_ERR_ALREADY_INIT,
        "plc_init was already called in this process (call plc_close first)",
    )
}

/// Checked before the arguments, whose errors would hide the real mistake.
pub(crate) fn check_detached() -> Result<(), Error> {
    match *state() {
        Some(_) => Err(already_init()),
        None => Ok(()),
    }
}

/// Attaches the process to the PLC `target` names.
pub(crate) fn init(target: Target) -> Result<(), Error> {
    let mut state = state();
    if state.is_some() {
        return Err(already_init());
    }
    let module = target.module.as_str();
    let context = |e: Error| Error::new(e.code, format!("module `{module}`: {}", e.message));
    // Tests make a module program die holding the PLC's lock through this variable.
    if let Ok(spec) = std::env::var(petriplc_runtime::testhook::ENV) {
        petriplc_runtime::testhook::arm_from(&spec)
            .map_err(|e| context(Error::new(PLC_ERR_ARGS, e)))?;
    }
    let config = read_config(&target.config).map_err(context)?;
    let plc_id = match target.plc_id {
        Some(id) => id,
        None => match config.plc.get("plc_id") {
            Some(s) if !s.value.is_empty() => s.value.clone(),
            _ => return Err(args::no_plc_id(module)),
        },
    };
    let decl = config
        .modules
        .iter()
        .find(|m| m.name == module)
        .ok_or_else(|| {
            let declared: Vec<&str> = config.modules.iter().map(|m| m.name.as_str()).collect();
            Error::new(
                PLC_ERR_MODULE,
                format!(
                    "module `{module}` is not declared in `{}` (declared: {}); check \
                     --PLCmodule / PETRIPLC_MODULE",
                    target.config.display(),
                    if declared.is_empty() {
                        "none".to_string()
                    } else {
                        declared.join(", ")
                    }
                ),
            )
        })?;
    let layout = Layout::new(&config).map_err(image_error).map_err(context)?;
    let net = SynchNet::from_config(&config)
        .map_err(synch_error)
        .map_err(context)?;
    let attach = |e: Error| {
        context(Error::new(
            e.code,
            format!("cannot attach to PLC `{plc_id}`: {}", e.message),
        ))
    };
    let attach_image = |e: ImageError| {
        attach(match e {
            ImageError::NotRunning { plc_id, shm } => not_running(&plc_id, &shm),
            e => image_error(e),
        })
    };
    let (map, global) = if decl.location == Location::Isolate {
        check_single_threaded().map_err(context)?;
        let mut map = ModuleMap::isolated(&layout, module, &plc_id).map_err(attach_image)?;
        // The module's retentive points go on from the image: read once here, before any
        // of the module's code runs, and never mapped again by this process.
        if let Ok(global) = GlobalMap::open(&plc_id) {
            if global.check_layout(&layout).is_ok() {
                retained::adopt(&mut map, &global, Adopt::Retentive);
            }
        }
        (map, None)
    } else {
        let mut map = ModuleMap::new(&layout, module, decl.location)
            .map_err(image_error)
            .map_err(context)?;
        let global = GlobalMap::open(&plc_id).map_err(attach_image)?;
        global
            .check_layout(&layout)
            .map_err(image_error)
            .map_err(attach)?;
        // Retentive points go on from the image (restored at start, or as a previous
        // process of this module left them), not from their init values.
        retained::adopt(&mut map, &global, Adopt::Retentive);
        (map, Some(global))
    };
    let clock = match decl.watchdog {
        None => None,
        Some(_) => {
            let index = config
                .modules
                .iter()
                .position(|m| m.name == module)
                .unwrap_or(usize::MAX);
            ScanClocks::open(&plc_id)
                .map_err(|e| attach(Error::new(PLC_ERR_OS, e.to_string())))?
                .clock(index)
        }
    };
    let synch = SharedSynch::open(&plc_id, &net)
        .map_err(|e| match e {
            SynchError::NotRunning { shm } => not_running(&plc_id, &shm),
            e => synch_error(e),
        })
        .map_err(attach)?;
    let handles = layout
        .points()
        .map(|(_, slot)| map.handle(&slot.name))
        .collect::<Result<Vec<_>, _>>()
        .map_err(image_error)?;
    *state = Some(Plc {
        session: SESSIONS
            .fetch_add(1, Ordering::Relaxed)
            .wrapping_add(1)
            .max(1),
        scan: net.scan_ref(module),
        scan_period: decl.scan_period,
        period: None,
        map,
        global,
        synch: Arc::new(synch),
        handles,
        stats: ScanStats::new(),
        under_way: None,
        report: Sender::from_env(),
        clock,
        scan_token: None,
    });
    Ok(())
}

/// An isolated module forks its proxy in `plc_init`: refused once the process has other
/// threads, whose locks the proxy would inherit held.
fn check_single_threaded() -> Result<(), Error> {
    match process_threads() {
        Some(n) if n > 1 => Err(Error::new(
            PLC_ERR_CONFIG,
            format!(
                "location = isolate forks a proxy process, which is only safe in a \
                 single-threaded process, and this one has {n} threads: call plc_init before \
                 starting threads, or use location = local"
            ),
        )),
        _ => Ok(()),
    }
}

/// Detaches; the PLC and the other modules go on.
pub(crate) fn close() -> Result<(), Error> {
    let mut plc = state().take().ok_or_else(not_init)?;
    if let Some(r) = &mut plc.report {
        r.send(&plc.stats, true);
    }
    Ok(())
}

pub(crate) fn pt_by_name(name: &str) -> Result<PlcPt, Error> {
    with_plc(|plc| {
        let h = plc.map.handle(name).map_err(image_error)?;
        Ok(PlcPt {
            index: h.id().0 + 1,
            session: plc.session,
        })
    })
}

impl Plc {
    fn update(&mut self) -> Result<(), Error> {
        match &self.global {
            Some(global) => self.map.update(global),
            None => self.map.update_isolated().map_err(image_error)?,
        }
        Ok(())
    }

    fn handle(&self, pt: PlcPt) -> Result<Handle, Error> {
        if pt.index == 0 {
            return Err(Error::new(
                PLC_ERR_POINT,
                "invalid point handle (the plc_pt_by_name that returned it failed)",
            ));
        }
        if pt.session != self.session {
            return Err(Error::new(
                PLC_ERR_POINT,
                "stale point handle: it was looked up before the last plc_init; look it up again",
            ));
        }
        self.handles
            .get(pt.index as usize - 1)
            .copied()
            .ok_or_else(|| Error::new(PLC_ERR_POINT, "invalid point handle"))
    }
}

pub(crate) fn pt_valid(pt: PlcPt) -> bool {
    with_plc(|plc| plc.handle(pt)).is_ok()
}

pub(crate) fn get(pt: PlcPt) -> Result<u32, Error> {
    with_plc(|plc| Ok(plc.map.get_u32(&plc.handle(pt)?)))
}

pub(crate) fn get_i32(pt: PlcPt) -> Result<i32, Error> {
    with_plc(|plc| Ok(plc.map.get_i32(&plc.handle(pt)?)))
}

pub(crate) fn get_f32(pt: PlcPt) -> Result<f32, Error> {
    with_plc(|plc| Ok(plc.map.get_f32(&plc.handle(pt)?)))
}

/// Writes the point's raw bits: for a signed point its two's complement in the point's
/// width, for a float point its IEEE 754 bits.
pub(crate) fn set(pt: PlcPt, bits: u32) -> Result<(), Error> {
    with_plc(|plc| {
        let h = plc.handle(pt)?;
        let result = match h.kind() {
            PointKind::Unsigned => plc.map.set_u32(&h, bits),
            PointKind::Float => plc.map.set_f32(&h, f32::from_bits(bits)),
            PointKind::Signed => {
                let width = u32::from(h.bits());
                if width < 32 && bits >> width != 0 {
                    Err(ImageError::OutOfRange {
                        point: plc.map.layout().slot(h.id()).name.clone(),
                        kind: "signed",
                        bits: h.bits(),
                        value: format!("the raw bits {bits:#x}"),
                    })
                } else {
                    // Sign-extend from the point's width, so the typed setter sees the value
                    // those bits stand for.
                    let shift = 32 - width;
                    plc.map.set_i32(&h, ((bits << shift) as i32) >> shift)
                }
            }
        };
        result.map_err(image_error)
    })
}

pub(crate) fn set_i32(pt: PlcPt, v: i32) -> Result<(), Error> {
    with_plc(|plc| {
        let h = plc.handle(pt)?;
        plc.map.set_i32(&h, v).map_err(image_error)
    })
}

pub(crate) fn set_f32(pt: PlcPt, v: f32) -> Result<(), Error> {
    with_plc(|plc| {
        let h = plc.handle(pt)?;
        plc.map.set_f32(&h, v).map_err(image_error)
    })
}

pub(crate) fn update() -> Result<(), Error> {
    with_plc(Plc::update)
}

/// Waits for the scan period (from the second scan on), synchronises on the module's
/// `scan_beg` transition, then updates the map.
pub(crate) fn scan_beg() -> Result<c_int, Error> {
    let (session, synch, beg, period) = with_plc(|plc| {
        let period = match plc.scan_period {
            None => None,
            Some(t) => match plc.period.take() {
                Some(p) => Some(p),
                None => {
                    plc.period = Some(Period::new(t));
                    None
                }
            },
        };
        Ok((plc.session, plc.synch.clone(), plc.scan, period))
    })?;
    let mut scan = (period::now(), Duration::ZERO, 0);
    if let Some(mut period) = period {
        // A stopping PLC should not wait a whole period to tell its modules.
        if !synch.is_stopping() {
            let w = period.wait();
            scan = (w.woke(), w.late, w.missed);
        }
        with_session(session, |plc| {
            plc.period = Some(period);
            Ok(())
        })?;
    }
    with_session(session, |plc| {
        plc.under_way = Some(scan);
        Ok(())
    })?;
    let began = match &beg {
        Some(scan) => synch.begin_scan(scan).map(drop),
        None => synch.synch(TransitionRef::Null).map(drop),
    };
    if began.is_err() {
        return Ok(PLC_STOPPING);
    }
    with_session(session, |plc| {
        plc.update()?;
        plc.scan_token = plc.clock.as_ref().map(ScanClock::begin);
        Ok(PLC_OK)
    })
}

/// Updates the map, then synchronises on the module's `scan_end` transition; counts the scan.
pub(crate) fn scan_end() -> Result<c_int, Error> {
    let ended = with_plc(|plc| {
        if let (Some(clock), Some(t)) = (&plc.clock, plc.scan_token.take()) {
            if !clock.end(t) {
                // The watchdog took this scan (the runner is killing this process): nothing
                // of it may be written.
                return Ok(None);
            }
        }
        plc.update()?;
        Ok(Some((plc.session, plc.synch.clone(), plc.scan)))
    })?;
    let Some((session, synch, scan)) = ended else {
        return Ok(PLC_STOPPING);
    };
    let ended = match &scan {
        Some(scan) => synch.end_scan(scan).map(drop),
        None => synch.synch(TransitionRef::Null).map(drop),
    };
    if ended.is_err() {
        return Ok(PLC_STOPPING);
    }
    with_session(session, |plc| {
        if let Some((began, late, missed)) = plc.under_way.take() {
            plc.stats
                .record(period::now().saturating_sub(began), late, missed);
            if let Some(r) = &mut plc.report {
                r.send(&plc.stats, false);
            }
        }
        Ok(PLC_OK)
    })
}

/// Synchronises on a transition of the net by name (for modules that synchronise at other
/// points of their scan than its beginning and end).
pub(crate) fn synch(transition: &str) -> Result<c_int, Error> {
    let (synch, t) = with_plc(|plc| {
        let t = plc.synch.net().transition(transition).ok_or_else(|| {
            Error::new(
                PLC_ERR_POINT,
                format!("no transition `{transition}` in the synchronisation net"),
            )
        })?;
        Ok((plc.synch.clone(), t))
    })?;
    Ok(match synch.synch(t) {
        Ok(_) => PLC_OK,
        Err(_) => PLC_STOPPING,
    })
}

/// Whether the PLC is stopping, without waiting.
pub(crate) fn stopping() -> Result<bool, Error> {
    with_plc(|plc| Ok(plc.synch.is_stopping()))
}
