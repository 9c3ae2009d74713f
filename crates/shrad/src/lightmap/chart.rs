//! Charts of a lightmap. A chart is a set of one object's patches with 2D coordinates (in
//! metres, so one texel size serves every chart) for each patch corner; the atlas places
//! its bounding rectangle. Three kinds make charts, tried in this order:
//!
//! - the object's own lightmap UVs (glTF `TEXCOORD_1`), when usable ([`super::uv_chart`]);
//! - **planar charts** (here): connected coplanar patches (patches that share a shading
//!   vertex and lie in the plane of the set's first patch), projected orthogonally onto that
//!   plane, so a chart is undistorted: a texel has the same size in metres everywhere on it.
//!   The scenes shrad patches are mostly planar faces (rooms, boxes, walls), where these
//!   are the best charts there are;
//! - what is left after that (a planar chart of a single input triangle, on a curved mesh)
//!   is grown into larger near-flat charts by [`super::grow`].

use glam::{Vec2, Vec3};

use crate::World;

/// Largest angle between a chart's plane and its patches: cos 0.5 degree.
const COPLANAR_COS: f32 = 0.99996;

/// One chart: patches of one object and their corners' 2D coordinates.
#[derive(Clone, Debug)]
pub struct Chart {
    /// The object.
    pub object: usize,
    /// Its patches.
    pub patches: Vec<usize>,
    /// Each patch's corners in chart coordinates (metres; corner order, a triangle repeats
    /// its last): an affine image of the patch, so a parallelogram stays one.
    pub coords: Vec<[Vec2; 4]>,
    /// The smallest chart coordinates of the patches' corners (metres).
    pub min: Vec2,
    /// The largest, see `min`.
    pub max: Vec2,
}

impl Chart {
    /// The chart of `patches` with corner coordinates `coords` (its bounds found here).
    pub fn new(object: usize, patches: Vec<usize>, coords: Vec<[Vec2; 4]>) -> Chart {
        let (mut min, mut max) = (Vec2::INFINITY, Vec2::NEG_INFINITY);
        for q in coords.iter().flatten() {
            (min, max) = (min.min(*q), max.max(*q));
        }
        Chart {
            object,
            patches,
            coords,
            min,
            max,
        }
    }

    /// Its area in chart coordinates (square metres), patch by patch.
    pub fn area(&self) -> f32 {
        self.coords.iter().map(polygon_area).sum()
    }
}

/// The area of a patch's corners (a triangle's fourth repeats its third, adding nothing).
pub fn polygon_area(c: &[Vec2; 4]) -> f32 {
    let twice: f32 = (0..4).map(|k| c[k].perp_dot(c[(k + 1) % 4])).sum();
    0.5 * twice.abs()
}

/// A plane's 2D frame: orthogonal projection of world points onto it.
#[derive(Clone, Copy, Debug)]
pub struct Plane {
    /// A point of the plane (world).
    pub origin: Vec3,
    /// Unit axes `u`, `v`; `u x v` is the plane's normal.
    pub axes: [Vec3; 2],
}

impl Plane {
    /// The plane through `origin` with normal `n`, `u` along `towards` (projected).
    pub fn new(origin: Vec3, n: Vec3, towards: Vec3) -> Plane {
        let u = towards
            .reject_from(n)
            .normalize_or(n.any_orthonormal_vector());
        Plane {
            origin,
            axes: [u, n.cross(u)],
        }
    }
    /// Plane coordinates (metres) of world point `y`.
    pub fn project(&self, y: Vec3) -> Vec2 {
        let d = y - self.origin;
        Vec2::new(d.dot(self.axes[0]), d.dot(self.axes[1]))
    }
    /// Every corner of patch `i` projected.
    pub fn patch(&self, world: &World, i: usize) -> [Vec2; 4] {
        world.patches.world_corners(i).map(|y| self.project(y))
    }
}

/// The corners of patch `i` (3 or 4), world.
pub fn patch_corners(world: &World, i: usize) -> Vec<Vec3> {
    let n = if world.patches.is_quad[i] { 4 } else { 3 };
    world.patches.world_corners(i)[..n].to_vec()
}

/// For each shading vertex, the patches with a corner there.
pub(super) fn vertex_patches(world: &World) -> Vec<Vec<u32>> {
    let p = &world.patches;
    let mut out = vec![Vec::new(); p.shading_vertex_count];
    for i in 0..p.len() {
        let n = if p.is_quad[i] { 4 } else { 3 };
        for &v in &p.corner_vertex[i][..n] {
            out[v as usize].push(i as u32);
        }
    }
    out
}

/// The planar charts of the patches `todo` marks (each such patch in exactly one chart).
pub fn planar_charts(world: &World, todo: &[bool]) -> Vec<Chart> {
    let p = &world.patches;
    let around = vertex_patches(world);
    let mut taken: Vec<bool> = todo.iter().map(|t| !t).collect();
    let mut out = Vec::new();
    for seed in 0..p.len() {
        if taken[seed] {
            continue;
        }
        let (n, origin) = (p.normal[seed], p.centre[seed]);
        // The plane's tolerance: a thousandth of the seed's size, or float rounding far from
        // the origin.
        let tol = (1e-3 * p.area[seed].sqrt()).max(1e-5 * origin.abs().max_element().max(1.0));
        let mut members = vec![seed];
        taken[seed] = true;
        let mut k = 0;
        while k < members.len() {
            let i = members[k];
            k += 1;
            let corners = if p.is_quad[i] { 4 } else { 3 };
            for &v in &p.corner_vertex[i][..corners] {
                for &j in &around[v as usize] {
                    let j = j as usize;
                    let flat = p.normal[j].dot(n) > COPLANAR_COS
                        && patch_corners(world, j)
                            .iter()
                            .all(|c| (*c - origin).dot(n).abs() < tol);
                    if !taken[j] && p.object[j] == p.object[seed] && flat {
                        taken[j] = true;
                        members.push(j);
                    }
                }
            }
        }
        // The plane of the seed, its first edge as `u`.
        let c = p.world_corners(seed);
        let plane = Plane::new(c[0], n, c[1] - c[0]);
        let coords = members.iter().map(|&i| plane.patch(world, i)).collect();
        out.push(Chart::new(p.object[seed] as usize, members, coords));
    }
    out
}
