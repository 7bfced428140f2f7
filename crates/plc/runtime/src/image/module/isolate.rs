//! The proxy of an isolated module (`location = isolate`, MatPLC's `--PLCisolate`): a
//! process forked from the module that alone maps the global map and performs the module's
//! `update()` on request over a socket, on a private map both processes share.
//!
//! The module process never maps the global map, so a module that scribbles over its memory
//! can corrupt only its own private map, never the PLC's image. The proxy holds the global
//! lock only with its death signal blocked, so a module killed mid-update never leaves the
//! lock held.
//!
//! Forking is safe only from a single-threaded process (the child has just the forking
//! thread, and locks other threads held stay held); [`process_threads`] lets callers that
//! own the process, such as the C ABI's `plc_init`, refuse otherwise.
//! `PR_SET_PDEATHSIG` fires when the *thread* that forked exits, so the map must be made on
//! a thread that lives as long as the module (its main thread, typically).

use std::io::{self, Read, Write};
use std::num::NonZeroUsize;
use std::os::fd::AsRawFd;
use std::os::unix::net::UnixStream;
use std::ptr::NonNull;
use std::sync::atomic::{fence, Ordering};

use nix::sys::mman::{mmap_anonymous, munmap, MapFlags, ProtFlags};
use nix::sys::signal::{signal, sigprocmask, SigHandler, SigSet, SigmaskHow, Signal};
use nix::sys::wait::waitpid;
use nix::unistd::{fork, getppid, ForkResult, Pid};

use super::super::layout::Layout;
use super::super::shm::{shm_name, GlobalMap, ImageGuard};
use super::super::ImageError;

/// The proxy's death signal: catchable (unlike SIGKILL), so the proxy can hold it off while
/// it holds the global lock.
const DEATH: Signal = Signal::SIGTERM;

/// The request and the reply of one update.
const UPDATE: u8 = b'u';
const DONE: u8 = b'd';

/// Status tags the proxy sends once it has (or has failed to) open the global map.
const READY: u8 = 0;
const NOT_RUNNING: u8 = 1;
const MISMATCH: u8 = 2;
const BAD_IMAGE: u8 = 3;
const OS: u8 = 4;

/// The module's side: the shared private words, the socket to the proxy and its pid.
pub(super) struct Proxy {
    map: NonNull<u32>,
    map_len: usize,
    base: usize,
    words: usize,
    sock: Option<UnixStream>,
    pid: Pid,
    /// Set once a request failed: the proxy is gone and every later update must say so.
    lost: Option<String>,
}

// SAFETY: the mapping is owned by the `Proxy` alone (no other pointer to it escapes except
// through `&self`/`&mut self` borrows), exactly like the `Vec` a local map keeps; the proxy
// process touches the words only while the owner is blocked in `update`.
unsafe impl Send for Proxy {}
// SAFETY: as for Send; `&self` gives only shared reads of the words.
unsafe impl Sync for Proxy {}

impl std::fmt::Debug for Proxy {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Proxy")
            .field("pid", &self.pid)
            .field("words", &self.words)
            .field("lost", &self.lost)
            .finish()
    }
}

impl Proxy {
    /// Maps the shared private words (`init`, placed at word `base` of a page), forks the
    /// proxy and waits until it has opened PLC `plc_id`'s global map and checked `layout`.
    /// `merge(global, private)` is the update the proxy runs under the global lock.
    pub(super) fn spawn(
        layout: &Layout,
        plc_id: &str,
        init: &[u32],
        base: usize,
        merge: impl Fn(&mut ImageGuard<'_>, &mut [u32]),
    ) -> Result<Proxy, ImageError> {
        let shm = shm_name(plc_id)?;
        let os = |what: &'static str, e: io::Error| ImageError::Os {
            what,
            shm: shm.clone(),
            source: e,
        };
        let map_len = (4 * (base + init.len())).next_multiple_of(4096).max(4096);
        // SAFETY: a fresh anonymous mapping overlaps nothing; it is unmapped only in Drop.
        // MAP_SHARED, so that the proxy forked below sees the same pages.
        let map = unsafe {
            mmap_anonymous(
                None,
                NonZeroUsize::new(map_len).expect("map_len is at least a page"),
                ProtFlags::PROT_READ | ProtFlags::PROT_WRITE,
                MapFlags::MAP_SHARED,
            )
        }
        .map_err(|e| {
            os(
                "cannot map the private map of an isolated module for",
                e.into(),
            )
        })?
        .cast::<u32>();
        let mut proxy = Proxy {
            map,
            map_len,
            base,
            words: init.len(),
            sock: None,
            pid: Pid::from_raw(0),
            lost: None,
        };
        proxy.words_mut().copy_from_slice(init);
        let (ours, theirs) =
            UnixStream::pair().map_err(|e| os("cannot create the isolation socket for", e))?;
        let parent = nix::unistd::getpid();
        // SAFETY: the child runs only `proxy_main`, which touches no lock another thread
        // could have held at the fork (the allocator is fork-safe in glibc and musl), and
        // leaves by `_exit`, never returning into the caller's code; `process_threads` lets
        // callers refuse multi-threaded processes.
        match unsafe { fork() } {
            Err(e) => return Err(os("cannot fork the isolation proxy for", e.into())),
            Ok(ForkResult::Child) => {
                drop(ours);
                let private = proxy.words_mut();
                let code = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    proxy_main(theirs, parent, plc_id, layout, private, &merge)
                }))
                .unwrap_or(101);
                // SAFETY: `_exit` skips atexit handlers and stdio flushing, which belong to
                // the module (they would run twice); it never returns.
                unsafe { libc::_exit(code) }
            }
            Ok(ForkResult::Parent { child }) => proxy.pid = child,
        }
        drop(theirs);
        proxy.sock = Some(ours);
        proxy.ready(plc_id, &shm)?;
        Ok(proxy)
    }

    /// Reads the proxy's first message: ready, or why it could not open the global map.
    fn ready(&mut self, plc_id: &str, shm: &str) -> Result<(), ImageError> {
        let sock = self.sock.as_mut().expect("set by spawn");
        let mut tag = [0u8; 1];
        let mut read = || -> io::Result<(u8, i32, String)> {
            sock.read_exact(&mut tag)?;
            if tag[0] == READY {
                return Ok((READY, 0, String::new()));
            }
            let mut head = [0u8; 8];
            sock.read_exact(&mut head)?;
            let errno = i32::from_le_bytes(head[..4].try_into().expect("4 bytes"));
            let len = u32::from_le_bytes(head[4..].try_into().expect("4 bytes"));
            let mut text = vec![0u8; len as usize];
            sock.read_exact(&mut text)?;
            Ok((tag[0], errno, String::from_utf8_lossy(&text).into_owned()))
        };
        let (tag, errno, text) = read().map_err(|e| ImageError::Os {
            what: "the isolation proxy exited before opening",
            shm: shm.to_string(),
            source: e,
        })?;
        Err(match tag {
            READY => return Ok(()),
            NOT_RUNNING => ImageError::NotRunning {
                plc_id: plc_id.to_string(),
                shm: shm.to_string(),
            },
            MISMATCH => ImageError::LayoutMismatch {
                plc_id: plc_id.to_string(),
            },
            BAD_IMAGE => ImageError::BadImage {
                shm: shm.to_string(),
                reason: text,
            },
            _ => ImageError::Os {
                what: "the isolation proxy cannot open",
                shm: shm.to_string(),
                source: if errno != 0 {
                    io::Error::from_raw_os_error(errno)
                } else {
                    io::Error::other(text)
                },
            },
        })
    }

    pub(super) fn words(&self) -> &[u32] {
        // SAFETY: the mapping holds `base + words` u32s from its (page-aligned) start and
        // lives as long as `self`; the proxy writes them only during `update`, which takes
        // `&mut self`, so no shared borrow is alive then.
        unsafe { std::slice::from_raw_parts(self.map.as_ptr().add(self.base), self.words) }
    }

    pub(super) fn words_mut(&mut self) -> &mut [u32] {
        // SAFETY: as in `words`; `&mut self` makes this the only borrow.
        unsafe { std::slice::from_raw_parts_mut(self.map.as_ptr().add(self.base), self.words) }
    }

    /// Has the proxy run one update and waits for it to finish.
    pub(super) fn update(&mut self) -> Result<(), String> {
        if let Some(why) = &self.lost {
            return Err(why.clone());
        }
        let result = self.round_trip();
        result.map_err(|e| {
            let why = self.why_lost(e);
            self.lost = Some(why.clone());
            why
        })
    }

    fn round_trip(&mut self) -> io::Result<()> {
        let sock = self.sock.as_mut().expect("set by spawn");
        // The socket calls are the hand-over of the private words between the processes.
        fence(Ordering::SeqCst);
        loop {
            // SAFETY: sends one byte from a live stack buffer on a socket we own;
            // MSG_NOSIGNAL, because a dead proxy must be an error, not a SIGPIPE that kills
            // the module.
            let n = unsafe {
                libc::send(
                    sock.as_raw_fd(),
                    [UPDATE].as_ptr().cast(),
                    1,
                    libc::MSG_NOSIGNAL,
                )
            };
            if n == 1 {
                break;
            }
            let e = io::Error::last_os_error();
            if e.kind() != io::ErrorKind::Interrupted {
                return Err(e);
            }
        }
        let mut reply = [0u8; 1];
        sock.read_exact(&mut reply)?;
        fence(Ordering::SeqCst);
        if reply[0] == DONE {
            Ok(())
        } else {
            Err(io::Error::other(format!(
                "unexpected reply {:#x}",
                reply[0]
            )))
        }
    }

    fn why_lost(&mut self, e: io::Error) -> String {
        // Closing first makes sure the proxy is leaving; reaping it tells how it ended.
        self.sock = None;
        let status = waitpid(self.pid, None);
        match status {
            Ok(s) => format!(
                "the isolation proxy (pid {}) is gone ({s:?}): {e}",
                self.pid
            ),
            Err(_) => format!("the isolation proxy (pid {}) is gone: {e}", self.pid),
        }
    }

    pub(super) fn pid(&self) -> u32 {
        self.pid.as_raw() as u32
    }
}

impl Drop for Proxy {
    fn drop(&mut self) {
        // Closing the socket is the proxy's signal to exit.
        if self.sock.take().is_some() && self.pid.as_raw() > 0 {
            let _ = waitpid(self.pid, None);
        }
        // SAFETY: the mapping was made by `spawn` with this address and length, and no
        // borrow of it outlives `self`.
        let _ = unsafe { munmap(self.map.cast(), self.map_len) };
    }
}

/// The proxy process: opens the global map, reports, then serves updates until the module
/// closes the socket. Returns the exit code.
fn proxy_main(
    mut sock: UnixStream,
    parent: Pid,
    plc_id: &str,
    layout: &Layout,
    private: &mut [u32],
    merge: &dyn Fn(&mut ImageGuard<'_>, &mut [u32]),
) -> i32 {
    // The module's handlers are the module's code, and its mask could block our death
    // signal for good: start from defaults. Terminal signals reach the whole process group;
    // the proxy leaves when the module does, when the socket closes.
    // SAFETY: installing SIG_DFL / SIG_IGN runs no code of ours in signal context.
    unsafe {
        for s in [
            Signal::SIGINT,
            Signal::SIGQUIT,
            Signal::SIGHUP,
            Signal::SIGPIPE,
        ] {
            let _ = signal(s, SigHandler::SigIgn);
        }
        let _ = signal(DEATH, SigHandler::SigDfl);
    }
    let _ = sigprocmask(SigmaskHow::SIG_SETMASK, Some(&SigSet::empty()), None);
    let _ = nix::sys::prctl::set_pdeathsig(DEATH);
    if getppid() != parent {
        // The module died before the death signal was armed.
        return 0;
    }
    close_other_fds(sock.as_raw_fd());
    let global = match GlobalMap::open(plc_id).and_then(|g| g.check_layout(layout).map(|()| g)) {
        Ok(g) => g,
        Err(e) => {
            let (tag, errno) = match &e {
                ImageError::NotRunning { .. } => (NOT_RUNNING, 0),
                ImageError::LayoutMismatch { .. } => (MISMATCH, 0),
                ImageError::BadImage { reason, .. } => {
                    let _ = send_error(&mut sock, BAD_IMAGE, 0, reason);
                    return 1;
                }
                ImageError::Os { source, .. } => (OS, source.raw_os_error().unwrap_or(0)),
                _ => (OS, 0),
            };
            let _ = send_error(&mut sock, tag, errno, &e.to_string());
            return 1;
        }
    };
    if sock.write_all(&[READY]).is_err() {
        return 0;
    }
    let mut death = SigSet::empty();
    death.add(DEATH);
    loop {
        let mut request = [0u8; 1];
        match sock.read(&mut request) {
            Ok(0) => return 0,
            Ok(_) if request[0] == UPDATE => {}
            Ok(_) => return 2,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(_) => return 0,
        }
        let _ = sigprocmask(SigmaskHow::SIG_BLOCK, Some(&death), None);
        {
            let mut guard = global.lock();
            merge(&mut guard, private);
        }
        // A death signal that came meanwhile terminates us here, with the lock free.
        let _ = sigprocmask(SigmaskHow::SIG_UNBLOCK, Some(&death), None);
        if sock.write_all(&[DONE]).is_err() {
            return 0;
        }
    }
}

fn send_error(sock: &mut UnixStream, tag: u8, errno: i32, text: &str) -> io::Result<()> {
    let mut msg = vec![tag];
    msg.extend_from_slice(&errno.to_le_bytes());
    msg.extend_from_slice(&(text.len() as u32).to_le_bytes());
    msg.extend_from_slice(text.as_bytes());
    sock.write_all(&msg)
}

/// Closes every descriptor but stdio and `keep`: the proxy must not keep the module's
/// files, pipes and sockets open (least of all another isolated map's socket, whose proxy
/// would then never see it close).
fn close_other_fds(keep: i32) {
    let ranges = [(3, keep - 1), (keep + 1, i32::MAX)];
    for (first, last) in ranges {
        if first > last {
            continue;
        }
        // SAFETY: close_range only closes descriptors; the ones in range belong to the
        // module's code, which never runs in this process. Without the syscall (Linux before
        // 5.9) the descriptors stay open, which costs only the early EOF.
        unsafe {
            libc::syscall(libc::SYS_close_range, first as u32, last as u32, 0u32);
        }
    }
}

/// How many threads the calling process has (`Threads:` in /proc/self/status), or `None`
/// if that cannot be read. Callers that fork an isolated map's proxy refuse more than one.
pub fn process_threads() -> Option<usize> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("Threads:"))
        .and_then(|n| n.trim().parse().ok())
}
