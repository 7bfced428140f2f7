//! `modbus_client`: a Modbus master (TCP and RTU) that polls ranges of remote devices into
//! points and writes points out, each device on its own period, with reconnection and
//! back-off and a per-device "stale" point. The polling runs on a tokio runtime in a
//! background thread (started by `init`, stopped by `close`); scans only exchange values
//! with it. See docs/modbus-client.md.
//!
//! ```text
//! [io]
//! device  drive  tcp:127.0.0.1:5020          1  100ms  500ms
//! device  panel  rtu:/dev/ttyUSB0:19200:8E1  3  50ms
//! read    drive  holding  0   speed  u16
//! write   drive  holding  10  setpoint  f32  low_first
//! stale   drive  io_drive_stale
//! backoff_max = 5s
//! connect_within = 10s     # optional: a device silent this long after start fails the module
//! ```
//!
//! Values from a device that no point can take (NaN or ±Inf for a float point, 300 for a
//! `u8`) are refused: the point keeps its value, the device's stale point says so, and the
//! first refusal per row is logged (docs/modbus-client.md, Bad values).

mod config;
mod plan;
mod poll;

use std::sync::mpsc;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use petriplc_config::{ModuleDecl, PointKind, PointValue};
use petriplc_modules::common::{self, error};
use petriplc_net::time::parse_duration;
use petriplc_runtime::image::{Handle, ModuleMap};
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};
use tokio::sync::watch;

use self::config::{Endpoint, PointRow, Spec};
use self::plan::{plan, Span};
use self::poll::{Device, Line, Raw, Shared};
use crate::value::{convert, decode, encode, from_bit, to_bit};

pub(crate) const KIND: &str = "modbus_client";

/// The longest wait between reconnection attempts when `backoff_max` is not set.
pub const DEFAULT_BACKOFF_MAX: Duration = Duration::from_secs(5);

/// The longest scan period the module asks for when its section sets none: read values
/// land in points at most this late after a poll.
pub const MAX_DEFAULT_SCAN: Duration = Duration::from_millis(100);

/// How long `close` waits for the polling thread before leaving it behind.
const STOP_WAIT: Duration = Duration::from_secs(2);

pub fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(ModbusClient::new(decl)?))
}

/// The settings a `modbus_client` section may have (besides the runner's).
pub const SETTINGS: &[&str] = &["backoff_max", "connect_within"];

/// The `modbus_client` module.
pub struct ModbusClient {
    name: String,
    backoff_max: Duration,
    /// `connect_within`: how long after its start a device may go without one complete cycle
    /// before the module fails (with the setting as written, for the message); `None`: never.
    connect_within: Option<(Duration, String)>,
    /// The time of the first scan since `init` (the runner's clock), from which
    /// `connect_within` counts.
    started: Option<Duration>,
    devices: Vec<DeviceView>,
    worker: Option<Worker>,
}

/// A device as the scans see it.
struct DeviceView {
    name: String,
    /// Where it is reached, for messages.
    endpoint: String,
    unit: u8,
    period: Duration,
    /// Values read from it that no point could take.
    bad_values: u64,
    reads: Vec<ReadRow>,
    writes: Vec<PointRow>,
    stale: Option<Handle>,
    shared: Arc<Shared>,
    /// Reused every scan: the values taken from `shared`.
    inbox: Vec<Option<Raw>>,
}

struct ReadRow {
    row: PointRow,
    device: String,
    /// The last value read was refused (the first of a run of refusals is logged); the point
    /// holds an older value, so the device's stale point is set.
    misfit: bool,
}

/// The polling thread.
struct Worker {
    stop: watch::Sender<bool>,
    done: mpsc::Receiver<()>,
    thread: JoinHandle<()>,
}

impl ModbusClient {
    /// Checks the settings; the rows are read by `init`, which sees the whole section.
    pub fn new(decl: &ModuleDecl) -> Result<ModbusClient, ModuleError> {
        common::check_decl(decl, KIND, SETTINGS)?;
        let backoff_max = match common::setting(decl, "backoff_max") {
            None => DEFAULT_BACKOFF_MAX,
            Some(v) => match parse_duration(v) {
                Ok(d) if !d.is_zero() => d,
                Ok(_) => {
                    return Err(error(
                        &decl.name,
                        "`backoff_max` must be more than 0, e.g. `backoff_max = 5s`",
                    ))
                }
                Err(e) => return Err(error(&decl.name, format!("`backoff_max = {v}`: {e}"))),
            },
        };
        let connect_within = match common::setting(decl, "connect_within") {
            None | Some("off" | "no" | "none") => None,
            Some(v) => match parse_duration(v) {
                Ok(d) if d.is_zero() => None,
                Ok(d) => Some((d, v.to_string())),
                Err(e) => {
                    return Err(error(
                        &decl.name,
                        format!(
                            "`connect_within = {v}`: {e}; write a time such as 10s or T#10s, \
                             or `off` (the default: a device that never answers is only \
                             reported)"
                        ),
                    ))
                }
            },
        };
        Ok(ModbusClient {
            name: decl.name.clone(),
            backoff_max,
            connect_within,
            started: None,
            devices: Vec::new(),
            worker: None,
        })
    }

    fn stop(&mut self) {
        let Some(w) = self.worker.take() else {
            return;
        };
        // A send fails only when every task has already ended.
        let _ = w.stop.send(true);
        // Every task stops at its next await; the thread then gives blocking work (a name
        // lookup) a moment and returns. Waiting is bounded all the same: `close` must not
        // hang on a device.
        match w.done.recv_timeout(STOP_WAIT) {
            Ok(()) | Err(mpsc::RecvTimeoutError::Disconnected) => {
                let _ = w.thread.join();
            }
            Err(mpsc::RecvTimeoutError::Timeout) => log::warn!(
                "module {}: the Modbus thread did not stop within {STOP_WAIT:?}; left behind",
                self.name
            ),
        }
    }

    fn start(&mut self, spec: Spec) -> Result<(), ModuleError> {
        let Spec {
            devices,
            reads,
            writes,
            stale,
        } = spec;
        let mut lines: Vec<Arc<Line>> = Vec::new();
        let mut tasks = Vec::new();
        let mut views = Vec::new();
        for (i, (d, stale)) in devices.into_iter().zip(stale).enumerate() {
            let my_reads: Vec<PointRow> = reads.iter().filter(|r| r.device == i).cloned().collect();
            let my_writes: Vec<PointRow> =
                writes.iter().filter(|r| r.device == i).cloned().collect();
            let spans = |rows: &[PointRow]| -> Vec<Span> {
                rows.iter()
                    .map(|r| Span {
                        table: r.table,
                        address: r.address,
                        width: r.width(),
                    })
                    .collect()
            };
            // Devices on one serial port share it; every TCP device has its own connection.
            let line = match &d.endpoint {
                Endpoint::Rtu(s) => lines
                    .iter()
                    .find(|l| matches!(&l.endpoint, Endpoint::Rtu(o) if o.path == s.path)),
                Endpoint::Tcp { .. } => None,
            };
            let line = match line {
                Some(l) => Arc::clone(l),
                None => {
                    let l = Arc::new(Line::new(d.endpoint.clone()));
                    lines.push(Arc::clone(&l));
                    l
                }
            };
            let shared = Arc::new(Shared::new(my_reads.len()));
            tasks.push(Device {
                module: self.name.clone(),
                name: d.name.clone(),
                unit: d.unit,
                period: d.period,
                timeout: d.timeout,
                backoff_max: self.backoff_max,
                line,
                reads: plan(&spans(&my_reads), false),
                read_widths: my_reads.iter().map(PointRow::width).collect(),
                writes: plan(&spans(&my_writes), true),
                write_widths: my_writes.iter().map(PointRow::width).collect(),
                shared: Arc::clone(&shared),
            });
            views.push(DeviceView {
                name: d.name.clone(),
                endpoint: d.endpoint.to_string(),
                unit: d.unit,
                period: d.period,
                bad_values: 0,
                inbox: vec![None; my_reads.len()],
                reads: my_reads
                    .into_iter()
                    .map(|row| ReadRow {
                        row,
                        device: d.name.clone(),
                        misfit: false,
                    })
                    .collect(),
                writes: my_writes,
                stale: stale.map(|(_, h)| h),
                shared,
            });
        }

        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()
            .map_err(|e| error(&self.name, format!("cannot start the Modbus runtime: {e}")))?;
        let (stop, stop_rx) = watch::channel(false);
        let (done_tx, done) = mpsc::channel();
        let thread = std::thread::Builder::new()
            .name(format!("modbus {}", self.name))
            .spawn(move || {
                runtime.block_on(async move {
                    let t0 = tokio::time::Instant::now();
                    let handles: Vec<_> = tasks
                        .into_iter()
                        .map(|d| tokio::spawn(d.run(t0, stop_rx.clone())))
                        .collect();
                    for h in handles {
                        let _ = h.await;
                    }
                });
                runtime.shutdown_timeout(Duration::from_millis(100));
                let _ = done_tx.send(());
            })
            .map_err(|e| error(&self.name, format!("cannot start the Modbus thread: {e}")))?;
        self.devices = views;
        self.worker = Some(Worker { stop, done, thread });
        Ok(())
    }
}

impl Module for ModbusClient {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        self.stop();
        self.started = None;
        let spec = config::read(ctx)?;
        self.start(spec)
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        if self.worker.is_none() {
            return Err(error(&self.name, "scanned before init"));
        }
        for d in &mut self.devices {
            let outs: Vec<Raw> = d
                .writes
                .iter()
                .map(|r| {
                    let v = ctx.map.get(&r.handle);
                    if r.table.is_bits() {
                        Raw::Bit(to_bit(v))
                    } else {
                        Raw::Words(encode(v, r.ty, r.order))
                    }
                })
                .collect();
            let stale = {
                let mut st = d.shared.lock();
                for (mine, theirs) in d.inbox.iter_mut().zip(st.reads.iter_mut()) {
                    *mine = theirs.take();
                }
                if !d.writes.is_empty() {
                    st.writes = Some(outs);
                }
                st.stale
            };
            for (r, raw) in d.reads.iter_mut().zip(d.inbox.iter_mut()) {
                if let Some(raw) = raw.take() {
                    if !deliver(&self.name, ctx.map, r, raw) {
                        d.bad_values += 1;
                    }
                }
            }
            // A point holding an older value than the device's because the last one was
            // refused is not fresh either.
            let stale = stale || d.reads.iter().any(|r| r.misfit);
            if let Some(h) = &d.stale {
                ctx.map
                    .set_bool(h, stale)
                    .map_err(|e| error(&self.name, e))?;
            }
        }
        self.check_connected(ctx.now)?;
        Ok(Control::Continue)
    }

    fn close(&mut self) {
        self.stop();
    }

    fn status(&self) -> String {
        self.devices
            .iter()
            .map(|d| link_state(d, &d.shared.lock()))
            .collect::<Vec<_>>()
            .join("; ")
    }

    fn default_scan_period(&self) -> Option<Duration> {
        let shortest = self.devices.iter().map(|d| d.period).min();
        Some(shortest.map_or(MAX_DEFAULT_SCAN, |p| p.min(MAX_DEFAULT_SCAN)))
    }
}

impl ModbusClient {
    /// With `connect_within`: fails the module once that long has passed since its first
    /// scan and a device has never completed a cycle, naming every such device.
    fn check_connected(&mut self, now: Duration) -> Result<(), ModuleError> {
        let Some((limit, text)) = &self.connect_within else {
            return Ok(());
        };
        let started = *self.started.get_or_insert(now);
        if now.saturating_sub(started) < *limit {
            return Ok(());
        }
        let silent: Vec<String> = self
            .devices
            .iter()
            .filter_map(|d| {
                let st = d.shared.lock();
                (st.cycles == 0).then(|| {
                    let last = st
                        .last_error
                        .as_deref()
                        .map(|e| format!(", last: {e}"))
                        .unwrap_or_default();
                    format!(
                        "device `{}` ({}, unit {}) never connected within connect_within = \
                         {text} ({}{last})",
                        d.name,
                        d.endpoint,
                        d.unit,
                        plural(st.failures, "failed attempt")
                    )
                })
            })
            .collect();
        if silent.is_empty() {
            // Every device has answered: the setting has done its job for this run.
            self.connect_within = None;
            return Ok(());
        }
        Err(error(
            &self.name,
            format!(
                "{}; check that the device is on and reachable at that address, or raise \
                 `connect_within` in [{}] (`off`: a device that never answers is only reported)",
                silent.join("; "),
                self.name
            ),
        ))
    }
}

/// A device's line in the status: its link's state, cycles, failures and refused values.
fn link_state(d: &DeviceView, st: &poll::State) -> String {
    let mut counts = format!(
        "{}, {}",
        plural(st.cycles, "cycle"),
        plural(st.failures, "failure")
    );
    if d.bad_values > 0 {
        counts.push_str(&format!(", {} refused", plural(d.bad_values, "value")));
    }
    let last = st
        .last_error
        .as_deref()
        .map(|e| format!(", last: {e}"))
        .unwrap_or_default();
    let name = &d.name;
    match (st.cycles, st.stale, st.down_since) {
        (0, _, _) => format!("{name} never connected to {} ({counts}{last})", d.endpoint),
        (_, false, _) => format!("{name} connected ({counts})"),
        (_, true, Some(t)) => format!(
            "{name} down since {} ({}; {counts}{last})",
            clock(t),
            d.endpoint
        ),
        (_, true, None) => format!("{name} down ({}; {counts}{last})", d.endpoint),
    }
}

fn plural(n: u64, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// `HH:MM:SS UTC`.
fn clock(t: SystemTime) -> String {
    let s = t.duration_since(UNIX_EPOCH).unwrap_or_default().as_secs() % 86_400;
    format!("{:02}:{:02}:{:02} UTC", s / 3600, s / 60 % 60, s % 60)
}

impl Drop for ModbusClient {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Writes a value read from a device into its point, or refuses one that the point cannot
/// take (reported once until a value fits again); returns whether it was written.
fn deliver(module: &str, map: &mut ModuleMap, r: &mut ReadRow, raw: Raw) -> bool {
    let row = &r.row;
    let (kind, bits) = (row.handle.kind(), row.handle.bits());
    let value = match raw {
        Raw::Bit(b) => from_bit(b, kind),
        Raw::Words(w) => decode(&w[..row.ty.registers()], row.ty, row.order),
    };
    let problem = match convert(value, kind, bits) {
        Ok(v) => match map.set(&row.handle, v) {
            Ok(()) => None,
            Err(e) => Some(e.to_string()),
        },
        Err(why) => Some(format!(
            "{why}, and point `{}` is {}{bits}",
            row.point,
            match kind {
                PointKind::Unsigned => 'u',
                PointKind::Signed => 'i',
                PointKind::Float => 'f',
            }
        )),
    };
    let Some(why) = problem else {
        r.misfit = false;
        return true;
    };
    if !r.misfit {
        r.misfit = true;
        let registers = match raw {
            Raw::Bit(b) => format!("bit {}", u8::from(b)),
            Raw::Words(w) => w[..row.ty.registers()]
                .iter()
                .map(|w| format!("0x{w:04X}"))
                .collect::<Vec<_>>()
                .join(" "),
        };
        log::warn!(
            "module {module}: refused {} ({registers}) read from device {} {} {} ({}): {why}; \
             the point keeps its value and the device's stale point is set until a value \
             fits (further refusals are only counted: status line, values refused)",
            show(value),
            r.device,
            row.table.name(),
            row.address,
            row.origin
        );
    }
    false
}

fn show(v: PointValue) -> String {
    match v {
        PointValue::Unsigned(u) => u.to_string(),
        PointValue::Signed(i) => i.to_string(),
        PointValue::Float(f) if f.is_nan() => "NaN".to_string(),
        PointValue::Float(f) if f.is_infinite() => {
            if f > 0.0 { "+Inf" } else { "-Inf" }.to_string()
        }
        PointValue::Float(f) => f.to_string(),
    }
}
