//! The settings and rows of an `mqtt` section, checked at start: every problem is reported at
//! once with the setting's or row's file:line and how to fix it.

use std::path::PathBuf;
use std::time::Duration;

use petriplc_config::{ModuleDecl, PointKind, PointValue, Row};
use petriplc_modules::common::{self, error};
use petriplc_runtime::image::{Handle, ModuleMap};
use petriplc_runtime::module::{InitContext, ModuleError};

use crate::payload::{self, Format};
use crate::sparkplug::Node;

pub const KIND: &str = "mqtt";

/// The settings an `mqtt` section may have (besides the runner's).
pub const SETTINGS: &[&str] = &[
    "broker",
    "topic_prefix",
    "client_id",
    "payload",
    "username",
    "password_file",
    "ca_file",
    "client_cert",
    "client_key",
    "keep_alive",
    "backoff_max",
    "max_payload",
    "stale",
    "sparkplug",
];

/// The tables an `mqtt` section reads.
pub const TABLES: &[&str] = &["publish", "subscribe"];

pub const DEFAULT_PORT: u16 = 1883;
pub const DEFAULT_TLS_PORT: u16 = 8883;
pub const DEFAULT_KEEP_ALIVE: Duration = Duration::from_secs(5);
pub const DEFAULT_BACKOFF_MAX: Duration = Duration::from_secs(5);
/// The largest payload taken from the broker by default: a point's value is a few bytes, a
/// gateway's JSON object or a Sparkplug B command a few hundred.
pub const DEFAULT_MAX_PAYLOAD: usize = 64 * 1024;
/// The largest `max_payload`: under MQTT's own limit on a packet, 256 MiB.
pub const MAX_MAX_PAYLOAD: usize = 255 * 1024 * 1024;

/// `65536`, `64 KiB`, `1 MiB`: a size in bytes.
pub fn parse_size(text: &str) -> Option<usize> {
    let text = text.trim();
    let digits = text
        .find(|c: char| !c.is_ascii_digit())
        .unwrap_or(text.len());
    let n: usize = text[..digits].parse().ok()?;
    let unit = match text[digits..].trim() {
        "" | "B" => 1,
        "KiB" | "k" | "K" | "kB" | "KB" => 1024,
        "MiB" | "M" | "MB" => 1024 * 1024,
        _ => return None,
    };
    n.checked_mul(unit)
}

/// Where the broker is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Broker {
    pub host: String,
    pub port: u16,
    pub tls: bool,
}

impl std::fmt::Display for Broker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let scheme = if self.tls { "mqtts://" } else { "" };
        if self.host.contains(':') {
            write!(f, "{scheme}[{}]:{}", self.host, self.port)
        } else {
            write!(f, "{scheme}{}:{}", self.host, self.port)
        }
    }
}

impl Broker {
    /// `HOST:PORT`, `HOST`, `mqtt://HOST[:PORT]`, `mqtts://HOST[:PORT]`, `[::1]:1883`.
    pub fn parse(text: &str) -> Result<Broker, String> {
        let fix = || {
            format!(
                "`broker = {text}`: write HOST:PORT (127.0.0.1:1883), mqtt://HOST:PORT, or \
                 mqtts://HOST:PORT for TLS"
            )
        };
        let (tls, rest) = if let Some(r) = text.strip_prefix("mqtts://") {
            (true, r)
        } else if let Some(r) = text.strip_prefix("mqtt://") {
            (false, r)
        } else if text.contains("://") {
            return Err(format!("{}: only mqtt:// and mqtts:// are known", fix()));
        } else {
            (false, text)
        };
        let rest = rest.strip_suffix('/').unwrap_or(rest);
        let default_port = if tls { DEFAULT_TLS_PORT } else { DEFAULT_PORT };
        let (host, port) = if let Some(r) = rest.strip_prefix('[') {
            let (host, after) = r.split_once(']').ok_or_else(fix)?;
            match after {
                "" => (host, None),
                p => (host, Some(p.strip_prefix(':').ok_or_else(fix)?)),
            }
        } else {
            match rest.rsplit_once(':') {
                Some((h, p)) if !h.contains(':') => (h, Some(p)),
                Some(_) => return Err(format!("{}: write an IPv6 host as [::1]:1883", fix())),
                None => (rest, None),
            }
        };
        if host.is_empty() || host.contains(['/', ' ']) {
            return Err(fix());
        }
        let port = match port {
            None => default_port,
            Some(p) => match p.parse::<u16>() {
                Ok(p) if p > 0 => p,
                _ => return Err(format!("{}: the port is 1 to 65535", fix())),
            },
        };
        Ok(Broker {
            host: host.to_string(),
            port,
            tls,
        })
    }
}

/// TLS files, read at start.
#[derive(Clone, Debug, Default)]
pub struct TlsFiles {
    pub ca_file: Option<PathBuf>,
    pub client_cert: Option<PathBuf>,
    pub client_key: Option<PathBuf>,
}

/// The checked settings of a section (rows are checked by `init`, which sees the points).
#[derive(Clone, Debug)]
pub struct Settings {
    pub broker: Broker,
    /// `None`: the PLC id.
    pub topic_prefix: Option<String>,
    pub client_id: Option<String>,
    pub format: Format,
    pub username: Option<String>,
    pub password_file: Option<PathBuf>,
    pub tls: TlsFiles,
    pub keep_alive: Duration,
    pub backoff_max: Duration,
    /// Larger payloads from the broker are dropped and counted (`relay.rs`).
    pub max_payload: usize,
    pub stale: Option<String>,
    /// `sparkplug = GROUP/EDGE_NODE`: publish as a Sparkplug B edge node.
    pub sparkplug: Option<Node>,
}

fn at(decl: &ModuleDecl, setting: &str) -> String {
    decl.settings
        .get(setting)
        .filter(|s| !s.origin.file.is_empty())
        .map(|s| format!("{}: ", s.origin))
        .unwrap_or_default()
}

/// Checks a topic level string: no wildcards, not empty, no NUL; MQTT limits a topic to
/// 65535 bytes.
pub fn check_topic(topic: &str) -> Result<(), String> {
    if topic.is_empty() {
        return Err("a topic cannot be empty".into());
    }
    if topic.contains(['+', '#']) {
        return Err(format!(
            "`{topic}` has a wildcard (+ or #): a point takes its value from one topic"
        ));
    }
    if topic.contains('\0') || topic.len() > 65535 {
        return Err(format!("`{topic}` is not a valid MQTT topic"));
    }
    Ok(())
}

impl Settings {
    pub fn parse(decl: &ModuleDecl) -> Result<Settings, ModuleError> {
        common::check_decl(decl, KIND, SETTINGS)?;
        let name = decl.name.as_str();
        let mut problems = Vec::new();
        let broker = match common::setting(decl, "broker") {
            None | Some("") => {
                problems.push(format!(
                    "no `broker` setting; add `broker = 127.0.0.1:1883` (or \
                     mqtts://HOST:8883) to [{name}]"
                ));
                None
            }
            Some(b) => Broker::parse(b)
                .map_err(|why| problems.push(format!("{}{why}", at(decl, "broker"))))
                .ok(),
        };
        let topic_prefix = common::setting(decl, "topic_prefix").map(str::to_string);
        if let Some(p) = &topic_prefix {
            if let Err(why) = check_topic(p) {
                problems.push(format!(
                    "{}`topic_prefix = {p}`: {why}; leave it out for the PLC id",
                    at(decl, "topic_prefix")
                ));
            }
        }
        let client_id = common::setting(decl, "client_id").map(str::to_string);
        if let Some(c) = &client_id {
            if c.is_empty() || c.len() > 23 * 8 || c.contains(char::is_whitespace) {
                problems.push(format!(
                    "{}`client_id = {c}`: write a short name without spaces, unique on the \
                     broker (default petriplc-PLCID-{name})",
                    at(decl, "client_id")
                ));
            }
        }
        let format = match common::setting(decl, "payload") {
            None => Format::Plain,
            Some(v) => Format::parse(v).unwrap_or_else(|| {
                problems.push(format!(
                    "{}`payload = {v}`: write `plain` (decimal text, the default) or `json`",
                    at(decl, "payload")
                ));
                Format::Plain
            }),
        };
        let duration =
            |setting: &str, default: Duration, problems: &mut Vec<String>| match common::setting(
                decl, setting,
            ) {
                None => default,
                Some(v) => match petriplc_net::time::parse_duration(v) {
                    Ok(d) if d >= Duration::from_millis(100) && d <= Duration::from_secs(3600) => d,
                    _ => {
                        problems.push(format!(
                        "{}`{setting} = {v}`: write a time from 100 ms to 1 h, in seconds (5) or \
                         as an IEC literal (T#5s)",
                        at(decl, setting)
                    ));
                        default
                    }
                },
            };
        let keep_alive = duration("keep_alive", DEFAULT_KEEP_ALIVE, &mut problems);
        if keep_alive < Duration::from_secs(1) {
            problems.push(format!(
                "{}`keep_alive`: MQTT counts keep-alive in whole seconds; write 1 s or more",
                at(decl, "keep_alive")
            ));
        }
        let backoff_max = duration("backoff_max", DEFAULT_BACKOFF_MAX, &mut problems);
        let max_payload = match common::setting(decl, "max_payload") {
            None => DEFAULT_MAX_PAYLOAD,
            Some(v) => match parse_size(v) {
                Some(n) if (16..=MAX_MAX_PAYLOAD).contains(&n) => n,
                _ => {
                    problems.push(format!(
                        "{}`max_payload = {v}`: write a size from 16 bytes to 255 MiB, in bytes \
                         (65536) or with a unit (64 KiB, 1 MiB)",
                        at(decl, "max_payload")
                    ));
                    DEFAULT_MAX_PAYLOAD
                }
            },
        };
        let path = |s: &str| common::setting(decl, s).map(PathBuf::from);
        let tls = TlsFiles {
            ca_file: path("ca_file"),
            client_cert: path("client_cert"),
            client_key: path("client_key"),
        };
        if tls.client_cert.is_some() != tls.client_key.is_some() {
            problems.push(
                "`client_cert` and `client_key` go together: give both (a client certificate \
                 and its private key, PEM) or neither"
                    .to_string(),
            );
        }
        if let Some(b) = &broker {
            if !b.tls {
                for s in ["ca_file", "client_cert", "client_key"] {
                    if common::setting(decl, s).is_some() {
                        problems.push(format!(
                            "{}`{s}` is a TLS setting but `broker = {b}` is plain TCP; write \
                             `broker = mqtts://{}:{}`",
                            at(decl, s),
                            b.host,
                            DEFAULT_TLS_PORT
                        ));
                    }
                }
            }
        }
        let username = common::setting(decl, "username").map(str::to_string);
        let password_file = path("password_file");
        if password_file.is_some() && username.is_none() {
            problems.push(format!(
                "{}`password_file` without `username`: add `username = NAME`",
                at(decl, "password_file")
            ));
        }
        let stale = common::setting(decl, "stale").map(str::to_string);
        let sparkplug = match common::setting(decl, "sparkplug") {
            None => None,
            Some(v) => Node::parse(v)
                .map_err(|why| problems.push(format!("{}{why}", at(decl, "sparkplug"))))
                .ok(),
        };
        if sparkplug.is_some() {
            for s in ["topic_prefix", "payload"] {
                if common::setting(decl, s).is_some() {
                    problems.push(format!(
                        "{}`{s}` does not apply with `sparkplug`: the published points are the \
                         metrics of the edge node (topics spBv1.0/GROUP/NDATA/EDGE_NODE, protobuf \
                         payloads); remove `{s}` or `sparkplug`",
                        at(decl, s)
                    ));
                }
            }
        }
        if !problems.is_empty() {
            return Err(error(name, problems.join(&format!("\nmodule {name}: "))));
        }
        Ok(Settings {
            broker: broker.expect("checked above"),
            topic_prefix,
            client_id,
            format,
            username,
            password_file,
            tls,
            keep_alive,
            backoff_max,
            max_payload,
            stale,
            sparkplug,
        })
    }
}

/// A published point.
#[derive(Clone, Debug)]
pub struct Published {
    pub point: String,
    pub handle: Handle,
    pub topic: String,
}

/// What a subscribed point takes while the broker is away.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fallback {
    Hold,
    Safe(PointValue),
}

/// A subscribed point.
#[derive(Clone, Debug)]
pub struct Subscribed {
    pub topic: String,
    pub point: String,
    pub handle: Handle,
    pub fallback: Fallback,
    pub origin: String,
}

/// The checked rows of a section.
#[derive(Clone, Debug, Default)]
pub struct Plan {
    pub publish: Vec<Published>,
    pub subscribe: Vec<Subscribed>,
    pub stale: Option<Handle>,
}

/// Reads and checks the `publish` and `subscribe` rows against the points.
pub fn plan(ctx: &InitContext<'_>, settings: &Settings, prefix: &str) -> Result<Plan, ModuleError> {
    let name = ctx.decl.name.as_str();
    let rows: Vec<&Row> = common::rows(ctx, KIND, TABLES)?;
    let map: &ModuleMap = ctx.map;
    let mut problems: Vec<String> = Vec::new();
    let mut plan = Plan::default();
    let owner = |point: &str| {
        ctx.config
            .points
            .iter()
            .find(|p| p.name == point)
            .map(|p| p.owner.clone())
            .unwrap_or_default()
    };
    for row in &rows {
        let at = &row.origin;
        match row.table.as_str() {
            "publish" => {
                if row.cells.is_empty() {
                    problems.push(format!("{at}: a publish row is `publish POINT...`"));
                }
                for point in &row.cells {
                    let handle = match map.handle(point) {
                        Ok(h) => h,
                        Err(e) => {
                            problems.push(format!("{at}: `publish {point}`: {e}"));
                            continue;
                        }
                    };
                    if plan.publish.iter().any(|p| &p.point == point) {
                        problems.push(format!(
                            "{at}: point `{point}` is published twice; keep one"
                        ));
                        continue;
                    }
                    plan.publish.push(Published {
                        point: point.clone(),
                        handle,
                        topic: format!("{prefix}/{point}"),
                    });
                }
            }
            "subscribe" => {
                let (topic, point, fallback) = match row.cells.as_slice() {
                    [t, p] => (t, p, None),
                    [t, p, f] => (t, p, Some(f.as_str())),
                    _ => {
                        problems.push(format!(
                            "{at}: a subscribe row is `subscribe TOPIC POINT [hold|SAFE_VALUE]`"
                        ));
                        continue;
                    }
                };
                if let Err(why) = check_topic(topic) {
                    problems.push(format!("{at}: `subscribe {topic} {point}`: {why}"));
                    continue;
                }
                let handle = match map.handle(point) {
                    Ok(h) => h,
                    Err(e) => {
                        problems.push(format!("{at}: `subscribe {topic} {point}`: {e}"));
                        continue;
                    }
                };
                if !map.owns(&handle) {
                    problems.push(format!(
                        "{at}: `subscribe {topic} {point}`: point `{point}` is owned by module \
                         `{}`; a subscribed point takes its value from the broker, so this \
                         module must own it: declare `point {point} \"...\" {name}`",
                        owner(point)
                    ));
                    continue;
                }
                if plan.subscribe.iter().any(|s| &s.point == point) {
                    problems.push(format!(
                        "{at}: point `{point}` is subscribed twice; a point takes its value from \
                         one topic"
                    ));
                    continue;
                }
                let fallback = match fallback {
                    None | Some("hold") => Fallback::Hold,
                    Some(v) => match safe_value(v, handle.kind(), handle.bits()) {
                        Ok(v) => Fallback::Safe(v),
                        Err(why) => {
                            problems.push(format!(
                                "{at}: `subscribe {topic} {point} {v}`: {why}; the last cell is \
                                 `hold` (keep the last value while the broker is away, the \
                                 default) or the safe value to take then"
                            ));
                            continue;
                        }
                    },
                };
                plan.subscribe.push(Subscribed {
                    topic: topic.clone(),
                    point: point.clone(),
                    handle,
                    fallback,
                    origin: at.to_string(),
                });
            }
            _ => unreachable!("common::rows refuses other tables"),
        }
    }
    for s in &plan.subscribe {
        if settings.sparkplug.is_some() {
            if s.topic
                .starts_with(&format!("{}/", crate::sparkplug::NAMESPACE))
            {
                problems.push(format!(
                    "{}: `subscribe {}`: Sparkplug B topics carry protobuf payloads, not values; \
                     subscribe to a plain topic",
                    s.origin, s.topic
                ));
            }
            continue;
        }
        if let Some(p) = plan.publish.iter().find(|p| p.topic == s.topic) {
            problems.push(format!(
                "{}: topic `{}` is both published (point {}) and subscribed (point {}): the \
                 module would read back its own value",
                s.origin, s.topic, p.point, s.point
            ));
        }
    }
    if let Some(stale) = &settings.stale {
        match map.handle(stale) {
            Ok(h) if !map.owns(&h) => problems.push(format!(
                "`stale = {stale}`: point `{stale}` is owned by module `{}`; declare \
                 `point {stale} \"broker unreachable\" {name}`",
                owner(stale)
            )),
            Ok(h) if h.kind() == PointKind::Float => problems.push(format!(
                "`stale = {stale}`: a stale flag is a bool (or integer) point, not a float"
            )),
            Ok(_) if plan.subscribe.iter().any(|s| s.point == *stale) => problems.push(format!(
                "`stale = {stale}`: point `{stale}` is also subscribed; use a point of its own"
            )),
            Ok(h) => plan.stale = Some(h),
            Err(e) => problems.push(format!(
                "`stale = {stale}`: {e}; declare `point {stale} \"broker unreachable\" {name}`"
            )),
        }
    }
    if plan.publish.is_empty() && plan.subscribe.is_empty() {
        problems.push(format!(
            "nothing to do: add `publish POINT...` or `subscribe TOPIC POINT` rows to [{name}]"
        ));
    }
    if problems.is_empty() {
        Ok(plan)
    } else {
        Err(error(name, problems.join(&format!("\nmodule {name}: "))))
    }
}

fn safe_value(text: &str, kind: PointKind, bits: u8) -> Result<PointValue, String> {
    payload::decode(text.as_bytes())
        .and_then(|n| payload::to_point(n, kind, bits))
        .map_err(|why| {
            format!(
                "`{text}` {why} for a {} point",
                payload::type_name(kind, bits)
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, expect: Result<(&str, u16, bool), &str>) {
        match (Broker::parse(text), expect) {
            (Ok(b), Ok((h, p, t))) => assert_eq!((b.host.as_str(), b.port, b.tls), (h, p, t)),
            (Err(e), Err(why)) => assert!(e.contains(why), "{text}: {e}"),
            (got, want) => panic!("{text}: got {got:?}, expected {want:?}"),
        }
    }

    #[test]
    fn broker_addresses() {
        check("127.0.0.1:1883", Ok(("127.0.0.1", 1883, false)));
        check("localhost", Ok(("localhost", 1883, false)));
        check("mqtt://broker.lan:1884", Ok(("broker.lan", 1884, false)));
        check("mqtts://broker.lan", Ok(("broker.lan", 8883, true)));
        check("mqtts://broker.lan:8884/", Ok(("broker.lan", 8884, true)));
        check("[::1]:1883", Ok(("::1", 1883, false)));
        check("mqtts://[fe80::1]", Ok(("fe80::1", 8883, true)));
        check("::1:1883", Err("IPv6"));
        check("ws://x:1", Err("only mqtt://"));
        check("host:0", Err("port is 1 to 65535"));
        check("host:x", Err("port is 1 to 65535"));
        check(":1883", Err("write HOST:PORT"));
        assert_eq!(Broker::parse("[::1]:5").unwrap().to_string(), "[::1]:5");
        assert_eq!(
            Broker::parse("mqtts://h").unwrap().to_string(),
            "mqtts://h:8883"
        );
    }

    #[test]
    fn sizes() {
        assert_eq!(parse_size("65536"), Some(65536));
        assert_eq!(parse_size("64 KiB"), Some(65536));
        assert_eq!(parse_size("1MiB"), Some(1 << 20));
        assert_eq!(parse_size("2 GiB"), None);
        assert_eq!(parse_size("-1"), None);
        assert_eq!(parse_size(""), None);
        assert_eq!(parse_size("99999999999999999999999"), None);
    }

    #[test]
    fn topics_have_no_wildcards() {
        assert!(check_topic("cell/a/N1").is_ok());
        assert!(check_topic("cell/+/N1").is_err());
        assert!(check_topic("#").is_err());
        assert!(check_topic("").is_err());
    }
}
