//! Diagnostics: what is wrong with a PNML file and where, under stable codes, and the crate's
//! error type.

use std::cell::Cell;
use std::path::PathBuf;

use petriplc_diag::Lines;
pub use petriplc_diag::{Code, Location, Severity};

/// One problem found in a file, at a 1-based line and column (counted in characters), with
/// the id of the element it is about in `element` when it has one; its code is one of
/// [`crate::CODES`].
pub type Diagnostic = petriplc_diag::Diagnostic<Location>;

/// Why a file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum PnmlError {
    #[error("could not read `{}`", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("could not write `{}`", path.display())]
    Write {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// Every problem found in the file, in file order.
    #[error("{}", Lines(.0))]
    Invalid(Vec<Diagnostic>),
}

impl PnmlError {
    /// The diagnostics, when the file was read but is not a valid net.
    pub fn diagnostics(&self) -> &[Diagnostic] {
        match self {
            PnmlError::Invalid(d) => d,
            _ => &[],
        }
    }
}

pub const XML: &str = "P001";
pub const NOT_PNML: &str = "P002";
pub const SEVERAL_NETS: &str = "P003";
pub const NET_TYPE: &str = "P004";
pub const MISSING_ATTRIBUTE: &str = "P005";
pub const DUPLICATE_ID: &str = "P006";
pub const REFERENCE: &str = "P007";
pub const NUMBER: &str = "P008";
pub const ARC_TYPE: &str = "P009";
pub const RESET_ARC: &str = "P010";
pub const ARC_TYPE_CONFLICT: &str = "P011";
pub const ARC_ENDS: &str = "P012";
pub const GUARD: &str = "P013";
pub const DELAY: &str = "P014";
pub const UNKNOWN_PETRIPLC: &str = "P015";
pub const REPEATED: &str = "P016";
pub const PETRIPLC_VALUE: &str = "P017";
pub const ARC_RULE: &str = "P018";
pub const PLACE_RULE: &str = "P019";
pub const SIGNAL_RULE: &str = "P020";

/// Turns byte offsets into 1-based lines and character columns. Queries in increasing order
/// (as diagnostics sorted by position are) cost only the characters between them, so a long
/// single-line file with many problems stays linear.
pub(crate) struct LineIndex<'a> {
    text: &'a str,
    starts: Vec<usize>,
    /// The last query: (offset, characters from its line's start to it).
    last: Cell<(usize, usize)>,
}

impl<'a> LineIndex<'a> {
    pub(crate) fn new(text: &'a str) -> Self {
        let mut starts = vec![0];
        starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        LineIndex {
            text,
            starts,
            last: Cell::new((0, 0)),
        }
    }

    pub(crate) fn position(&self, offset: usize) -> (u32, u32) {
        let offset = offset.min(self.text.len());
        let line = self.starts.partition_point(|&s| s <= offset).max(1);
        let start = self.starts.get(line - 1).copied().unwrap_or(0);
        let (last, last_chars) = self.last.get();
        let (from, before) = if last >= start && last <= offset {
            (last, last_chars)
        } else {
            (start, 0)
        };
        let chars = match self.text.get(from..offset) {
            Some(s) => before + s.chars().count(),
            // An offset inside a character: count bytes, which is close enough to point there.
            None => before + (offset - from),
        };
        self.last.set((offset, chars));
        (to_u32(line), to_u32(chars + 1))
    }
}

fn to_u32(n: usize) -> u32 {
    u32::try_from(n).unwrap_or(u32::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str, offset: usize, expect: (u32, u32)) {
        assert_eq!(
            LineIndex::new(text).position(offset),
            expect,
            "{text:?} at {offset}"
        );
    }

    #[test]
    fn positions_count_lines_and_characters() {
        check("abc", 0, (1, 1));
        check("abc", 2, (1, 3));
        check("a\nbc", 2, (2, 1));
        check("a\nbc", 3, (2, 2));
        check("é<x", 2, (1, 2));
        check("é<x", 1, (1, 2));
        check("a\n", 99, (2, 1));
        check("ab\ncd\né\nf", 9, (4, 1));
        check("ab\ncd\né\nf", 8, (3, 2));
    }

    #[test]
    fn displays_one_line_per_diagnostic() {
        let d = |line, code, message: &str| {
            Diagnostic::new(
                Severity::Error,
                Code(code),
                Location::new("n.pnml", line, 3),
                message,
            )
            .with_element("a7")
        };
        let e = PnmlError::Invalid(vec![
            d(4, ARC_ENDS, "arc `a7`: bad"),
            d(9, NUMBER, "place `p`: worse"),
        ]);
        assert_eq!(
            e.to_string(),
            "n.pnml:4:3: error[P012]: arc `a7`: bad\nn.pnml:9:3: error[P008]: place `p`: worse"
        );
    }
}
