//! The parts of vendor libraries petriplc declares in Structured Text (`builtin/*.st`):
//! TwinCAT's types, enumerations and functions that are ordinary IEC code in the vendor's
//! library too (`T_MaxString`, `__SYSTEM.TYPE_CLASS`, `E_TcMemoryArea`…), and Beremiz's
//! (SVGHMI types, LOGGER, the Python blocks, matiec's PID). A loaded library's
//! source is parsed as the user's and checked with it (`petriplc_iec_sema::vendor`), so its
//! names resolve, type-check and run exactly as the user's would. Its files have ids of their
//! own, from [`BASE`] up, that every [`SourceMap`](crate::source::SourceMap) knows: a message
//! or a run-time fault inside the library names `<twincat library>:line:col`
//! (`<beremiz library>`).

use std::sync::OnceLock;

use crate::ast::Library;
use crate::diag::Diagnostics;
use crate::source::{FileId, SourceFile};

/// The first file id of the built-in sources (far above any project's count of files).
pub const BASE: u32 = 0xFFFF_0000;

/// A library's source: the library (`--lib` name), the name messages print, the text.
const SOURCES: &[(&str, &str, &str)] = &[
    (
        "twincat",
        "<twincat library>",
        include_str!("builtin/twincat.st"),
    ),
    (
        "beremiz",
        "<beremiz library>",
        include_str!("builtin/beremiz.st"),
    ),
];

fn files() -> &'static [SourceFile] {
    static FILES: OnceLock<Vec<SourceFile>> = OnceLock::new();
    FILES.get_or_init(|| {
        SOURCES
            .iter()
            .map(|(_, name, text)| SourceFile::new(name.to_string(), text.to_string(), 0, 0))
            .collect()
    })
}

/// Whether file id `id` is a built-in source (its warnings are the library's, not the
/// project's; its POUs are not counted as the project's).
pub fn is_builtin(id: FileId) -> bool {
    id.0 >= BASE
}

/// The built-in source of file id `id`, if it is one.
pub(crate) fn file(id: FileId) -> Option<&'static SourceFile> {
    id.0.checked_sub(BASE).and_then(|i| files().get(i as usize))
}

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
