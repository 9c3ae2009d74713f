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
    pub const MISS: Hit = Hit {
        id: NO_HIT,
        object: u32::MAX,
        t: f32::INFINITY,
        front: false,
    };
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
    /// A hint: queries will often exclude this object (a probe's own object). Backends
    /// that exclude by ray mask give such objects mask bits of their own first; exclusion
    /// is exact either way.
    pub often_excluded: bool,
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
    fn closest(
        &self,
        origins: &[Vec3],
        directions: &[Vec3],
        t_min: f32,
        exclude: &[u32],
        out: &mut [Hit],
    );
    /// [`Visibility::closest`] up to `t_max`: ray `i`'s nearest hit where it lies at `t <=
    /// t_max`, else a miss. Backends stop the traversal there, so short rays (a near field)
    /// cost less; this default traces whole rays and drops the hits beyond.
    fn closest_within(
        &self,
        origins: &[Vec3],
        directions: &[Vec3],
        (t_min, t_max): (f32, f32),
        exclude: &[u32],
        out: &mut [Hit],
    ) {
        self.closest(origins, directions, t_min, exclude, out);
        for h in out.iter_mut().filter(|h| h.is_hit() && h.t > t_max) {
            *h = Hit::MISS;
        }
    }
    /// Cube-map capture: for every point `p` and every texel direction `d`, the nearest hit;
    /// `out[p * directions.len() + d]`. Rays from one point are coherent: backends use packets.
    fn capture(
        &self,
        points: &[Vec3],
        directions: &[Vec3],
        t_min: f32,
        exclude: &[u32],
        out: &mut [Hit],
    );
    /// Shadow rays: `out[i]` is true when something lies strictly between `from[i]` and
    /// `to[i]` (shortened by `eps` at both ends), ignoring objects in `exclude`.
    fn occluded(&self, from: &[Vec3], to: &[Vec3], eps: f32, exclude: &[u32], out: &mut [bool]);
    /// Shadow rays against the objects in `among` only (every other object transparent):
    /// whether one of them lies strictly between `from[i]` and `to[i]`. A ray known to pass
    /// everything else (a shadow ray that was clear before some objects moved) needs only
    /// this. Backends may make it cheaper than [`Visibility::occluded`]; this default excludes
    /// the others.
    fn occluded_among(
        &self,
        from: &[Vec3],
        to: &[Vec3],
        eps: f32,
        among: &[u32],
        out: &mut [bool],
    ) {
        let others: Vec<u32> = (0..self.object_count() as u32)
            .filter(|o| !among.contains(o))
            .collect();
        self.occluded(from, to, eps, &others, out)
    }
}

/// The backends compiled into this build, best first (Embree when the system library was
/// found at build time, then the pure-Rust BVH). [`Backend::Auto`] is not listed.
pub fn available_backends() -> Vec<Backend> {
    let mut v = Vec::with_capacity(2);
    if cfg!(shrad_embree) {
        v.push(Backend::Embree);
    }
    v.push(Backend::Bvh);
    v
}

/// Build a visibility structure over `meshes` with their initial transforms.
///
/// Errors: [`VisError::Invalid`] when `meshes` and `transforms` differ in length, a mesh has
/// not one id per triangle, or an index is out of range; [`VisError::Unavailable`] when
/// [`Backend::Embree`] is asked for but this build has no Embree (or the device failed).
pub fn build(
    backend: Backend,
    meshes: &[MeshRef<'_>],
    transforms: &[Affine3A],
) -> Result<Box<dyn Visibility>, VisError> {
    validate(meshes, transforms)?;
    match backend {
        Backend::Bvh => Ok(Box::new(bvh::BvhVis::new(meshes, transforms))),
        Backend::Embree => build_embree(meshes, transforms),
        Backend::Auto => {
            if cfg!(shrad_embree) {
                if let Ok(v) = build_embree(meshes, transforms) {
                    return Ok(v);
                }
            }
            Ok(Box::new(bvh::BvhVis::new(meshes, transforms)))
        }
    }
}

#[cfg(shrad_embree)]
fn build_embree(
    meshes: &[MeshRef<'_>],
    transforms: &[Affine3A],
) -> Result<Box<dyn Visibility>, VisError> {
    Ok(Box::new(embree::EmbreeVis::new(meshes, transforms)?))
}

#[cfg(not(shrad_embree))]
fn build_embree(
    _meshes: &[MeshRef<'_>],
    _transforms: &[Affine3A],
) -> Result<Box<dyn Visibility>, VisError> {
    Err(VisError::Unavailable(
        "this build of shrad has no Embree: install libembree-dev (Embree 3) and rebuild without SHRAD_NO_EMBREE",
    ))
}

fn validate(meshes: &[MeshRef<'_>], transforms: &[Affine3A]) -> Result<(), VisError> {
    if meshes.len() != transforms.len() {
        return Err(VisError::Invalid(format!(
            "{} meshes but {} transforms",
            meshes.len(),
            transforms.len()
        )));
    }
    if meshes.len() >= u32::MAX as usize {
        return Err(VisError::Invalid("too many objects".into()));
    }
    for (o, m) in meshes.iter().enumerate() {
        if m.ids.len() != m.triangles.len() {
            return Err(VisError::Invalid(format!(
                "object {o}: {} triangles but {} ids",
                m.triangles.len(),
                m.ids.len()
            )));
        }
        let n = m.positions.len();
        if let Some((t, _)) = m
            .triangles
            .iter()
            .enumerate()
            .find(|(_, t)| t.iter().any(|&i| i as usize >= n))
        {
            return Err(VisError::Invalid(format!(
                "object {o}: triangle {t} indexes past {n} vertices"
            )));
        }
        if m.positions.iter().any(|p| !p.is_finite()) {
            return Err(VisError::Invalid(format!(
                "object {o}: non-finite vertex position"
            )));
        }
        if !transforms[o].is_finite() {
            return Err(VisError::Invalid(format!(
                "object {o}: non-finite transform"
            )));
        }
    }
    Ok(())
}

/// Per-triangle data both backends keep: the object-frame geometric normal
/// `(v1 - v0) x (v2 - v0)` (unnormalised) and the payload.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriInfo {
    pub n: Vec3,
    pub id: u32,
}

/// An object's transform with what queries need from it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Xform {
    pub world_from_object: Affine3A,
    pub object_from_world: Affine3A,
}

impl Xform {
    pub fn new(world_from_object: Affine3A) -> Self {
        Xform {
            world_from_object,
            object_from_world: world_from_object.inverse(),
        }
    }

    /// Does world direction `d` meet the front of a triangle with object-frame normal `n`?
    /// The front is the object frame's counter-clockwise side, whatever the transform (the
    /// glTF rule: a mirroring transform makes the world winding clockwise, and the world
    /// normal is the inverse transpose `L^-T n`), and `dot(d, L^-T n) = dot(L^-1 d, n)`.
    #[inline]
    pub fn front(&self, n: Vec3, d: Vec3) -> bool {
        let d_obj = self.object_from_world.transform_vector3(d);
        d_obj.dot(n) < 0.0
    }
}

pub(crate) fn tri_infos(m: &MeshRef<'_>) -> Vec<TriInfo> {
    m.triangles
        .iter()
        .zip(m.ids)
        .map(|(t, &id)| {
            let [a, b, c] = t.map(|i| m.positions[i as usize]);
            TriInfo {
                n: (b - a).cross(c - a),
                id,
            }
        })
        .collect()
}

/// A shadow segment as (unit direction, length), or `None` when it is too short to hold
/// anything strictly inside after the `eps` trims (or is not finite).
#[inline]
pub(crate) fn segment(from: Vec3, to: Vec3, eps: f32) -> Option<(Vec3, f32)> {
    let delta = to - from;
    let len = delta.length();
    (len > 2.0 * eps && len.is_finite() && from.is_finite()).then(|| (delta / len, len))
}

/// Rays per parallel work item.
pub(crate) const CHUNK: usize = 256;

/// Fill `out` in parallel, [`CHUNK`] items a work item: `fill(first, chunk)` writes
/// `out[first..first + chunk.len()]`.
#[inline]
pub(crate) fn par_fill<T: Send>(out: &mut [T], fill: impl Fn(usize, &mut [T]) + Sync) {
    use rayon::prelude::*;
    out.par_chunks_mut(CHUNK)
        .enumerate()
        .for_each(|(c, chunk)| fill(c * CHUNK, chunk));
}

mod bvh;
#[cfg(shrad_embree)]
mod embree;

#[cfg(test)]
mod tests;
