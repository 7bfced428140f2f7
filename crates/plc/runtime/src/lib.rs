//! The soft PLC runtime (MatPLC, seed 000, rebuilt): a process image of plc points in POSIX
//! shared memory that modules see through private maps synchronised by `update()`, the
//! synchronisation Petri net that orders module scans, and scan periods on absolute
//! deadlines with statistics.

mod futex;
pub mod harness;
pub mod image;
pub mod module;
pub mod owner;
pub mod period;
pub mod process;
pub mod report;
pub mod retained;
mod shm_name;
pub mod status;
pub mod synch;
pub mod testhook;
pub mod watchdog;
