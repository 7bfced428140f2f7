//! IEC 61131-3 sources: Structured Text text, PLCopen XML projects and TwinCAT 3 files read into one syntax
//! tree ([`ast`]) with a source position on every node, and the diagnostics of every stage
//! ([`diag`]) with stable codes and `file:line:col` positions ([`source`]).
//!
//! Nothing here knows types or runs anything: the checker (`petriplc-iec-sema`) resolves and
//! types the tree, the VM (`petriplc-iec-vm`) runs what the checker lowers.

pub mod ast;
mod build;
pub mod builtin;
pub mod codes;
pub mod depth;
pub mod diag;
pub mod dialect;
pub mod fb_init;
pub mod lexer;
pub mod parser;
pub mod plcopen;
mod sfc;
pub mod source;
pub mod twincat;
pub mod xml;

pub use diag::{Code, Diagnostic, Diagnostics, Severity};
pub use dialect::Dialect;
pub use parser::{parse, parse_il};
pub use source::{FileId, SourceMap, Span};
