//! Plain-data scene model. Conventions (spec section 2): linear RGB, Lambertian surfaces,
//! reflectance `rho` in [0,1), emitted radiance `L_e` of the front side (exitance
//! `M = pi * L_e`), counter-clockwise triangles seen from the front.
//!
//! One file an idea: [`Role`] and [`Object`] (`object.rs`), [`Material`], [`Mesh`], the
//! keyframed [`Animation`], the animated light and emission properties
//! (`property_tracks.rs`), [`Camera`] and [`Scene`] (`scene.rs`), and the checks every
//! solver relies on ([`Scene::validate`], `validate.rs`) with the warning of a light shut
//! inside an object (`enclosed_lights.rs`).

mod animation;
mod enclosed_lights;
mod environment;
mod light;
mod material;
mod mesh;
mod object;
mod property_tracks;
mod scene;
mod validate;

pub use animation::{Animation, EmissionKey, Keyframe, ReflectanceKey};
pub use environment::{EnvMap, Environment, MAX_ENV_SIDE};
pub use light::{ConeFalloff, Light, LightKind, LUMENS_PER_WATT};
pub use material::{Material, MAX_REFLECTANCE};
pub use mesh::Mesh;
pub use object::{Object, Role};
pub use property_tracks::{LightTracks, MaterialTracks};
pub(crate) use scene::{faces_towards, holds};
pub use scene::{Camera, Scene, SceneSettings};
pub use validate::{
    emission_problem, is_singular, placement_problem, transform_problem, MAX_COORDINATE,
    MAX_RADIANCE,
};
