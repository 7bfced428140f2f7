//! Diagnostics: what is wrong with a configuration and where, under stable codes, and the
//! crate's error type, which carries every problem found rather than only the first.

use std::fmt;

use petriplc_diag::{Code, Located, Location, Severity};

use crate::model::Origin;

/// One problem, at the file and line where it was written (line 0: the file as a whole, it
/// could not be read at all); its code is one of [`crate::CODES`], its message says what is wrong
/// and how to fix it.
pub type Diagnostic = petriplc_diag::Diagnostic<Origin>;

/// An error at `origin`, its message kept whole (it may name a file).
pub(crate) fn diagnostic(
    origin: &Origin,
    code: &'static str,
    message: impl Into<String>,
) -> Diagnostic {
    Diagnostic::new(Severity::Error, Code(code), origin.clone(), message)
}

impl Located for Origin {
    fn location(&self) -> Location {
        Location::new(
            self.file.clone(),
            u32::try_from(self.line).unwrap_or(u32::MAX),
            0,
        )
    }
}

/// A configuration that must not be started: every problem found, one per line when
/// displayed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigError {
    pub diagnostics: Vec<Diagnostic>,
}

impl ConfigError {
    /// The codes in order, for tests and tools that only care which checks fired.
    pub fn codes(&self) -> Vec<&'static str> {
        self.diagnostics.iter().map(|d| d.code.0).collect()
    }
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.diagnostics.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ConfigError {}

// Layer 1: lines, sections, includes.
pub const UNREADABLE: &str = "C001";
pub const CIRCULAR_INCLUDE: &str = "C002";
pub const UNTERMINATED_QUOTE: &str = "C003";
pub const BAD_SECTION_HEADER: &str = "C004";
pub const OUTSIDE_SECTION: &str = "C005";
pub const BAD_DIRECTIVE: &str = "C006";
pub const CONFLICTING_SETTING: &str = "C007";
pub const BAD_LINE: &str = "C008";
pub const INCLUDE_TOO_DEEP: &str = "C009";

// Layer 2: the [PLC] tables.
pub const UNKNOWN_TABLE: &str = "C010";
pub const UNSUPPORTED_TABLE: &str = "C011";
pub const UNKNOWN_PLC_SETTING: &str = "C012";
pub const BAD_PLC_ID: &str = "C013";

// Points.
pub const POINT_SHAPE: &str = "C020";
pub const DUPLICATE_POINT: &str = "C021";
pub const UNKNOWN_OWNER: &str = "C022";
pub const BAD_AT: &str = "C023";
pub const BAD_POINT_TYPE: &str = "C024";
pub const POINT_OVERFLOWS_WORD: &str = "C025";
pub const FLOAT_NOT_32_BITS: &str = "C026";
pub const BAD_INIT: &str = "C027";
pub const OVERLAPPING_POINTS: &str = "C028";

// Modules and their settings.
pub const MODULE_SHAPE: &str = "C030";
pub const DUPLICATE_MODULE: &str = "C031";
pub const RESERVED_NAME: &str = "C032";
pub const UNDECLARED_MODULE_SETTING: &str = "C033";
pub const BAD_SCAN_PERIOD: &str = "C034";
pub const BAD_LOCATION: &str = "C035";
pub const BAD_PRIORITY: &str = "C036";
pub const BAD_ON_FAILURE: &str = "C037";
pub const UNKNOWN_SCAN_TRANSITION: &str = "C038";
pub const SECTION_CASE: &str = "C039";
pub const BAD_RESTART: &str = "C029";

// Retentive values and watchdogs.
pub const BAD_WATCHDOG: &str = "C060";
pub const BAD_RETAIN_SETTING: &str = "C061";

// The synchronisation net.
pub const PLACE_SHAPE: &str = "C040";
pub const TRANSITION_SHAPE: &str = "C041";
pub const DUPLICATE_NODE: &str = "C042";
pub const ARC_SHAPE: &str = "C043";
pub const BAD_ARROW: &str = "C044";
pub const UNKNOWN_ARC_END: &str = "C045";
pub const ARC_SAME_KIND: &str = "C046";
pub const ZERO_WEIGHT_FROM_TRANSITION: &str = "C047";
pub const SYNCH_SHAPE: &str = "C050";
pub const ZERO_WEIGHT_SYNCH: &str = "C051";
pub const UNKNOWN_SYNCH_MODULE: &str = "C052";

#[cfg(test)]
mod tests {
    use super::*;

    fn check(diags: &[(&str, usize, &'static str, &str)], expect: &str) {
        let err = ConfigError {
            diagnostics: diags
                .iter()
                .map(|&(file, line, code, msg)| {
                    let origin = Origin {
                        file: file.into(),
                        line,
                    };
                    diagnostic(&origin, code, msg)
                })
                .collect(),
        };
        assert_eq!(err.to_string(), expect);
    }

    #[test]
    fn one_line_per_diagnostic() {
        check(
            &[
                ("a.conf", 3, DUPLICATE_POINT, "x"),
                ("b.conf", 0, UNREADABLE, "y"),
            ],
            "a.conf:3: error[C021]: x\nb.conf: error[C001]: y",
        );
        check(&[], "");
    }
}
