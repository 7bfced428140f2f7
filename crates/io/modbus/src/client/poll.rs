//! The network side of `modbus_client`: one tokio task per device polls it on an absolute
//! schedule, exchanging values with the module's scans through a small mutex-guarded state
//! per device; errors mark the device stale, drop the connection and back off.

use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use tokio::net::TcpStream;
use tokio::sync::watch;
use tokio::time::{interval_at, sleep, timeout, Instant, MissedTickBehavior};
use tokio_modbus::client::{rtu, tcp, Client, Context};
use tokio_modbus::prelude::SlaveContext;
use tokio_modbus::{ExceptionCode, Request as MbRequest, Response, Slave};

use super::config::{Endpoint, Table};
use super::plan::Request;

/// The first wait after a failed cycle; it doubles with each failure up to `backoff_max`.
pub const BACKOFF_MIN: Duration = Duration::from_millis(100);

/// A value as it travels: one bit, or one or two registers as they were on the wire.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Raw {
    Bit(bool),
    Words([u16; 2]),
}

/// What a device's task and the module's scans share.
#[derive(Debug, Default)]
pub struct State {
    /// Per read row of the device: the value read since the last scan took it.
    pub reads: Vec<Option<Raw>>,
    /// Per write row: the value to write, as of the last scan (`None` before the first).
    pub writes: Option<Vec<Raw>>,
    /// True until the first complete cycle and from any error to the next complete cycle.
    pub stale: bool,
    /// Complete cycles.
    pub cycles: u64,
    /// Failed cycles (including failed connections).
    pub failures: u64,
    /// What went wrong last, while stale.
    pub last_error: Option<String>,
    /// When the device last stopped answering after a complete cycle (`None` while it
    /// answers, and while it never has).
    pub down_since: Option<std::time::SystemTime>,
}

/// A device's [`State`] behind a mutex that a panic elsewhere cannot poison for good: the
/// state is plain data, valid after any partial update.
#[derive(Debug, Default)]
pub struct Shared(Mutex<State>);

impl Shared {
    pub fn new(reads: usize) -> Shared {
        Shared(Mutex::new(State {
            reads: vec![None; reads],
            stale: true,
            ..State::default()
        }))
    }

    pub fn lock(&self) -> MutexGuard<'_, State> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// A connection target: a TCP device, or a serial port that every device on the line
/// shares (their cycles take turns on its lock).
pub struct Line {
    pub endpoint: Endpoint,
    conn: tokio::sync::Mutex<Option<Context>>,
}

impl Line {
    pub fn new(endpoint: Endpoint) -> Line {
        Line {
            endpoint,
            conn: tokio::sync::Mutex::new(None),
        }
    }

    async fn connect(&self, unit: u8) -> Result<Context, String> {
        match &self.endpoint {
            Endpoint::Tcp { host, port } => {
                let stream = TcpStream::connect((host.as_str(), *port))
                    .await
                    .map_err(|e| format!("cannot connect to {}: {e}", self.endpoint))?;
                // Requests are small and each waits for its answer: Nagle would only delay.
                let _ = stream.set_nodelay(true);
                Ok(tcp::attach_slave(stream, Slave(unit)))
            }
            Endpoint::Rtu(serial) => {
                let port = serial.open().map_err(|e| e.to_string())?;
                Ok(rtu::attach_slave(port, Slave(unit)))
            }
        }
    }

    /// The silence an RTU master keeps before each request so that devices see a frame
    /// start (tokio-modbus sends at once).
    fn frame_gap(&self) -> Option<Duration> {
        match &self.endpoint {
            Endpoint::Rtu(s) => Some(s.frame_gap()),
            Endpoint::Tcp { .. } => None,
        }
    }
}

/// Everything a device's task needs.
pub struct Device {
    pub module: String,
    pub name: String,
    pub unit: u8,
    pub period: Duration,
    pub timeout: Duration,
    pub backoff_max: Duration,
    pub line: Arc<Line>,
    pub reads: Vec<Request>,
    /// Addresses taken by each read row.
    pub read_widths: Vec<u16>,
    pub writes: Vec<Request>,
    /// Addresses taken by each write row.
    pub write_widths: Vec<u16>,
    pub shared: Arc<Shared>,
}

impl Device {
    /// Polls until `stop` turns true (or its sender goes away).
    pub async fn run(self, t0: Instant, mut stop: watch::Receiver<bool>) {
        let mut ticks = interval_at(t0, self.period);
        // After a stall (a long timeout, a slow line) the schedule goes on at its next
        // deadline instead of running the missed cycles back to back.
        ticks.set_missed_tick_behavior(MissedTickBehavior::Skip);
        let mut backoff = BACKOFF_MIN.min(self.backoff_max);
        let mut retry_at: Option<Instant> = None;
        let mut failures: u64 = 0;
        loop {
            tokio::select! {
                biased;
                _ = stop.wait_for(|s| *s) => return,
                _ = ticks.tick() => {}
            }
            if retry_at.is_some_and(|t| Instant::now() < t) {
                continue;
            }
            let result = tokio::select! {
                biased;
                _ = stop.wait_for(|s| *s) => return,
                r = self.cycle() => r,
            };
            match result {
                Ok(()) => {
                    let mut st = self.shared.lock();
                    st.stale = false;
                    st.cycles += 1;
                    st.last_error = None;
                    st.down_since = None;
                    drop(st);
                    if failures > 0 {
                        log::info!(
                            "module {}: device {} answers again (after {failures} failed \
                             attempt{})",
                            self.module,
                            self.name,
                            if failures == 1 { "" } else { "s" }
                        );
                    }
                    failures = 0;
                    backoff = BACKOFF_MIN.min(self.backoff_max);
                    retry_at = None;
                }
                Err(e) => {
                    if failures == 0 {
                        log::warn!(
                            "module {}: device {} ({}, unit {}) does not answer: {e}; it is \
                             stale until it does, retried with back-off up to {:?}",
                            self.module,
                            self.name,
                            self.line.endpoint,
                            self.unit,
                            self.backoff_max
                        );
                    }
                    failures += 1;
                    let mut st = self.shared.lock();
                    if st.cycles > 0 && !st.stale {
                        st.down_since = Some(std::time::SystemTime::now());
                    }
                    st.stale = true;
                    st.failures += 1;
                    st.last_error = Some(e);
                    drop(st);
                    retry_at = Some(Instant::now() + backoff);
                    backoff = (backoff * 2).min(self.backoff_max);
                }
            }
        }
    }

    /// One cycle: the reads, then the writes; any error drops the connection.
    async fn cycle(&self) -> Result<(), String> {
        let mut conn = self.line.conn.lock().await;
        let result = self.exchange(&mut conn).await;
        if result.is_err() {
            *conn = None;
        }
        result
    }

    async fn exchange(&self, conn: &mut Option<Context>) -> Result<(), String> {
        let ctx = match conn {
            Some(c) => c,
            None => {
                let c = timeout(self.timeout, self.line.connect(self.unit))
                    .await
                    .map_err(|_| {
                        format!(
                            "no connection to {} within {:?}",
                            self.line.endpoint, self.timeout
                        )
                    })??;
                conn.insert(c)
            }
        };
        // Devices on one serial line share the connection.
        ctx.set_slave(Slave(self.unit));
        for req in &self.reads {
            let values = self.read(ctx, req).await?;
            let mut st = self.shared.lock();
            for ((row, _), v) in req.rows.iter().zip(values) {
                if let Some(slot) = st.reads.get_mut(*row) {
                    *slot = Some(v);
                }
            }
        }
        let outs = self.shared.lock().writes.clone();
        if let Some(outs) = outs {
            for req in &self.writes {
                self.write(ctx, req, &outs).await?;
            }
        }
        Ok(())
    }

    /// One read request; the value of each of its rows.
    async fn read(&self, ctx: &mut Context, req: &Request) -> Result<Vec<Raw>, String> {
        let (a, n) = (req.address, req.count);
        let what = describe("reading", req);
        let call = match req.table {
            Table::Coil => MbRequest::ReadCoils(a, n),
            Table::DiscreteInput => MbRequest::ReadDiscreteInputs(a, n),
            Table::Holding => MbRequest::ReadHoldingRegisters(a, n),
            Table::Input => MbRequest::ReadInputRegisters(a, n),
        };
        let response = self.call(ctx, call, &what).await?;
        let n = usize::from(n);
        // The library checks function codes, not lengths: a short answer is refused here
        // rather than read past.
        let bad = |got: usize| format!("{what}: the device answered {got} values for {n}");
        let values = match (req.table, response) {
            (Table::Coil, Response::ReadCoils(bits))
            | (Table::DiscreteInput, Response::ReadDiscreteInputs(bits)) => {
                // Bits come in whole bytes: up to 7 padding bits follow.
                if bits.len() < n || bits.len() >= n + 8 {
                    return Err(bad(bits.len()));
                }
                req.rows
                    .iter()
                    .map(|&(_, off)| Raw::Bit(bits[usize::from(off)]))
                    .collect()
            }
            (Table::Holding, Response::ReadHoldingRegisters(words))
            | (Table::Input, Response::ReadInputRegisters(words)) => {
                if words.len() != n {
                    return Err(bad(words.len()));
                }
                req.rows
                    .iter()
                    .map(|&(row, off)| {
                        let off = usize::from(off);
                        let width = self.read_widths.get(row).copied().unwrap_or(1);
                        let second = if width == 2 { words[off + 1] } else { 0 };
                        Raw::Words([words[off], second])
                    })
                    .collect()
            }
            (_, other) => return Err(format!("{what}: unexpected answer {other:?}")),
        };
        Ok(values)
    }

    /// One write request with the values of its rows.
    async fn write(&self, ctx: &mut Context, req: &Request, outs: &[Raw]) -> Result<(), String> {
        let what = describe("writing", req);
        let a = req.address;
        let n = usize::from(req.count);
        let (call, expect) = if req.table == Table::Coil {
            let mut bits = vec![false; n];
            for &(row, off) in &req.rows {
                if let Some(Raw::Bit(b)) = outs.get(row) {
                    bits[usize::from(off)] = *b;
                }
            }
            if n == 1 {
                (
                    MbRequest::WriteSingleCoil(a, bits[0]),
                    Response::WriteSingleCoil(a, bits[0]),
                )
            } else {
                (
                    MbRequest::WriteMultipleCoils(a, bits.into()),
                    Response::WriteMultipleCoils(a, req.count),
                )
            }
        } else {
            let mut words = vec![0u16; n];
            for &(row, off) in &req.rows {
                if let Some(Raw::Words(w)) = outs.get(row) {
                    let off = usize::from(off);
                    words[off] = w[0];
                    if self.write_widths.get(row) == Some(&2) {
                        words[off + 1] = w[1];
                    }
                }
            }
            if n == 1 {
                (
                    MbRequest::WriteSingleRegister(a, words[0]),
                    Response::WriteSingleRegister(a, words[0]),
                )
            } else {
                (
                    MbRequest::WriteMultipleRegisters(a, words.into()),
                    Response::WriteMultipleRegisters(a, req.count),
                )
            }
        };
        let response = self.call(ctx, call, &what).await?;
        if response != expect {
            return Err(format!(
                "{what}: the device confirmed {response:?} instead of {expect:?}"
            ));
        }
        Ok(())
    }

    async fn call(
        &self,
        ctx: &mut Context,
        req: MbRequest<'_>,
        what: &str,
    ) -> Result<Response, String> {
        if let Some(gap) = self.line.frame_gap() {
            sleep(gap).await;
        }
        match timeout(self.timeout, ctx.call(req)).await {
            Err(_) => Err(format!("{what}: no answer within {:?}", self.timeout)),
            Ok(Err(e)) => Err(format!("{what}: {e}")),
            Ok(Ok(Err(code))) => Err(format!("{what}: {}", exception(code))),
            Ok(Ok(Ok(response))) => Ok(response),
        }
    }
}

fn describe(verb: &str, req: &Request) -> String {
    let last = u32::from(req.address) + u32::from(req.count) - 1;
    if req.count == 1 {
        format!("{verb} {} {}", req.table.name(), req.address)
    } else {
        format!("{verb} {} {}..={last}", req.table.name(), req.address)
    }
}

fn exception(code: ExceptionCode) -> String {
    format!("exception {} ({code})", u8::from(code))
}
