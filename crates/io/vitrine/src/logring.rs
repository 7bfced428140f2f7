//! The log while a vitrine holds the terminal: log lines go to a global bounded ring that
//! the footer shows instead of onto the screen, and the lines logged meanwhile are printed
//! on standard error when the terminal is given back, so that nothing logged is lost.

use std::collections::VecDeque;
use std::io::Write;
use std::sync::{Mutex, MutexGuard, PoisonError};

/// Lines kept: the footer shows a few, the rest are printed when the display closes.
const KEEP: usize = 2000;

struct Ring {
    lines: VecDeque<String>,
    /// Lines ever pushed: the sequence number of the next one.
    next: u64,
    /// While a vitrine holds the terminal: the sequence number of the first line logged
    /// since it took it.
    held_from: Option<u64>,
}

static RING: Mutex<Ring> = Mutex::new(Ring {
    lines: VecDeque::new(),
    next: 0,
    held_from: None,
});

fn ring() -> MutexGuard<'static, Ring> {
    // A panic while a line was pushed leaves the ring usable: keep logging.
    RING.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Appends a complete line: printed on standard error at once unless a vitrine holds the
/// terminal, kept in the ring either way.
pub fn push(line: String) {
    let mut r = ring();
    if r.held_from.is_none() {
        // Standard error may be closed: a log line is not worth failing for.
        let _ = writeln!(std::io::stderr(), "{line}");
    }
    if r.lines.len() == KEEP {
        r.lines.pop_front();
    }
    r.lines.push_back(line);
    r.next += 1;
}

/// The last `n` lines, oldest first.
pub fn last(n: usize) -> Vec<String> {
    let r = ring();
    r.lines
        .iter()
        .skip(r.lines.len().saturating_sub(n))
        .cloned()
        .collect()
}

/// From now on lines are only kept, not printed (the vitrine draws the screen).
pub(crate) fn hold() {
    let mut r = ring();
    if r.held_from.is_none() {
        r.held_from = Some(r.next);
    }
}

/// Prints the lines logged since [`hold`] on standard error and prints later lines again.
pub(crate) fn release() {
    release_to(&mut std::io::stderr().lock());
}

fn release_to(err: &mut impl Write) {
    let mut r = ring();
    let Some(from) = r.held_from.take() else {
        return;
    };
    let oldest = r.next - r.lines.len() as u64;
    if from < oldest {
        let _ = writeln!(
            err,
            "vitrine: {} log lines written while the display was up were dropped (it keeps \
             the last {KEEP}; use `petriplc run --log FILE` for all)",
            oldest - from
        );
    }
    let skip = from.saturating_sub(oldest) as usize;
    for line in r.lines.iter().skip(skip) {
        let _ = writeln!(err, "{line}");
    }
}

/// A log destination (e.g. for simplelog's `WriteLogger`) that appends complete lines to
/// the vitrine's log: shown in its footer while it holds the terminal, printed on standard
/// error otherwise. Made by [`crate::log_writer`].
#[derive(Debug, Default)]
pub struct LogWriter {
    /// The end of a line not yet terminated by a newline.
    partial: Vec<u8>,
}

impl Write for LogWriter {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.partial.extend_from_slice(buf);
        while let Some(end) = self.partial.iter().position(|&b| b == b'\n') {
            let line: Vec<u8> = self.partial.drain(..=end).collect();
            let text = String::from_utf8_lossy(&line[..end]);
            push(text.trim_end_matches('\r').to_string());
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writer_splits_lines_and_keeps_partial_ones() {
        let mut w = LogWriter::default();
        let tag = format!("logring-test-{}", std::process::id());
        write!(w, "{tag} one\n{tag} tw").unwrap();
        write!(w, "o\n{tag} three").unwrap();
        let mine: Vec<String> = last(KEEP)
            .into_iter()
            .filter(|l| l.starts_with(&tag))
            .collect();
        assert_eq!(mine, [format!("{tag} one"), format!("{tag} two")]);
        assert_eq!(w.partial, format!("{tag} three").into_bytes());
    }

    #[test]
    fn lines_logged_while_held_are_printed_on_release() {
        let tag = format!("held-test-{}", std::process::id());
        push(format!("{tag} before"));
        hold();
        push(format!("{tag} during"));
        let mut out = Vec::new();
        release_to(&mut out);
        let out = String::from_utf8(out).unwrap();
        assert!(out.contains(&format!("{tag} during\n")), "{out}");
        assert!(!out.contains(&format!("{tag} before")), "{out}");
        let mut again = Vec::new();
        release_to(&mut again);
        assert!(again.is_empty(), "released once");
    }

    #[test]
    fn simplelogs_write_logger_gives_whole_lines() {
        use simplelog::{Config, LevelFilter, WriteLogger};
        let logger = WriteLogger::new(LevelFilter::Info, Config::default(), LogWriter::default());
        let tag = format!("simplelog-test-{}", std::process::id());
        log::Log::log(
            &*logger,
            &log::Record::builder()
                .args(format_args!("{tag} first"))
                .level(log::Level::Warn)
                .build(),
        );
        log::Log::log(
            &*logger,
            &log::Record::builder()
                .args(format_args!("{tag} second"))
                .level(log::Level::Info)
                .build(),
        );
        let mine: Vec<String> = last(KEEP)
            .into_iter()
            .filter(|l| l.contains(&tag))
            .collect();
        assert_eq!(mine.len(), 2, "{mine:?}");
        assert!(mine[0].contains("[WARN]") && mine[0].ends_with(&format!("{tag} first")));
        assert!(mine[1].contains("[INFO]") && mine[1].ends_with(&format!("{tag} second")));
    }
}
