//! The positioned XML tree the reader walks: petriplc-xml's, shared with the PLCopen reader.
//! Text is kept whole ([`LeadingBlanks::Keep`]): names are written back as they were read.

#[cfg(test)]
pub(crate) use petriplc_xml::MAX_DEPTH;
pub(crate) use petriplc_xml::{allowed, parse_at, Element, LeadingBlanks};
