//! The settings of an `opcua_server` section, checked before anything starts: every problem
//! is reported at once with the setting's file:line and how to fix it.

use std::net::{SocketAddr, ToSocketAddrs};
use std::path::PathBuf;

use petriplc_config::ModuleDecl;
use petriplc_modules::common::{self, error};
use petriplc_runtime::module::ModuleError;

pub const KIND: &str = "opcua_server";

/// The settings an `opcua_server` section may have (besides the runner's).
pub const SETTINGS: &[&str] = &[
    "listen",
    "security",
    "anonymous",
    "users",
    "state_dir",
    "trust_client_certs",
    "max_sessions",
];

/// `listen` when the section has none (4840 is OPC UA's registered port).
pub const DEFAULT_LISTEN: &str = "127.0.0.1:4840";
pub const DEFAULT_MAX_SESSIONS: usize = 20;

/// What anonymous sessions may do.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Anonymous {
    No,
    Read,
    Write,
}

/// The endpoints offered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Security {
    /// Security policy None (no signing, no encryption): loopback only.
    pub none: bool,
    /// Basic256Sha256 and Aes256-Sha256-RsaPss, Sign & Encrypt.
    pub encrypt: bool,
}

/// The checked settings.
#[derive(Clone, Debug)]
pub struct Settings {
    pub listen: SocketAddr,
    pub security: Security,
    pub anonymous: Anonymous,
    /// The password file, as written (relative to the configuration's folder).
    pub users: Option<PathBuf>,
    /// `None`: the default, `$XDG_STATE_HOME/petriplc/PLCID/MODULE`.
    pub state_dir: Option<PathBuf>,
    pub trust_client_certs: bool,
    pub max_sessions: usize,
}

fn at(decl: &ModuleDecl, setting: &str) -> String {
    decl.settings
        .get(setting)
        .filter(|s| !s.origin.file.is_empty())
        .map(|s| format!("{}: ", s.origin))
        .unwrap_or_default()
}

/// `HOST:PORT` as the Modbus server reads it (a name is resolved once, at start).
pub fn parse_listen(text: &str) -> Result<SocketAddr, String> {
    let fix = format!(
        "`listen = {text}`: write HOST:PORT (e.g. {DEFAULT_LISTEN}, 0.0.0.0:4840, [::1]:4840; \
         port 0 picks a free one)"
    );
    if let Ok(a) = text.parse::<SocketAddr>() {
        return Ok(a);
    }
    match text.to_socket_addrs() {
        Ok(mut addrs) => addrs.next().ok_or(fix),
        Err(e) => Err(format!("{fix} ({e})")),
    }
}

impl Settings {
    pub fn parse(decl: &ModuleDecl) -> Result<Settings, ModuleError> {
        common::check_decl(decl, KIND, SETTINGS)?;
        let name = decl.name.as_str();
        let mut problems: Vec<String> = Vec::new();
        let listen_text = common::setting(decl, "listen").unwrap_or(DEFAULT_LISTEN);
        let listen = parse_listen(listen_text)
            .map_err(|why| problems.push(format!("{}{why}", at(decl, "listen"))))
            .unwrap_or_else(|()| DEFAULT_LISTEN.parse().expect("a valid address"));
        let loopback = listen.ip().is_loopback();
        let security = match common::setting(decl, "security") {
            None if loopback => Security {
                none: true,
                encrypt: false,
            },
            None => Security {
                none: false,
                encrypt: true,
            },
            Some(v) => {
                let mut s = Security {
                    none: false,
                    encrypt: false,
                };
                for word in v.split([',', ' ']).filter(|w| !w.is_empty()) {
                    match word {
                        "none" => s.none = true,
                        "encrypt" | "sign_encrypt" | "basic256sha256" => s.encrypt = true,
                        other => problems.push(format!(
                            "{}`security = {v}`: unknown `{other}`; write `none` (loopback \
                             only), `encrypt` (Basic256Sha256 and Aes256-Sha256-RsaPss, Sign & \
                             Encrypt) or both: `none, encrypt`",
                            at(decl, "security")
                        )),
                    }
                }
                if !s.none && !s.encrypt {
                    problems.push(format!(
                        "{}`security` names no endpoint; write `none` or `encrypt`",
                        at(decl, "security")
                    ));
                }
                s
            }
        };
        if security.none && !loopback {
            problems.push(format!(
                "{}security policy None on {listen}: without signing or encryption anyone on \
                 the network could read and write points; it is allowed on a loopback \
                 address only. Write `security = encrypt` (and `users = FILE`), or listen on \
                 127.0.0.1",
                at(decl, "security")
            ));
        }
        let anonymous = match common::setting(decl, "anonymous") {
            None | Some("no" | "off" | "false") => Anonymous::No,
            Some("read" | "read_only") => Anonymous::Read,
            Some("yes" | "write" | "read_write") => Anonymous::Write,
            Some(v) => {
                problems.push(format!(
                    "{}`anonymous = {v}`: write `no` (the default), `read` (browse, read and \
                     subscribe, no writes) or `write`",
                    at(decl, "anonymous")
                ));
                Anonymous::No
            }
        };
        let users = common::setting(decl, "users")
            .filter(|s| !s.is_empty())
            .map(PathBuf::from);
        if anonymous == Anonymous::No && users.is_none() {
            problems.push(format!(
                "nobody could connect: anonymous access is off and there is no `users` file; \
                 add `users = opcua.users` (lines `NAME:BCRYPT_HASH`, made by `petriplc user \
                 add opcua.users NAME`) or `anonymous = read` to [{name}]"
            ));
        }
        let state_dir = common::setting(decl, "state_dir")
            .filter(|s| !s.is_empty())
            .map(PathBuf::from);
        let trust_client_certs = common::flag(decl, "trust_client_certs")?;
        let max_sessions = match common::setting(decl, "max_sessions") {
            None => DEFAULT_MAX_SESSIONS,
            Some(v) => match v.parse::<usize>() {
                Ok(n) if (1..=1000).contains(&n) => n,
                _ => {
                    problems.push(format!(
                        "{}`max_sessions = {v}`: write a whole number from 1 to 1000",
                        at(decl, "max_sessions")
                    ));
                    DEFAULT_MAX_SESSIONS
                }
            },
        };
        if !problems.is_empty() {
            return Err(error(name, problems.join(&format!("\nmodule {name}: "))));
        }
        Ok(Settings {
            listen,
            security,
            anonymous,
            users,
            state_dir,
            trust_client_certs,
            max_sessions,
        })
    }
}
