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
mod en_eno;
mod expr;
mod il;
pub mod ir;
mod limits;
mod members;
pub mod memory;
mod oop;
pub mod ops;
mod recursion;
mod stdlib;
mod stmt;
pub mod types;
pub mod value;
mod var_config;
pub mod vendor;

use petriplc_iec_syntax::ast::Library;
use petriplc_iec_syntax::Diagnostics;

pub use ops::Overflow;
pub use stdlib::{is_standard_function, standard_fbs, standard_fbs_in, STANDARD_FUNCTIONS};

/// What the checker knows besides the sources.
#[derive(Clone, Debug, Default)]
pub struct Options {
    /// Function blocks implemented in Rust, beside the standard ones (e.g. DSP blocks).
    pub natives: Vec<ir::NativeSig>,
    /// Whose names the standard function blocks' inputs have ([`standard_fbs_in`]).
    pub dialect: petriplc_iec_syntax::Dialect,
    /// A library checked alone (`petriplc check`), not a program built to run: a
    /// VAR_EXTERNAL whose VAR_GLOBAL is not among the sources is the warning W021 (the
    /// project using the library declares it), not the error E106.
    pub library: bool,
    /// What integer overflow, shift counts and REAL-to-integer conversions out of range do
    /// (docs/iec.md, "Rules where the standard leaves a choice"): wrap by default.
    pub overflow: ops::Overflow,
    /// Vendor libraries loaded ([`vendor::LIBRARIES`]: `codesys`, `twincat`, `pcworx`):
    /// their functions are callable, others' are refused naming their library.
    pub libs: Vec<String>,
}

/// Checks a library. Returns the lowered project when there is no error, and every
/// diagnostic (warnings too) in source order.
pub fn check(lib: &Library, options: &Options) -> (Option<ir::Project>, Diagnostics) {
    // The loaded vendor libraries' declarations in Structured Text come first.
    let mut diags = Diagnostics::default();
    let whole = vendor::with_sources(lib, &options.libs, &mut diags);
    let lib = whole.as_ref().unwrap_or(lib);
    // CODESYS's and TwinCAT's implicit FB_init calls, written out as method calls.
    let lowered = petriplc_iec_syntax::fb_init::lower(lib, &mut diags);
    let lib = lowered.as_ref().unwrap_or(lib);
    let (project, more) = check::Checker::new(lib, options).run();
    diags.extend(more);
    let project = project.filter(|_| !diags.has_errors());
    (project, diags)
}

#[cfg(test)]
mod array_star_tests;
#[cfg(test)]
mod codesys_tests;
#[cfg(test)]
mod en_eno_tests;
#[cfg(test)]
mod il_tests;
#[cfg(test)]
mod itf_tests;
#[cfg(test)]
mod oop_tests;
#[cfg(test)]
mod others_tests;
#[cfg(test)]
mod reference_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod union_tests;
#[cfg(test)]
mod wstring_tests;
