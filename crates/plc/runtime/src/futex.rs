//! The locks of the PLC's shared memory: [`RobustMutex`], the robust, priority-inheriting,
//! process-shared mutex that guards the process image and the synchronisation net's marking,
//! and futex wait/wake on plain words (the synchronisation net's generation counter).
//!
//! # Why a robust pthread mutex with priority inheritance
//!
//! Any module process may be killed at any moment, also while it holds the lock (inside
//! `update()` or a firing). A plain futex mutex would then stay held for ever and every other
//! module would block. A *robust* mutex is released by the kernel when its holder dies: the
//! holder's thread keeps the mutex on its robust list, which the kernel walks at thread exit,
//! marking each held mutex `FUTEX_OWNER_DIED` and waking a waiter. The next locker gets
//! `EOWNERDEAD`, repairs the data (each user keeps a journal of its half-done change and
//! undoes it, see `image/shm.rs` and `synch/shared.rs`), and declares the mutex consistent.
//!
//! glibc owns each thread's robust list (there is one list head per thread, registered with
//! `set_robust_list` when the thread starts), so the mutex must be glibc's own
//! `pthread_mutex_t` with `PTHREAD_MUTEX_ROBUST` rather than a hand-made futex, which could
//! not join that list. `PTHREAD_PRIO_INHERIT` makes it a PI futex (`FUTEX_LOCK_PI`): a
//! SCHED_FIFO module waiting for the lock lends its priority to the holder, so priority
//! inversion is bounded by the holder's few microseconds under the lock, as seed 000 asks of
//! a hard real-time MatPLC. Where the kernel refuses PI futexes the mutex is made robust
//! without PI ([`RobustMutex::init`] says which). The uncontended paths of both stay in user
//! space (one compare-and-swap, plus glibc's robust-list bookkeeping).
//!
//! The words live in a `MAP_SHARED` mapping, so wait/wake use the shared (not
//! `FUTEX_PRIVATE_FLAG`) variants: the kernel then keys waiters by the page, and a wake in one
//! process reaches waiters in every process that maps it.

#![allow(unsafe_code)]

use std::cell::UnsafeCell;
use std::marker::PhantomData;
use std::ptr;
use std::sync::atomic::AtomicU32;
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

/// A robust, process-shared pthread mutex, priority-inheriting where supported, laid out in
/// shared memory (one cache line, so that headers can reserve a fixed space for it whatever
/// the size of `pthread_mutex_t` on the target).
#[repr(C, align(64))]
pub(crate) struct RobustMutex {
    raw: UnsafeCell<libc::pthread_mutex_t>,
}

const _: () = assert!(std::mem::size_of::<RobustMutex>() == 64);

// SAFETY: the pthread mutex is made for concurrent use from many threads and processes; all
// access goes through pthread calls.
unsafe impl Sync for RobustMutex {}
// SAFETY: as for Sync (it is only ever reached through references into shared memory).
unsafe impl Send for RobustMutex {}

/// How a [`RobustMutex`] was made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Protocol {
    /// Robust with priority inheritance.
    Inherit,
    /// Robust only: the kernel refused PI futexes.
    Plain,
}

fn check(what: &str, r: libc::c_int) -> std::io::Result<()> {
    if r == 0 {
        Ok(())
    } else {
        Err(std::io::Error::new(
            std::io::Error::from_raw_os_error(r).kind(),
            format!("{what}: {}", std::io::Error::from_raw_os_error(r)),
        ))
    }
}

impl RobustMutex {
    /// Initialises the mutex in place: process-shared, robust, with priority inheritance if
    /// the system allows it.
    ///
    /// # Safety
    /// Nobody else may use the mutex yet (it lives in shared memory not yet published), and
    /// it must not be held.
    pub(crate) unsafe fn init(&self) -> std::io::Result<Protocol> {
        // SAFETY: the caller guarantees exclusive access; the attribute object lives on this
        // stack frame and is destroyed before returning.
        unsafe {
            match self.init_with(true) {
                Ok(()) => Ok(Protocol::Inherit),
                // A kernel or sandbox without PI futexes: still robust.
                Err(_) => self.init_with(false).map(|()| Protocol::Plain),
            }
        }
    }

    /// # Safety
    /// As for [`RobustMutex::init`].
    unsafe fn init_with(&self, inherit: bool) -> std::io::Result<()> {
        // SAFETY: `attr` is initialised by pthread_mutexattr_init before any other use and
        // destroyed on every path; `self.raw` is valid, aligned memory we may write.
        unsafe {
            let mut attr = std::mem::MaybeUninit::<libc::pthread_mutexattr_t>::uninit();
            check(
                "pthread_mutexattr_init",
                libc::pthread_mutexattr_init(attr.as_mut_ptr()),
            )?;
            let a = attr.as_mut_ptr();
            let result = (|| {
                check(
                    "pthread_mutexattr_setpshared",
                    libc::pthread_mutexattr_setpshared(a, libc::PTHREAD_PROCESS_SHARED),
                )?;
                check(
                    "pthread_mutexattr_setrobust",
                    libc::pthread_mutexattr_setrobust(a, libc::PTHREAD_MUTEX_ROBUST),
                )?;
                if inherit {
                    check(
                        "pthread_mutexattr_setprotocol",
                        libc::pthread_mutexattr_setprotocol(a, libc::PTHREAD_PRIO_INHERIT),
                    )?;
                }
                check(
                    "pthread_mutex_init",
                    libc::pthread_mutex_init(self.raw.get(), a),
                )?;
                if inherit {
                    // glibc accepts the attribute even where the kernel has no PI futexes;
                    // the first lock would fail then. Find out now, while nobody waits.
                    check(
                        "pthread_mutex_lock",
                        libc::pthread_mutex_lock(self.raw.get()),
                    )?;
                    check(
                        "pthread_mutex_unlock",
                        libc::pthread_mutex_unlock(self.raw.get()),
                    )?;
                }
                Ok(())
            })();
            libc::pthread_mutexattr_destroy(a);
            result
        }
    }

    /// Takes the mutex. If its previous holder died holding it, runs `repair` first (with
    /// the mutex held) to put the data it guards back in a consistent state, then marks the
    /// mutex consistent again.
    ///
    /// # Panics
    /// If the mutex is unusable (`ENOTRECOVERABLE`: a repair itself failed; the PLC must be
    /// restarted) or this thread already holds it.
    pub(crate) fn lock(&self, repair: impl FnOnce()) -> Guard<'_> {
        // SAFETY: `raw` was initialised by `init` before the memory was published (users
        // check the header's magic, stored after `init`), and lives as long as `self`.
        let r = unsafe { libc::pthread_mutex_lock(self.raw.get()) };
        let guard = Guard {
            mutex: self,
            _not_send: PhantomData,
        };
        match r {
            0 => guard,
            libc::EOWNERDEAD => {
                repair();
                // SAFETY: we hold the mutex (EOWNERDEAD hands it over); the data is repaired.
                let c = unsafe { libc::pthread_mutex_consistent(self.raw.get()) };
                if c != 0 {
                    // Unlocking unrepaired would make it unrecoverable for everybody.
                    std::mem::forget(guard);
                    panic!(
                        "pthread_mutex_consistent: {}",
                        std::io::Error::from_raw_os_error(c)
                    );
                }
                guard
            }
            e => {
                std::mem::forget(guard);
                panic!(
                    "cannot take the PLC's shared-memory lock: {} (the PLC must be restarted)",
                    std::io::Error::from_raw_os_error(e)
                )
            }
        }
    }
}

/// Holds a [`RobustMutex`] until dropped. Not `Send`: a PI mutex must be unlocked by the
/// thread that locked it.
pub(crate) struct Guard<'a> {
    mutex: &'a RobustMutex,
    _not_send: PhantomData<*const ()>,
}

impl Drop for Guard<'_> {
    fn drop(&mut self) {
        // SAFETY: this thread holds the mutex (the guard is created only after a successful
        // lock and cannot leave the thread).
        unsafe {
            libc::pthread_mutex_unlock(self.mutex.raw.get());
        }
    }
}
