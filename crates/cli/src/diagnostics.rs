//! Diagnostics printed for a person, the one place every command prints them (`check`,
//! `sim`, `run`, `compile`, whichever front end found them: IEC sources, PNML, configurations):
//! at most [`MAX_SHOWN`] per command, then one line counting the rest, so a garbage file gives
//! a screenful rather than thousands of lines. Standard error closed by the reader (a pager
//! quit early) ends nothing.

use std::io::Write;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Diagnostics printed per command; the rest are counted.
pub const MAX_SHOWN: usize = 50;

/// Diagnostic lines printed so far by this command (one command per process).
static SHOWN: AtomicUsize = AtomicUsize::new(0);

/// Whether a line is a diagnostic: `WHERE: error[CODE]: …` or `WHERE: warning[CODE]: …`.
fn severity(line: &str) -> Option<&'static str> {
    for (tag, what) in [(": error[", "error"), (": warning[", "warning")] {
        if let Some(at) = line.find(tag) {
            let rest = &line[at + tag.len()..];
            if rest
                .split_once("]: ")
                .is_some_and(|(code, _)| !code.is_empty() && code.len() <= 8)
            {
                return Some(what);
            }
        }
    }
    None
}

/// `text` as it is printed: every line but the diagnostics past the command's first
/// [`MAX_SHOWN`], which are replaced by one line counting them (`… and 957 more errors`)
/// where the first of them was.
pub fn capped(text: &str) -> String {
    let mut out = String::with_capacity(text.len().min(1 << 16));
    let (mut errors, mut warnings) = (0usize, 0usize);
    let mut summary_at = None;
    for line in text.lines() {
        match severity(line) {
            Some(kind) if SHOWN.load(Ordering::Relaxed) >= MAX_SHOWN => {
                if kind == "error" {
                    errors += 1;
                } else {
                    warnings += 1;
                }
                summary_at.get_or_insert(out.len());
            }
            Some(_) => {
                SHOWN.fetch_add(1, Ordering::Relaxed);
                out.push_str(line);
                out.push('\n');
            }
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    if let Some(at) = summary_at {
        let count = |n: usize, what: &str| match n {
            0 => None,
            1 => Some(format!("1 more {what}")),
            n => Some(format!("{n} more {what}s")),
        };
        let parts: Vec<String> = [count(errors, "error"), count(warnings, "warning")]
            .into_iter()
            .flatten()
            .collect();
        out.insert_str(at, &format!("… and {}\n", parts.join(" and ")));
    }
    if !text.ends_with('\n') && out.ends_with('\n') {
        out.pop();
    }
    out
}

/// Prints `text` (one or more lines) to standard error with the command's cap applied.
pub fn eprint(text: &str) {
    let mut text = capped(text);
    text.push('\n');
    // A closed standard error (the reader quit) is no reason to fail or panic.
    let _ = std::io::stderr().lock().write_all(text.as_bytes());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recognises_diagnostics_of_every_front_end() {
        assert_eq!(
            severity("a.st:1:2: error[E100]: `x` is not declared"),
            Some("error")
        );
        assert_eq!(severity("a.pnml:3:4: error[P005]: …"), Some("error"));
        assert_eq!(severity("plc.conf:3: error[C021]: x"), Some("error"));
        assert_eq!(severity("a.st:1:2: warning[W003]: y"), Some("warning"));
        assert_eq!(severity("error: 3 problems found; nothing was run"), None);
        assert_eq!(severity("error: module m: a.st does not compile:"), None);
    }

    /// The cap is per process: this test alone uses it in this test binary.
    #[test]
    fn the_first_fifty_then_a_count() {
        let mut text = String::from("error: module m: a.st does not compile:\n");
        for i in 0..1059 {
            text.push_str(&format!("a.st:{i}:1: error[E001]: bad\n"));
        }
        text.push_str("a.st:2000:1: warning[W003]: w\nnothing was started");
        let out = capped(&text);
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines.len(), 1 + MAX_SHOWN + 2, "{out}");
        assert_eq!(lines[0], "error: module m: a.st does not compile:");
        assert_eq!(lines[MAX_SHOWN], "a.st:49:1: error[E001]: bad");
        assert_eq!(
            lines[MAX_SHOWN + 1],
            "… and 1009 more errors and 1 more warning"
        );
        assert_eq!(lines[MAX_SHOWN + 2], "nothing was started");
        // Later output of the same command is capped too.
        assert_eq!(capped("b.st:1:1: error[E001]: x\n"), "… and 1 more error\n");
    }
}
