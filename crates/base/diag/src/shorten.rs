//! Messages kept to one short line: a source excerpt or a name can be any size, a diagnostic
//! should not be a screenful.

/// Characters of a name or excerpt a message shows in full.
pub const MAX_SHOWN: usize = 60;
/// Characters kept of a longer one (then `…` and its length).
const KEPT: usize = 40;

/// A message on one line (a source excerpt's line breaks and other control characters become
/// spaces), with every name or excerpt longer than [`MAX_SHOWN`] characters cut to its first
/// 40, `…` and its length (`aaaa…(10000 characters)`): a `…`-quoted excerpt as a whole, and
/// any other run of characters without spaces. A 10 000-character identifier is then one
/// short line, not a screenful per message.
pub fn shorten(message: String) -> String {
    let message = if message.contains(char::is_control) {
        message
            .chars()
            .map(|c| if c.is_control() { ' ' } else { c })
            .collect()
    } else {
        message
    };
    let long = |s: &str| s.chars().nth(MAX_SHOWN).is_some();
    if !long(&message) {
        return message;
    }
    let cut = |s: &str| {
        let n = s.chars().count();
        if n <= MAX_SHOWN {
            return s.to_string();
        }
        let kept: String = s.chars().take(KEPT).collect();
        format!("{kept}…({n} characters)")
    };
    // Quoted excerpts first (they may hold spaces), then every word outside them.
    let mut out = String::with_capacity(message.len().min(4096));
    for (k, part) in message.split('`').enumerate() {
        if k > 0 {
            out.push('`');
        }
        let quoted = k % 2 == 1 && message.split('`').count() > k + 1;
        if quoted {
            out.push_str(&cut(part));
            continue;
        }
        let mut word = String::new();
        for c in part.chars() {
            if c.is_whitespace() {
                out.push_str(&cut(&word));
                word.clear();
                out.push(c);
            } else {
                word.push(c);
            }
        }
        out.push_str(&cut(&word));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_names_and_excerpts_are_cut() {
        let name = "a".repeat(10_000);
        assert_eq!(
            shorten(format!("`{name}` is not declared")),
            format!("`{}…(10000 characters)` is not declared", "a".repeat(40))
        );
        let spaced = format!("x := {}", "1 + ".repeat(100));
        let m = shorten(format!("after `{spaced}`: {name}"));
        assert!(m.len() < 200, "{m}");
        assert!(m.contains("…(405 characters)`: aaaa"), "{m}");
        // An excerpt across lines stays on the diagnostic's line.
        assert_eq!(
            shorten("after `a\n   b`, found `1`".into()),
            "after `a    b`, found `1`"
        );
        let short = "`x` is not declared; declare it in VAR".to_string();
        assert_eq!(shorten(short.clone()), short);
    }
}
