//! The built-in vendor libraries' source files (`crate::builtin` parses them): their texts
//! and the file ids every `SourceMap` knows them by, kept here so that the map needs nothing
//! from the parser.

use std::sync::OnceLock;

use super::{FileId, SourceFile};

/// The first file id of the built-in sources (far above any project's count of files).
pub const BASE: u32 = 0xFFFF_0000;

/// A library's source: the library (`--lib` name), the name messages print, the text.
pub(crate) const SOURCES: &[(&str, &str, &str)] = &[
    (
        "twincat",
        "<twincat library>",
        include_str!("../builtin/twincat.st"),
    ),
    (
        "beremiz",
        "<beremiz library>",
        include_str!("../builtin/beremiz.st"),
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
