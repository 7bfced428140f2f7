//! The IEC 61131-3 engine: the checker's lowered form ([`petriplc_iec_sema::ir`]) compiled
//! to a register bytecode ([`op`]) and run by a VM ([`exec`]) over 64-bit slots.
//!
//! - Faults (integer division by zero, overflow, array index out of range, failed
//!   conversions, a loop past the iteration budget) stop the run with the POU, line and
//!   values ([`Fault`]); a bug in the engine is caught the same way, never a crash.
//! - Time is passed in: the same program and inputs give the same results.
//! - Function blocks written in Rust plug in through [`native::NativeFb`].
//! - Retentive variables are listed ([`Engine::retained`]), saved and restored
//!   ([`Machine::snapshot_retain`], [`Machine::restore_retain`]).

pub mod compile;
pub mod exec;
pub mod ext;
mod handle;
pub mod heap;
pub mod layout;
mod machine;
pub mod native;
pub mod op;
pub mod pointer;
mod text;
mod vars;

pub use compile::{CompileError, InstanceSpec};
pub use exec::FaultKind;
pub use machine::{
    Backend, Compiled, Compiler, Engine, Fault, Machine, Ran, Scanner, DEFAULT_ITERATIONS,
};
pub use native::{NativeCtx, NativeFb};
pub use text::{display, string_literal, wide_literal};
pub use vars::{RetainImage, Retained, VarRef};
