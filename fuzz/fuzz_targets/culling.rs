//! The scenes and rays of `trace_packets`, traced with a culling setting chosen by the input:
//! every packet and stream path with culling equals the scalar path. See `culling` in
//! `tests/fuzz_checks/mod.rs`.
#![no_main]

#[path = "../../tests/fuzz_checks/mod.rs"]
mod fuzz_checks;

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_checks::culling(data));
