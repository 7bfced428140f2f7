//! What the integration tests share: building a C module program against the
//! `libpetriplc.so` built with the test, reading a process's log line by line as it comes,
//! and writing a source for a command to read.

// Each test file compiles this module on its own and uses a part of it.
#![allow(dead_code)]

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
    let include = Path::new(env!("CARGO_MANIFEST_DIR")).join("../plc/capi/include");
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

/// The standard error of `child` (spawned with it piped), line by line as it comes, so that a
/// test can wait for exactly the line it needs instead of running for a fixed time.
pub struct Lines {
    rx: std::sync::mpsc::Receiver<String>,
    /// Every line read so far, for messages.
    pub seen: String,
}

impl Lines {
    pub fn of(child: &mut std::process::Child) -> Lines {
        let stderr = child.stderr.take().expect("standard error piped");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            use std::io::BufRead;
            for line in std::io::BufReader::new(stderr).lines() {
                let Ok(line) = line else { return };
                if tx.send(line).is_err() {
                    return;
                }
            }
        });
        Lines {
            rx,
            seen: String::new(),
        }
    }

    /// Reads until a line contains `text` (within `patience`); panics with what came if none
    /// does.
    pub fn until(&mut self, text: &str, patience: std::time::Duration) {
        let deadline = std::time::Instant::now() + patience;
        loop {
            let left = deadline.saturating_duration_since(std::time::Instant::now());
            match self.rx.recv_timeout(left) {
                Ok(line) => {
                    self.seen.push_str(&line);
                    self.seen.push('\n');
                    if line.contains(text) {
                        return;
                    }
                }
                Err(e) => panic!("no line with `{text}` ({e}):\n{}", self.seen),
            }
        }
    }

    /// Everything until the process closes its standard error.
    pub fn rest(mut self) -> String {
        for line in self.rx.iter() {
            self.seen.push_str(&line);
            self.seen.push('\n');
        }
        self.seen
    }
}

/// Writes `text` as `dir/NAME` and returns its path, as a command's argument.
pub fn file(dir: &tempfile::TempDir, name: &str, text: &str) -> String {
    let p = dir.path().join(name);
    fs::write(&p, text).unwrap();
    p.display().to_string()
}
