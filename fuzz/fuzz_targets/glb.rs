//! A `.glb` (binary glTF: header, JSON chunk, BIN chunk).
#![no_main]
mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    common::load_files(&[("s.glb", data)], &[]);
});
