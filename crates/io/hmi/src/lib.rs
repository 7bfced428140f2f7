//! The `hmi` module of petriplc run: a web page with the live points, the modules' status and
//! every petrinet module's net drawn with its tokens; forcing a point needs the token the
//! module prints at start-up (docs/hmi.md).
//!
//! ```text
//! [hmi]
//! listen = 127.0.0.1:8080   # the default; port 0 picks a free one (the log says which);
//!                           # `off`: no web server
//! token = SECRET            # default: 128 random bits, printed at start-up
//! refresh = T#100ms         # how often pages get changes (seconds or an IEC literal)
//! ```

mod server;
mod state;
mod svg;

use std::net::{SocketAddr, TcpListener};
use std::sync::Arc;
use std::time::Duration;

use petriplc_config::ModuleDecl;
use petriplc_modules::common::{self, error};
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};
use petriplc_runtime::status::PlcStatus;

use crate::server::Server;
use crate::state::{NetInfo, PointInfo, Shared};

/// The module kinds of this crate.
pub const KINDS: &[&str] = &["hmi"];

const KIND: &str = "hmi";
const DEFAULT_LISTEN: &str = "127.0.0.1:8080";
const DEFAULT_REFRESH: Duration = Duration::from_millis(100);
/// The module's scan period when its section sets none: it only copies values for pages.
const SCAN_PERIOD: Duration = Duration::from_millis(50);
/// How often the status file the runner writes (every 50 ms) is read again.
const STATUS_EVERY: Duration = Duration::from_millis(200);

/// The factory of a module kind of this crate (see [`KINDS`]).
pub fn builtin(kind: &str) -> Option<Factory> {
    (kind == KIND).then_some(factory as Factory)
}

fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Hmi::new(decl)?))
}

/// The `hmi` module.
pub struct Hmi {
    name: String,
    /// `None`: `listen = off`.
    listen: Option<SocketAddr>,
    token: Option<String>,
    refresh: Duration,
    run: Option<Run>,
}

/// What `init` starts.
struct Run {
    shared: Arc<Shared>,
    server: Server,
    plc_id: String,
    /// When the status file was last read (`None`: not yet).
    status_at: Option<Duration>,
    /// The values of this scan, before they are compared with the last published ones.
    scratch: Vec<(petriplc_config::PointValue, u32, bool)>,
}

impl Hmi {
    /// Checks the settings; `init` binds the address and starts the server.
    pub fn new(decl: &ModuleDecl) -> Result<Hmi, ModuleError> {
        common::check_decl(decl, KIND, &["listen", "token", "refresh"])?;
        let at = |name: &str| {
            decl.settings
                .get(name)
                .filter(|s| !s.origin.file.is_empty())
                .map(|s| format!("{}: ", s.origin))
                .unwrap_or_default()
        };
        let listen = match common::setting(decl, "listen").unwrap_or(DEFAULT_LISTEN) {
            "off" | "no" | "none" => None,
            listen => Some(listen.parse::<SocketAddr>().map_err(|_| {
                error(
                    &decl.name,
                    format!(
                        "{}`listen = {listen}` is not an address and port; write e.g. `listen = \
                         {DEFAULT_LISTEN}` (port 0 for any free port), or `off`",
                        at("listen")
                    ),
                )
            })?),
        };
        let token = match common::setting(decl, "token") {
            None => None,
            Some(t) if t.len() >= 8 && t.chars().all(|c| c.is_ascii_graphic()) => {
                Some(t.to_string())
            }
            Some(_) => {
                return Err(error(
                    &decl.name,
                    format!(
                        "{}`token` must be at least 8 printable ASCII characters without \
                         spaces (it travels in an HTTP header); or leave it out for a random \
                         token printed at start-up",
                        at("token")
                    ),
                ))
            }
        };
        let refresh = match common::setting(decl, "refresh") {
            None => DEFAULT_REFRESH,
            Some(v) => match petriplc_net::time::parse_duration(v) {
                Ok(d) if d >= Duration::from_millis(10) && d <= Duration::from_secs(60) => d,
                _ => {
                    return Err(error(
                        &decl.name,
                        format!(
                            "{}`refresh = {v}`: write a time from 10 ms to 60 s, in seconds \
                             (0.1) or as an IEC literal (T#100ms)",
                            at("refresh")
                        ),
                    ))
                }
            },
        };
        Ok(Hmi {
            name: decl.name.clone(),
            listen,
            token,
            refresh,
            run: None,
        })
    }

    /// The page's address once `init` has bound it.
    pub fn url(&self) -> Option<&str> {
        self.run.as_ref().map(|r| r.shared.url.as_str())
    }

    fn bind(&self, listen: SocketAddr) -> Result<TcpListener, ModuleError> {
        TcpListener::bind(listen).map_err(|e| {
            let why = if e.kind() == std::io::ErrorKind::AddrInUse {
                "address already in use".to_string()
            } else {
                common::chain(&e)
            };
            let mut other = listen;
            other.set_port(listen.port().wrapping_add(1).max(1));
            error(
                &self.name,
                format!(
                    "cannot listen on {listen}: {why}; set `listen = HOST:PORT` in [{}] or run \
                     with --set {}:listen={other}",
                    self.name, self.name
                ),
            )
        })
    }
}

/// Every petrinet module's net, read the way that module reads it and drawn.
fn nets(ctx: &InitContext<'_>, me: &str) -> Result<Vec<NetInfo>, ModuleError> {
    let nets = petriplc_modules::petrinet_nets(ctx.config, ctx.base_dir).map_err(|e| {
        error(
            me,
            format!(
                "cannot draw the net of module {} (`net = {}` in [{}]): {}",
                e.module,
                e.file,
                e.module,
                common::chain(&e.source)
            ),
        )
    })?;
    Ok(nets
        .into_iter()
        .map(|n| NetInfo {
            svg: svg::draw(&n.doc.net, &n.doc.layout, &format!("net{}", n.index)),
            module: n.module,
            file: n.file,
        })
        .collect())
}

/// 128 random bits from the OS, as hex.
fn random_token() -> Result<String, String> {
    let mut bytes = [0u8; 16];
    getrandom::fill(&mut bytes).map_err(|e| e.to_string())?;
    Ok(bytes.iter().map(|b| format!("{b:02x}")).collect())
}

impl Module for Hmi {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        common::rows(ctx, KIND, &[])?;
        let Some(listen) = self.listen else {
            log::info!("{}: off (listen = off): no web page", self.name);
            return Ok(());
        };
        let mut points = Vec::new();
        for p in &ctx.config.points {
            let handle = ctx
                .map
                .handle(&p.name)
                .map_err(|e| error(&self.name, format!("point {}: {e}", p.name)))?;
            points.push(PointInfo {
                name: p.name.clone(),
                description: p.description.clone(),
                owner: p.owner.clone(),
                kind: p.kind,
                bits: p.bits,
                handle,
            });
        }
        let nets = nets(ctx, &self.name)?;
        let token = match &self.token {
            Some(t) => t.clone(),
            None => random_token().map_err(|e| {
                error(
                    &self.name,
                    format!(
                        "cannot draw a random token from the OS ({e}); set `token = ...` in [{}]",
                        self.name
                    ),
                )
            })?,
        };
        let listener = self.bind(listen)?;
        let addr = listener
            .local_addr()
            .map_err(|e| error(&self.name, format!("cannot read the bound address: {e}")))?;
        let url = format!("http://{addr}/");
        let shared = Arc::new(Shared::new(
            self.name.clone(),
            url.clone(),
            token.clone(),
            self.refresh,
            points,
            nets,
        ));
        let server = Server::start(listener, Arc::clone(&shared))
            .map_err(|e| error(&self.name, format!("cannot start the web server: {e}")))?;
        // Warn level, so that it shows whatever the log level: the operator needs the token.
        // On a line of its own, short enough for the log pane of an 80-column vitrine.
        log::warn!(
            "{}: web page {url} (forcing needs the token below)",
            self.name
        );
        log::warn!("{}: forcing token {token}", self.name);
        self.run = Some(Run {
            shared,
            server,
            plc_id: ctx.plc_id.to_string(),
            status_at: None,
            scratch: Vec::new(),
        });
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(run) = &mut self.run else {
            if self.listen.is_none() {
                return Ok(Control::Continue);
            }
            return Err(error(&self.name, "scanned before init"));
        };
        let shared = &run.shared;
        for r in shared.take_requests() {
            let h = &shared.points[r.point].handle;
            let result = match r.value {
                Some(v) => ctx.map.force(h, v),
                None => ctx.map.unforce(h),
            };
            let _ = r.reply.send(result.map_err(|e| e.to_string()));
        }
        run.scratch.clear();
        run.scratch.extend(shared.points.iter().map(|p| {
            (
                ctx.map.get(&p.handle),
                ctx.map.get_u32(&p.handle),
                ctx.map.is_forced(&p.handle),
            )
        }));
        let status = match run.status_at {
            Some(at) if ctx.now.saturating_sub(at) < STATUS_EVERY => None,
            _ => {
                run.status_at = Some(ctx.now);
                Some(
                    PlcStatus::read(&run.plc_id)
                        .map(|s| s.modules)
                        .unwrap_or_default(),
                )
            }
        };
        let mut live = shared.live();
        live.now = ctx.now;
        let mut changed = live.values.len() != run.scratch.len()
            || live
                .values
                .iter()
                .zip(&run.scratch)
                .any(|(a, b)| (a.1, a.2) != (b.1, b.2));
        if changed {
            std::mem::swap(&mut live.values, &mut run.scratch);
        }
        if let Some(modules) = status {
            if modules != live.modules {
                live.modules = modules;
                changed = true;
            }
        }
        if changed {
            live.version += 1;
        }
        Ok(Control::Continue)
    }

    fn close(&mut self) {
        if let Some(mut run) = self.run.take() {
            run.server.stop();
        }
    }

    /// The page's address and how many pages watch it (never the token).
    fn status(&self) -> String {
        match &self.run {
            Some(run) => {
                let n = run.shared.pages();
                format!(
                    "{} — {n} page{} connected",
                    run.shared.url,
                    if n == 1 { "" } else { "s" }
                )
            }
            None if self.listen.is_none() => "off (listen = off)".to_string(),
            None => String::new(),
        }
    }

    fn listens(&self) -> Vec<(&'static str, SocketAddr)> {
        self.listen
            .filter(|a| a.port() != 0)
            .map(|a| ("listen", a))
            .into_iter()
            .collect()
    }

    fn default_scan_period(&self) -> Option<Duration> {
        Some(SCAN_PERIOD)
    }
}
