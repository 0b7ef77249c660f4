//! Arbitrary bytes as an OBJ file, plain and gzip-compressed: see `obj_loader` in
//! `tests/fuzz_checks/mod.rs`.
#![no_main]

#[path = "../../tests/fuzz_checks/mod.rs"]
mod fuzz_checks;

libfuzzer_sys::fuzz_target!(|data: &[u8]| fuzz_checks::obj_loader(data));
