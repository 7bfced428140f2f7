//! Writing results to standard output the way command-line tools should: a reader that
//! stops early (`| head`) ends the program quietly instead of making it panic or complain.

use std::io::{self, Write};

use anyhow::Context;

use crate::failure::{Failure, RunExt};

/// Writes `produce`'s output to standard output, buffered (standard output alone flushes at
/// every line: a long trace would cost a system call per row); a closed pipe is not an error.
pub fn to_stdout(produce: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<(), Failure> {
    let stdout = io::stdout();
    let mut out = io::BufWriter::with_capacity(64 * 1024, stdout.lock());
    match produce(&mut out).and_then(|()| out.flush()) {
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => Ok(()),
        other => other
            .context("cannot write to standard output")
            .run_failure(),
    }
}

/// Creates the folders `path` needs: every `--out`, `--svg`, `--dot` and `--plot` may name a
/// folder that does not exist yet.
pub fn create_parent(path: &std::path::Path) -> Result<(), Failure> {
    match path.parent().filter(|p| !p.as_os_str().is_empty()) {
        Some(dir) => std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the folder {}", dir.display()))
            .run_failure(),
        None => Ok(()),
    }
}

/// Writes a file the user asked for, creating its folder, and says so on standard error:
/// `wrote out/mixer-sfc.xml (SFC in a PLCopen XML project, 21 KB)`.
pub fn write_file(path: &std::path::Path, contents: &[u8], what: &str) -> Result<(), Failure> {
    create_parent(path)?;
    std::fs::write(path, contents)
        .with_context(|| format!("cannot write {}", path.display()))
        .run_failure()?;
    wrote(path, what);
    Ok(())
}

/// The line every command prints for a file it wrote.
pub fn wrote(path: &std::path::Path, what: &str) {
    eprintln!("wrote {} ({what})", path.display());
}
