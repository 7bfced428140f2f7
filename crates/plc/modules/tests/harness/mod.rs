//! The runtime's in-process harness with this crate's built-in kinds.
#![allow(dead_code, unused_imports)]

use std::path::Path;

pub use petriplc_runtime::harness::{examples, ms, Plc};
use petriplc_runtime::module::ModuleError;

pub fn start(text: &str, dir: &Path) -> Result<Plc, ModuleError> {
    petriplc_runtime::harness::start(text, dir, petriplc_modules::builtin)
}

pub fn start_err(text: &str, dir: &Path) -> String {
    petriplc_runtime::harness::start_err(text, dir, petriplc_modules::builtin)
}
