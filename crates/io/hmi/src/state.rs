//! What the module's scans and the web server share: the points and nets (fixed at start-up),
//! the latest values, module status and net markings (written by the scan, read as JSON by
//! the pages), and the force requests the pages queue for the next scan.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use petriplc_config::{PointKind, PointValue};
use petriplc_runtime::image::Handle;
use petriplc_runtime::status::ModuleStatus;
use serde_json::{json, Value};
use tokio::sync::oneshot;

/// A point as the page lists it.
pub(crate) struct PointInfo {
    pub name: String,
    pub description: String,
    pub owner: String,
    pub kind: PointKind,
    pub bits: u8,
    pub handle: Handle,
}

impl PointInfo {
    /// `bool`, `u8`, `i16`, `f32`…
    pub fn type_name(&self) -> String {
        match self.kind {
            PointKind::Unsigned if self.bits == 1 => "bool".into(),
            PointKind::Unsigned => format!("u{}", self.bits),
            PointKind::Signed => format!("i{}", self.bits),
            PointKind::Float => "f32".into(),
        }
    }
}

/// A petrinet module's net, drawn once.
pub(crate) struct NetInfo {
    pub module: String,
    pub file: String,
    pub svg: String,
}

/// A force (`Some`) or release (`None`) of a point, applied by the next scan, which answers
/// on `reply`.
pub(crate) struct ForceRequest {
    pub point: usize,
    pub value: Option<PointValue>,
    pub reply: oneshot::Sender<Result<(), String>>,
}

/// What changes while the PLC runs.
pub(crate) struct Live {
    /// Bumped whenever anything below changes: pages send a snapshot only then.
    pub version: u64,
    pub now: Duration,
    /// Per point: the value, its raw bits (compared, so that a NaN is not a change every
    /// scan), and whether it is forced.
    pub values: Vec<(PointValue, u32, bool)>,
    pub modules: Vec<ModuleStatus>,
    /// The JSON of `version`, made once however many pages read it.
    cache: Option<(u64, Arc<str>)>,
}

pub(crate) struct Shared {
    pub module: String,
    pub url: String,
    pub token: String,
    pub refresh: Duration,
    pub points: Vec<PointInfo>,
    pub nets: Vec<NetInfo>,
    pub live: Mutex<Live>,
    pub requests: Mutex<Vec<ForceRequest>>,
    /// Pages with an open event stream.
    pub pages: AtomicUsize,
}

impl Shared {
    pub fn new(
        module: String,
        url: String,
        token: String,
        refresh: Duration,
        points: Vec<PointInfo>,
        nets: Vec<NetInfo>,
    ) -> Shared {
        Shared {
            module,
            url,
            token,
            refresh,
            points,
            nets,
            live: Mutex::new(Live {
                version: 0,
                now: Duration::ZERO,
                values: Vec::new(),
                modules: Vec::new(),
                cache: None,
            }),
            requests: Mutex::new(Vec::new()),
            pages: AtomicUsize::new(0),
        }
    }

    /// The live state; a panic elsewhere while it was held leaves plain data, still usable.
    pub fn live(&self) -> MutexGuard<'_, Live> {
        self.live.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub fn take_requests(&self) -> Vec<ForceRequest> {
        std::mem::take(&mut *self.requests.lock().unwrap_or_else(|e| e.into_inner()))
    }

    /// Queues a request for the next scan. A newer request for a point replaces one still
    /// waiting (its page is told so): the queue never holds more requests than points, however
    /// many arrive while the module does not scan.
    pub fn queue(&self, r: ForceRequest) {
        let mut requests = self.requests.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(i) = requests.iter().position(|q| q.point == r.point) {
            let old = requests.swap_remove(i);
            let _ = old.reply.send(Err(format!(
                "point `{}`: replaced by a newer request before a scan applied it",
                self.points[r.point].name
            )));
        }
        requests.push(r);
    }

    pub fn point(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| p.name == name)
    }

    /// The version and JSON of the current snapshot.
    pub fn snapshot(&self) -> (u64, Arc<str>) {
        let mut live = self.live();
        if let Some((v, json)) = &live.cache {
            if *v == live.version {
                return (*v, Arc::clone(json));
            }
        }
        let json: Arc<str> = self.to_json(&live).to_string().into();
        live.cache = Some((live.version, Arc::clone(&json)));
        (live.version, json)
    }

    fn to_json(&self, live: &Live) -> Value {
        let points: Vec<Value> = self
            .points
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (value, forced) = match live.values.get(i) {
                    Some((v, _, f)) => (value_json(*v), *f),
                    None => (Value::Null, false),
                };
                json!({
                    "name": p.name,
                    "description": p.description,
                    "owner": p.owner,
                    "kind": p.type_name(),
                    "value": value,
                    "forced": forced,
                })
            })
            .collect();
        let modules: Vec<Value> = live.modules.iter().map(|m| m.to_json()).collect();
        let nets: Vec<Value> = self
            .nets
            .iter()
            .map(|n| {
                let marking = live
                    .modules
                    .iter()
                    .find(|m| m.name == n.module)
                    .map(|m| m.marking.clone())
                    .unwrap_or_default();
                json!({ "module": n.module, "marking": marking })
            })
            .collect();
        json!({
            "version": live.version,
            "time_s": live.now.as_secs_f64(),
            "points": points,
            "modules": modules,
            "nets": nets,
        })
    }

    pub fn pages(&self) -> usize {
        self.pages.load(Ordering::Relaxed)
    }
}

/// A point value as a JSON number (a float that JSON cannot carry, NaN or infinite, as null).
pub(crate) fn value_json(v: PointValue) -> Value {
    match v {
        PointValue::Unsigned(u) => json!(u),
        PointValue::Signed(i) => json!(i),
        // Through the shortest text of the f32, so that 0.1 shows as 0.1, not 0.10000000149.
        PointValue::Float(f) => json!(f.to_string().parse::<f64>().unwrap_or(f64::NAN)),
    }
}

/// Counts an open event stream while it lives.
pub(crate) struct PageGuard(pub Arc<Shared>);

impl PageGuard {
    pub fn new(shared: Arc<Shared>) -> PageGuard {
        shared.pages.fetch_add(1, Ordering::Relaxed);
        PageGuard(shared)
    }
}

impl Drop for PageGuard {
    fn drop(&mut self) {
        self.0.pages.fetch_sub(1, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use petriplc_config::Location;
    use petriplc_runtime::image::{Layout, ModuleMap};

    fn shared() -> Shared {
        let cfg = petriplc_runtime::harness::config(
            "[PLC]\nmodule hmi hmi\npoint A \"\" hmi\npoint B \"\" hmi\n",
            std::path::Path::new("."),
        );
        let layout = Layout::new(&cfg).unwrap();
        let map = ModuleMap::new(&layout, "hmi", Location::Local).unwrap();
        let points = ["A", "B"]
            .iter()
            .map(|n| PointInfo {
                name: n.to_string(),
                description: String::new(),
                owner: "hmi".into(),
                kind: PointKind::Unsigned,
                bits: 1,
                handle: map.handle(n).unwrap(),
            })
            .collect();
        Shared::new(
            "hmi".into(),
            String::new(),
            String::new(),
            Duration::from_millis(100),
            points,
            Vec::new(),
        )
    }

    /// Issue 27: requests that arrive while the module does not scan cannot grow the queue
    /// without bound: a newer one for a point replaces the waiting one, which is answered.
    #[test]
    fn the_queue_holds_at_most_one_request_per_point() {
        let s = shared();
        let mut answers = Vec::new();
        for i in 0..10_000u32 {
            let (reply, answer) = oneshot::channel();
            s.queue(ForceRequest {
                point: (i % 2) as usize,
                value: Some(PointValue::Unsigned(i % 2)),
                reply,
            });
            answers.push(answer);
        }
        assert_eq!(s.requests.lock().unwrap().len(), 2);
        let replaced = answers
            .iter_mut()
            .filter_map(|a| a.try_recv().ok())
            .filter(|r| {
                r.as_ref()
                    .is_err_and(|e| e.contains("replaced by a newer request"))
            })
            .count();
        assert_eq!(replaced, 9_998);
        let left: Vec<usize> = s.take_requests().iter().map(|r| r.point).collect();
        assert_eq!(left.len(), 2);
        assert!(left.contains(&0) && left.contains(&1));
    }
}
