//! A shrad scene file (`.toml`). It is alone in its directory, so only primitives load;
//! a `file = "s.toml"` refers to itself (the nesting guard must stop it).
#![no_main]
mod common;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    common::load_files(&[("s.toml", data)], &[]);
});
