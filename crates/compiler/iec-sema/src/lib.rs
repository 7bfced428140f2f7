//! The IEC 61131-3 checker: resolves every name of a syntax tree, types every expression by
//! the standard's rules (implicit widening only, literals typed by their context), checks
//! calls, assignments, CASE labels, loops and configurations, and lowers the result to the
//! typed form of [`ir`] that the VM compiles.
//!
//! Every problem is collected with its code and position; nothing is lowered for a library
//! with errors. The standard function blocks (TON, TOF, TP, R_TRIG, F_TRIG, CTU, CTD, CTUD,
//! SR, RS) and any function block implemented in Rust are described by [`ir::NativeSig`]
//! ([`stdlib::standard_fbs`]); the VM supplies their behaviour.

mod check;
mod consts;
mod expr;
mod il;
pub mod ir;
mod limits;
pub mod memory;
pub mod ops;
mod stdlib;
mod stmt;
pub mod types;
pub mod value;

use petriplc_iec_syntax::ast::Library;
use petriplc_iec_syntax::Diagnostics;

pub use stdlib::{is_standard_function, standard_fbs, STANDARD_FUNCTIONS};

/// What the checker knows besides the sources.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Function blocks implemented in Rust, beside the standard ones (e.g. DSP blocks).
    pub natives: Vec<ir::NativeSig>,
}

/// Checks a library. Returns the lowered project when there is no error, and every
/// diagnostic (warnings too) in source order.
pub fn check(lib: &Library, options: &Options) -> (Option<ir::Project>, Diagnostics) {
    check::Checker::new(lib, options).run()
}

#[cfg(test)]
mod il_tests;
#[cfg(test)]
mod reference_tests;
#[cfg(test)]
mod tests;
