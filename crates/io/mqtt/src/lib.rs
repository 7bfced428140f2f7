//! The `mqtt` module of petriplc run: publishes points to an MQTT broker (retained, QoS 1,
//! topic `PREFIX/POINT`) and takes points it owns from subscribed topics, so that a point of
//! one PLC becomes an input of another through the broker (docs/mqtt.md).
//!
//! ```text
//! [mqtt]
//! broker = 127.0.0.1:1883          # or mqtts://HOST:8883
//! topic_prefix = cell-a            # default: the PLC id
//! payload = plain                  # or json
//! stale = link_down                # a bool point of this module: true while the broker is away
//! max_payload = 64 KiB             # larger messages are dropped and counted (relay.rs)
//! publish V1 V2 V3
//! subscribe cell-b/N1 N1           # N1 owned by this module; `hold` (default) or a safe value
//! subscribe cell-b/N2 N2 0
//! # sparkplug = plant/cell-a      # publish as a Sparkplug B edge node instead (sparkplug.rs)
//! ```
//!
//! The network runs on a tokio runtime in a thread of its own (started by `init`, stopped by
//! `close`); the scan only swaps values with it under short locks, so a slow or absent broker
//! never holds a scan. What a peer publishes reaches a point only as a finite value within
//! the point's type (`payload.rs`); everything else is refused, counted and logged once per
//! topic and burst (`refusals.rs`).

mod link;
pub mod payload;
mod refusals;
mod relay;
pub mod settings;
pub mod sparkplug;
#[doc(hidden)]
pub mod testing;

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicU8, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use petriplc_config::{ModuleDecl, PointValue};
use petriplc_modules::common::error;
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};

use crate::payload::Format;
use crate::settings::{Fallback, Plan, Settings, KIND};

/// The module kinds of this crate.
pub const KINDS: &[&str] = &[KIND];

/// The scan period when the section sets none: changes reach the broker, and received
/// values the points, within this time.
pub const DEFAULT_SCAN_PERIOD: Duration = Duration::from_millis(10);

/// The factory of a module kind of this crate (see [`KINDS`]).
pub fn builtin(kind: &str) -> Option<Factory> {
    (kind == KIND).then_some(factory as Factory)
}

fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Mqtt::new(decl)?))
}

/// The latest value of a published point (with the wall-clock time of the scan that saw it,
/// in ms) and whether the broker has it yet.
#[derive(Default)]
struct Slot {
    value: Option<(PointValue, u64)>,
    dirty: bool,
}

/// What the network side of a Sparkplug B edge node keeps.
pub(crate) struct Spb {
    node: sparkplug::Node,
    metrics: Vec<sparkplug::MetricDef>,
    /// The bdSeq of the current (or next) connection's will and NBIRTH, 0–255.
    bd_seq: AtomicU8,
    /// A host asked for a rebirth (NCMD `Node Control/Rebirth`).
    rebirth: AtomicBool,
}

/// What the scan and the network share.
pub(crate) struct Shared {
    name: String,
    broker: String,
    /// One slot per published point: values are coalesced, never queued without bound.
    outbox: Mutex<Vec<Slot>>,
    wake: tokio::sync::Notify,
    /// One per subscribed row: the latest value received since the last scan.
    inbox: Mutex<Vec<Option<PointValue>>>,
    /// Connected and subscribed.
    up: AtomicBool,
    outages: AtomicU64,
    published: AtomicU64,
    /// Changes overwritten by a newer value before the network sent them (the broker, or
    /// the link to it, slower than the changes).
    coalesced: AtomicU64,
    received: AtomicU64,
    /// Messages refused (not a finite number, out of a point's range, larger than
    /// `max_payload`, a malformed command).
    rejected: AtomicU64,
    /// Which refusals are logged.
    refusals: Mutex<refusals::Refusals>,
    last_error: Mutex<String>,
    format: Format,
    /// Set when the module publishes as a Sparkplug B edge node.
    spb: Option<Spb>,
}

impl Shared {
    /// Counts a refused message; logs it (`what`: what was refused and why) if it is the
    /// first on its topic since a good message, at most one line per topic every 10 s
    /// (`refusals.rs`): a peer publishing garbage at 1 kHz logs one line, not a thousand.
    pub(crate) fn refuse(&self, topic: &str, what: impl FnOnce() -> String) {
        let logged = lock(&self.refusals).refused(topic, Instant::now());
        if let Some(unlogged) = logged {
            let more = match unlogged {
                0 => String::new(),
                n => format!(", as were {n} more since the last line about it"),
            };
            log::warn!(
                "mqtt {}: topic {topic}: {}; refused{more} (further refusals on this topic are \
                 only counted until a good message arrives)",
                self.name,
                what()
            );
        }
        // Counted once logged: a status that shows the refusal finds its line in the log.
        self.rejected.fetch_add(1, Ordering::Relaxed);
    }

    /// A good message on `topic`: its next refusal is logged again.
    pub(crate) fn accepted(&self, topic: &str) {
        lock(&self.refusals).accepted(topic);
    }

    #[cfg(test)]
    pub(crate) fn for_tests() -> Shared {
        Shared::new(
            "test".into(),
            "127.0.0.1:1".into(),
            0,
            0,
            Format::Plain,
            None,
        )
    }

    fn new(
        name: String,
        broker: String,
        published: usize,
        subscribed: usize,
        format: Format,
        spb: Option<Spb>,
    ) -> Shared {
        Shared {
            name,
            broker,
            outbox: Mutex::new((0..published).map(|_| Slot::default()).collect()),
            wake: tokio::sync::Notify::new(),
            inbox: Mutex::new(vec![None; subscribed]),
            up: AtomicBool::new(false),
            outages: AtomicU64::new(0),
            published: AtomicU64::new(0),
            coalesced: AtomicU64::new(0),
            received: AtomicU64::new(0),
            rejected: AtomicU64::new(0),
            refusals: Mutex::new(refusals::Refusals::default()),
            last_error: Mutex::new(String::new()),
            format,
            spb,
        }
    }
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The `mqtt` module.
pub struct Mqtt {
    name: String,
    settings: Settings,
    run: Option<Run>,
    /// The status line when the module closed (for the PLC's final report).
    closed: String,
}

struct Run {
    shared: Arc<Shared>,
    plan: Plan,
    link: link::Link,
    /// The value of each published point last handed to the network.
    last: Vec<Option<PointValue>>,
    /// Whether the link was up at the last scan (`None`: no scan yet).
    was_up: Option<bool>,
}

impl Mqtt {
    /// Checks the settings; `init` checks the rows and starts the network.
    pub fn new(decl: &ModuleDecl) -> Result<Mqtt, ModuleError> {
        Ok(Mqtt {
            name: decl.name.clone(),
            settings: Settings::parse(decl)?,
            run: None,
            closed: String::new(),
        })
    }
}

/// Whether two values are the same bits (a NaN float equals itself here, so it is published
/// once, not every scan).
fn same(a: PointValue, b: PointValue) -> bool {
    match (a, b) {
        (PointValue::Float(x), PointValue::Float(y)) => x.to_bits() == y.to_bits(),
        (a, b) => a == b,
    }
}

fn now_ms() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

impl Module for Mqtt {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let name = self.name.clone();
        let prefix = self
            .settings
            .topic_prefix
            .clone()
            .unwrap_or_else(|| ctx.plc_id.to_string());
        let spb_node = self.settings.sparkplug.clone();
        // A Sparkplug B node publishes under spBv1.0/GROUP/…: the prefix is not used.
        let checked = if spb_node.is_some() {
            Ok(())
        } else {
            settings::check_topic(&prefix)
        };
        if let Err(why) = checked {
            return Err(error(
                &name,
                format!(
                    "the PLC id `{prefix}` cannot be a topic prefix ({why}); set \
                     `topic_prefix = NAME` in [{name}]"
                ),
            ));
        }
        let plan = settings::plan(ctx, &self.settings, &prefix)?;
        let spb = spb_node.map(|node| Spb {
            node,
            metrics: plan
                .publish
                .iter()
                .enumerate()
                .map(|(i, p)| sparkplug::MetricDef {
                    name: p.point.clone(),
                    alias: i as u64 + 1,
                    datatype: sparkplug::datatype_of(p.handle.kind(), p.handle.bits()),
                })
                .collect(),
            bd_seq: AtomicU8::new(0),
            rebirth: AtomicBool::new(false),
        });
        let shared = Arc::new(Shared::new(
            name.clone(),
            self.settings.broker.to_string(),
            plan.publish.len(),
            plan.subscribe.len(),
            self.settings.format,
            spb,
        ));
        let client_id = self
            .settings
            .client_id
            .clone()
            .unwrap_or_else(|| format!("petriplc-{}-{name}", ctx.plc_id));
        let link = link::Link::start(
            &self.settings,
            ctx.base_dir,
            &client_id,
            &plan,
            Arc::clone(&shared),
        )?;
        let under = match &shared.spb {
            Some(spb) => format!("as Sparkplug B edge node {}", spb.node.topic("NDATA")),
            None => format!("under {prefix}/"),
        };
        log::info!(
            "mqtt {name}: broker {}, {} published {under}, {} subscribed",
            self.settings.broker,
            plan.publish.len(),
            plan.subscribe.len()
        );
        self.run = Some(Run {
            last: vec![None; plan.publish.len()],
            shared,
            plan,
            link,
            was_up: None,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        let shared = &run.shared;
        // Values received since the last scan (checked against their points on arrival).
        let received: Vec<(usize, PointValue)> = {
            let mut inbox = lock(&shared.inbox);
            inbox
                .iter_mut()
                .enumerate()
                .filter_map(|(i, v)| v.take().map(|v| (i, v)))
                .collect()
        };
        let up = shared.up.load(Ordering::Acquire);
        for (i, v) in received {
            let s = &run.plan.subscribe[i];
            if let Err(e) = ctx.map.set(&s.handle, v) {
                log::warn!("mqtt {}: {}: {e}", self.name, s.topic);
            }
        }
        if run.was_up != Some(up) {
            if let Some(h) = &run.plan.stale {
                let _ = ctx.map.set_bool(h, !up);
            }
            run.was_up = Some(up);
        }
        if !up {
            // While the broker is away, points with a safe value hold it (every scan, so a
            // value that arrived just before the link went down cannot linger).
            for s in &run.plan.subscribe {
                if let Fallback::Safe(v) = s.fallback {
                    let _ = ctx.map.set(&s.handle, v);
                }
            }
        }
        let mut changed = false;
        let mut ts = None;
        let mut outbox = None;
        for (i, p) in run.plan.publish.iter().enumerate() {
            let v = ctx.map.get(&p.handle);
            if run.last[i].is_some_and(|last| same(last, v)) {
                continue;
            }
            run.last[i] = Some(v);
            let ts = *ts.get_or_insert_with(now_ms);
            let outbox = outbox.get_or_insert_with(|| lock(&shared.outbox));
            if outbox[i].dirty && shared.up.load(Ordering::Relaxed) {
                shared.coalesced.fetch_add(1, Ordering::Relaxed);
            }
            outbox[i] = Slot {
                value: Some((v, ts)),
                dirty: true,
            };
            changed = true;
        }
        drop(outbox);
        if changed {
            shared.wake.notify_one();
        }
        Ok(Control::Continue)
    }

    fn close(&mut self) {
        if self.run.is_some() {
            self.closed = self.status();
        }
        if let Some(mut run) = self.run.take() {
            run.link.stop();
        }
    }

    fn status(&self) -> String {
        let Some(run) = &self.run else {
            return self.closed.clone();
        };
        let s = &run.shared;
        let state = if s.up.load(Ordering::Relaxed) {
            "up".to_string()
        } else {
            let why = lock(&s.last_error).clone();
            if why.is_empty() {
                "connecting".to_string()
            } else {
                format!("stale: {why}")
            }
        };
        let coalesced = match s.coalesced.load(Ordering::Relaxed) {
            0 => String::new(),
            n => format!(", {n} coalesced"),
        };
        format!(
            "broker {} {state}; {} published, {} received, {} rejected, {} outages{coalesced}",
            s.broker,
            s.published.load(Ordering::Relaxed),
            s.received.load(Ordering::Relaxed),
            s.rejected.load(Ordering::Relaxed),
            s.outages.load(Ordering::Relaxed)
        )
    }

    fn default_scan_period(&self) -> Option<Duration> {
        Some(DEFAULT_SCAN_PERIOD)
    }
}

impl Drop for Mqtt {
    fn drop(&mut self) {
        self.close();
    }
}
