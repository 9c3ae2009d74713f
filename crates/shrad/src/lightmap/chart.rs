//! Charts of a lightmap: the patches' own planar faces. Each object's patches are grouped
//! into connected coplanar sets (patches that share a shading vertex and lie in the plane
//! of the set's first patch), and each set is projected orthogonally onto that plane, so a
//! chart is undistorted: a texel has the same size in metres everywhere on it.
//!
//! Why not an unwrapper (xatlas): the scenes shrad patches are built of planar faces (rooms,
//! boxes, walls), where the planar faces are the best charts there are; a curved mesh gets a
//! chart per patch, which wastes padding but is never wrong. An unwrapper for curved meshes
//! (xatlas is C++; no Rust binding of it was tried) is left undone.

use glam::{Vec2, Vec3};

use crate::World;

/// Largest angle between a chart's plane and its patches: cos 0.5 degree.
const COPLANAR_COS: f32 = 0.99996;

/// One chart: connected coplanar patches of one object and their plane's 2D frame.
#[derive(Clone, Debug)]
pub struct Chart {
    /// The object.
    pub object: usize,
    /// Its patches.
    pub patches: Vec<usize>,
    /// A point of the plane (world).
    pub origin: Vec3,
    /// Unit axes of the plane (world): `u`, `v`; `u x v` is the patches' normal.
    pub axes: [Vec3; 2],
    /// The smallest and largest plane coordinates of the patches' corners (metres).
    pub min: Vec2,
    /// See `min`.
    pub max: Vec2,
}

impl Chart {
    /// Plane coordinates (metres) of world point `y`.
    pub fn project(&self, y: Vec3) -> Vec2 {
        let d = y - self.origin;
        Vec2::new(d.dot(self.axes[0]), d.dot(self.axes[1]))
    }

    /// World point of plane coordinates `q`.
    pub fn unproject(&self, q: Vec2) -> Vec3 {
        self.origin + self.axes[0] * q.x + self.axes[1] * q.y
    }
}

/// The corners of patch `i` (3 or 4), world.
pub fn patch_corners(world: &World, i: usize) -> Vec<Vec3> {
    let n = if world.patches.is_quad[i] { 4 } else { 3 };
    world.patches.world_corners(i)[..n].to_vec()
}

/// For each shading vertex, the patches with a corner there.
fn vertex_patches(world: &World) -> Vec<Vec<u32>> {
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

/// The charts of every object with patches (every patch in exactly one chart).
pub fn charts(world: &World) -> Vec<Chart> {
    let p = &world.patches;
    let around = vertex_patches(world);
    let mut chart_of = vec![usize::MAX; p.len()];
    let mut out = Vec::new();
    for seed in 0..p.len() {
        if chart_of[seed] != usize::MAX {
            continue;
        }
        let (n, origin) = (p.normal[seed], p.centre[seed]);
        // The plane's tolerance: a thousandth of the seed's size, or float rounding far from
        // the origin.
        let tol = (1e-3 * p.area[seed].sqrt()).max(1e-5 * origin.abs().max_element().max(1.0));
        let mut members = vec![seed];
        chart_of[seed] = out.len();
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
                    if chart_of[j] == usize::MAX && p.object[j] == p.object[seed] && flat {
                        chart_of[j] = out.len();
                        members.push(j);
                    }
                }
            }
        }
        out.push(chart(world, seed, members));
    }
    out
}

/// The chart of `members`, in the plane of `seed` (its first edge as `u`).
fn chart(world: &World, seed: usize, members: Vec<usize>) -> Chart {
    let p = &world.patches;
    let n = p.normal[seed];
    let c = p.world_corners(seed);
    let u = (c[1] - c[0])
        .reject_from(n)
        .normalize_or(n.any_orthonormal_vector());
    let mut chart = Chart {
        object: p.object[seed] as usize,
        patches: Vec::new(),
        origin: c[0],
        axes: [u, n.cross(u)],
        min: Vec2::splat(f32::INFINITY),
        max: Vec2::splat(f32::NEG_INFINITY),
    };
    for &i in &members {
        for y in patch_corners(world, i) {
            let q = chart.project(y);
            chart.min = chart.min.min(q);
            chart.max = chart.max.max(q);
        }
    }
    chart.patches = members;
    chart
}
