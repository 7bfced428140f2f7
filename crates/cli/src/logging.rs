//! Where `petriplc run` sends its log lines besides `--log FILE`: the terminal, the systemd
//! journal (its native protocol, with the priority of each line and the PLC id as fields;
//! chosen by itself when systemd connected standard error to the journal, which it says in
//! `JOURNAL_STREAM`), or syslog (RFC 3164, to the local socket, another Unix socket or a
//! remote host over UDP, as MatPLC's log library planned to forward its messages); and
//! [`Policed`], the one place where third-party crates' lines are given the level they
//! deserve and floods of them are rate-limited.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use log::{Level, LevelFilter, Log, Metadata, Record};
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

/// What a crate says about its log lines (or a third-party crate's under it): the level a
/// line is shown at and whether its repeats are rate-limited, or `None` for lines it does
/// not know. `petriplc_opcua::log_policy` is one.
pub type Policy = fn(&Record<'_>) -> Option<(Level, bool)>;

/// The window of the rate limit: the first line of a kind is shown, the rest of the window
/// counted and summed up in one line when it ends.
pub const WINDOW: Duration = Duration::from_secs(60);

/// A logger that shows each line at the level its crate's [`Policy`] gives it, and lets a
/// rate-limited kind of line (one place in the code) through once per [`WINDOW`], followed
/// by `N more like this in the last S s` when the window ends (or at [`Log::flush`]).
pub struct Policed {
    level: LevelFilter,
    policies: Vec<Policy>,
    shared: Arc<Shared>,
}

struct Shared {
    inner: Box<dyn Log>,
    limiter: Mutex<Limiter>,
    /// Wakes the thread that writes the summaries when a window starts.
    wake: Condvar,
}

impl Policed {
    /// Wraps `inner` (which shows lines up to `level`); starts the thread that writes the
    /// summaries of windows that end while nothing else is logged.
    pub fn new(inner: Box<dyn Log>, level: LevelFilter, policies: Vec<Policy>) -> Policed {
        let shared = Arc::new(Shared {
            inner,
            limiter: Mutex::new(Limiter::default()),
            wake: Condvar::new(),
        });
        let summaries = Arc::clone(&shared);
        // Without the thread the summaries still come, at the next line or at the end.
        let _ = std::thread::Builder::new()
            .name("log summaries".into())
            .spawn(move || summaries.summarise_forever());
        Policed {
            level,
            policies,
            shared,
        }
    }
}

impl Shared {
    fn limiter(&self) -> MutexGuard<'_, Limiter> {
        self.limiter.lock().unwrap_or_else(PoisonError::into_inner)
    }

    fn summarise_forever(&self) {
        let mut limiter = self.limiter();
        loop {
            let now = Instant::now();
            let due = limiter.due(now, false);
            if !due.is_empty() {
                drop(limiter);
                self.write(&due);
                limiter = self.limiter();
                continue;
            }
            limiter = match limiter.next_end() {
                Some(end) => {
                    let wait = end.saturating_duration_since(now);
                    self.wake
                        .wait_timeout(limiter, wait)
                        .unwrap_or_else(PoisonError::into_inner)
                        .0
                }
                None => self
                    .wake
                    .wait(limiter)
                    .unwrap_or_else(PoisonError::into_inner),
            };
        }
    }

    fn write(&self, summaries: &[Summary]) {
        for s in summaries {
            self.inner.log(
                &Record::builder()
                    .level(s.level)
                    .target(&s.target)
                    .args(format_args!(
                        "{} more like this in the last {} s: {}",
                        s.more,
                        s.secs.max(1),
                        s.first
                    ))
                    .build(),
            );
        }
    }
}

impl Log for Policed {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        // A policy only ever lowers a line's level: one above ours is not shown either way.
        metadata.level() <= self.level
    }

    fn log(&self, record: &Record<'_>) {
        let (level, limited) = self
            .policies
            .iter()
            .find_map(|p| p(record))
            .unwrap_or((record.level(), false));
        if level > self.level {
            return;
        }
        if limited {
            let key = Kind {
                target: record.target().to_string(),
                file: record.file().map(str::to_string),
                line: record.line(),
                level,
            };
            let (show, summary) = {
                let mut limiter = self.shared.limiter();
                let started = !limiter.bursts.contains_key(&key);
                let decision = limiter.admit(key, || record.args().to_string(), Instant::now());
                if started {
                    self.shared.wake.notify_one();
                }
                decision
            };
            self.shared.write(summary.as_slice());
            if !show {
                return;
            }
        }
        self.shared.inner.log(
            &Record::builder()
                .level(level)
                .target(record.target())
                .module_path(record.module_path())
                .file(record.file())
                .line(record.line())
                .args(*record.args())
                .build(),
        );
    }

    fn flush(&self) {
        let due = self.shared.limiter().due(Instant::now(), true);
        self.shared.write(&due);
        self.shared.inner.flush();
    }
}

/// One kind of rate-limited line: a place in the code (its target if the file and line are
/// not known) at a level. Bounded in number by the code, whatever a client sends.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct Kind {
    target: String,
    file: Option<String>,
    line: Option<u32>,
    level: Level,
}

/// The lines of one kind in the current window.
#[derive(Debug)]
struct Burst {
    since: Instant,
    /// The line shown, for the summary (cut to 200 characters).
    first: String,
    /// Lines not shown.
    more: u64,
}

/// A summary to write: `more` lines like `first` were not shown over `secs` seconds.
#[derive(Debug, PartialEq)]
struct Summary {
    level: Level,
    target: String,
    first: String,
    more: u64,
    secs: u64,
}

/// The rate limit, time passed in.
#[derive(Debug, Default)]
struct Limiter {
    bursts: HashMap<Kind, Burst>,
}

impl Limiter {
    /// Whether a line of `kind` is shown now, and the summary of its previous window if that
    /// just ended.
    fn admit(
        &mut self,
        kind: Kind,
        text: impl FnOnce() -> String,
        now: Instant,
    ) -> (bool, Option<Summary>) {
        match self.bursts.get_mut(&kind) {
            Some(b) if now.saturating_duration_since(b.since) < WINDOW => {
                b.more += 1;
                (false, None)
            }
            _ => {
                let summary = self
                    .bursts
                    .remove(&kind)
                    .and_then(|b| summary(&kind, b, now));
                let first: String = text().chars().take(200).collect();
                self.bursts.insert(
                    kind,
                    Burst {
                        since: now,
                        first,
                        more: 0,
                    },
                );
                (true, summary)
            }
        }
    }

    /// The summaries of the windows that have ended (`all`: of every window, as the log
    /// ends), in a stable order; their kinds start afresh.
    fn due(&mut self, now: Instant, all: bool) -> Vec<Summary> {
        let ended: Vec<Kind> = self
            .bursts
            .iter()
            .filter(|(_, b)| all || now.saturating_duration_since(b.since) >= WINDOW)
            .map(|(k, _)| k.clone())
            .collect();
        let mut out: Vec<(Instant, Summary)> = Vec::new();
        for k in ended {
            if let Some(b) = self.bursts.remove(&k) {
                let since = b.since;
                out.extend(summary(&k, b, now).map(|s| (since, s)));
            }
        }
        out.sort_by(|a, b| a.0.cmp(&b.0).then_with(|| a.1.first.cmp(&b.1.first)));
        out.into_iter().map(|(_, s)| s).collect()
    }

    /// When the first window ends.
    fn next_end(&self) -> Option<Instant> {
        self.bursts.values().map(|b| b.since + WINDOW).min()
    }
}

fn summary(kind: &Kind, b: Burst, now: Instant) -> Option<Summary> {
    (b.more > 0).then(|| Summary {
        level: kind.level,
        target: kind.target.clone(),
        first: b.first,
        more: b.more,
        secs: now
            .saturating_duration_since(b.since)
            .min(WINDOW)
            .as_secs_f64()
            .round() as u64,
    })
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

#[cfg(test)]
mod limiter_tests {
    use super::*;

    fn kind(line: u32) -> Kind {
        Kind {
            target: "opcua_server::session::controller".into(),
            file: Some("controller.rs".into()),
            line: Some(line),
            level: Level::Warn,
        }
    }

    fn admit(l: &mut Limiter, line: u32, text: &str, at: Instant) -> (bool, Option<Summary>) {
        l.admit(kind(line), || text.to_string(), at)
    }

    #[test]
    fn a_flood_of_one_kind_is_one_line_and_a_count_per_window() {
        let t0 = Instant::now();
        let s = Duration::from_secs;
        let mut l = Limiter::default();
        assert_eq!(admit(&mut l, 147, "timeout 0", t0), (true, None));
        for i in 1..300 {
            assert_eq!(admit(&mut l, 147, "timeout", t0 + s(i % 50)), (false, None));
        }
        // Another kind has its own window.
        assert_eq!(admit(&mut l, 173, "garbage", t0 + s(1)), (true, None));
        assert_eq!(l.next_end(), Some(t0 + WINDOW));
        assert!(l.due(t0 + s(59), false).is_empty());
        // The window ends: one summary; the garbage line had no repeats.
        assert_eq!(
            l.due(t0 + s(61), false),
            vec![Summary {
                level: Level::Warn,
                target: "opcua_server::session::controller".into(),
                first: "timeout 0".into(),
                more: 299,
                secs: 60,
            }]
        );
        assert!(l.bursts.is_empty());
        // The next line is shown at once and opens a new window.
        assert_eq!(admit(&mut l, 147, "timeout 1", t0 + s(62)), (true, None));
        assert_eq!(admit(&mut l, 147, "timeout", t0 + s(63)), (false, None));
        // A line after the window ends, before the summary thread wrote it: summary first.
        let (shown, summary) = admit(&mut l, 147, "timeout 2", t0 + s(130));
        assert!(shown);
        assert_eq!(summary.map(|s| (s.more, s.secs)), Some((1, 60)));
        // At the end of the log every window is summed up, however young.
        admit(&mut l, 147, "timeout", t0 + s(131));
        let last = l.due(t0 + s(140), true);
        assert_eq!(last.len(), 1);
        assert_eq!((last[0].more, last[0].secs), (1, 10));
    }

    #[test]
    fn the_first_line_is_kept_short() {
        let mut l = Limiter::default();
        let t0 = Instant::now();
        admit(&mut l, 1, &"x".repeat(100_000), t0);
        admit(&mut l, 1, "y", t0);
        assert_eq!(l.due(t0, true)[0].first.len(), 200);
    }

    /// Lines and summaries as the wrapped logger saw them.
    struct Seen(Arc<Mutex<Vec<String>>>);

    impl Log for Seen {
        fn enabled(&self, _: &Metadata<'_>) -> bool {
            true
        }
        fn log(&self, r: &Record<'_>) {
            self.0
                .lock()
                .unwrap()
                .push(format!("{} {}", r.level(), r.args()));
        }
        fn flush(&self) {}
    }

    fn stack_policy(r: &Record<'_>) -> Option<(Level, bool)> {
        match r.target() {
            "stack" if r.level() == Level::Info => Some((Level::Debug, false)),
            "stack" => Some((Level::Warn, true)),
            _ => None,
        }
    }

    #[test]
    fn policies_set_the_level_and_the_limit_of_their_lines() {
        let seen = Arc::new(Mutex::new(Vec::new()));
        let log = Policed::new(
            Box::new(Seen(Arc::clone(&seen))),
            LevelFilter::Info,
            vec![stack_policy],
        );
        let line = |target: &str, level: Level, text: &str| {
            log.log(
                &Record::builder()
                    .target(target)
                    .level(level)
                    .file(Some("x.rs"))
                    .line(Some(7))
                    .args(format_args!("{text}"))
                    .build(),
            );
        };
        for i in 0..300 {
            line("stack", Level::Error, &format!("idle connection {i}"));
            line("stack", Level::Info, "accepted");
        }
        line("petriplc_plc", Level::Error, "module calc failed");
        line("petriplc_plc", Level::Error, "module calc failed");
        log.flush();
        let seen = seen.lock().unwrap();
        assert_eq!(
            seen[..3],
            [
                "WARN idle connection 0",
                "ERROR module calc failed",
                "ERROR module calc failed",
            ]
        );
        // However long the test took (the seconds are the window's so far).
        assert_eq!(seen.len(), 4, "{seen:?}");
        assert!(
            seen[3].starts_with("WARN 299 more like this in the last ")
                && seen[3].ends_with(" s: idle connection 0"),
            "{seen:?}"
        );
    }
}
