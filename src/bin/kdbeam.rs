//! The kdbeam command-line tool.
fn main() {}
