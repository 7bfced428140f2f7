//! Where tests find their data: the repository's `testdata/` (always there), and the
//! third-party code the conformance tests read from `../shared` beside the checkout (there
//! on CI, perhaps not in a user's clone: then the test says in one line that it was skipped).

use std::path::{Path, PathBuf};

/// The repository's root.
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../..")
}

/// `testdata/REL` (testdata/SOURCES.md says what is there).
pub fn testdata(rel: &str) -> PathBuf {
    root().join("testdata").join(rel)
}

/// `../shared/REL` for a conformance test over third-party code, or `None` after one line on
/// standard error saying the test was skipped because it is not there.
pub fn conformance(test: &str, rel: &str) -> Option<PathBuf> {
    let path = root().join("../shared").join(rel);
    if path.exists() {
        Some(path)
    } else {
        eprintln!(
            "conformance test {test} skipped: ../shared/{rel} (third-party code, not in the \
             repository) is not beside the checkout"
        );
        None
    }
}
