//! `{…}` pragmas, as CODESYS and TwinCAT sources are full of them: `{attribute '…'}`,
//! `{warning '…'}`, `{error '…'}`, conditional compilation (`{IF defined(…)}`) and others.
//! None is a syntax error. What petriplc does not model is skipped with one warning per
//! source (W010); `{warning 'text'}` and `{error 'text'}` say their text as CODESYS does
//! (W011, E015); conditional compilation, which would change what is compiled, is refused
//! as not supported (E190) rather than read with every branch.

use crate::diag::{self, Diagnostics};
use crate::source::{FileId, Span};

/// What a pragma is, by its first word.
#[derive(Debug, PartialEq)]
enum Kind<'a> {
    /// `{warning 'text'}`: CODESYS prints the text as a warning.
    Warning(&'a str),
    /// `{error 'text'}`: CODESYS stops with the text as an error.
    Error(&'a str),
    /// `{IF …}`, `{ELSIF …}`, `{ELSE}`, `{END_IF}`, `{define …}`, `{undefine …}`.
    Conditional,
    /// Anything else (`{attribute …}`, `{warning disable …}`, `{library …}`, Beremiz's
    /// `{{ C code }}`…): nothing petriplc models.
    Other,
}

fn kind(body: &str) -> Kind<'_> {
    let body = body.trim();
    let (word, rest) = body
        .split_once(|c: char| c.is_whitespace() || c == '\'')
        .map_or((body, ""), |(w, _)| (w, &body[w.len()..]));
    let rest = rest.trim();
    let text = rest
        .strip_prefix('\'')
        .and_then(|r| r.strip_suffix('\''))
        .filter(|t| !t.contains('\''));
    match (word.to_ascii_uppercase().as_str(), text) {
        ("WARNING", Some(t)) => Kind::Warning(t),
        ("ERROR", Some(t)) => Kind::Error(t),
        ("IF" | "ELSIF" | "ELSE" | "END_IF" | "DEFINE" | "UNDEFINE", _) => Kind::Conditional,
        _ => Kind::Other,
    }
}

/// Reports the pragmas found at `spans` (byte ranges of `{…}` in `text`).
pub(super) fn report(file: FileId, text: &str, spans: &[(usize, usize)], diags: &mut Diagnostics) {
    let mut ignored: Vec<&str> = Vec::new();
    let mut first_ignored = None;
    let mut conditional_reported = false;
    for &(start, end) in spans {
        let whole = &text[start..end];
        let body = &whole[1..whole.len() - 1];
        let span = Span::new(file, start, end);
        match kind(body) {
            Kind::Warning(t) => diags.warning(
                diag::PRAGMA_WARNING,
                span,
                format!("the source's own warning: {t}"),
            ),
            Kind::Error(t) => diags.error(
                diag::PRAGMA_ERROR,
                span,
                format!("the source's own error: {t}"),
            ),
            Kind::Conditional if !conditional_reported => {
                conditional_reported = true;
                diags.error(
                    diag::UNSUPPORTED,
                    span,
                    "conditional compilation ({IF …} … {END_IF}) is not supported; keep the branch meant for this PLC and remove the pragmas",
                );
            }
            Kind::Conditional => {}
            Kind::Other => {
                first_ignored.get_or_insert(span);
                let shown = whole.lines().next().unwrap_or(whole);
                if ignored.len() < 3 && !ignored.contains(&shown) {
                    ignored.push(shown);
                }
            }
        }
    }
    if let Some(span) = first_ignored {
        let n = spans
            .iter()
            .filter(|&&(s, e)| kind(&text[s + 1..e - 1]) == Kind::Other)
            .count();
        let more = if n > ignored.len() { ", …" } else { "" };
        diags.warning(
            diag::PRAGMA_IGNORED,
            span,
            format!(
                "{n} pragma{} ignored here ({}{more}): petriplc does not model them",
                if n == 1 { "" } else { "s" },
                ignored.join(", ")
            ),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kinds() {
        assert_eq!(kind("warning 'check this'"), Kind::Warning("check this"));
        assert_eq!(kind("error 'no'"), Kind::Error("no"));
        assert_eq!(kind("warning disable C0228"), Kind::Other);
        assert_eq!(kind("attribute 'qualified_only'"), Kind::Other);
        assert_eq!(kind("IF defined (pou:F)"), Kind::Conditional);
        assert_eq!(kind("END_IF"), Kind::Conditional);
        assert_eq!(kind("{ int x; }"), Kind::Other);
    }
}
