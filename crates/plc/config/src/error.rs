//! Diagnostics: what is wrong with a configuration and where, under stable codes, and the
//! crate's error type, which carries every problem found rather than only the first.

use std::fmt;

use petriplc_diag::{Code, Located, Location, Severity};

use crate::model::Origin;

/// One problem, at the file and line where it was written (line 0: the file as a whole, it
/// could not be read at all); its code is one of [`CODES`], its message says what is wrong
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

/// Every code with a one-line summary (docs and `--explain`-style tools list these).
pub const CODES: &[(&str, &str)] = &[
    (UNREADABLE, "a file (or an *include) cannot be read"),
    (CIRCULAR_INCLUDE, "files include each other in a circle"),
    (UNTERMINATED_QUOTE, "a \" is not closed on its line"),
    (BAD_SECTION_HEADER, "a [section] header is malformed"),
    (
        OUTSIDE_SECTION,
        "a setting or row comes before any [section] header of its file",
    ),
    (BAD_DIRECTIVE, "a *directive other than `*include FILE`"),
    (
        CONFLICTING_SETTING,
        "one setting given two different values in a section",
    ),
    (
        BAD_LINE,
        "a line that is no setting, row, header or directive",
    ),
    (INCLUDE_TOO_DEEP, "*include nested more than 64 files deep"),
    (UNKNOWN_TABLE, "an unknown table in [PLC]"),
    (
        UNKNOWN_PLC_SETTING,
        "a setting in [PLC] other than plc_id, retain_file, retain_write (nothing would read it)",
    ),
    (BAD_PLC_ID, "an empty plc_id"),
    (
        UNSUPPORTED_TABLE,
        "a MatPLC [PLC] table petriplc does not support",
    ),
    (
        POINT_SHAPE,
        "a `point` row without name, description and owner",
    ),
    (DUPLICATE_POINT, "two points with one name"),
    (UNKNOWN_OWNER, "a point's owner is not a declared module"),
    (BAD_AT, "a malformed or out-of-range `at WORD.BIT`"),
    (
        BAD_POINT_TYPE,
        "a malformed type/length or an unexpected word in a point",
    ),
    (POINT_OVERFLOWS_WORD, "a point's bit + length exceeds 32"),
    (FLOAT_NOT_32_BITS, "a float point that is not 32 bits"),
    (
        BAD_INIT,
        "an initial value that does not parse or fit the point",
    ),
    (OVERLAPPING_POINTS, "two placed points share bits"),
    (MODULE_SHAPE, "a `module` row without name and kind/path"),
    (DUPLICATE_MODULE, "two modules with one name"),
    (
        RESERVED_NAME,
        "a module, place or transition named PLC or NULL",
    ),
    (
        UNDECLARED_MODULE_SETTING,
        "a setting or row for a module that is not declared",
    ),
    (BAD_SCAN_PERIOD, "a scan_period that is not a duration"),
    (
        BAD_LOCATION,
        "a location other than local, shared or isolate",
    ),
    (BAD_PRIORITY, "a priority outside 1-99"),
    (
        BAD_ON_FAILURE,
        "an on_failure other than stop, restart or ignore",
    ),
    (
        UNKNOWN_SCAN_TRANSITION,
        "scan_beg/scan_end naming an undeclared transition",
    ),
    (SECTION_CASE, "a section spelled like [PLC] in another case"),
    (
        BAD_RESTART,
        "a bad restart_delay/restart_delay_max/restart_limit, or one without on_failure = restart",
    ),
    (
        BAD_WATCHDOG,
        "a watchdog that is not a duration longer than 0",
    ),
    (
        BAD_RETAIN_SETTING,
        "an empty retain_file, or a retain_write other than `change` or a duration",
    ),
    (PLACE_SHAPE, "a malformed `place` row"),
    (TRANSITION_SHAPE, "a malformed `transition` row"),
    (DUPLICATE_NODE, "two places/transitions with one name"),
    (ARC_SHAPE, "an `arc` row that is not FROM ARROW TO"),
    (BAD_ARROW, "an arrow that is not [-][(][weight][)][-]>"),
    (
        UNKNOWN_ARC_END,
        "an arc naming an undeclared place/transition or NULL",
    ),
    (
        ARC_SAME_KIND,
        "an arc between two places or two transitions",
    ),
    (
        ZERO_WEIGHT_FROM_TRANSITION,
        "a weight-0 arc from a transition",
    ),
    (SYNCH_SHAPE, "a malformed `synch` or `synch_start` row"),
    (ZERO_WEIGHT_SYNCH, "a `synch` rule with weight 0"),
    (
        UNKNOWN_SYNCH_MODULE,
        "`synch`/`synch_start` naming an undeclared module",
    ),
];

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

    #[test]
    fn codes_are_unique() {
        let mut seen = std::collections::HashSet::new();
        for (code, _) in CODES {
            assert!(seen.insert(code), "{code} twice");
        }
    }
}
