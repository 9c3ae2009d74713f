//! Visibility for shrad (spec section 6): one batch interface for "from these points, in
//! these directions, which triangle is nearest, front or back face, with these objects left
//! out", plus occlusion (shadow) queries. Built once per scene; a moving object updates its
//! instance transform and [`Visibility::commit`] refits the top level only.
//!
//! Backends are chosen in one place, [`build`]: Embree 3 (production, when the system
//! library is present) and a pure-Rust BVH (always available). One test suite runs over both.

use glam::{Affine3A, Vec3};

/// "No hit" in [`Hit::id`].
pub const NO_HIT: u32 = u32::MAX;

/// The nearest surface along a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// The payload of the triangle hit (a patch id, given at build time), or [`NO_HIT`].
    pub id: u32,
    /// Object (instance) index of the triangle hit; undefined when `id == NO_HIT`.
    pub object: u32,
    /// Distance along the (unit) ray direction.
    pub t: f32,
    /// The ray met the triangle's front face (counter-clockwise side).
    pub front: bool,
}

impl Hit {
    /// A miss.
    pub const MISS: Hit = Hit { id: NO_HIT, object: u32::MAX, t: f32::INFINITY, front: false };
    /// Did the ray hit anything?
    pub fn is_hit(&self) -> bool {
        self.id != NO_HIT
    }
}

/// One object's geometry, in its own frame.
#[derive(Clone, Copy, Debug)]
pub struct MeshRef<'a> {
    /// Vertex positions (object frame).
    pub positions: &'a [Vec3],
    /// Triangles (vertex indices, counter-clockwise from the front).
    pub triangles: &'a [[u32; 3]],
    /// One payload per triangle, returned in [`Hit::id`].
    pub ids: &'a [u32],
}

/// Which backend [`build`] makes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Backend {
    /// Embree if this build found it, else the pure-Rust BVH.
    #[default]
    Auto,
    /// Intel Embree 3.
    Embree,
    /// Pure-Rust BVH.
    Bvh,
}

/// Errors of [`build`].
#[derive(Debug)]
pub enum VisError {
    /// The backend asked for is not in this build.
    Unavailable(&'static str),
    /// Inputs of the wrong length or out of range.
    Invalid(String),
}

impl std::fmt::Display for VisError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            VisError::Unavailable(s) => write!(f, "visibility backend unavailable: {s}"),
            VisError::Invalid(s) => write!(f, "invalid visibility input: {s}"),
        }
    }
}

impl std::error::Error for VisError {}

/// The one visibility interface. All queries are batched and run multi-threaded inside;
/// directions are unit vectors; rays start at `t_min` (the caller offsets origins off
/// surfaces) and end at `t_max`.
pub trait Visibility: Send + Sync {
    /// Name of the backend, for reports.
    fn name(&self) -> &'static str;
    /// Number of objects (instances).
    fn object_count(&self) -> usize;
    /// Set an object's transform; takes effect at the next [`Visibility::commit`].
    fn set_transform(&mut self, object: usize, world_from_object: Affine3A);
    /// Rebuild / refit what changed since the last commit.
    fn commit(&mut self);
    /// Nearest hit of ray `i` = (`origins[i]`, `directions[i]`), ignoring objects in `exclude`
    /// (they are transparent). `out.len() == origins.len() == directions.len()`.
    fn closest(&self, origins: &[Vec3], directions: &[Vec3], t_min: f32, exclude: &[u32], out: &mut [Hit]);
    /// Cube-map capture: for every point `p` and every texel direction `d`, the nearest hit;
    /// `out[p * directions.len() + d]`. Rays from one point are coherent: backends use packets.
    fn capture(&self, points: &[Vec3], directions: &[Vec3], t_min: f32, exclude: &[u32], out: &mut [Hit]);
    /// Shadow rays: `out[i]` is true when something lies strictly between `from[i]` and
    /// `to[i]` (shortened by `eps` at both ends), ignoring objects in `exclude`.
    fn occluded(&self, from: &[Vec3], to: &[Vec3], eps: f32, exclude: &[u32], out: &mut [bool]);
}

/// Build a visibility structure over `meshes` with their initial transforms.
pub fn build(backend: Backend, meshes: &[MeshRef<'_>], transforms: &[Affine3A]) -> Result<Box<dyn Visibility>, VisError> {
    let _ = (backend, meshes, transforms);
    Err(VisError::Unavailable("not built yet"))
}
