//! Every integration test of this crate in one binary: one link instead of one per file
//! (the suite's build time, `scripts/test`). Each file is a module; run one with
//! `cargo test --test all FILE::`.
//! `soak` keeps a binary of its own (Cargo.toml): it measures the process's memory, which
//! tests running beside it would disturb.

mod bake;
mod common;
mod contact_shadow;
mod empty_scene;
mod energy;
mod engine;
mod files_from_other_tools;
mod gltf_animation;
mod lightmap;
mod lightmap_curved;
mod lightmap_rgbm;
mod lightmap_uv1;
mod punctual_lights;
mod reference;
mod reflectance;
mod scenes;
mod sky;
mod spellings;
mod textures;
