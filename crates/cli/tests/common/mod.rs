//! What the tests that run C modules share: building a module program against the
//! `libpetriplc.so` built with the test.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Builds the C module `source` as `dir/NAME` against a copy of the `libpetriplc.so` built
/// with this test (it sits beside the test binary: petriplc-capi is a dev-dependency for it),
/// with `cc -std=c99 -Wall -Werror` and `flags`; panics with cc's messages when it fails.
pub fn c_module(dir: &Path, name: &str, source: &str, flags: &[&str]) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let lib = exe.parent().unwrap().join("libpetriplc.so");
    assert!(lib.exists(), "{} is missing", lib.display());
    fs::copy(&lib, dir.join("libpetriplc.so")).unwrap();
    let file = dir.join(format!("{name}.c"));
    fs::write(&file, source).unwrap();
    let program = dir.join(name);
    let include = Path::new(env!("CARGO_MANIFEST_DIR")).join("../capi/include");
    let out = Command::new("cc")
        .args(["-std=c99"])
        .args(flags)
        .args(["-Wall", "-Werror", "-I"])
        .arg(&include)
        .arg(&file)
        .arg("-L")
        .arg(dir)
        // DT_RPATH, searched before LD_LIBRARY_PATH (cargo's points at target/debug, where
        // an older libpetriplc.so may lie): the module loads the library copied beside it.
        .arg("-Wl,--disable-new-dtags")
        .arg(format!("-Wl,-rpath,{}", dir.display()))
        .args(["-lpetriplc", "-o"])
        .arg(&program)
        .output()
        .expect("a C compiler `cc` is needed");
    assert!(
        out.status.success(),
        "cc failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    program
}
