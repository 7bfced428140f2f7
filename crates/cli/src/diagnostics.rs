//! Diagnostics printed for a person, the one place every command prints them (`check`,
//! `sim`, `run`, `compile`, whichever front end found them: IEC sources, PNML, configurations):
//! at most [`petriplc_diag::cap::MAX_PRINTED`] per command, then one line counting the rest (the cap itself is
//! `petriplc_diag::cap`, shared by every front end). Standard error closed by the reader (a
//! pager quit early) ends nothing.

use std::io::Write;
use std::sync::Mutex;

/// Diagnostic lines printed so far by this command (one command per process).
static SHOWN: Mutex<usize> = Mutex::new(0);

/// `text` as it is printed: every line but the diagnostics past the command's first
/// [`petriplc_diag::cap::MAX_PRINTED`], which are replaced by one line counting them (`… and 957 more errors`)
/// where the first of them was.
pub fn capped(text: &str) -> String {
    let mut shown = SHOWN.lock().unwrap_or_else(|e| e.into_inner());
    petriplc_diag::cap::capped(text, &mut shown)
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
    use petriplc_diag::cap::MAX_PRINTED;

    /// The cap is per process: this test alone uses it in this test binary.
    #[test]
    fn the_first_fifty_then_a_count_across_calls() {
        let mut text = String::new();
        for i in 0..MAX_PRINTED + 9 {
            text.push_str(&format!("a.st:{i}:1: error[E001]: bad\n"));
        }
        let out = capped(&text);
        assert_eq!(out.lines().count(), MAX_PRINTED + 1, "{out}");
        assert!(out.ends_with("… and 9 more errors\n"), "{out}");
        // Later output of the same command is capped too.
        assert_eq!(capped("b.st:1:1: error[E001]: x\n"), "… and 1 more error\n");
    }
}
