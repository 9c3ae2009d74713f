//! shrad: global illumination (diffuse interreflection, "radiosity") for dynamic scenes.
//!
//! It implements Wang, Liu and Wu, "Dispersive calculation of global illumination based on
//! spherical harmonics method" (2007), with the paper's baseline (a uniform grid of SH probes,
//! Nijasure et al. 2003) and a converged reference solver, all over one scene model:
//!
//! ```text
//! shrad_scene::Scene ─► Patches (SoA, per-object ranges) ─► World { patches, visibility }
//!                                                             │
//!               reference::solve / dispersive / grid  ◄───────┘ ─► radiosity per patch
//!                                                             ─► render ─► PNG / EXR
//! ```
//!
//! See `ARCHITECTURE.md` at the repository root for the layers and the data flow of a frame.

pub mod bake;
pub mod direct;
pub mod dispersive;
pub mod energy;
pub mod engine;
mod footprint_cones;
pub mod form_factors;
pub mod frame;
pub mod grid;
pub mod image_io;
pub mod lightmap;
pub mod lights;
pub mod limits;
pub mod metrics;
pub mod patches;
pub mod probe_export;
pub mod probes;
pub mod progress;
pub mod reference;
pub mod render;
pub mod sampling;
mod segments;
pub mod settings;
mod shadow_rays;
pub mod sky;
pub mod solid_core;
pub mod solver;
pub mod sparse;
pub mod surface;
pub mod view_data;
pub mod warm_pool;
mod world;

pub use patches::{PatchSizing, Patches};
pub use progress::{NoProgress, Progress};
pub use shrad_scene as scene;
pub use shrad_vis as vis;
pub use world::World;

use std::path::PathBuf;

/// Errors of the shrad library.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene could not be loaded.
    #[error(transparent)]
    Scene(#[from] shrad_scene::SceneError),
    /// Inputs that make no sense (the message says what).
    #[error("{0}")]
    Invalid(String),
    /// An input file (not a scene) could not be read.
    #[error("{0}: {1}")]
    Input(PathBuf, String),
    /// An output file could not be written (nothing is left behind).
    #[error("{0}: cannot write: {1}")]
    Output(PathBuf, String),
    /// The front end asked the work to stop ([`Progress::stop_requested`]); what it was
    /// making was thrown away.
    #[error("interrupted")]
    Interrupted,
}

/// With `SHRAD_TRACE` set, print the time since `t` of a part of the frame to stderr (the
/// per-function table of docs/results.md §5 comes from `examples/moving_frame.rs` run so).
pub(crate) fn trace_part(label: &str, t: std::time::Instant) {
    static ON: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    if *ON.get_or_init(|| std::env::var_os("SHRAD_TRACE").is_some()) {
        eprintln!("  {label}: {:.2}", t.elapsed().as_secs_f64() * 1e3);
    }
}
