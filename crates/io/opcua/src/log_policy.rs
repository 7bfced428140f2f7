//! How `petriplc run`'s log shows the lines of the OPC UA stack (async-opcua, which logs
//! through `tracing`'s `log` records, targets `opcua_*`) and this module's per-client lines:
//! what a client does (connects, sends garbage, stays idle, guesses passwords) is not an
//! ERROR an operator must act on, and a flood of it is rate-limited (docs/opcua.md, "Log").

use log::{Level, Record};

/// Lines about the server's own certificate and key that are never news: without an
/// encrypted endpoint there is no certificate by design (yet the stack looks for it at start
/// and for every connection), and with one, `init` has made or checked it — reporting what
/// is wrong with its fix — before the stack starts.
const OWN_CERTIFICATE: &[&str] = &[
    "Failed to read own certificate",
    "Failed to read own private key",
    "Failed to get cert",
    "Server is missing its application instance certificate",
    "Folder for storing certificates cannot be examined",
];

/// The level a line is shown at and whether its repeats are rate-limited, for the lines of
/// the OPC UA stack and this module's per-client lines; `None` for any other line.
///
/// - the stack's lines about the server's own certificate: DEBUG;
/// - the stack's INFO lines (every connection accepted, handshake, session created and
///   closed; the endpoints at start, which the module's own `listening on …` line sums up):
///   DEBUG;
/// - the stack's WARN and ERROR lines (a client's garbage, an idle connection timing out, a
///   failed request): WARN, rate-limited; a panic inside the stack stays an ERROR;
/// - this module's refusal of a user (a wrong password): WARN, rate-limited.
pub fn log_policy(record: &Record<'_>) -> Option<(Level, bool)> {
    let target = record.target();
    if target.starts_with("petriplc_opcua") {
        let refusal =
            record.level() <= Level::Warn && record.args().to_string().contains(": refused user `");
        return refusal.then_some((Level::Warn, true));
    }
    // A span's lines have the target `tracing::span` and the stack's module path.
    let stack = |s: &str| s.starts_with("opcua_");
    if !(stack(target) || record.module_path().is_some_and(stack)) {
        return None;
    }
    let level = record.level();
    if level > Level::Info {
        return Some((level, false));
    }
    let text = record.args().to_string();
    if OWN_CERTIFICATE.iter().any(|m| text.starts_with(m)) {
        return Some((Level::Debug, false));
    }
    Some(match level {
        Level::Info => (Level::Debug, false),
        _ if text.contains("panic") => (Level::Error, true),
        _ => (Level::Warn, true),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(target: &str, level: Level, text: &str, expect: Option<(Level, bool)>) {
        // A line's module path is its target's, except for spans (`tracing::span`).
        let module = match target.split_once(' ') {
            Some((t, m)) => (t, m),
            None => (target, target),
        };
        let got = log_policy(
            &Record::builder()
                .target(module.0)
                .module_path(Some(module.1))
                .level(level)
                .args(format_args!("{text}"))
                .build(),
        );
        assert_eq!(got, expect, "{target} {level} {text}");
    }

    #[test]
    fn the_stack_logs_no_error_for_what_clients_do() {
        // What security = none logged for every connection, and at start.
        check(
            "opcua_core::comms::secure_channel",
            Level::Error,
            "Failed to read own certificate: Cannot read cert from path \"x\"",
            Some((Level::Debug, false)),
        );
        check(
            "opcua_core::comms::secure_channel",
            Level::Error,
            "Failed to read own private key: Cannot read pkey",
            Some((Level::Debug, false)),
        );
        check(
            "opcua_crypto::certificate_store",
            Level::Error,
            "Failed to get cert and private key: a, b",
            Some((Level::Debug, false)),
        );
        check(
            "opcua_server::server",
            Level::Warn,
            "Server is missing its application instance certificate and/or its private key.",
            Some((Level::Debug, false)),
        );
        // Every idle or garbage connection.
        check(
            "opcua_server::session::controller",
            Level::Error,
            "Connection failed while waiting for channel to be established: BadTimeout",
            Some((Level::Warn, true)),
        );
        check(
            "opcua_core::comms::tcp_types",
            Level::Error,
            "message type doesn't match anything",
            Some((Level::Warn, true)),
        );
        check(
            "opcua_server::server",
            Level::Info,
            "Accept new connection from 127.0.0.1:4711 (3)",
            Some((Level::Debug, false)),
        );
        check(
            "tracing::span opcua_server::session::controller",
            Level::Info,
            "++ Establish TCP channel; span=3",
            Some((Level::Debug, false)),
        );
        check(
            "tracing::span petriplc_hmi",
            Level::Info,
            "++ request;",
            None,
        );
        check(
            "opcua_server::server",
            Level::Error,
            "Connection panic! boom",
            Some((Level::Error, true)),
        );
        check(
            "opcua_server::server",
            Level::Debug,
            "anything",
            Some((Level::Debug, false)),
        );
        // This module's lines: only the refusals of users are rate-limited.
        check(
            "petriplc_opcua::space",
            Level::Warn,
            "opcua_server opcua: refused user `op` (unknown user or wrong password)",
            Some((Level::Warn, true)),
        );
        check(
            "petriplc_opcua",
            Level::Info,
            "opcua_server opcua: listening on opc.tcp://127.0.0.1:4840/",
            None,
        );
        check("petriplc_plc", Level::Error, "module calc failed", None);
    }
}
