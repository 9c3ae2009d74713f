//! Every integration test of this crate in one binary: one link instead of one per file
//! (the suite's build time, `scripts/test`). Each file is a module; run one with
//! `cargo test --test all FILE::`.

mod bake_lightmap;
mod bake_view;
mod cli;
mod cli_doc;
mod common;
mod empty_scene;
