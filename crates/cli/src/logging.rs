//! Where `petriplc run` sends its log lines besides `--log FILE`: the terminal, the systemd
//! journal (its native protocol, with the priority of each line and the PLC id as fields;
//! chosen by itself when systemd connected standard error to the journal, which it says in
//! `JOURNAL_STREAM`), or syslog (RFC 3164, to the local socket, another Unix socket or a
//! remote host over UDP, as MatPLC's log library planned to forward its messages).

use std::path::PathBuf;

use log::{LevelFilter, Log, Metadata, Record};
use simplelog::{Config, SharedLogger};

/// `--log-to`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LogTo {
    /// The journal when systemd runs the PLC, else the terminal.
    Auto,
    Terminal,
    Journal,
    Syslog(SyslogAt),
}

/// Where syslog is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SyslogAt {
    /// The local syslog socket (`/dev/log`, …).
    Local,
    /// A Unix datagram socket.
    Unix(PathBuf),
    /// `HOST:PORT`, over UDP.
    Udp(String),
}

pub fn parse_log_to(s: &str) -> Result<LogTo, String> {
    Ok(match s {
        "auto" => LogTo::Auto,
        "terminal" => LogTo::Terminal,
        "journal" => LogTo::Journal,
        "syslog" => LogTo::Syslog(SyslogAt::Local),
        _ => match s.strip_prefix("syslog:") {
            Some(p) if p.starts_with('/') || p.starts_with('.') => {
                LogTo::Syslog(SyslogAt::Unix(PathBuf::from(p)))
            }
            Some(a)
                if a.rsplit_once(':')
                    .is_some_and(|(h, port)| !h.is_empty() && port.parse::<u16>().is_ok()) =>
            {
                LogTo::Syslog(SyslogAt::Udp(a.to_string()))
            }
            _ => {
                return Err(format!(
                    "`{s}`: write auto, terminal, journal, syslog, syslog:/PATH/OF/SOCKET or \
                     syslog:HOST:PORT"
                ))
            }
        },
    })
}

/// Whether systemd connected this process's standard error (or output) to the journal.
pub fn under_journal() -> bool {
    std::env::var_os("JOURNAL_STREAM").is_some() && systemd_journal_logger::connected_to_journal()
}

/// The logger that replaces the terminal's, or `None` for the terminal; `Err` says why the
/// one asked for cannot be used.
pub fn system_logger(
    to: &LogTo,
    level: LevelFilter,
    plc_id: &str,
) -> Result<Option<Box<dyn SharedLogger>>, String> {
    let journal = match to {
        LogTo::Terminal => return Ok(None),
        LogTo::Auto if !under_journal() => return Ok(None),
        LogTo::Auto | LogTo::Journal => true,
        LogTo::Syslog(_) => false,
    };
    if journal {
        let j = systemd_journal_logger::JournalLog::new()
            .map_err(|e| format!("cannot log to the systemd journal: {e}"))?
            .with_syslog_identifier("petriplc".to_string())
            .with_extra_fields([("PETRIPLC_PLC_ID", plc_id)]);
        return Ok(Some(Box::new(Leveled { level, inner: j })));
    }
    let LogTo::Syslog(at) = to else {
        return Ok(None);
    };
    let formatter = syslog::Formatter3164 {
        facility: syslog::Facility::LOG_DAEMON,
        hostname: None,
        process: "petriplc".into(),
        pid: std::process::id(),
    };
    let logger = match at {
        SyslogAt::Local => syslog::unix(formatter),
        SyslogAt::Unix(p) => syslog::unix_custom(formatter, p),
        SyslogAt::Udp(a) => syslog::udp(formatter, "0.0.0.0:0", a.as_str()),
    }
    .map_err(|e| format!("cannot log to syslog: {e}"))?;
    Ok(Some(Box::new(Leveled {
        level,
        inner: syslog::BasicLogger::new(logger),
    })))
}

/// A `log` logger with a level, as simplelog combines them.
struct Leveled<L> {
    level: LevelFilter,
    inner: L,
}

impl<L: Log> Log for Leveled<L> {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        metadata.level() <= self.level
    }

    fn log(&self, record: &Record<'_>) {
        if self.enabled(record.metadata()) {
            self.inner.log(record);
        }
    }

    fn flush(&self) {
        self.inner.flush();
    }
}

impl<L: Log + 'static> SharedLogger for Leveled<L> {
    fn level(&self) -> LevelFilter {
        self.level
    }

    fn config(&self) -> Option<&Config> {
        None
    }

    fn as_log(self: Box<Self>) -> Box<dyn Log> {
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(input: &str, expect: Result<LogTo, &str>) {
        assert_eq!(
            parse_log_to(input).map_err(|e| e.to_string()),
            expect.map_err(String::from)
        );
    }

    #[test]
    fn destinations() {
        check("auto", Ok(LogTo::Auto));
        check("journal", Ok(LogTo::Journal));
        check("syslog", Ok(LogTo::Syslog(SyslogAt::Local)));
        check(
            "syslog:/run/log.sock",
            Ok(LogTo::Syslog(SyslogAt::Unix("/run/log.sock".into()))),
        );
        check(
            "syslog:logs.plant:514",
            Ok(LogTo::Syslog(SyslogAt::Udp("logs.plant:514".into()))),
        );
        check(
            "syslog:logs.plant",
            Err(
                "`syslog:logs.plant`: write auto, terminal, journal, syslog, \
                 syslog:/PATH/OF/SOCKET or syslog:HOST:PORT",
            ),
        );
        check(
            "file",
            Err(
                "`file`: write auto, terminal, journal, syslog, syslog:/PATH/OF/SOCKET or \
                 syslog:HOST:PORT",
            ),
        );
    }
}
