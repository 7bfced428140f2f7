//! A log that never makes a scan wait: lines are handed to a thread of their own, which
//! writes them to the real loggers (the terminal, the journal, a file).
//!
//! Standard error can block: a pipe nobody reads fills up, and every module thread that
//! then logs a line would stop in the middle of its scan, with the watchdogs firing and the
//! PLC looking hung for a reason no log line could say. Here a line goes into a bounded queue
//! and the caller goes on; when the queue is full the line is dropped and counted, and the
//! writer says how many were dropped as soon as it can write again.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::Arc;
use std::time::Duration;

use log::{Level, Log, Metadata, Record};

/// How many lines may wait for the writer: minutes of a busy PLC's log, a few MiB at most.
pub const QUEUE: usize = 16_384;

/// How long the end of a run waits for the last lines to be written.
const FLUSH_WAIT: Duration = Duration::from_secs(5);

enum Msg {
    Line {
        level: Level,
        target: String,
        module_path: Option<String>,
        file: Option<String>,
        line: Option<u32>,
        text: String,
    },
    Flush(SyncSender<()>),
}

/// The logger `log` calls: formats each line on the caller's thread and queues it.
pub struct Queued {
    tx: SyncSender<Msg>,
    dropped: Arc<AtomicU64>,
    level: log::LevelFilter,
}

impl Queued {
    /// Starts the writer thread in front of `inner`, which shows lines up to `level`.
    pub fn new(inner: Box<dyn Log>, level: log::LevelFilter) -> Queued {
        Queued::with_capacity(inner, level, QUEUE)
    }

    fn with_capacity(inner: Box<dyn Log>, level: log::LevelFilter, capacity: usize) -> Queued {
        let (tx, rx) = mpsc::sync_channel(capacity);
        let dropped = Arc::new(AtomicU64::new(0));
        let counter = Arc::clone(&dropped);
        let spawned = std::thread::Builder::new()
            .name("log writer".into())
            .spawn(move || write_forever(&*inner, &rx, &counter));
        if let Err(e) = spawned {
            // Without a writer every line would be dropped: say so once, where it can be seen.
            eprintln!("warning: cannot start the log's writer thread ({e}); no log lines follow");
        }
        Queued { tx, dropped, level }
    }
}

fn write_forever(inner: &dyn Log, rx: &Receiver<Msg>, dropped: &AtomicU64) {
    loop {
        let msg = match rx.recv_timeout(Duration::from_secs(1)) {
            Ok(m) => Some(m),
            Err(RecvTimeoutError::Timeout) => None,
            Err(RecvTimeoutError::Disconnected) => return,
        };
        let lost = dropped.swap(0, Ordering::Relaxed);
        if lost > 0 {
            inner.log(
                &Record::builder()
                    .level(Level::Warn)
                    .target("petriplc")
                    .args(format_args!(
                        "{lost} log line{} dropped: whatever reads the log (standard error, \
                         the journal) did not keep up, and the PLC does not wait for it",
                        if lost == 1 { "" } else { "s" }
                    ))
                    .build(),
            );
        }
        match msg {
            Some(Msg::Line {
                level,
                target,
                module_path,
                file,
                line,
                text,
            }) => inner.log(
                &Record::builder()
                    .level(level)
                    .target(&target)
                    .module_path(module_path.as_deref())
                    .file(file.as_deref())
                    .line(line)
                    .args(format_args!("{text}"))
                    .build(),
            ),
            Some(Msg::Flush(done)) => {
                inner.flush();
                let _ = done.send(());
            }
            None => {}
        }
    }
}

impl Log for Queued {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        metadata.level() <= self.level
    }

    fn log(&self, record: &Record<'_>) {
        if !self.enabled(record.metadata()) {
            return;
        }
        let msg = Msg::Line {
            level: record.level(),
            target: record.target().to_string(),
            module_path: record.module_path().map(str::to_string),
            file: record.file().map(str::to_string),
            line: record.line(),
            text: record.args().to_string(),
        };
        if let Err(TrySendError::Full(_)) = self.tx.try_send(msg) {
            self.dropped.fetch_add(1, Ordering::Relaxed);
        }
    }

    /// Waits (a few seconds at most) until every queued line is written.
    fn flush(&self) {
        let (done, wait) = mpsc::sync_channel(1);
        let (tx, msg) = (self.tx.clone(), Msg::Flush(done));
        // Queued behind the lines already there; a writer stuck on a blocked standard
        // error is not waited for beyond FLUSH_WAIT.
        let sent = std::thread::spawn(move || tx.send(msg).is_ok());
        let deadline = std::time::Instant::now() + FLUSH_WAIT;
        while !sent.is_finished() && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(5));
        }
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        let _ = wait.recv_timeout(left);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Condvar, Mutex};

    /// An inner logger that records lines, and can be made to block like a full pipe.
    #[derive(Default)]
    struct Blocking {
        lines: Mutex<Vec<String>>,
        open: Mutex<bool>,
        opened: Condvar,
    }

    struct Sink(Arc<Blocking>);

    impl Log for Sink {
        fn enabled(&self, _: &Metadata<'_>) -> bool {
            true
        }
        fn log(&self, record: &Record<'_>) {
            let mut open = self.0.open.lock().unwrap();
            while !*open {
                open = self.0.opened.wait(open).unwrap();
            }
            self.0.lines.lock().unwrap().push(record.args().to_string());
        }
        fn flush(&self) {}
    }

    fn line(log: &Queued, text: &str) {
        log.log(
            &Record::builder()
                .level(Level::Info)
                .args(format_args!("{text}"))
                .build(),
        );
    }

    /// Issue 27 (found by the MQTT flood test): with standard error a pipe nobody reads,
    /// a module thread logging a line stopped in its scan. Now the caller never waits: the
    /// lines beyond the queue are dropped, counted and said once the log moves again.
    #[test]
    fn a_blocked_log_never_blocks_the_caller_and_says_what_it_dropped() {
        let inner = Arc::new(Blocking::default());
        let log = Queued::with_capacity(
            Box::new(Sink(Arc::clone(&inner))),
            log::LevelFilter::Info,
            4,
        );
        // Far more lines than the queue holds, while the writer is stuck: all return.
        for k in 0..1000 {
            line(&log, &format!("line {k}"));
        }
        *inner.open.lock().unwrap() = true;
        inner.opened.notify_all();
        log.flush();
        line(&log, "after");
        log.flush();
        let lines = inner.lines.lock().unwrap().clone();
        // The queue's four lines, one more if the writer freed a slot before it blocked, a
        // count before and after that line (when the writer starts late, lines are dropped
        // before it takes the first), and "after": never more, however the threads ran.
        assert!(lines.len() <= 8, "{lines:?}");
        assert!(
            lines.iter().any(|l| l.contains("log lines dropped")),
            "{lines:?}"
        );
        assert_eq!(lines.last().map(String::as_str), Some("after"));
    }
}
