//! Every integration test of this crate in one binary: one link instead of one per file
//! (the suite's build time, `scripts/test`). Each file is a module; run one with
//! `cargo test --test all FILE::`.
//! `validator_suite`, `fuzz_regressions`, `compressed` and `gltf_spec` keep binaries of their
//! own (Cargo.toml): each installs a panic hook that counts panics, which tests running
//! beside it would disturb.

mod blender_animated_lights;
mod blender_animation;
mod blender_base_color;
mod blender_camera;
mod blender_instancing;
mod blender_skin;
mod common;
mod default_camera;
mod environment;
mod gltf_animation;
mod gltf_animation_pointer;
mod gltf_camera_animation;
mod gltf_files_outside;
mod gltf_instancing;
mod gltf_ktx2;
mod gltf_lights;
mod gltf_mask_cutout;
mod gltf_morph_alpha;
mod gltf_skin;
mod gltf_visibility;
mod io;
mod lightmap_uvs;
mod obj_map_d;
mod scene_file_lights;
