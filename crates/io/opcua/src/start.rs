//! The steps of the module's `init`: the password file, the address space (points, then a
//! folder per module with its status and marking), the listening socket, the server's
//! identity and certificate, the server built on its own tokio runtime and run on a thread.

use std::collections::HashMap;
use std::net::{IpAddr, SocketAddr, TcpListener};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Duration;

use opcua::crypto::SecurityPolicy;
use opcua::server::node_manager::memory::{InMemoryNodeManager, InMemoryNodeManagerBuilder};
use opcua::server::{ServerBuilder, ServerHandle, ServerUserToken, ANONYMOUS_USER_TOKEN_ID};
use opcua::types::{DataTypeId, DateTime, MessageSecurityMode, NodeId, Variant};
use petriplc_modules::common::{self, error};
use petriplc_runtime::module::{InitContext, ModuleError};

use crate::space::{self, Folder, Layout, PlcNodes, PlcNodesBuilder, Var};
use crate::{
    certificate, hostname, state_dir, update, Anonymous, Point, Settings, Shared, Users, Values,
    Writes, USERS_TOKEN,
};

/// The password file of `users`, if set; an error names the setting's line.
pub(crate) fn users(
    ctx: &InitContext<'_>,
    settings: &Settings,
    name: &str,
) -> Result<Users, ModuleError> {
    Ok(match &settings.users {
        None => Users::default(),
        Some(p) => Users::read(&ctx.base_dir.join(p), &p.display().to_string()).map_err(|why| {
            let at = ctx
                .decl
                .settings
                .get("users")
                .map(|s| format!("{}: ", s.origin))
                .unwrap_or_default();
            error(name, format!("{at}{why}"))
        })?,
    })
}

/// The address space being laid out, with each variable's first value.
#[derive(Default)]
pub(crate) struct Space {
    pub layout: Layout,
    values: Vec<Variant>,
}

/// Per module: the variable indices of State, Scans, Overruns.
type StatusVars = HashMap<String, [usize; 3]>;
/// (module, place label) → variable index.
type MarkingVars = HashMap<(String, String), usize>;

impl Space {
    /// Every point as a typed variable in its owner's folder, writable when this module owns
    /// it.
    pub fn points(&mut self, ctx: &InitContext<'_>, name: &str) -> Result<Vec<Point>, ModuleError> {
        let (layout, values) = (&mut self.layout, &mut self.values);
        let mut points = Vec::new();
        for p in &ctx.config.points {
            let handle = ctx
                .map
                .handle(&p.name)
                .map_err(|e| error(name, format!("point {}: {e}", p.name)))?;
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
        Ok(points)
    }

    /// A folder per module with its status variables, and the marking of each petrinet
    /// module among `nets`.
    pub fn modules(
        &mut self,
        ctx: &InitContext<'_>,
        nets: &[(String, Vec<String>)],
    ) -> (StatusVars, MarkingVars) {
        let (layout, values) = (&mut self.layout, &mut self.values);
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
        (status_vars, marking_vars)
    }

    /// What the scan and the server share, starting from the first values.
    pub fn shared(&mut self, scan_period: Duration, points: usize) -> Arc<Shared> {
        let values = std::mem::take(&mut self.values);
        Arc::new(Shared {
            scan_ms: scan_period.as_secs_f64() * 1000.0,
            values: Mutex::new(Values {
                at: vec![DateTime::now(); values.len()],
                now: values,
                dirty: Vec::new(),
            }),
            wake: tokio::sync::Notify::new(),
            writes: Mutex::new(Writes::new(points)),
            ready: AtomicBool::new(false),
            written: AtomicU64::new(0),
        })
    }
}

/// The listening socket (non-blocking, for tokio) and the address it is bound to.
pub(crate) fn bind(
    listen: SocketAddr,
    name: &str,
) -> Result<(TcpListener, SocketAddr), ModuleError> {
    let listener = TcpListener::bind(listen)
        .and_then(|l| l.set_nonblocking(true).map(|()| l))
        .map_err(|e| {
            error(
                name,
                format!(
                    "cannot listen on {listen}: {}; choose another `listen` address or \
                     port (e.g. --set {name}:listen=127.0.0.1:4841)",
                    common::chain(&e)
                ),
            )
        })?;
    let local = listener
        .local_addr()
        .map_err(|e| error(name, format!("cannot read the bound address: {e}")))?;
    Ok((listener, local))
}

/// How the server names itself: host, endpoint URL, application name and URI, and the
/// folder of its certificates.
pub(crate) struct Identity {
    host: String,
    port: u16,
    pub endpoint: String,
    app: String,
    uri: String,
    pki: PathBuf,
}

impl Identity {
    /// The identity of the server listening on `local`; with encryption, its certificate is
    /// made on the first start.
    pub fn new(
        settings: &Settings,
        ctx: &InitContext<'_>,
        name: &str,
        local: &SocketAddr,
    ) -> Result<Identity, ModuleError> {
        let host = match local.ip() {
            ip if ip.is_unspecified() => hostname(),
            IpAddr::V6(ip) => format!("[{ip}]"),
            ip => ip.to_string(),
        };
        let endpoint = format!("opc.tcp://{host}:{}/", local.port());
        let app = format!("opcua_server {name}");
        let uri = format!("urn:petriplc:{}:{name}", ctx.plc_id);
        let state = state_dir(settings, ctx, name);
        let pki = state.join("pki");
        if settings.security.encrypt {
            std::fs::create_dir_all(&pki).map_err(|e| {
                error(
                    name,
                    format!(
                        "cannot create the state directory {}: {e}; set `state_dir = PATH` in \
                         [{name}]",
                        pki.display()
                    ),
                )
            })?;
            certificate(&pki, &uri, &app, local).map_err(|e| {
                error(
                    name,
                    format!(
                        "server certificate in {}: {e}; remove own/ and private/ there to \
                         make a new one",
                        pki.display()
                    ),
                )
            })?;
        }
        Ok(Identity {
            host,
            port: local.port(),
            endpoint,
            app,
            uri,
            pki,
        })
    }
}

/// The server's settings: identity, security endpoints, user tokens and the sampling and
/// publishing limits of the scan period, and petriplc's address space (`nodes`).
pub(crate) fn builder(
    settings: &Settings,
    scan_period: Duration,
    id: &Identity,
    users: Users,
    nodes: PlcNodesBuilder,
    name: &str,
) -> ServerBuilder {
    let scan_ms = (scan_period.as_millis() as u64).max(1);
    // What the stack logs per endpoint; the sessions themselves are checked by `Auth`.
    let mut tokens: Vec<&str> = Vec::new();
    if settings.anonymous != Anonymous::No {
        tokens.push(ANONYMOUS_USER_TOKEN_ID);
    }
    let has_users = !users.is_empty();
    if has_users {
        tokens.push(USERS_TOKEN);
    }
    let mut builder = ServerBuilder::new()
        .application_name(id.app.clone())
        .application_uri(id.uri.clone())
        .product_uri("urn:petriplc")
        .host(id.host.clone())
        .port(id.port)
        .pki_dir(&id.pki)
        .certificate_path("own/cert.der")
        .private_key_path("private/private.pem")
        .create_sample_keypair(false)
        .trust_client_certs(settings.trust_client_certs)
        .max_sessions(settings.max_sessions)
        .subscription_poll_interval_ms(scan_ms)
        .discovery_urls(vec![id.endpoint.clone()])
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
            anonymous: settings.anonymous,
            users: Arc::new(users),
            module: name.to_string(),
        }))
        .with_node_manager(InMemoryNodeManagerBuilder::new(nodes));
    if settings.security.none {
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
    if settings.security.encrypt {
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
    builder
}

/// Builds the server on a tokio runtime of its own and runs it on a thread, with the task
/// that moves the scan's changes into the address space.
pub(crate) fn serve(
    builder: ServerBuilder,
    listener: TcpListener,
    layout: &Layout,
    shared: &Arc<Shared>,
    ns_uri: &str,
    name: &str,
) -> Result<(ServerHandle, JoinHandle<()>), ModuleError> {
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get().min(2));
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(workers)
        .enable_all()
        .thread_name(format!("opcua {name}"))
        .build()
        .map_err(|e| error(name, format!("cannot start the network runtime: {e}")))?;
    // The stack's own node managers start tasks as they are built.
    let entered = rt.enter();
    let (server, handle) = builder
        .build()
        .map_err(|e| error(name, format!("cannot build the OPC UA server: {e}")))?;
    let manager = handle
        .node_managers()
        .get_of_type::<InMemoryNodeManager<PlcNodes>>()
        .ok_or_else(|| error(name, "the address space was not built"))?;
    let ns = handle
        .get_namespace_index(ns_uri)
        .ok_or_else(|| error(name, "petriplc's namespace was not registered"))?;
    let ids: Vec<NodeId> = layout
        .vars
        .iter()
        .map(|v| NodeId::new(ns, v.id.clone()))
        .collect();

    drop(entered);
    let (h, sh) = (handle.clone(), Arc::clone(shared));
    let points_of: Vec<Option<usize>> = layout.vars.iter().map(|v| v.writable).collect();
    let thread_name = name.to_string();
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
        .map_err(|e| error(name, format!("cannot start the network thread: {e}")))?;
    Ok((handle, thread))
}

/// The line that says where the server listens and how it is secured.
pub(crate) fn log_listening(settings: &Settings, name: &str, endpoint: &str, points: usize) {
    let security = match (settings.security.none, settings.security.encrypt) {
        (true, true) => "None and Basic256Sha256/Aes256-Sha256-RsaPss Sign&Encrypt",
        (true, false) => "None (loopback)",
        _ => "Basic256Sha256/Aes256-Sha256-RsaPss Sign&Encrypt",
    };
    log::info!(
        "opcua_server {name}: listening on {endpoint} (security {security}; anonymous {}; \
         {} points)",
        match settings.anonymous {
            Anonymous::No => "off",
            Anonymous::Read => "read-only",
            Anonymous::Write => "read-write",
        },
        points
    );
}
