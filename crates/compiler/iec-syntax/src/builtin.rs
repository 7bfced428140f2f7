//! The parts of vendor libraries petriplc declares in Structured Text (`builtin/*.st`):
//! TwinCAT's types, enumerations and functions that are ordinary IEC code in the vendor's
//! library too (`T_MaxString`, `__SYSTEM.TYPE_CLASS`, `E_TcMemoryArea`…), and Beremiz's
//! (SVGHMI types, LOGGER, the Python blocks, matiec's PID). A loaded library's
//! source is parsed as the user's and checked with it (`petriplc_iec_sema::vendor`), so its
//! names resolve, type-check and run exactly as the user's would. Its files have ids of their
//! own, from [`BASE`] up, that every [`SourceMap`](crate::source::SourceMap) knows: a message
//! or a run-time fault inside the library names `<twincat library>:line:col`
//! (`<beremiz library>`).

use crate::ast::Library;
use crate::diag::Diagnostics;
use crate::source::builtin::SOURCES;
pub use crate::source::builtin::{is_builtin, BASE};
use crate::source::FileId;

/// The declarations library `lib` (any case) brings in Structured Text, parsed; `None` when
/// it has none. The sources are part of petriplc and tested: an error in one is a bug, kept
/// in `diags` like any other.
pub fn library(lib: &str, diags: &mut Diagnostics) -> Option<Library> {
    let i = SOURCES
        .iter()
        .position(|(l, _, _)| l.eq_ignore_ascii_case(lib))?;
    Some(crate::parser::parse(
        FileId(BASE + i as u32),
        SOURCES[i].2,
        diags,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::source::SourceMap;

    #[test]
    fn every_source_parses_and_is_located() {
        for (i, (lib, name, _)) in SOURCES.iter().enumerate() {
            let mut d = Diagnostics::default();
            let parsed = library(lib, &mut d).unwrap();
            assert!(!d.has_errors(), "{lib}: {d:?}");
            assert!(!parsed.elements.is_empty());
            let map = SourceMap::new();
            let span = crate::source::Span::new(FileId(BASE + i as u32), 0, 0);
            assert!(is_builtin(span.file));
            assert_eq!(map.position(span).file, *name);
        }
        assert!(library("pcworx", &mut Diagnostics::default()).is_none());
    }
}
