//! Linux futexes on words in shared memory: wait/wake, and the three-state mutex (0 free,
//! 1 locked, 2 locked with waiters) after Drepper's "Futexes Are Tricky" that guards both the
//! process image and the synchronisation net's marking.
//!
//! The words live in a `MAP_SHARED` mapping, so the operations use the shared (not
//! `FUTEX_PRIVATE_FLAG`) variants: the kernel then keys waiters by the page, and a wake in
//! one process reaches waiters in every process that maps it.

#![allow(unsafe_code)]

use std::ptr;
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

/// Sleeps while `*word == expected`, at most `timeout`. Returns `false` only when the
/// timeout expired; spurious wake-ups, signals and a changed value all return `true`, and
/// callers re-check their condition either way.
pub(crate) fn wait(word: &AtomicU32, expected: u32, timeout: Option<Duration>) -> bool {
    let ts = timeout.map(|d| libc::timespec {
        tv_sec: libc::time_t::try_from(d.as_secs()).unwrap_or(libc::time_t::MAX),
        tv_nsec: d.subsec_nanos() as _,
    });
    let ts_ptr = ts
        .as_ref()
        .map_or(ptr::null(), |t| t as *const libc::timespec);
    // SAFETY: `word` is a live, aligned u32 for the whole call (it borrows the mapping);
    // the kernel only reads it and the optional timespec, which outlives the call.
    let r = unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAIT,
            expected,
            ts_ptr,
            ptr::null::<u32>(),
            0u32,
        )
    };
    !(r == -1 && std::io::Error::last_os_error().raw_os_error() == Some(libc::ETIMEDOUT))
}

/// Wakes up to `count` waiters on `word`.
pub(crate) fn wake(word: &AtomicU32, count: i32) {
    // SAFETY: `word` is a live, aligned u32; FUTEX_WAKE does not access its value.
    unsafe {
        libc::syscall(
            libc::SYS_futex,
            word.as_ptr(),
            libc::FUTEX_WAKE,
            count,
            ptr::null::<libc::timespec>(),
            ptr::null::<u32>(),
            0u32,
        );
    }
}

/// Holds the futex mutex on a word until dropped.
pub(crate) struct Guard<'a> {
    word: &'a AtomicU32,
}

/// Spins this many times on a held lock before sleeping: holders keep it for a few µs at
/// most, less than a futex round trip.
const SPIN: u32 = 100;

/// Takes the futex mutex on `word`.
pub(crate) fn lock(word: &AtomicU32) -> Guard<'_> {
    if word
        .compare_exchange(0, 1, Ordering::Acquire, Ordering::Relaxed)
        .is_err()
    {
        lock_contended(word);
    }
    Guard { word }
}

#[cold]
fn lock_contended(word: &AtomicU32) {
    for _ in 0..SPIN {
        std::hint::spin_loop();
        if word.load(Ordering::Relaxed) == 0
            && word
                .compare_exchange(0, 1, Ordering::Acquire, Ordering::Relaxed)
                .is_ok()
        {
            return;
        }
    }
    // Once anyone has waited, keep marking the lock contended (2) so that the holder's
    // unlock knows to wake someone: waking nobody is cheap, a lost wake-up is a hang.
    while word.swap(2, Ordering::Acquire) != 0 {
        wait(word, 2, None);
    }
}

fn unlock(word: &AtomicU32) {
    if word.swap(0, Ordering::Release) == 2 {
        wake(word, 1);
    }
}

impl Drop for Guard<'_> {
    fn drop(&mut self) {
        unlock(self.word);
    }
}
