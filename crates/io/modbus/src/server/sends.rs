//! The answers of one turn of a TCP loop, written in one io_uring submission.
//!
//! Why: on a 2-core machine a `send` that wakes a client often lets that client take the
//! server's core on the way back to user space, so a loop writing sixteen answers with sixteen
//! `send`s is preempted up to sixteen times, each time with answers still unwritten. One
//! `io_uring_enter` carries every send of the turn and returns once, after all of them: 1.29x
//! libmodbus's requests per second with 16 clients, where one `send` each gave 1.17x
//! (docs/modbus.md, Performance).
//!
//! Each send has MSG_DONTWAIT, so a socket that cannot take its answer completes at once with
//! EAGAIN instead of being left pending in the kernel: when [`Sends::send`] returns, no
//! request refers to a buffer any more. Where the kernel refuses io_uring (an old kernel, a
//! container's seccomp profile, `kernel.io_uring_disabled`), or with `io_uring = no`, the loop
//! writes with one `send` per connection, as before.

#![allow(unsafe_code)] // one block: queueing a send that points at a caller's buffer

use std::io;
use std::os::fd::RawFd;

use io_uring::{opcode, types, IoUring};

/// The most answers sent in one submission; a turn with more submits several times.
const ENTRIES: u32 = 128;

pub(super) struct Sends {
    ring: IoUring,
    /// Per answer of the current batch: its key and what the send did.
    results: Vec<(usize, io::Result<usize>)>,
}

impl Sends {
    /// A ring for one loop, or why the kernel refused it. Kernels from 5.1 to 5.5 have
    /// io_uring without its `send`; they are asked (a probe, itself from 5.6) rather than
    /// left to fail every send.
    pub(super) fn new() -> io::Result<Sends> {
        let ring = IoUring::new(ENTRIES)?;
        let mut probe = io_uring::Probe::new();
        ring.submitter().register_probe(&mut probe)?;
        if !probe.is_supported(opcode::Send::CODE) {
            return Err(io::Error::other("this kernel's io_uring has no send"));
        }
        Ok(Sends {
            ring,
            results: Vec::new(),
        })
    }

    /// Sends each `(key, socket, bytes)` once, without waiting for room in any socket, and
    /// returns for each key the bytes sent or the error (`WouldBlock` when the socket had no
    /// room). The order of the results is not the order of `batch`.
    ///
    /// An error of io_uring itself (not of a send) is returned as such; sends it did not
    /// report on were not made, and their keys are not in the results.
    pub(super) fn send<'a>(
        &mut self,
        batch: impl IntoIterator<Item = (usize, RawFd, &'a [u8])>,
    ) -> io::Result<&[(usize, io::Result<usize>)]> {
        self.results.clear();
        let mut queued = 0usize;
        for (key, fd, bytes) in batch {
            let len = u32::try_from(bytes.len()).unwrap_or(u32::MAX);
            let sqe = opcode::Send::new(types::Fd(fd), bytes.as_ptr(), len)
                .flags(libc::MSG_DONTWAIT | libc::MSG_NOSIGNAL)
                .build()
                .user_data(key as u64);
            if self.ring.submission().is_full() {
                self.complete(queued)?;
                queued = 0;
            }
            // SAFETY: `bytes` outlives this call, and every queued send has completed (read
            // its bytes) before this function returns, by `complete`; MSG_DONTWAIT keeps the
            // kernel from keeping a send pending on a full socket.
            unsafe {
                if self.ring.submission().push(&sqe).is_err() {
                    return Err(io::Error::other("the submission queue is full"));
                }
            }
            queued += 1;
        }
        self.complete(queued)?;
        Ok(&self.results)
    }

    /// Submits what is queued and waits for the `queued` completions.
    fn complete(&mut self, queued: usize) -> io::Result<()> {
        let mut done = 0;
        while done < queued {
            match self.ring.submit_and_wait(queued - done) {
                Ok(_) => {}
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
            for cqe in self.ring.completion() {
                done += 1;
                let r = cqe.result();
                let r = if r >= 0 {
                    Ok(r as usize)
                } else {
                    Err(io::Error::from_raw_os_error(-r))
                };
                self.results.push((cqe.user_data() as usize, r));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;
    use std::os::fd::AsRawFd;

    /// Two connected TCP sockets: (client side, server side).
    fn pair() -> (std::net::TcpStream, std::net::TcpStream) {
        let l = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        let a = std::net::TcpStream::connect(l.local_addr().unwrap()).unwrap();
        let (b, _) = l.accept().unwrap();
        (a, b)
    }

    #[test]
    fn every_answer_arrives_and_a_full_socket_says_would_block() {
        let Ok(mut sends) = Sends::new() else {
            // The kernel refuses io_uring here; the loop writes with send() then (tested by
            // the server's tests with `io_uring = no`).
            return;
        };
        let conns: Vec<_> = (0..3).map(|_| pair()).collect();
        let texts: Vec<Vec<u8>> = (0..3).map(|i| vec![b'a' + i as u8; 10 + i]).collect();
        let mut got: Vec<_> = sends
            .send(
                conns
                    .iter()
                    .zip(&texts)
                    .enumerate()
                    .map(|(k, ((_, srv), t))| (k, srv.as_raw_fd(), t.as_slice())),
            )
            .unwrap()
            .iter()
            .map(|(k, r)| (*k, *r.as_ref().unwrap()))
            .collect();
        got.sort();
        assert_eq!(got, vec![(0, 10), (1, 11), (2, 12)]);
        for ((mut client, _), t) in conns.into_iter().zip(&texts) {
            let mut b = vec![0; t.len()];
            client.read_exact(&mut b).unwrap();
            assert_eq!(&b, t);
        }
        // More sends than the ring holds, in one batch.
        let many: Vec<_> = (0..150).map(|_| pair()).collect();
        let n = sends
            .send(
                many.iter()
                    .enumerate()
                    .map(|(k, (_, s))| (k, s.as_raw_fd(), &b"x"[..])),
            )
            .unwrap()
            .len();
        assert_eq!(n, 150);
        // A client that reads nothing: its socket fills and then refuses at once.
        let (_client, srv) = pair();
        let big = vec![0u8; 1 << 20];
        let mut refused = false;
        for _ in 0..1000 {
            let r = sends.send([(7, srv.as_raw_fd(), &big[..])]).unwrap();
            if let [(7, Err(e))] = r {
                assert_eq!(e.kind(), io::ErrorKind::WouldBlock, "{e}");
                refused = true;
                break;
            }
        }
        assert!(refused, "a full socket refuses instead of blocking");
    }
}
