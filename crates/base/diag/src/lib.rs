//! One diagnostic for every front end (IEC sources, PNML nets, PLC configurations): a stable
//! code, a severity, a message, where it is, other places that explain it (secondary labels)
//! and help, rendered one way (`file:line:col: error[CODE]: message`, then one
//! `file:line:col: note: …` line per label) and capped one way ([`cap`]).
//!
//! A diagnostic is generic over its position: the IEC front end keeps byte spans and turns
//! them into lines and columns only when rendering (after sorting by span), the others hold a
//! resolved [`Location`] or a line of a file.

pub mod cap;
pub mod doc;
mod shorten;

use std::fmt;

pub use shorten::{shorten, MAX_SHOWN};

/// A stable diagnostic code such as `E110`, `P012` or `C021`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Code(pub &'static str);

impl fmt::Display for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.0)
    }
}

impl PartialEq<&str> for Code {
    fn eq(&self, other: &&str) -> bool {
        self.0 == *other
    }
}

impl PartialEq<Code> for &str {
    fn eq(&self, other: &Code) -> bool {
        *self == other.0
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Severity {
    Error,
    Warning,
}

impl Severity {
    /// The word a rendered line shows: `error` or `warning`.
    pub fn as_str(self) -> &'static str {
        match self {
            Severity::Error => "error",
            Severity::Warning => "warning",
        }
    }
}

/// A resolved position as a person reads it: `file:line:col`.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Location {
    pub file: String,
    /// 1-based; 0 means the file as a whole (it could not be read, or a value given on the
    /// command line), printed as the file alone.
    pub line: u32,
    /// 1-based, in characters; 0 when only the line is known, printed `file:line`.
    pub column: u32,
    /// An element of a graphical body (`LD contact localId 3`), printed instead of the line
    /// and column: a diagram has no lines a person could go to.
    pub element: Option<String>,
}

impl Location {
    pub fn new(file: impl Into<String>, line: u32, column: u32) -> Self {
        Location {
            file: file.into(),
            line,
            column,
            element: None,
        }
    }
}

impl fmt::Display for Location {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.element {
            Some(e) => write!(f, "{}: {e}", self.file),
            None if self.line == 0 => f.write_str(&self.file),
            None if self.column == 0 => write!(f, "{}:{}", self.file, self.line),
            None => write!(f, "{}:{}:{}", self.file, self.line, self.column),
        }
    }
}

/// A position that knows where it is without a source map (a [`Location`], a configuration
/// line), so that its diagnostic can be displayed directly.
pub trait Located {
    fn location(&self) -> Location;
}

impl Located for Location {
    fn location(&self) -> Location {
        self.clone()
    }
}

/// What turns a diagnostic's positions of type `S` into locations (the IEC front end's
/// source map for its byte spans).
pub trait Locate<S> {
    fn locate(&self, span: &S) -> Location;
}

/// A second place that explains the first: "first declared here".
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Label<S> {
    pub span: S,
    pub text: String,
}

/// One problem, where it is, and what to write instead.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Diagnostic<S = Location> {
    pub code: Code,
    pub severity: Severity,
    pub span: S,
    /// What is wrong and what to write instead.
    pub message: String,
    /// The id or name of the element the problem is about (a PNML element's id), for tools
    /// that group problems; not printed, the message names it.
    pub element: Option<String>,
    /// Other places that explain this one, printed after it as `note` lines.
    pub labels: Vec<Label<S>>,
    /// How to fix it, when the message alone does not say.
    pub help: Option<String>,
}

impl<S> Diagnostic<S> {
    /// A diagnostic whose message is kept as written (it may quote a path that must print
    /// whole).
    pub fn new(severity: Severity, code: Code, span: S, message: impl Into<String>) -> Self {
        Diagnostic {
            code,
            severity,
            span,
            message: message.into(),
            element: None,
            labels: Vec::new(),
            help: None,
        }
    }

    /// An error whose message is put on one line with long names cut ([`shorten`]): source
    /// excerpts can be any size.
    pub fn error(code: Code, span: S, message: impl Into<String>) -> Self {
        Self::new(Severity::Error, code, span, shorten(message.into()))
    }

    /// A warning, its message shortened as [`Diagnostic::error`]'s.
    pub fn warning(code: Code, span: S, message: impl Into<String>) -> Self {
        Self::new(Severity::Warning, code, span, shorten(message.into()))
    }

    /// Adds a secondary label: another place and why it matters.
    pub fn with_label(mut self, span: S, text: impl Into<String>) -> Self {
        self.labels.push(Label {
            span,
            text: text.into(),
        });
        self
    }

    pub fn with_help(mut self, help: impl Into<String>) -> Self {
        self.help = Some(help.into());
        self
    }

    pub fn with_element(mut self, element: impl Into<String>) -> Self {
        self.element = Some(element.into());
        self
    }

    pub fn is_error(&self) -> bool {
        self.severity == Severity::Error
    }

    /// `file:line:col: error[E110]: message`, then `file:line:col: note: text` per label and
    /// `file:line:col: help: text` (no final newline).
    pub fn render<M: Locate<S> + ?Sized>(&self, map: &M) -> String {
        self.render_with(|s| map.locate(s))
    }

    /// As [`Diagnostic::render`], with the positions resolved by `locate`.
    pub fn render_with(&self, locate: impl Fn(&S) -> Location) -> String {
        let at = locate(&self.span);
        let mut out = format!(
            "{at}: {}[{}]: {}",
            self.severity.as_str(),
            self.code,
            self.message
        );
        for label in &self.labels {
            out.push_str(&format!("\n{}: note: {}", locate(&label.span), label.text));
        }
        if let Some(help) = &self.help {
            out.push_str(&format!("\n{at}: help: {help}"));
        }
        out
    }
}

impl<S: Located> fmt::Display for Diagnostic<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.render_with(Located::location))
    }
}

/// Diagnostics displayed one per line (with their notes), as an error type's message lists
/// them.
pub struct Lines<'a, S>(pub &'a [Diagnostic<S>]);

impl<S: Located> fmt::Display for Lines<'_, S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locations_print_what_is_known() {
        let at = |line, column| Location::new("a.st", line, column).to_string();
        assert_eq!(at(2, 3), "a.st:2:3");
        assert_eq!(at(2, 0), "a.st:2");
        assert_eq!(at(0, 0), "a.st");
        let mut l = Location::new("p.xml", 4, 5);
        l.element = Some("LD contact localId 3".into());
        assert_eq!(l.to_string(), "p.xml: LD contact localId 3");
    }

    #[test]
    fn renders_the_line_then_notes_then_help() {
        let d = Diagnostic::error(Code("E103"), Location::new("a.st", 7, 5), "`x` twice")
            .with_label(Location::new("a.st", 3, 5), "first declared here")
            .with_help("rename one of them");
        assert_eq!(
            d.to_string(),
            "a.st:7:5: error[E103]: `x` twice\n\
             a.st:3:5: note: first declared here\n\
             a.st:7:5: help: rename one of them"
        );
        let w = Diagnostic::warning(Code("W003"), Location::new("b.st", 1, 1), "w");
        assert_eq!(w.to_string(), "b.st:1:1: warning[W003]: w");
        assert!(!w.is_error());
    }

    #[test]
    fn positions_are_resolved_by_the_caller() {
        struct Map;
        impl Locate<usize> for Map {
            fn locate(&self, at: &usize) -> Location {
                Location::new("m", 1, *at as u32 + 1)
            }
        }
        let d = Diagnostic::error(Code("P006"), 9usize, "dup").with_label(2, "first");
        assert_eq!(
            d.render(&Map),
            "m:1:10: error[P006]: dup\nm:1:3: note: first"
        );
    }

    #[test]
    fn new_keeps_the_message_and_error_shortens_it() {
        let long = format!("could not read `{}`", "/x".repeat(50));
        let d = Diagnostic::new(Severity::Error, Code("C001"), Location::default(), &*long);
        assert_eq!(d.message, long);
        let d = Diagnostic::error(Code("C001"), Location::default(), &*long);
        assert!(d.message.contains("…(100 characters)"), "{}", d.message);
    }

    #[test]
    fn codes_compare_with_strings() {
        assert!(Code("C021") == "C021");
        assert!("C021" == Code("C021"));
        assert_eq!(Code("E100").to_string(), "E100");
    }
}
