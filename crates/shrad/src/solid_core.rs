//! The solid core of a closed mesh: a sphere and a box about one centre, both inside its
//! surface (object frame). A segment that passes through the core and whose two ends lie
//! outside the mesh (outside its box or its bounding sphere) goes in through the surface and
//! out again, so it is blocked without a trace. A mover's move sends the solvers' shadow rays
//! through it again (Step 1, paper 2.3.2: the boundary patches it may shadow,
//! `DirectCache::update`); most of those that pass a ball or a box pass through its core, and
//! [`SolidCores::blocks`] settles them before the backend is asked (`World`'s
//! `occluded_among`; the 77k room's moving frame traces 7.4k rays instead of 12.1k, the same
//! light).
//!
//! Only a closed surface has an inside: every edge (corners welded by position) must be
//! shared by an even number of triangles, and the centre of the mesh's box must lie inside
//! (a crossing count along three directions, all odd). A mesh with a hole, or whose box
//! centre is outside it (a ring, a chair), has no core, and its rays are all traced.

use glam::{Affine3A, Vec3};
use rayon::prelude::*;
use shrad_scene::Aabb;
use std::collections::HashMap;

use crate::direct::mover_spheres::segment_meets_sphere;

/// How far inside the surface the core stays, as a share of the nearest distance to it (the
/// sphere's radius, the box's half size): float rounding of the mesh and its transform never
/// puts the surface inside the core.
const MARGIN: f32 = 0.98;

/// A sphere and a box about `centre`, inside a closed mesh (object frame), either of which
/// may be empty (radius 0, half size 0); and the mesh's box and the sphere about `centre`
/// that hold it, outside which a point is outside the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SolidCore {
    centre: Vec3,
    radius: f32,
    half: Vec3,
    hull: Aabb,
    hull_radius: f32,
}

impl SolidCore {
    /// The core of the mesh `positions`, `triangles` (object frame), if it is closed and the
    /// centre of its box lies inside it.
    pub fn of_mesh(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<SolidCore> {
        match closed(positions, triangles) {
            true => SolidCore::of_closed(positions, triangles),
            false => None,
        }
    }

    /// The core of a mesh known to close a solid (its source mesh is [`closed`]; a patch
    /// mesh splits its triangles where its patches meet, so its own edges need not pair),
    /// if the centre of its box lies inside it.
    pub fn of_closed(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<SolidCore> {
        let corners = |t: &[u32; 3]| t.map(|i| positions[i as usize]);
        let tris: Vec<[Vec3; 3]> = triangles.iter().map(corners).collect();
        let bounds = Aabb::from_points(tris.iter().flatten().copied())?;
        if !(bounds.size().min_element() > 0.0 && bounds.size().is_finite()) {
            return None;
        }
        let centre = bounds.centre();
        if !inside(centre, &tris) {
            return None;
        }
        let nearest = (tris.iter())
            .map(|t| (closest_on_triangle(centre, t) - centre).length())
            .fold(f32::INFINITY, f32::min);
        let half = largest_free_box(centre, 0.5 * bounds.size(), &tris);
        let farthest = (tris.iter().flatten())
            .map(|p| (*p - centre).length())
            .fold(0.0, f32::max);
        Some(SolidCore {
            centre,
            radius: MARGIN * nearest,
            half: MARGIN * half,
            hull: bounds,
            hull_radius: farthest,
        })
    }

    /// Whether `p` (object frame) lies more than `gap` outside the mesh: outside its box or
    /// its sphere by that much.
    fn clear_of(&self, p: Vec3, gap: f32) -> bool {
        !self.hull.padded(Vec3::splat(gap)).contains(p)
            || (p - self.centre).length() > self.hull_radius + gap
    }

    /// Whether the segment `a`-`b` (object frame) meets the core.
    pub fn meets(&self, a: Vec3, b: Vec3) -> bool {
        let in_sphere = self.radius > 0.0 && segment_meets_sphere(a, b, (self.centre, self.radius));
        let solid_box = Aabb::new(self.centre - self.half, self.centre + self.half);
        in_sphere || (self.half.min_element() > 0.0 && solid_box.meets_segment(a, b))
    }

    /// The core's sphere radius and box half size (object frame), for tests and reports.
    pub fn size(&self) -> (f32, Vec3) {
        (self.radius, self.half)
    }
}

/// The solid cores of a world's objects where they are now: which shadow rays among some
/// objects are blocked without a trace ([`SolidCores::blocks`]).
#[derive(Clone, Debug, Default)]
pub struct SolidCores {
    /// Each object's core (object frame), `None` without one.
    cores: Vec<Option<SolidCore>>,
    /// Where each object with a core is: its frame from the world's (`None`: a transform
    /// that cannot be inverted, no core there), and a bound on how much that stretches a
    /// length (its Frobenius norm).
    places: Vec<Option<(Affine3A, f32)>>,
}

impl SolidCores {
    /// The cores of the objects `solid` picks, which the caller knows close a solid (meshes
    /// in their own frames, placed by `world_from_local`), found in parallel.
    pub fn new(
        meshes: &[(&[Vec3], &[[u32; 3]])],
        world_from_local: &[Affine3A],
        solid: impl Fn(usize) -> bool + Sync,
    ) -> SolidCores {
        let cores: Vec<Option<SolidCore>> = (0..meshes.len())
            .into_par_iter()
            .map(|o| match solid(o) {
                true => SolidCore::of_closed(meshes[o].0, meshes[o].1),
                false => None,
            })
            .collect();
        let mut cores = SolidCores {
            places: vec![None; cores.len()],
            cores,
        };
        for (o, &m) in world_from_local.iter().enumerate() {
            cores.place(o, m);
        }
        cores
    }

    /// Object `o` is now at `world_from_local`. A transform that cannot be inverted (a
    /// scale of zero) leaves it without a core there.
    pub fn place(&mut self, o: usize, world_from_local: Affine3A) {
        if self.cores.get(o).is_none_or(|c| c.is_none()) {
            return;
        }
        let invertible = world_from_local.matrix3.determinant().abs() > 0.0;
        let local_from_world = world_from_local.inverse();
        let m = local_from_world.matrix3;
        let stretch =
            (m.x_axis.length_squared() + m.y_axis.length_squared() + m.z_axis.length_squared())
                .sqrt();
        self.places[o] = (invertible && local_from_world.is_finite() && stretch.is_finite())
            .then_some((local_from_world, stretch));
    }

    /// Whether one of the objects `among` blocks the segment `from`-`to` for sure: it passes
    /// through the object's core and both its ends lie more than `2 eps` (in the world)
    /// outside the object's mesh, so the surface crosses it twice, each crossing more than
    /// `eps` from its ends (the part a shadow ray tests).
    pub fn blocks(&self, among: &[u32], from: Vec3, to: Vec3, eps: f32) -> bool {
        among.iter().any(|&o| {
            let o = o as usize;
            let (Some(Some(core)), Some(Some((local_from_world, stretch)))) =
                (self.cores.get(o), self.places.get(o))
            else {
                return false;
            };
            let (a, b) = (
                local_from_world.transform_point3(from),
                local_from_world.transform_point3(to),
            );
            // A world length l is at most `stretch * l` in the object's frame.
            let gap = 2.0 * eps * stretch;
            core.clear_of(a, gap) && core.clear_of(b, gap) && core.meets(a, b)
        })
    }

    /// Whether any of the objects `among` has a core.
    pub fn any(&self, among: &[u32]) -> bool {
        (among.iter()).any(|&o| matches!(self.cores.get(o as usize), Some(Some(_))))
    }
}

/// Whether every edge of the mesh (corners welded where their positions are equal) is shared
/// by an even number of triangles: then it bounds a solid, and a point is inside it where a
/// ray from it crosses it an odd number of times.
pub fn closed(positions: &[Vec3], triangles: &[[u32; 3]]) -> bool {
    let mut welded: HashMap<[u32; 3], u32> = HashMap::new();
    // (`+ 0.0` makes -0 and 0 one position.)
    let ids: Vec<u32> = (positions.iter())
        .map(|p| {
            let n = welded.len() as u32;
            let key = (*p + Vec3::ZERO).to_array().map(f32::to_bits);
            *welded.entry(key).or_insert(n)
        })
        .collect();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    for t in triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            // A corner out of range: not a mesh that closes anything.
            let (Some(&a), Some(&b)) = (ids.get(a as usize), ids.get(b as usize)) else {
                return false;
            };
            if a != b {
                *edges.entry((a.min(b), a.max(b))).or_insert(0) += 1;
            }
        }
    }
    edges.values().all(|&n| n % 2 == 0)
}

/// Whether `p` is inside the closed mesh `tris`: rays along three unrelated directions each
/// cross it an odd number of times (they disagree only where one grazes an edge, and then it
/// is not called inside).
fn inside(p: Vec3, tris: &[[Vec3; 3]]) -> bool {
    [
        Vec3::new(0.5773, 0.6123, 0.5403),
        Vec3::new(-0.6959, 0.1234, 0.7075),
        Vec3::new(0.2357, -0.9428, 0.2357),
    ]
    .iter()
    .all(|&d| tris.iter().filter(|t| ray_crosses(p, d, t)).count() % 2 == 1)
}

/// Whether the ray `o + t d`, `t > 0`, crosses triangle `t` (Möller-Trumbore).
fn ray_crosses(o: Vec3, d: Vec3, [a, b, c]: &[Vec3; 3]) -> bool {
    let (e1, e2) = (*b - *a, *c - *a);
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-12 * e1.length_squared().max(e2.length_squared()) {
        return false;
    }
    let s = o - *a;
    let u = s.dot(h) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    let t = e2.dot(q) / det;
    (0.0..=1.0).contains(&u) && v >= 0.0 && u + v <= 1.0 && t > 0.0
}

/// The point of triangle `[a, b, c]` closest to `p` (by its Voronoi regions).
fn closest_on_triangle(p: Vec3, [a, b, c]: &[Vec3; 3]) -> Vec3 {
    let (ab, ac, ap) = (*b - *a, *c - *a, p - *a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return *a;
    }
    let bp = p - *b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return *b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return *a + ab * (d1 / (d1 - d3));
    }
    let cp = p - *c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return *c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return *a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return *b + (*c - *b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    *a + ab * (vb * denom) + ac * (vc * denom)
}

/// The half size of the largest box about `centre` of the shape of `half` (scaled) that no
/// triangle meets, found by halving the interval of scales (to a thousandth).
fn largest_free_box(centre: Vec3, half: Vec3, tris: &[[Vec3; 3]]) -> Vec3 {
    let free = |s: f32| !tris.iter().any(|t| triangle_meets_box(t, centre, s * half));
    let (mut lo, mut hi) = (0.0f32, 1.0f32);
    for _ in 0..10 {
        let mid = 0.5 * (lo + hi);
        match free(mid) {
            true => lo = mid,
            false => hi = mid,
        }
    }
    lo * half
}

/// Whether triangle `t` meets the box `centre ± half` (the separating axis test of
/// Akenine-Möller: the box's three axes, the triangle's normal, and the nine crossings of
/// the two's edges).
fn triangle_meets_box(t: &[Vec3; 3], centre: Vec3, half: Vec3) -> bool {
    let v = t.map(|p| p - centre);
    let separates = |axis: Vec3| {
        let p = v.map(|p| p.dot(axis));
        let r = half.dot(axis.abs());
        let (lo, hi) = (p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]));
        lo > r || hi < -r
    };
    let edges = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    let axes = [Vec3::X, Vec3::Y, Vec3::Z];
    if axes.iter().any(|&a| separates(a)) || separates(edges[0].cross(edges[1])) {
        return false;
    }
    !(axes.iter()).any(|&a| edges.iter().any(|&e| separates(a.cross(e))))
}

#[cfg(test)]
mod tests;
