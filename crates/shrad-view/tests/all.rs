//! Every integration test of this crate in one binary: one link instead of one per file
//! (the suite's build time, `scripts/test`). Each file is a module; run one with
//! `cargo test --test all FILE::`.

mod common;
mod lights;
mod server;
mod sharing;
