//! The `opcua_server` module of petriplc run: an OPC UA server (async-opcua) whose address
//! space holds every point as a typed variable in a folder per owning module, every petrinet
//! module's marking and every module's status; clients read, subscribe (down to the scan) and
//! write the points this module owns (docs/opcua.md).
//!
//! ```text
//! [opcua]
//! listen = 127.0.0.1:4840     # default; security None is allowed on loopback only
//! security = encrypt          # Basic256Sha256 / Aes256-Sha256-RsaPss, Sign & Encrypt
//! users = opcua.users         # NAME:BCRYPT_HASH lines (`petriplc user add`)
//! anonymous = read            # no (default) | read | write
//! ```
//!
//! The server runs on its own tokio runtime (started by `init`, stopped by `close`). The scan
//! only swaps values with it: client writes queued since the last scan go to the points, and
//! changed values are handed to a task that updates the address space and notifies the
//! subscriptions, so a slow client never holds a scan.

mod log_policy;
mod settings;
mod space;
mod start;
mod users;

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use opcua::crypto::{CertificateStore, X509Data};
use opcua::server::node_manager::memory::InMemoryNodeManager;
use opcua::server::ServerHandle;
use opcua::types::{
    ApplicationDescription, DataTypeId, DataValue, DateTime, LocalizedText, NodeId, Variant,
};
use petriplc_config::{ModuleDecl, PointValue};
use petriplc_modules::common::{self, error};
use petriplc_runtime::image::Handle;
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};
use petriplc_runtime::status::PlcStatus;

pub use log_policy::log_policy;
pub use settings::{Anonymous, Settings, DEFAULT_LISTEN, KIND, SETTINGS};
use space::{PlcNodes, PlcNodesBuilder};
pub use users::{
    check_name, hash_password, may_set, read_text, with_user, without_user, Edit, EditError, Users,
    BCRYPT_PREFIXES, MAX_PASSWORD_BYTES,
};

/// The module kinds of this crate.
pub const KINDS: &[&str] = &[KIND];

/// The scan period when the section sets none; also the smallest sampling and publishing
/// interval the server grants.
pub const DEFAULT_SCAN_PERIOD: Duration = Duration::from_millis(10);
/// The stack's id for the users of the password file.
const USERS_TOKEN: &str = "users";
/// How often the PLC's status file (module states, markings) is read again.
const STATUS_EVERY: Duration = Duration::from_millis(100);

/// The factory of a module kind of this crate (see [`KINDS`]).
pub fn builtin(kind: &str) -> Option<Factory> {
    (kind == KIND).then_some(factory as Factory)
}

fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(OpcuaServer::new(decl)?))
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

/// What the scan and the server share.
pub(crate) struct Shared {
    /// The smallest sampling interval, ms (the scan period).
    scan_ms: f64,
    /// The current value of every variable of the layout, in its order, and what changed.
    values: Mutex<Values>,
    wake: tokio::sync::Notify,
    /// Client writes the next scan applies.
    writes: Mutex<Writes>,
    /// The address space exists.
    ready: AtomicBool,
    /// Client writes accepted.
    written: AtomicU64,
}

/// The variables' values as the scans left them.
pub(crate) struct Values {
    pub now: Vec<Variant>,
    /// When each last changed (the scan that saw it: the source timestamp).
    pub at: Vec<DateTime>,
    /// Changed since the server last took them.
    pub dirty: Vec<usize>,
}

/// Client writes since the last scan: the last value per point (a scan applies them in one
/// go, so an earlier one would be overwritten anyway), which bounds what a client writing
/// faster than the PLC scans can queue to one value per point.
pub(crate) struct Writes {
    /// Per point index.
    value: Vec<Option<PointValue>>,
    /// The points written, each once.
    order: Vec<usize>,
}

impl Writes {
    fn new(points: usize) -> Writes {
        Writes {
            value: vec![None; points],
            order: Vec::new(),
        }
    }

    pub(crate) fn push(&mut self, point: usize, v: PointValue) {
        if self.value[point].replace(v).is_none() {
            self.order.push(point);
        }
    }

    /// Whether a write to `point` waits for the next scan.
    pub(crate) fn pending(&self, point: usize) -> bool {
        self.value[point].is_some()
    }

    fn take(&mut self) -> Vec<(usize, PointValue)> {
        let order = std::mem::take(&mut self.order);
        order
            .into_iter()
            .filter_map(|p| self.value[p].take().map(|v| (p, v)))
            .collect()
    }
}

/// A point of the PLC as the server shows it.
struct Point {
    handle: Handle,
    ty: DataTypeId,
}

/// The module.
pub struct OpcuaServer {
    name: String,
    settings: Settings,
    scan_period: Duration,
    run: Option<Run>,
    /// The status line when the module closed (for the PLC's final report).
    closed: String,
}

struct Run {
    shared: Arc<Shared>,
    points: Vec<Point>,
    last: Vec<Option<PointValue>>,
    /// Per module: the variable indices of State, Scans, Overruns.
    status_vars: HashMap<String, [usize; 3]>,
    /// (module, place label) → variable index.
    marking_vars: HashMap<(String, String), usize>,
    plc_id: String,
    status_at: Option<Duration>,
    handle: ServerHandle,
    thread: Option<JoinHandle<()>>,
    endpoint: String,
}

impl OpcuaServer {
    /// Checks the settings; `init` reads the points and starts the server.
    pub fn new(decl: &ModuleDecl) -> Result<OpcuaServer, ModuleError> {
        let settings = Settings::parse(decl)?;
        let scan_period = match common::setting(decl, "scan_period") {
            Some(v) => petriplc_net::time::parse_duration(v).unwrap_or(DEFAULT_SCAN_PERIOD),
            None => DEFAULT_SCAN_PERIOD,
        };
        Ok(OpcuaServer {
            name: decl.name.clone(),
            settings,
            scan_period: scan_period.max(Duration::from_millis(1)),
            run: None,
            closed: String::new(),
        })
    }

    /// The endpoint URL once `init` has bound the address (the port chosen for port 0).
    pub fn endpoint(&self) -> Option<&str> {
        self.run.as_ref().map(|r| r.endpoint.as_str())
    }
}

/// Every place label of every petrinet module's net, read the way that module reads it.
fn markings(ctx: &InitContext<'_>, me: &str) -> Result<Vec<(String, Vec<String>)>, ModuleError> {
    let nets = petriplc_modules::petrinet_nets(ctx.config, ctx.base_dir).map_err(|e| {
        error(
            me,
            format!(
                "cannot read the net of module {} (`net = {}`): {}",
                e.module,
                e.file,
                common::chain(&e.source)
            ),
        )
    })?;
    Ok(nets
        .into_iter()
        .map(|n| {
            let net = n.doc.net;
            let labels = net
                .place_ids()
                .map(|p| net.place_label(p).to_string())
                .collect();
            (n.module, labels)
        })
        .collect())
}

/// The folder of the server's certificate, key and trust lists.
fn state_dir(settings: &Settings, ctx: &InitContext<'_>, name: &str) -> PathBuf {
    if let Some(d) = &settings.state_dir {
        return ctx.base_dir.join(d);
    }
    let base = std::env::var_os("XDG_STATE_HOME")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".local/state")))
        .unwrap_or_else(|| PathBuf::from("."));
    base.join("petriplc").join(ctx.plc_id).join(name)
}

fn hostname() -> String {
    std::fs::read_to_string("/proc/sys/kernel/hostname")
        .map(|h| h.trim().to_string())
        .ok()
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "localhost".to_string())
}

/// The server's certificate and key in `pki`: created on first start, read afterwards; the
/// SHA-1 thumbprint is logged so that clients can check what they are shown.
fn certificate(pki: &Path, uri: &str, app: &str, listen: &SocketAddr) -> Result<(), String> {
    let cert = pki.join("own/cert.der");
    let key = pki.join("private/private.pem");
    let (x509, made) = if cert.exists() && key.exists() {
        // The stack reads them whole, each time a client connects: a device or a FIFO
        // there would never end.
        for f in [&cert, &key] {
            petriplc_files::check(f, petriplc_files::SMALL).map_err(|e| e.to_string())?;
        }
        (CertificateStore::read_cert(&cert)?, false)
    } else {
        let mut addresses = vec![hostname(), "localhost".to_string()];
        if !listen.ip().is_unspecified() {
            addresses.push(listen.ip().to_string());
        }
        let desc = ApplicationDescription {
            application_uri: uri.into(),
            application_name: LocalizedText::new("", app),
            ..Default::default()
        };
        let mut data = X509Data::from((desc, Some(addresses)));
        data.certificate_duration_days = 3650;
        data.key_size = 2048;
        let (x509, _) = CertificateStore::create_certificate_and_key(&data, false, &cert, &key)?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(&key, std::fs::Permissions::from_mode(0o600))
                .map_err(|e| format!("cannot protect {}: {e}", key.display()))?;
        }
        (x509, true)
    };
    log::info!(
        "{app}: {} server certificate {} (SHA-1 thumbprint {})",
        if made { "created the" } else { "using the" },
        cert.display(),
        x509.thumbprint().as_hex_string()
    );
    Ok(())
}

impl Module for OpcuaServer {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        let name = self.name.clone();
        common::rows(ctx, KIND, &[])?;
        let users = start::users(ctx, &self.settings, &name)?;

        // The address space: a folder per module, its points, its status and marking.
        let mut space = start::Space::default();
        let points = space.points(ctx, &name)?;
        let nets = markings(ctx, &name)?;
        let (status_vars, marking_vars) = space.modules(ctx, &nets);

        // Bind first, so that a taken port stops the PLC's start with a message.
        let (listener, local) = start::bind(self.settings.listen, &name)?;
        let id = start::Identity::new(&self.settings, ctx, &name, &local)?;
        let shared = space.shared(self.scan_period, points.len());
        let layout = Arc::new(space.layout);
        let ns_uri = format!("urn:petriplc:{}", ctx.plc_id);
        let nodes = PlcNodesBuilder {
            uri: ns_uri.clone(),
            layout: Arc::clone(&layout),
            shared: Arc::clone(&shared),
        };
        let builder = start::builder(&self.settings, self.scan_period, &id, users, nodes, &name);
        let (handle, thread) = start::serve(builder, listener, &layout, &shared, &ns_uri, &name)?;
        start::log_listening(&self.settings, &name, &id.endpoint, points.len());
        self.run = Some(Run {
            shared,
            last: vec![None; points.len()],
            points,
            status_vars,
            marking_vars,
            plc_id: ctx.plc_id.to_string(),
            status_at: None,
            handle,
            thread: Some(thread),
            endpoint: id.endpoint,
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            return Err(error(&self.name, "scanned before init"));
        };
        let writes = lock(&run.shared.writes).take();
        for (p, v) in writes {
            // Checked against the point when it arrived; an error here would be a bug, not
            // the client's fault, and must not stop the PLC.
            if let Err(e) = ctx.map.set(&run.points[p].handle, v) {
                log::warn!("opcua_server {}: client write not applied: {e}", self.name);
            }
        }
        let mut changed: Vec<(usize, Variant)> = Vec::new();
        for (i, p) in run.points.iter().enumerate() {
            let v = ctx.map.get(&p.handle);
            let same = match (run.last[i], v) {
                (Some(PointValue::Float(a)), PointValue::Float(b)) => a.to_bits() == b.to_bits(),
                (Some(a), b) => a == b,
                (None, _) => false,
            };
            if !same {
                run.last[i] = Some(v);
                changed.push((i, space::variant(v, p.ty)));
            }
        }
        let status_due = run
            .status_at
            .is_none_or(|at| ctx.now.saturating_sub(at) >= STATUS_EVERY);
        if status_due {
            run.status_at = Some(ctx.now);
            if let Some(status) = PlcStatus::read(&run.plc_id) {
                for m in &status.modules {
                    if let Some(idx) = run.status_vars.get(&m.name) {
                        changed.push((idx[0], Variant::from(m.state.as_str())));
                        changed.push((idx[1], Variant::UInt64(m.scans)));
                        changed.push((idx[2], Variant::UInt64(m.overruns)));
                    }
                    for (place, tokens) in &m.marking {
                        if let Some(&i) = run.marking_vars.get(&(m.name.clone(), place.clone())) {
                            changed.push((i, Variant::UInt64(*tokens)));
                        }
                    }
                }
            }
        }
        if changed.is_empty() {
            return Ok(Control::Continue);
        }
        let mut any = false;
        let now = DateTime::now();
        {
            let mut values = lock(&run.shared.values);
            for (i, v) in changed {
                if values.now[i] != v {
                    values.now[i] = v;
                    values.at[i] = now;
                    if !values.dirty.contains(&i) {
                        values.dirty.push(i);
                    }
                    any = true;
                }
            }
        }
        if any {
            run.shared.wake.notify_one();
        }
        Ok(Control::Continue)
    }

    fn close(&mut self) {
        if self.run.is_some() {
            self.closed = self.status();
        }
        if let Some(mut run) = self.run.take() {
            run.handle.cancel();
            if let Some(t) = run.thread.take() {
                if t.join().is_err() {
                    log::error!("opcua_server {}: the server thread panicked", self.name);
                }
            }
        }
    }

    fn status(&self) -> String {
        match &self.run {
            Some(run) => format!(
                "{} — {} client writes",
                run.endpoint,
                run.shared.written.load(Ordering::Relaxed)
            ),
            None => self.closed.clone(),
        }
    }

    fn default_scan_period(&self) -> Option<Duration> {
        Some(DEFAULT_SCAN_PERIOD)
    }
}

impl Drop for OpcuaServer {
    fn drop(&mut self) {
        self.close();
    }
}

/// Moves changed values into the address space and notifies the monitored items.
/// `points_of`: per variable, the index of the point clients may write through it.
async fn update(
    handle: ServerHandle,
    manager: Arc<InMemoryNodeManager<PlcNodes>>,
    shared: Arc<Shared>,
    ids: Vec<NodeId>,
    points_of: Vec<Option<usize>>,
) {
    let mut batch: Vec<(usize, Variant, DateTime)> = Vec::new();
    loop {
        shared.wake.notified().await;
        if !shared.ready.load(Ordering::Acquire) {
            // The address space is built from the current values when it is made.
            continue;
        }
        {
            let mut guard = lock(&shared.values);
            let values = &mut *guard;
            batch.extend(
                values
                    .dirty
                    .drain(..)
                    .map(|i| (i, values.now[i].clone(), values.at[i])),
            );
        }
        let now = DateTime::now();
        // `set_values` runs this iterator under the address space's lock, which a client's
        // write holds while it shows its value and queues it: a value the scan took before
        // that write must not replace it (the read-back would go back to the older value
        // until the next scan applies the write).
        let result = manager.set_values(
            handle.subscriptions(),
            batch
                .drain(..)
                .filter(|(i, _, _)| points_of[*i].is_none_or(|p| !lock(&shared.writes).pending(p)))
                .map(|(i, v, at)| {
                    (
                        &ids[i],
                        None,
                        DataValue {
                            value: Some(v),
                            status: Some(opcua::types::StatusCode::Good),
                            source_timestamp: Some(at),
                            server_timestamp: Some(now),
                            ..Default::default()
                        },
                    )
                }),
        );
        if let Err(e) = result {
            log::warn!("opcua_server: cannot update the address space: {e}");
        }
    }
}
