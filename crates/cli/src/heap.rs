//! The C heap's policy for the analysis commands: freed blocks kept for reuse instead of
//! being unmapped.
//!
//! Why: `analyze` allocates and frees large buffers all through a search (hash tables that
//! double, frontiers per round and per level of the backward search). With glibc's defaults
//! every block past 128 KiB (a threshold that grows only as such blocks are freed) is a fresh
//! `mmap`, faulted in page by page and unmapped on free, which interrupts the other search
//! thread to flush its TLB. On Kanban-PT-00005 that was 0.3 s of the 1.5 s command in the
//! kernel; with blocks up to 32 MiB taken from the heap, and the heap grown 64 MiB at a
//! time, it is 0.05 s and the command takes 1.3 s, for 3 MB more peak memory
//! (docs/performance.md). The PLC runtime keeps glibc's defaults: with memory locked, a
//! 64 MiB step of the heap would be locked and faulted in at once.
#![allow(unsafe_code)] // one call into the C library, below

/// Blocks up to this size come from the heap.
const MMAP_THRESHOLD: i32 = 32 << 20;
/// The heap grows by this much more than it needs when it grows.
const TOP_PAD: i32 = 64 << 20;

/// Sets the policy; call before the work starts. Without glibc, nothing.
pub fn reuse_freed_memory() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        // SAFETY: `mallopt` only changes glibc's allocator parameters (under its own lock);
        // it takes plain integers and touches no memory of ours.
        unsafe {
            libc::mallopt(libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD);
            libc::mallopt(libc::M_TOP_PAD, TOP_PAD);
        }
    }
}
