//! MatPLC's DSP function blocks and the filter design behind them, free of the PLC runtime.

pub mod design;
