//! MatPLC's DSP function blocks and the filter design behind them, free of the PLC runtime:
//! `design` reproduces `scipy.signal`'s IIR and FIR design, `block` holds the blocks as
//! plain structs, `chain` parses MatPLC's `fblock` rows and runs a module's blocks in order
//! over an array of point values.

pub mod block;
pub mod chain;
pub mod design;
