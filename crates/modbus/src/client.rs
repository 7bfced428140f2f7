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
//! ```

mod config;
mod plan;
mod poll;

use std::sync::mpsc;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use petriplc_config::{ModuleDecl, PointKind};
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

/// The `modbus_client` module.
pub struct ModbusClient {
    name: String,
    backoff_max: Duration,
    devices: Vec<DeviceView>,
    worker: Option<Worker>,
}

/// A device as the scans see it.
struct DeviceView {
    name: String,
    period: Duration,
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
    /// A value that did not fit the point was reported, and none has fitted since.
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
        common::check_decl(decl, KIND, &["backoff_max"])?;
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
        Ok(ModbusClient {
            name: decl.name.clone(),
            backoff_max,
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
                period: d.period,
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
                    deliver(&self.name, ctx.map, r, raw);
                }
            }
            if let Some(h) = &d.stale {
                ctx.map
                    .set_bool(h, stale)
                    .map_err(|e| error(&self.name, e))?;
            }
        }
        Ok(Control::Continue)
    }

    fn close(&mut self) {
        self.stop();
    }

    fn status(&self) -> String {
        self.devices
            .iter()
            .map(|d| {
                let st = d.shared.lock();
                let counts = format!(
                    "{} cycle{}, {} error{}",
                    st.cycles,
                    if st.cycles == 1 { "" } else { "s" },
                    st.errors,
                    if st.errors == 1 { "" } else { "s" }
                );
                match (&st.last_error, st.stale) {
                    (_, false) => format!("{} up ({counts})", d.name),
                    (Some(e), true) => format!("{} stale: {e} ({counts})", d.name),
                    (None, true) => format!("{} connecting ({counts})", d.name),
                }
            })
            .collect::<Vec<_>>()
            .join("; ")
    }

    fn default_scan_period(&self) -> Option<Duration> {
        let shortest = self.devices.iter().map(|d| d.period).min();
        Some(shortest.map_or(MAX_DEFAULT_SCAN, |p| p.min(MAX_DEFAULT_SCAN)))
    }
}

impl Drop for ModbusClient {
    fn drop(&mut self) {
        self.stop();
    }
}

/// Writes a value read from a device into its point, or reports (once until a value fits
/// again) one that the point cannot hold.
fn deliver(module: &str, map: &mut ModuleMap, r: &mut ReadRow, raw: Raw) {
    let row = &r.row;
    let (kind, bits) = (row.handle.kind(), row.handle.bits());
    let value = match raw {
        Raw::Bit(b) => from_bit(b, kind),
        Raw::Words(w) => decode(&w[..row.ty.registers()], row.ty, row.order),
    };
    let problem = match convert(value, kind, bits) {
        Some(v) => match map.set(&row.handle, v) {
            Ok(()) => None,
            Err(e) => Some(e.to_string()),
        },
        None => Some(format!(
            "it does not fit point `{}` ({}{bits})",
            row.point,
            match kind {
                PointKind::Unsigned => 'u',
                PointKind::Signed => 'i',
                PointKind::Float => 'f',
            }
        )),
    };
    match problem {
        None => r.misfit = false,
        Some(why) if !r.misfit => {
            r.misfit = true;
            log::warn!(
                "module {module}: {} read from device {} {} {} ({}): {why}; the point keeps its \
                 value until a value fits",
                show(value),
                r.device,
                row.table.name(),
                row.address,
                row.origin
            );
        }
        Some(_) => {}
    }
}

fn show(v: petriplc_config::PointValue) -> String {
    match v {
        petriplc_config::PointValue::Unsigned(u) => u.to_string(),
        petriplc_config::PointValue::Signed(i) => i.to_string(),
        petriplc_config::PointValue::Float(f) => f.to_string(),
    }
}
