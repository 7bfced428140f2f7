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
