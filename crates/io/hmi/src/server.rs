//! The web side of the hmi module: an axum server on a tokio runtime of its own thread,
//! serving the page, the event stream of snapshots, the state and nets as JSON and SVG, and
//! the force and release requests, which need the token.

use std::convert::Infallible;
use std::net::TcpListener;
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::{header, HeaderMap, HeaderValue, StatusCode};
use axum::response::sse::{Event, Sse};
use axum::response::{IntoResponse, Response};
use axum::routing::{get, post};
use axum::Router;
use futures_util::Stream;
use petriplc_config::{PointKind, PointValue};
use serde_json::{json, Value};
use subtle::ConstantTimeEq;
use tokio::sync::{oneshot, watch};

use crate::state::{ForceRequest, PageGuard, Shared};

/// A page's event stream sends the snapshot again after this long without a change, so that
/// it can tell a quiet PLC from a dead connection.
const KEEP_ALIVE: Duration = Duration::from_secs(5);
/// How long a force request waits for the module's next scan to apply it.
const APPLY_WAIT: Duration = Duration::from_secs(2);
/// The most pages that may follow the PLC's changes at once.
const MAX_PAGES: usize = 256;
/// How long `close` lets open requests finish before the runtime is dropped.
const GRACE: Duration = Duration::from_secs(2);

const PAGE: &str = include_str!("page/index.html");
const SCRIPT: &str = include_str!("page/hmi.js");
const STYLE: &str = include_str!("page/hmi.css");

/// The running server; dropping it stops it.
pub(crate) struct Server {
    stop: watch::Sender<bool>,
    thread: Option<JoinHandle<()>>,
}

impl Server {
    /// Serves `shared` on `listener` (already bound, so that `init` reports bind errors).
    pub fn start(listener: TcpListener, shared: Arc<Shared>) -> std::io::Result<Server> {
        listener.set_nonblocking(true)?;
        let (stop, stopped) = watch::channel(false);
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?;
        let name = format!("{}-http", shared.module);
        let thread = std::thread::Builder::new().name(name).spawn(move || {
            let module = shared.module.clone();
            runtime.block_on(serve(listener, shared, stopped));
            runtime.shutdown_timeout(Duration::from_millis(200));
            log::debug!("{module}: web server stopped");
        })?;
        Ok(Server {
            stop,
            thread: Some(thread),
        })
    }

    /// Stops the server: open event streams end, open requests get `GRACE` to finish.
    pub fn stop(&mut self) {
        let _ = self.stop.send(true);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.stop();
    }
}

async fn serve(listener: TcpListener, shared: Arc<Shared>, stopped: watch::Receiver<bool>) {
    let module = shared.module.clone();
    let hosts = listener
        .local_addr()
        .ok()
        .and_then(loopback_hosts)
        .map(Arc::new);
    let listener = match tokio::net::TcpListener::from_std(listener) {
        Ok(l) => l,
        Err(e) => {
            log::error!("{module}: cannot serve: {e}");
            return;
        }
    };
    let app = router(App {
        shared,
        stopped: stopped.clone(),
        hosts,
    });
    let mut signal = stopped.clone();
    let server = axum::serve(listener, app).with_graceful_shutdown(async move {
        let _ = signal.wait_for(|s| *s).await;
    });
    let mut deadline = stopped;
    tokio::select! {
        r = server => {
            if let Err(e) = r {
                log::error!("{module}: web server: {e}");
            }
        }
        _ = async {
            let _ = deadline.wait_for(|s| *s).await;
            tokio::time::sleep(GRACE).await;
        } => log::warn!("{module}: web requests still open after {GRACE:?}; closing them"),
    }
}

#[derive(Clone)]
struct App {
    shared: Arc<Shared>,
    stopped: watch::Receiver<bool>,
    /// The `Host` headers accepted, when the server listens on a loopback address.
    hosts: Option<Arc<Vec<String>>>,
}

/// The names a browser on this machine uses for a loopback address and port. `None` for
/// other addresses, whose names the server cannot know.
fn loopback_hosts(addr: std::net::SocketAddr) -> Option<Vec<String>> {
    if !addr.ip().is_loopback() {
        return None;
    }
    let port = addr.port();
    let ip = match addr {
        std::net::SocketAddr::V4(a) => a.ip().to_string(),
        std::net::SocketAddr::V6(a) => format!("[{}]", a.ip()),
    };
    Some(vec![
        format!("{ip}:{port}"),
        format!("localhost:{port}"),
        format!("127.0.0.1:{port}"),
        format!("[::1]:{port}"),
    ])
}

/// On a loopback address, only requests naming it by a loopback name are served: a page of
/// another site whose DNS name is rebound to 127.0.0.1 sends its own name as `Host`, and
/// would otherwise read the PLC's values.
async fn check_host(
    State(app): State<App>,
    request: axum::extract::Request,
    next: axum::middleware::Next,
) -> Response {
    if let Some(hosts) = &app.hosts {
        let host = request
            .headers()
            .get(header::HOST)
            .and_then(|h| h.to_str().ok())
            .unwrap_or("");
        if !hosts.iter().any(|h| h.eq_ignore_ascii_case(host)) {
            return json_error(
                StatusCode::MISDIRECTED_REQUEST,
                format!(
                    "this HMI answers requests for {} only (got Host `{host}`)",
                    hosts.join(", ")
                ),
            );
        }
    }
    next.run(request).await
}

fn router(app: App) -> Router {
    Router::new()
        .route("/", get(page))
        .route("/hmi.js", get(script))
        .route("/hmi.css", get(style))
        .route("/events", get(events))
        .route("/api/state", get(state))
        .route("/api/nets", get(nets))
        .route("/api/nets/{module}", get(net_svg))
        .route("/api/force", post(force))
        .route("/api/unforce", post(unforce))
        .fallback(not_found)
        .layer(axum::middleware::from_fn_with_state(
            app.clone(),
            check_host,
        ))
        .with_state(app)
}

fn with_type(content_type: &'static str, body: impl IntoResponse) -> Response {
    let mut r = body.into_response();
    let h = r.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-store"));
    r
}

async fn page() -> Response {
    let mut r = with_type("text/html; charset=utf-8", PAGE);
    // Everything the page uses comes from here: no inline script, no other origin.
    r.headers_mut().insert(
        header::CONTENT_SECURITY_POLICY,
        HeaderValue::from_static(
            "default-src 'self'; img-src 'self' data:; style-src 'self'; \
             frame-ancestors 'none'",
        ),
    );
    r
}

async fn script() -> Response {
    with_type("text/javascript; charset=utf-8", SCRIPT)
}

async fn style() -> Response {
    with_type("text/css; charset=utf-8", STYLE)
}

async fn not_found() -> Response {
    json_error(
        StatusCode::NOT_FOUND,
        "no such page; the HMI is at /".into(),
    )
}

fn json_response(status: StatusCode, v: &Value) -> Response {
    (status, with_type("application/json", v.to_string())).into_response()
}

fn json_error(status: StatusCode, message: String) -> Response {
    json_response(status, &json!({ "error": message }))
}

async fn state(State(app): State<App>) -> Response {
    let (_, json) = app.shared.snapshot();
    with_type("application/json", json.to_string())
}

async fn nets(State(app): State<App>) -> Response {
    let nets: Vec<Value> = app
        .shared
        .nets
        .iter()
        .map(|n| json!({ "module": n.module, "file": n.file, "svg": n.svg }))
        .collect();
    json_response(StatusCode::OK, &Value::Array(nets))
}

async fn net_svg(State(app): State<App>, Path(module): Path<String>) -> Response {
    let module = module.strip_suffix(".svg").unwrap_or(&module);
    match app.shared.nets.iter().find(|n| n.module == module) {
        Some(n) => with_type("image/svg+xml", n.svg.clone()),
        None => json_error(
            StatusCode::NOT_FOUND,
            format!(
                "no petrinet module `{module}`; nets: {}",
                app.shared
                    .nets
                    .iter()
                    .map(|n| n.module.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ),
    }
}

/// The snapshots, as server-sent events: at once, then every `refresh` when something
/// changed, and after `KEEP_ALIVE` without a change; the stream ends when the server stops.
async fn events(State(app): State<App>) -> Response {
    // Each open page costs a task and its buffers: a client opening streams without end is
    // refused rather than allowed to grow the PLC's memory.
    if app.shared.pages() >= MAX_PAGES {
        return json_error(
            StatusCode::SERVICE_UNAVAILABLE,
            format!(
                "{MAX_PAGES} pages already follow this PLC; close some (or raise the limit in \
                 a build of your own)"
            ),
        );
    }
    stream(app).into_response()
}

fn stream(app: App) -> Sse<impl Stream<Item = Result<Event, Infallible>>> {
    let guard = PageGuard::new(Arc::clone(&app.shared));
    let mut tick = tokio::time::interval(app.shared.refresh);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let start = (guard, app.stopped, tick, None::<(u64, Instant)>);
    let stream = futures_util::stream::unfold(
        start,
        |(guard, mut stopped, mut tick, mut last)| async move {
            loop {
                tokio::select! {
                    _ = stopped.wait_for(|s| *s) => return None,
                    _ = tick.tick() => {}
                }
                let (version, json) = guard.0.snapshot();
                let due = match last {
                    None => true,
                    Some((v, at)) => v != version || at.elapsed() >= KEEP_ALIVE,
                };
                if due {
                    let mut event = Event::default().event("snapshot").data(&*json);
                    if last.is_none() {
                        // Reconnect soon after a restart of the PLC.
                        event = event.retry(Duration::from_millis(1000));
                    }
                    last = Some((version, Instant::now()));
                    return Some((Ok(event), (guard, stopped, tick, last)));
                }
            }
        },
    );
    Sse::new(stream)
}

/// Whether the request carries the token, compared in constant time.
fn authorised(shared: &Shared, headers: &HeaderMap) -> bool {
    let Some(given) = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "))
    else {
        return false;
    };
    bool::from(given.trim().as_bytes().ct_eq(shared.token.as_bytes()))
}

fn unauthorised() -> Response {
    let mut r = json_error(
        StatusCode::UNAUTHORIZED,
        "forcing needs the token the PLC printed when it started: send `Authorization: Bearer \
         TOKEN` (on the page, enter it in the token field)"
            .into(),
    );
    r.headers_mut().insert(
        header::WWW_AUTHENTICATE,
        HeaderValue::from_static("Bearer realm=\"petriplc hmi\""),
    );
    r
}

/// The request body as a JSON object with a `point` the PLC has.
fn parse_request(shared: &Shared, body: &Bytes) -> Result<(usize, Value), String> {
    let v: Value = serde_json::from_slice(body).map_err(|e| {
        format!("the body is not JSON ({e}); send {{\"point\": \"NAME\", \"value\": 1}}")
    })?;
    let Some(name) = v.get("point").and_then(Value::as_str) else {
        return Err(
            "no `point` in the request; send {\"point\": \"NAME\", \"value\": 1}".to_string(),
        );
    };
    let Some(i) = shared.point(name) else {
        return Err(format!("no point `{name}` in this PLC"));
    };
    Ok((i, v))
}

async fn force(State(app): State<App>, headers: HeaderMap, body: Bytes) -> Response {
    change(app, headers, body, true).await
}

async fn unforce(State(app): State<App>, headers: HeaderMap, body: Bytes) -> Response {
    change(app, headers, body, false).await
}

/// A force or a release: checked here, queued for the module's next scan, answered once
/// that scan has applied it.
async fn change(app: App, headers: HeaderMap, body: Bytes, force: bool) -> Response {
    let shared = &app.shared;
    if !authorised(shared, &headers) {
        return unauthorised();
    }
    let (point, request) = match parse_request(shared, &body) {
        Ok(r) => r,
        Err(e) => return json_error(StatusCode::BAD_REQUEST, e),
    };
    let info = &shared.points[point];
    let value = if force {
        match point_value(info.kind, info.bits, request.get("value")) {
            Ok(v) => Some(v),
            Err(e) => {
                return json_error(
                    StatusCode::BAD_REQUEST,
                    format!("point `{}`: {e}", info.name),
                )
            }
        }
    } else {
        None
    };
    let (reply, applied) = oneshot::channel();
    shared.queue(ForceRequest {
        point,
        value,
        reply,
    });
    let what = match value {
        Some(v) => format!("forced to {}", crate::state::value_json(v)),
        None => "released".to_string(),
    };
    match tokio::time::timeout(APPLY_WAIT, applied).await {
        Ok(Ok(Ok(()))) => {
            log::info!(
                "{}: point {} {what} from the web page",
                shared.module,
                info.name
            );
            json_response(
                StatusCode::OK,
                &json!({ "point": info.name, "forced": force, "value": value.map(crate::state::value_json) }),
            )
        }
        Ok(Ok(Err(e))) => json_error(StatusCode::BAD_REQUEST, e),
        // Not scanned in time (the PLC waits in its synchronisation, or is stopping): the
        // request stays queued.
        _ => json_response(
            StatusCode::ACCEPTED,
            &json!({
                "point": info.name,
                "queued": true,
                "message": format!(
                    "point {} will be {what} at the next scan of module {}",
                    info.name, shared.module
                ),
            }),
        ),
    }
}

/// A JSON value as a value of a point of `kind` and `bits`: a number, a JSON boolean or a
/// string holding one; it must fit the point.
pub(crate) fn point_value(
    kind: PointKind,
    bits: u8,
    v: Option<&Value>,
) -> Result<PointValue, String> {
    let Some(v) = v else {
        return Err("no `value` in the request; send {\"point\": \"NAME\", \"value\": 1}".into());
    };
    let text = match v {
        Value::Bool(b) => u8::from(*b).to_string(),
        Value::Number(n) => n.to_string(),
        Value::String(s) if s.len() > 64 => {
            return Err(format!("value {} is not a number", short(s)))
        }
        Value::String(s) => match s.trim().to_ascii_lowercase().as_str() {
            "true" | "on" => "1".to_string(),
            "false" | "off" => "0".to_string(),
            other => other.to_string(),
        },
        other => return Err(format!("value {other} is not a number")),
    };
    let type_name = match kind {
        PointKind::Unsigned if bits == 1 => "bool".to_string(),
        PointKind::Unsigned => format!("u{bits}"),
        PointKind::Signed => format!("i{bits}"),
        PointKind::Float => "f32".to_string(),
    };
    let range =
        |lo: i64, hi: i64| format!("value {text} does not fit type {type_name} ({lo} to {hi})");
    match kind {
        PointKind::Float => match text.parse::<f64>() {
            Ok(f) if f.is_finite() && f.abs() <= f64::from(f32::MAX) => {
                Ok(PointValue::Float(f as f32))
            }
            // No point ever holds NaN or an infinity from outside (docs/runtime.md).
            Ok(f) if !f.is_finite() => Err(format!(
                "value {} is not a finite number; the PLC refuses NaN and infinities",
                short(&text)
            )),
            Ok(_) => Err(format!(
                "value {} does not fit type {type_name} (±3.4e38)",
                short(&text)
            )),
            Err(_) => Err(format!("value {} is not a number", short(&text))),
        },
        PointKind::Unsigned => {
            let hi = (1i64 << bits) - 1;
            match text.parse::<i64>() {
                Ok(i) if (0..=hi).contains(&i) => Ok(PointValue::Unsigned(i as u32)),
                Ok(_) => Err(range(0, hi)),
                Err(_) => Err(format!("value {text} is not a whole number")),
            }
        }
        PointKind::Signed => {
            let half = 1i64 << (bits - 1);
            match text.parse::<i64>() {
                Ok(i) if (-half..half).contains(&i) => Ok(PointValue::Signed(i as i32)),
                Ok(_) => Err(range(-half, half - 1)),
                Err(_) => Err(format!("value {text} is not a whole number")),
            }
        }
    }
}

/// A value as a message quotes it: at most 40 characters.
fn short(text: &str) -> String {
    match text.char_indices().nth(40) {
        Some((i, _)) => format!("{}… ({} characters)", &text[..i], text.chars().count()),
        None => text.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(kind: PointKind, bits: u8, v: Value) -> String {
        match point_value(kind, bits, Some(&v)) {
            Ok(v) => format!("{v:?}"),
            Err(e) => e,
        }
    }

    #[test]
    fn values_are_checked_against_the_point() {
        use PointKind::*;
        assert_eq!(check(Unsigned, 1, json!(true)), "Unsigned(1)");
        assert_eq!(check(Unsigned, 1, json!("off")), "Unsigned(0)");
        assert_eq!(
            check(Unsigned, 1, json!(2)),
            "value 2 does not fit type bool (0 to 1)"
        );
        assert_eq!(check(Unsigned, 8, json!("255")), "Unsigned(255)");
        assert_eq!(check(Signed, 16, json!(-32768)), "Signed(-32768)");
        assert_eq!(
            check(Signed, 16, json!(32768)),
            "value 32768 does not fit type i16 (-32768 to 32767)"
        );
        assert_eq!(
            check(Signed, 16, json!(1.5)),
            "value 1.5 is not a whole number"
        );
        assert_eq!(check(Float, 32, json!(2.5)), "Float(2.5)");
        assert_eq!(check(Float, 32, json!("x")), "value x is not a number");
        assert_eq!(
            check(Float, 32, json!(1e300)),
            "value 1e+300 does not fit type f32 (±3.4e38)"
        );
        // Issue 27: NaN and infinities, however written, never reach a point.
        for v in [
            json!("NaN"),
            json!("nan"),
            json!("inf"),
            json!("-Infinity"),
            json!("1e400"),
        ] {
            assert!(
                check(Float, 32, v.clone())
                    .ends_with("is not a finite number; the PLC refuses NaN and infinities"),
                "{v}: {}",
                check(Float, 32, v.clone())
            );
        }
        assert_eq!(
            check(Float, 32, json!("1e39")),
            "value 1e39 does not fit type f32 (±3.4e38)"
        );
        let long = "9".repeat(10_000);
        assert_eq!(
            check(Float, 32, json!(long)),
            format!(
                "value {}… (10000 characters) is not a number",
                "9".repeat(40)
            )
        );
        assert_eq!(check(Unsigned, 8, json!([1])), "value [1] is not a number");
        assert_eq!(
            point_value(Unsigned, 8, None).unwrap_err(),
            "no `value` in the request; send {\"point\": \"NAME\", \"value\": 1}"
        );
    }
}
