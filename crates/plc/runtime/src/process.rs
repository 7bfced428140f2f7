//! Processes of the PLC, identified by what the kernel says rather than by a number in a
//! file: pidfds (a handle on one process that a reused pid can never redirect), process
//! start times (which tell a process from a later one with the same pid), and module
//! programs started so that they die with the PLC (`PR_SET_PDEATHSIG`).

#![allow(unsafe_code)]

use std::io;
use std::os::fd::{AsFd, AsRawFd, FromRawFd, OwnedFd};
use std::os::unix::process::CommandExt;
use std::process::{Child, Command};
use std::time::Duration;

use nix::poll::{poll, PollFd, PollFlags, PollTimeout};
use nix::sys::signal::Signal;

/// A handle on one process: signals sent through it reach that process or fail, never
/// another one that got its pid later.
#[derive(Debug)]
pub struct Pidfd {
    fd: OwnedFd,
    pid: u32,
}

impl Pidfd {
    /// Opens a handle on process `pid` (Linux 5.3 and later).
    pub fn open(pid: u32) -> io::Result<Pidfd> {
        let raw =
            libc::pid_t::try_from(pid).map_err(|_| io::Error::from_raw_os_error(libc::ESRCH))?;
        // SAFETY: pidfd_open takes a pid and flags and returns a new descriptor or -1; it
        // touches no memory of ours.
        let fd = unsafe { libc::syscall(libc::SYS_pidfd_open, raw, 0) };
        if fd < 0 {
            return Err(io::Error::last_os_error());
        }
        // SAFETY: the kernel just returned this descriptor to us; nobody else owns it.
        let fd = unsafe { OwnedFd::from_raw_fd(fd as i32) };
        Ok(Pidfd { fd, pid })
    }

    pub fn pid(&self) -> u32 {
        self.pid
    }

    /// Sends `signal` to the process (an error if it has exited, even if its pid was reused).
    pub fn signal(&self, signal: Signal) -> io::Result<()> {
        // SAFETY: pidfd_send_signal reads only its arguments (no siginfo is passed).
        let r = unsafe {
            libc::syscall(
                libc::SYS_pidfd_send_signal,
                self.fd.as_raw_fd(),
                signal as libc::c_int,
                std::ptr::null::<libc::siginfo_t>(),
                0u32,
            )
        };
        if r < 0 {
            Err(io::Error::last_os_error())
        } else {
            Ok(())
        }
    }

    /// Waits until the process has exited, at most `timeout`; says whether it has.
    pub fn wait_exit(&self, timeout: Duration) -> bool {
        let ms = u16::try_from(timeout.as_millis()).unwrap_or(u16::MAX);
        let mut fds = [PollFd::new(self.fd.as_fd(), PollFlags::POLLIN)];
        loop {
            match poll(&mut fds, PollTimeout::from(ms)) {
                Ok(n) => return n > 0,
                Err(nix::errno::Errno::EINTR) => continue,
                Err(_) => return false,
            }
        }
    }
}

/// A `fcntl` lock request of `kind` (`F_WRLCK`, `F_RDLCK`) on a whole file, every other
/// field zero (open-file-description locks require `l_pid == 0`).
pub(crate) fn whole_file(kind: libc::c_short) -> libc::flock {
    // SAFETY: `flock` is a plain C struct of integers (plus padding on some targets), for
    // which all zeros is a valid value.
    let mut l: libc::flock = unsafe { std::mem::zeroed() };
    l.l_type = kind;
    l.l_whence = libc::SEEK_SET as libc::c_short;
    l
}

/// When process `pid` started, in clock ticks since boot (field 22 of `/proc/PID/stat`), or
/// `None` if there is no such process. A pid and its start time name one process for good.
pub fn start_time(pid: u32) -> Option<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).ok()?;
    parse_start_time(&stat)
}

fn parse_start_time(stat: &str) -> Option<u64> {
    // The command name (field 2) is in parentheses and may itself hold spaces and `)`:
    // the fields after it start after the last `)`.
    let rest = &stat[stat.rfind(')')? + 1..];
    // `rest` starts with field 3 (state); the start time is field 22.
    rest.split_whitespace().nth(19)?.parse().ok()
}

/// Starts `command` so that it receives `signal` when the thread that starts it ends (the
/// PLC's process dies), so that no module program outlives a PLC killed with `kill -9`.
/// Start it from a thread that lives as long as the child should.
pub fn spawn_tied(command: &mut Command, signal: Signal) -> io::Result<Child> {
    let parent = std::process::id();
    let sig = signal as libc::c_int;
    // SAFETY: the closure runs in the child between fork and exec, where only
    // async-signal-safe calls are allowed: prctl, getppid and _exit are; it allocates
    // nothing and touches no lock.
    unsafe {
        command.pre_exec(move || {
            if libc::prctl(libc::PR_SET_PDEATHSIG, sig as libc::c_ulong, 0, 0, 0) != 0 {
                return Err(io::Error::last_os_error());
            }
            // The parent may have died before the death signal was armed.
            if libc::getppid() as u32 != parent {
                libc::_exit(1);
            }
            Ok(())
        });
    }
    command.spawn()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(stat: &str, expect: Option<u64>) {
        assert_eq!(parse_start_time(stat), expect, "{stat}");
    }

    #[test]
    fn start_time_is_field_22() {
        let fields: Vec<String> = (3..=25).map(|i| i.to_string()).collect();
        check(&format!("123 (name) {}", fields.join(" ")), Some(22));
        check(&format!("123 (a) b) c) {}", fields.join(" ")), Some(22));
        check("123 (short) S 1", None);
        check("garbage", None);
    }

    #[test]
    fn this_process_has_a_start_time_and_a_pidfd() {
        let me = std::process::id();
        assert!(start_time(me).is_some());
        let fd = Pidfd::open(me).unwrap();
        assert_eq!(fd.pid(), me);
        assert!(!fd.wait_exit(Duration::from_millis(1)), "we are alive");
    }

    #[test]
    fn a_pidfd_sees_its_process_exit() {
        let mut child = spawn_tied(Command::new("true").arg("x"), Signal::SIGKILL).unwrap();
        let fd = Pidfd::open(child.id()).unwrap();
        assert!(fd.wait_exit(Duration::from_secs(10)));
        child.wait().unwrap();
        assert!(fd.signal(Signal::SIGTERM).is_err(), "it has exited");
    }
}
