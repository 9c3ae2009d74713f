//! A `.gltf` (JSON text, buffers as data URIs or files that do not exist).
#![no_main]
mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    common::load_files(&[("s.gltf", data)], &[]);
});
