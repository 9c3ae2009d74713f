//! An `.obj` and its `.mtl`: the input is split at its first NUL byte into the OBJ text
//! (written as `s.obj`) and the MTL text (written as `m.mtl`, which the seeds name with
//! `mtllib m.mtl`). With no NUL there is no MTL file (a missing library is a warning).
#![no_main]
mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    match data.iter().position(|&b| b == 0) {
        Some(i) => common::load_files(&[("s.obj", &data[..i]), ("m.mtl", &data[i + 1..])], &[]),
        None => common::load_files(&[("s.obj", data)], &["m.mtl"]),
    }
});
