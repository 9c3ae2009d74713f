//! The scene model of shrad (spec section 3) and everything that makes one:
//! glTF 2.0 and OBJ/MTL importers, the TOML scene file, and the built-in scenes.
//!
//! A [`Scene`] is a list of [`Object`]s: a triangle mesh in the object's own (rest) frame,
//! one [`Material`], a [`Role`] and an optional rigid [`Animation`]. Everything here is plain
//! data; patches, visibility and the solvers live in the crates above this one.

mod aabb;
mod builtin;
mod cutout;
mod error;
mod gltf_io;
mod ktx2;
mod load;
mod model;
mod node_anim;
mod obj_io;
mod roles;
pub mod scene_def;
mod scene_file;
mod scene_lights;
mod texture;
mod write_atomic;

pub use aabb::Aabb;
pub use builtin::{box_mesh, builtin, builtin_names, cornell_box, quad, room, RoomParams};
pub use error::SceneError;
pub use gltf_io::builder as gltf_builder;
pub use gltf_io::write_gltf;
pub use load::{clamp_reflectance, load, LoadOptions};
pub use model::*;
pub use node_anim::{
    AnimationInfo, GraphNode, Interpolation, NodeAnimation, NodeGraph, NodeRest, Track, TrackValue,
};
pub use obj_io::write_obj;
pub use roles::{infer_roles, warn_faces_turned_away};
pub use texture::{srgb_to_linear, Filter, Texture, TextureImage, UvTransform, Wrap};
pub use write_atomic::{
    remove_unfinished, same_file, staged_path, write_atomic, StagedFiles, WriteError,
};

/// A fresh empty folder `shrad-NAME-PID` in the temporary directory, for unit tests.
#[cfg(test)]
pub(crate) fn test_folder(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("shrad-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
