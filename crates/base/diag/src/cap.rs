//! The cap on diagnostics printed by one command (issue 27): the first [`MAX_PRINTED`], then
//! one line counting the rest, so that a garbage file gives a screenful rather than
//! thousands of lines. It works on rendered text, so that it applies whichever front end
//! rendered the lines and whatever else the command prints between them.

/// Diagnostics printed per command; the rest are counted.
pub const MAX_PRINTED: usize = 50;

/// Whether a line is a diagnostic: `WHERE: error[CODE]: …` or `WHERE: warning[CODE]: …`.
pub fn severity(line: &str) -> Option<&'static str> {
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

/// Whether a line continues the diagnostic before it (a secondary label or its help).
fn continues(line: &str) -> bool {
    line.contains(": note: ") || line.contains(": help: ")
}

/// `text` as it is printed when `shown` diagnostics were printed before: every line but the
/// diagnostics past the first [`MAX_PRINTED`] (with their `note` and `help` lines), which
/// are replaced by one line counting them (`… and 957 more errors`) where the first of them
/// was. `shown` is advanced by the diagnostics printed.
pub fn capped(text: &str, shown: &mut usize) -> String {
    let mut out = String::with_capacity(text.len().min(1 << 16));
    let (mut errors, mut warnings) = (0usize, 0usize);
    let mut summary_at = None;
    // Whether the last diagnostic line was dropped (its notes go with it), or kept.
    let mut last: Option<bool> = None;
    for line in text.lines() {
        match severity(line) {
            Some(kind) if *shown >= MAX_PRINTED => {
                if kind == "error" {
                    errors += 1;
                } else {
                    warnings += 1;
                }
                summary_at.get_or_insert(out.len());
                last = Some(true);
            }
            Some(_) => {
                *shown += 1;
                out.push_str(line);
                out.push('\n');
                last = Some(false);
            }
            None if last == Some(true) && continues(line) => {}
            None => {
                if !continues(line) {
                    last = None;
                }
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
        assert_eq!(severity("a.st:1:2: note: first declared here"), None);
        assert_eq!(severity("error: 3 problems found; nothing was run"), None);
        assert_eq!(severity("error: module m: a.st does not compile:"), None);
    }

    #[test]
    fn the_first_fifty_then_a_count() {
        let mut shown = 0;
        let mut text = String::from("error: module m: a.st does not compile:\n");
        for i in 0..1059 {
            text.push_str(&format!("a.st:{i}:1: error[E001]: bad\n"));
        }
        text.push_str("a.st:2000:1: warning[W003]: w\nnothing was started");
        let out = capped(&text, &mut shown);
        let lines: Vec<&str> = out.lines().collect();
        assert_eq!(lines.len(), 1 + MAX_PRINTED + 2, "{out}");
        assert_eq!(lines[0], "error: module m: a.st does not compile:");
        assert_eq!(lines[MAX_PRINTED], "a.st:49:1: error[E001]: bad");
        assert_eq!(
            lines[MAX_PRINTED + 1],
            "… and 1009 more errors and 1 more warning"
        );
        assert_eq!(lines[MAX_PRINTED + 2], "nothing was started");
        // Later output of the same command is capped too.
        assert_eq!(
            capped("b.st:1:1: error[E001]: x\n", &mut shown),
            "… and 1 more error\n"
        );
    }

    #[test]
    fn notes_go_with_their_diagnostic() {
        let mut shown = MAX_PRINTED - 1;
        let text = "a.st:9:1: error[E103]: `x` twice\n\
                    a.st:2:1: note: first declared here\n\
                    a.st:12:1: error[E103]: `y` twice\n\
                    a.st:3:1: note: first declared here\n\
                    a.st:12:1: help: rename one\n\
                    done\n";
        assert_eq!(
            capped(text, &mut shown),
            "a.st:9:1: error[E103]: `x` twice\n\
             a.st:2:1: note: first declared here\n\
             … and 1 more error\n\
             done\n"
        );
        // A note counts for nothing: fifty diagnostics with notes are all shown.
        let mut shown = 0;
        let mut text = String::new();
        for i in 0..MAX_PRINTED {
            text.push_str(&format!("a.st:{i}:1: error[E103]: d\na.st:1:1: note: n\n"));
        }
        assert_eq!(capped(&text, &mut shown), text);
        assert_eq!(shown, MAX_PRINTED);
    }
}
