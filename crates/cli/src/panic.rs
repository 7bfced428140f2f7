//! What a panic does to a command: it ends it, with a message and exit code 1, whatever
//! thread it happens in, so that no command ever hangs with its other threads waiting for
//! one that died (an exploration's workers at a barrier, say).
//!
//! `petriplc run` is the exception: its module threads catch their own panics and handle
//! them as module failures (`on_failure`), so there a panic only prints its message, and a
//! panic of the main thread unwinds into [`catch`], which stops the PLC cleanly on the way.

use std::panic::{self, AssertUnwindSafe};

use crate::failure::Failure;

const BUG: &str = "petriplc stopped on an internal error (a bug: please report it with the \
                   message above)";

/// Makes any panic in any thread end the process with exit code 1.
pub fn exit_on_panic() {
    let default = panic::take_hook();
    panic::set_hook(Box::new(move |info| {
        default(info);
        eprintln!("error: {BUG}");
        std::process::exit(1);
    }));
}

/// Runs a command, turning a panic of the calling thread into a failure.
pub fn catch(command: impl FnOnce() -> Result<(), Failure>) -> Result<(), Failure> {
    panic::catch_unwind(AssertUnwindSafe(command))
        .unwrap_or_else(|_| Err(Failure::Run(anyhow::anyhow!("{BUG}"))))
}

/// Test hook: with `PETRIPLC_TEST_PANIC=worker` in the environment, a worker thread panics
/// while the command's main thread waits for it at a barrier that can never open, as an
/// exploration's leader waits for its workers; the command must still end.
pub fn test_hook() {
    if std::env::var_os("PETRIPLC_TEST_PANIC").is_some_and(|v| v == "worker") {
        let barrier = std::sync::Arc::new(std::sync::Barrier::new(2));
        let theirs = barrier.clone();
        std::thread::spawn(move || {
            let _never = theirs;
            panic!("a worker thread panicked (PETRIPLC_TEST_PANIC=worker)");
        });
        barrier.wait();
    }
}
