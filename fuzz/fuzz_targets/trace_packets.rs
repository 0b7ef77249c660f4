//! A small mesh and rays decoded from arbitrary bytes: every ISA's packet and stream paths equal
//! the scalar path. See `trace_packets` in `tests/fuzz_checks/mod.rs`.
#![no_main]

#[path = "../../tests/fuzz_checks/mod.rs"]
mod fuzz_checks;

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_checks::trace_packets(data));
