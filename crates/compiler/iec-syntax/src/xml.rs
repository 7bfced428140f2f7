//! The positioned XML tree the PLCopen reader and its graphical front ends walk: petriplc-xml's,
//! shared with the PNML reader.

pub use petriplc_xml::{parse, Element, XmlError, MAX_DEPTH};
