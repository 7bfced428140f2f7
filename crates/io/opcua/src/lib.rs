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
mod users;

use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use opcua::crypto::{CertificateStore, SecurityPolicy, X509Data};
use opcua::server::node_manager::memory::{InMemoryNodeManager, InMemoryNodeManagerBuilder};
use opcua::server::{ServerBuilder, ServerHandle, ServerUserToken, ANONYMOUS_USER_TOKEN_ID};
use opcua::types::{
    ApplicationDescription, DataTypeId, DataValue, DateTime, LocalizedText, MessageSecurityMode,
    NodeId, Variant,
};
use petriplc_config::{ModuleDecl, PointValue};
use petriplc_modules::common::{self, error};
use petriplc_runtime::image::Handle;
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};
use petriplc_runtime::status::PlcStatus;

pub use log_policy::log_policy;
pub use settings::{Anonymous, Settings, DEFAULT_LISTEN, KIND, SETTINGS};
use space::{Folder, Layout, PlcNodes, PlcNodesBuilder, Var};
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
        let users = match &self.settings.users {
            None => Users::default(),
            Some(p) => {
                Users::read(&ctx.base_dir.join(p), &p.display().to_string()).map_err(|why| {
                    let at = ctx
                        .decl
                        .settings
                        .get("users")
                        .map(|s| format!("{}: ", s.origin))
                        .unwrap_or_default();
                    error(&name, format!("{at}{why}"))
                })?
            }
        };

        // The address space: a folder per module, its points, its status and marking.
        let mut layout = Layout::default();
        let mut points = Vec::new();
        let mut values = Vec::new();
        for p in &ctx.config.points {
            let handle = ctx
                .map
                .handle(&p.name)
                .map_err(|e| error(&name, format!("point {}: {e}", p.name)))?;
            let ty = space::data_type(p.kind, p.bits);
            let owned = ctx.map.owns(&handle);
            values.push(space::variant(ctx.map.get(&handle), ty));
            layout.vars.push(Var {
                id: p.name.clone(),
                name: p.name.clone(),
                description: p.description.clone(),
                parent: format!("module:{}", p.owner),
                data_type: ty,
                writable: owned.then_some(points.len()),
                kind: Some((p.kind, p.bits)),
                owner: Some(p.owner.clone()),
            });
            points.push(Point { handle, ty });
        }
        let nets = markings(ctx, &name)?;
        let mut status_vars = HashMap::new();
        let mut marking_vars = HashMap::new();
        for m in &ctx.config.modules {
            let folder = format!("module:{}", m.name);
            let status = format!("{folder}.Status");
            let mut children = vec![(status.clone(), "Status".to_string())];
            let mut idx = [0; 3];
            for (k, (var, ty, init)) in [
                ("State", DataTypeId::String, Variant::from("starting")),
                ("Scans", DataTypeId::UInt64, Variant::UInt64(0)),
                ("Overruns", DataTypeId::UInt64, Variant::UInt64(0)),
            ]
            .into_iter()
            .enumerate()
            {
                idx[k] = layout.vars.len();
                layout.vars.push(Var {
                    id: format!("{status}.{var}"),
                    name: var.to_string(),
                    description: format!("module {}: {}", m.name, var.to_lowercase()),
                    parent: status.clone(),
                    data_type: ty,
                    writable: None,
                    kind: None,
                    owner: None,
                });
                values.push(init);
            }
            status_vars.insert(m.name.clone(), idx);
            if let Some((_, places)) = nets.iter().find(|(n, _)| n == &m.name) {
                let marking = format!("{folder}.Marking");
                children.push((marking.clone(), "Marking".to_string()));
                for place in places {
                    marking_vars.insert((m.name.clone(), place.clone()), layout.vars.len());
                    layout.vars.push(Var {
                        id: format!("{marking}.{place}"),
                        name: place.clone(),
                        description: format!("tokens in place {place} of module {}", m.name),
                        parent: marking.clone(),
                        data_type: DataTypeId::UInt64,
                        writable: None,
                        kind: None,
                        owner: None,
                    });
                    values.push(Variant::UInt64(0));
                }
            }
            layout.folders.push(Folder {
                id: folder,
                name: m.name.clone(),
                description: format!("module {} ({})", m.name, m.kind),
                children,
            });
        }

        // Bind first, so that a taken port stops the PLC's start with a message.
        let listen = self.settings.listen;
        let listener = std::net::TcpListener::bind(listen)
            .and_then(|l| l.set_nonblocking(true).map(|()| l))
            .map_err(|e| {
                error(
                    &name,
                    format!(
                        "cannot listen on {listen}: {}; choose another `listen` address or \
                         port (e.g. --set {name}:listen=127.0.0.1:4841)",
                        common::chain(&e)
                    ),
                )
            })?;
        let local = listener
            .local_addr()
            .map_err(|e| error(&name, format!("cannot read the bound address: {e}")))?;
        let host = match local.ip() {
            ip if ip.is_unspecified() => hostname(),
            IpAddr::V6(ip) => format!("[{ip}]"),
            ip => ip.to_string(),
        };
        let endpoint = format!("opc.tcp://{host}:{}/", local.port());
        let app = format!("opcua_server {name}");
        let uri = format!("urn:petriplc:{}:{name}", ctx.plc_id);
        let state = state_dir(&self.settings, ctx, &name);
        let pki = state.join("pki");
        if self.settings.security.encrypt {
            std::fs::create_dir_all(&pki).map_err(|e| {
                error(
                    &name,
                    format!(
                        "cannot create the state directory {}: {e}; set `state_dir = PATH` in \
                         [{name}]",
                        pki.display()
                    ),
                )
            })?;
            certificate(&pki, &uri, &app, &local).map_err(|e| {
                error(
                    &name,
                    format!(
                        "server certificate in {}: {e}; remove own/ and private/ there to \
                         make a new one",
                        pki.display()
                    ),
                )
            })?;
        }

        let shared = Arc::new(Shared {
            scan_ms: self.scan_period.as_secs_f64() * 1000.0,
            values: Mutex::new(Values {
                at: vec![DateTime::now(); values.len()],
                now: values,
                dirty: Vec::new(),
            }),
            wake: tokio::sync::Notify::new(),
            writes: Mutex::new(Writes::new(points.len())),
            ready: AtomicBool::new(false),
            written: AtomicU64::new(0),
        });
        let layout = Arc::new(layout);
        let ns_uri = format!("urn:petriplc:{}", ctx.plc_id);
        let scan_ms = (self.scan_period.as_millis() as u64).max(1);
        // What the stack logs per endpoint; the sessions themselves are checked by `Auth`.
        let mut tokens: Vec<&str> = Vec::new();
        if self.settings.anonymous != Anonymous::No {
            tokens.push(ANONYMOUS_USER_TOKEN_ID);
        }
        let has_users = !users.is_empty();
        if has_users {
            tokens.push(USERS_TOKEN);
        }
        let mut builder = ServerBuilder::new()
            .application_name(app.clone())
            .application_uri(uri.clone())
            .product_uri("urn:petriplc")
            .host(host.clone())
            .port(local.port())
            .pki_dir(&pki)
            .certificate_path("own/cert.der")
            .private_key_path("private/private.pem")
            .create_sample_keypair(false)
            .trust_client_certs(self.settings.trust_client_certs)
            .max_sessions(self.settings.max_sessions)
            .subscription_poll_interval_ms(scan_ms)
            .discovery_urls(vec![endpoint.clone()])
            .diagnostics_enabled(false)
            .add_user_token(
                USERS_TOKEN,
                ServerUserToken {
                    user: "users of the password file".to_string(),
                    // Never compared: `Auth` checks passwords against the bcrypt hashes.
                    pass: Some(format!("{:x}", std::process::id())),
                    ..Default::default()
                },
            )
            .with_authenticator(Arc::new(space::Auth {
                anonymous: self.settings.anonymous,
                users: Arc::new(users),
                module: name.clone(),
            }))
            .with_node_manager(InMemoryNodeManagerBuilder::new(PlcNodesBuilder {
                uri: ns_uri.clone(),
                layout: Arc::clone(&layout),
                shared: Arc::clone(&shared),
            }));
        if self.settings.security.none {
            builder = builder.add_endpoint(
                "none",
                (
                    "/",
                    SecurityPolicy::None,
                    MessageSecurityMode::None,
                    &tokens as &[&str],
                ),
            );
        }
        if self.settings.security.encrypt {
            builder = builder
                .add_endpoint(
                    "basic256sha256",
                    (
                        "/",
                        SecurityPolicy::Basic256Sha256,
                        MessageSecurityMode::SignAndEncrypt,
                        &tokens as &[&str],
                    ),
                )
                .add_endpoint(
                    "aes256sha256rsapss",
                    (
                        "/",
                        SecurityPolicy::Aes256Sha256RsaPss,
                        MessageSecurityMode::SignAndEncrypt,
                        &tokens as &[&str],
                    ),
                );
        }
        {
            let limits = builder.limits_mut();
            limits.subscriptions.min_sampling_interval_ms = scan_ms as f64;
            limits.subscriptions.min_publishing_interval_ms = scan_ms as f64;
        }
        let workers = std::thread::available_parallelism().map_or(1, |n| n.get().min(2));
        let rt = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(workers)
            .enable_all()
            .thread_name(format!("opcua {name}"))
            .build()
            .map_err(|e| error(&name, format!("cannot start the network runtime: {e}")))?;
        // The stack's own node managers start tasks as they are built.
        let entered = rt.enter();
        let (server, handle) = builder
            .build()
            .map_err(|e| error(&name, format!("cannot build the OPC UA server: {e}")))?;
        let manager = handle
            .node_managers()
            .get_of_type::<InMemoryNodeManager<PlcNodes>>()
            .ok_or_else(|| error(&name, "the address space was not built"))?;
        let ns = handle
            .get_namespace_index(&ns_uri)
            .ok_or_else(|| error(&name, "petriplc's namespace was not registered"))?;
        let ids: Vec<NodeId> = layout
            .vars
            .iter()
            .map(|v| NodeId::new(ns, v.id.clone()))
            .collect();

        drop(entered);
        let (h, sh) = (handle.clone(), Arc::clone(&shared));
        let points_of: Vec<Option<usize>> = layout.vars.iter().map(|v| v.writable).collect();
        let thread_name = name.clone();
        let thread = std::thread::Builder::new()
            .name(format!("opcua {name}"))
            .spawn(move || {
                rt.block_on(async move {
                    let listener = match tokio::net::TcpListener::from_std(listener) {
                        Ok(l) => l,
                        Err(e) => {
                            log::error!("opcua_server {thread_name}: {e}");
                            return;
                        }
                    };
                    let updater = tokio::spawn(update(h, manager, sh, ids, points_of));
                    if let Err(e) = server.run_with(listener).await {
                        log::error!("opcua_server {thread_name}: the server stopped: {e}");
                    }
                    updater.abort();
                });
                rt.shutdown_timeout(Duration::from_secs(1));
            })
            .map_err(|e| error(&name, format!("cannot start the network thread: {e}")))?;
        let security = match (self.settings.security.none, self.settings.security.encrypt) {
            (true, true) => "None and Basic256Sha256/Aes256-Sha256-RsaPss Sign&Encrypt",
            (true, false) => "None (loopback)",
            _ => "Basic256Sha256/Aes256-Sha256-RsaPss Sign&Encrypt",
        };
        log::info!(
            "opcua_server {name}: listening on {endpoint} (security {security}; anonymous {}; \
             {} points)",
            match self.settings.anonymous {
                Anonymous::No => "off",
                Anonymous::Read => "read-only",
                Anonymous::Write => "read-write",
            },
            points.len()
        );
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
            endpoint,
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
