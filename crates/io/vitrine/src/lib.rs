//! The `vitrine` module of `petriplc run` (MatPLC's curses vitrine and keyboard module,
//! rebuilt with ratatui): a live terminal display of the points, MatPLC `show` screens,
//! sparkline graphs, every module's state and statistics and the marking of every
//! `petrinet` module, with keys bound to points. See docs/vitrine.md.

mod format;
mod keys;
mod logring;
mod setup;
mod term;
pub mod view;
mod vitrine;

use petriplc_runtime::module::Factory;

pub use keys::{parse_key, KeySpec, Named};
pub use logring::LogWriter;
pub use setup::DataType;
pub use term::takes_terminal;
pub use vitrine::{Probe, Vitrine, DEFAULT_PERIOD};

/// The module kinds of this crate.
pub const KINDS: &[&str] = &["vitrine"];

/// The factory of a module kind of this crate (see [`KINDS`]).
pub fn builtin(kind: &str) -> Option<Factory> {
    (kind == setup::KIND).then_some(vitrine::factory as Factory)
}

/// A log destination for `petriplc run`'s logger while a vitrine has the terminal (see
/// [`takes_terminal`]): complete lines go to the vitrine's footer, and are printed on
/// standard error when it gives the terminal back (or at once while no vitrine holds it).
pub fn log_writer() -> LogWriter {
    LogWriter::default()
}
