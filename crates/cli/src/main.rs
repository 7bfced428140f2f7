//! The `petriplc` command line.

fn main() {}
