//! Direct light from emitters, computed without visible noise: the unoccluded irradiance
//! from each emitter triangle is exact (Lambert's polygon formula, the emitter clipped to the
//! receiver's upper hemisphere), at the patch's centre, or averaged over points of the patch
//! where the emitter is within a few patch sizes of it (its near field, where the
//! irradiance varies over the patch); it is scaled by the fraction of the emitter that the
//! receiver sees, estimated with stratified shadow rays weighted by their contribution
//! (`cos cos / r^2`). Fully lit and fully shadowed patches are therefore exact; only
//! penumbrae carry (small, structured) estimation error.
//!
//! The reference solver uses it for its direct term; the dispersive solver uses it for
//! Step 1 (paper 2.3.2, direct light on the boundary) and, beyond the paper, for direct light
//! on interior patches.

use glam::Vec3;

use shrad_scene::Aabb;

use crate::sampling::{hammersley, hash, hash2, unit};
use crate::World;

pub(crate) mod blocks;
mod cache;
pub(crate) mod mover_spheres;
mod recent_moves;
mod sample_ends;
pub use cache::{DirectCache, MOVER_PATCHES_AT_ONCE, SETTLED_AT_ONCE, SHADOW_RAYS_AT_ONCE};
pub use mover_spheres::{Moves, Sphere};

/// One emitting object, in world space at the current time.
struct Emitter {
    triangles: Vec<[Vec3; 3]>,
    normals: Vec<Vec3>,
    /// Cumulative area of the triangles, normalised to end at 1.
    cdf: Vec<f32>,
    radiance: Vec3,
    double_sided: bool,
    object: usize,
    /// Bounding sphere of its triangles.
    sphere: (Vec3, f32),
}

/// The objects that emit (positive exitance), in order: those [`emitters`] returns.
fn emitting_objects(world: &World) -> impl Iterator<Item = usize> + '_ {
    emitters(world).into_iter().map(|e| e.object)
}

fn emitters(world: &World) -> Vec<Emitter> {
    let mut out = Vec::new();
    for (o, object) in world.scene.objects.iter().enumerate() {
        let r = world.patches.range(o);
        if r.is_empty() {
            continue;
        }
        // An emissive texture makes the exitance vary over the object: its area average.
        let exitance = if world.emission_texture.is_empty() {
            world.exitance[r.start]
        } else {
            let area: f32 = r.clone().map(|p| world.patches.area_local[p]).sum();
            let flux: Vec3 = r
                .clone()
                .map(|p| world.exitance[p] * world.patches.area_local[p])
                .sum();
            flux / area.max(f32::MIN_POSITIVE)
        };
        let radiance = exitance / std::f32::consts::PI;
        if radiance.max_element() <= 0.0 {
            continue;
        }
        let m = world.patches.world_from_local[o];
        let shape = &world.patches.shapes[o];
        let triangles: Vec<[Vec3; 3]> = shape
            .triangles
            .iter()
            .map(|t| t.map(|i| m.transform_point3(shape.positions[i as usize])))
            .collect();
        let areas: Vec<f32> = triangles
            .iter()
            .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
            .collect();
        let total: f32 = areas.iter().sum();
        let mut acc = 0.0;
        let cdf = areas
            .iter()
            .map(|a| {
                acc += a / total;
                acc
            })
            .collect();
        let normals = triangles
            .iter()
            .map(|[a, b, c]| (*b - *a).cross(*c - *a).normalize_or_zero())
            .collect();
        let sphere = Aabb::from_points(triangles.iter().flatten().copied())
            .map_or((Vec3::ZERO, 0.0), |b| b.bounding_sphere());
        out.push(Emitter {
            sphere,
            triangles,
            normals,
            cdf,
            radiance,
            double_sided: object.material.double_sided,
            object: o,
        });
    }
    out
}

/// Irradiance at `x` (unit normal `n`) from a triangle of unit radiance, unoccluded: the
/// triangle clipped to the half-space above `x`'s tangent plane, then Lambert's formula
/// `E = 1/2 * sum_k theta_k (n . gamma_k)`.
pub fn polygon_irradiance(x: Vec3, n: Vec3, tri: &[Vec3; 3]) -> f32 {
    // A triangle in the receiver's own plane subtends no projected solid angle: without this
    // the clip below keeps it whole and a double-sided planar light lit itself with pi L.
    // (Tolerance: float noise of the coordinates and of the distances involved.)
    let reach = tri.iter().map(|v| (*v - x).length()).fold(0.0, f32::max);
    let tolerance = 1e-6 * (reach + x.abs().max_element());
    if tri.iter().all(|v| n.dot(*v - x) <= tolerance) {
        return 0.0;
    }
    // Clip against n . (v - x) >= 0 (Sutherland-Hodgman, at most 4 vertices out).
    let mut poly = [Vec3::ZERO; 4];
    let mut len = 0;
    for k in 0..3 {
        let (a, b) = (tri[k] - x, tri[(k + 1) % 3] - x);
        let (da, db) = (n.dot(a), n.dot(b));
        if da >= 0.0 {
            poly[len] = a;
            len += 1;
        }
        if (da >= 0.0) != (db >= 0.0) {
            let s = da / (da - db);
            poly[len] = a + (b - a) * s;
            len += 1;
        }
    }
    if len < 3 {
        return 0.0;
    }
    let mut sum = 0.0;
    for k in 0..len {
        let (a, b) = (poly[k], poly[(k + 1) % len]);
        let (la, lb) = (a.length(), b.length());
        if la <= 0.0 || lb <= 0.0 {
            continue;
        }
        let cross = a.cross(b);
        let cl = cross.length();
        if cl <= 1e-20 {
            continue;
        }
        let theta = cl.atan2(a.dot(b));
        sum += theta * n.dot(cross / cl);
    }
    0.5 * sum.abs()
}

/// Direct irradiance on each patch of `receivers` (front side), with `samples` shadow rays
/// per (receiver, emitting object) for the visible fraction.
pub fn direct_irradiance(world: &World, receivers: &[u32], samples: u32) -> Vec<Vec3> {
    DirectCache::new(world, receivers.to_vec(), samples)
        .irradiance()
        .to_vec()
}

/// The sample stream of [`direct_irradiance_independent`].
pub const INDEPENDENT_STREAM: u32 = 0x5eed_0001;

/// [`direct_irradiance`] from shadow rays no solver casts (another stream of samples): the
/// reference's, so that an error measured against it sees a solver's sampling noise. With
/// the same rays, the dispersive default (16 samples) against `ReferenceOptions::fast`
/// (16) read 0.23 % where the closed form says 1.85 % (a furnace with a sphere and a box).
pub fn direct_irradiance_independent(world: &World, receivers: &[u32], samples: u32) -> Vec<Vec3> {
    let cache = DirectCache::new_in_stream(world, receivers.to_vec(), samples, INDEPENDENT_STREAM);
    cache.irradiance().to_vec()
}

/// The weighted fraction of the `samples` shadow rays from `at` (point, normal) to `em`
/// that `blocked` says are clear.
fn visible_fraction(
    em: &Emitter,
    at: (Vec3, Vec3),
    shift: (f32, f32),
    samples: u32,
    eps: f32,
    blocked: impl Fn(u32) -> bool,
) -> f32 {
    weighted_fraction((0..samples).map(|j| {
        let (_, _, w) = shadow_sample(em, at.0, at.1, shift, j, samples, eps);
        (w, blocked(j))
    }))
}

/// The weighted fraction of samples `(weight, blocked)` not blocked, summed in order; 1 when
/// the weights sum to nothing.
fn weighted_fraction(samples: impl Iterator<Item = (f32, bool)>) -> f32 {
    let (mut total, mut seen) = (0.0, 0.0);
    for (w, blocked) in samples {
        total += w;
        if !blocked {
            seen += w;
        }
    }
    if total > 0.0 {
        seen / total
    } else {
        1.0
    }
}

/// Unoccluded irradiance at `x` (normal `n`) from emitter `em` of unit radiance, exact.
/// [`unoccluded_irradiance`] averaged over patch `i`, as its radiosity is: at its centre
/// where the emitter is far beside the patch (the irradiance varies little over it), else
/// the mean over points of the patch ([`patch_points`]). At the centre alone, a ceiling
/// patch half over a panel hung 5 cm under it took the panel's full `pi L` for its whole
/// area (or, a patch over, next to nothing): the room's absorbed light swung between 91 and
/// 112 % of the emitted with the patch count.
///
/// `reach` is the patch's radius ([`crate::patches::Patches::radius`]), found once a patch by
/// the caller, not once an emitter.
fn patch_unoccluded_irradiance(em: &Emitter, world: &World, i: usize, reach: f32) -> f32 {
    let p = &world.patches;
    let (x, n) = (p.centre[i], p.normal[i]);
    let (c, r) = em.sphere;
    if (x - c).length() - r > NEAR_FIELD * reach {
        return unoccluded_irradiance(em, x, n);
    }
    let points = patch_points(p.world_corners(i));
    let sum: f32 = points
        .iter()
        .map(|&y| unoccluded_irradiance(em, y, n))
        .sum();
    sum / points.len() as f32
}

/// An emitter nearer a patch than this many times the patch's radius (centre to corner)
/// is in its near field: the irradiance is averaged over the patch, not taken at its centre.
const NEAR_FIELD: f32 = 4.0;

/// Points of equal weight over a patch with `corners` (a triangle repeats its last): a
/// quad's 3 x 3 midpoint rule in its bilinear map (of equal area on a parallelogram), a
/// triangle's centroids of its four halved-edge sub-triangles.
fn patch_points([a, b, c, d]: [Vec3; 4]) -> Vec<Vec3> {
    if c == d {
        let (ab, bc, ca) = ((a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5);
        let centroid = |u: Vec3, v: Vec3, w: Vec3| (u + v + w) / 3.0;
        return vec![
            centroid(a, ab, ca),
            centroid(ab, b, bc),
            centroid(ca, bc, c),
            centroid(ab, bc, ca),
        ];
    }
    const AT: [f32; 3] = [1.0 / 6.0, 0.5, 5.0 / 6.0];
    let bilinear = |u: f32, v: f32| a.lerp(b, u).lerp(d.lerp(c, u), v);
    AT.iter()
        .flat_map(|&v| AT.iter().map(move |&u| bilinear(u, v)))
        .collect()
}

fn unoccluded_irradiance(em: &Emitter, x: Vec3, n: Vec3) -> f32 {
    em.triangles
        .iter()
        .zip(&em.normals)
        .map(|(t, ne)| {
            let front = ne.dot(x - t[0]) > 0.0;
            if front || em.double_sided {
                polygon_irradiance(x, n, t)
            } else {
                0.0
            }
        })
        .sum()
}

/// The toroidal shift of receiver `i`'s samples on emitter `em` in sample stream `stream`:
/// a function of the three alone, so a patch gets the same rays whichever list it is
/// computed in.
fn sample_shift(i: usize, em: &Emitter, stream: u32) -> (f32, f32) {
    let seed = hash2(
        i as u32,
        em.object as u32 ^ 0x9e37_79b9 ^ stream.wrapping_mul(0x85eb_ca6b),
    );
    // (Stream 0, the solvers', is the shift as it always was.)
    (unit(seed), unit(hash(seed)))
}

/// Shadow ray `j` of `samples` from `x` (normal `n`) to a stratified point of `em`:
/// `(from, to, weight)`, the weight its contribution `cos cos / r^2`.
fn shadow_sample(
    em: &Emitter,
    x: Vec3,
    n: Vec3,
    shift: (f32, f32),
    j: u32,
    samples: u32,
    eps: f32,
) -> (Vec3, Vec3, f32) {
    let (ti, y) = sample_point(em, shift, j, samples);
    let d = y - x;
    let r2 = d.length_squared().max(1e-30);
    let dir = d / r2.sqrt();
    let cos_e = -em.normals[ti].dot(dir);
    let cos_e = if em.double_sided {
        cos_e.abs()
    } else {
        cos_e.max(0.0)
    };
    (x + n * eps, y, n.dot(dir).max(0.0) * cos_e / r2)
}

/// [`shadow_sample`]'s segment alone (the same floats), for finding the rays a mover may
/// have changed, which need no weight.
fn shadow_segment(
    em: &Emitter,
    (x, n): (Vec3, Vec3),
    shift: (f32, f32),
    j: u32,
    samples: u32,
    eps: f32,
) -> (Vec3, Vec3) {
    (x + n * eps, sample_point(em, shift, j, samples).1)
}

/// Sample `j` of `samples` on `em`, stratified: its triangle and the point.
fn sample_point(em: &Emitter, shift: (f32, f32), j: u32, samples: u32) -> (usize, Vec3) {
    let (u, v) = hammersley(j, samples, shift);
    let ti = em
        .cdf
        .partition_point(|&c| c < u)
        .min(em.triangles.len() - 1);
    let lo = if ti == 0 { 0.0 } else { em.cdf[ti - 1] };
    let u2 = ((u - lo) / (em.cdf[ti] - lo).max(1e-12)).clamp(0.0, 1.0);
    let [a, b, c] = em.triangles[ti];
    let su = u2.sqrt();
    (ti, a * (1.0 - su) + b * (su * (1.0 - v)) + c * (su * v))
}

/// Does the cone from `x` to the sphere `(lc, lr)` meet the sphere `(bc, br)`? The cone is
/// every point `x + s (y - x)`, `s` in [0, 1], `y` in the first sphere: the points within
/// `s lr` of the axis point `a(s) = x + s (lc - x)`. It meets the second sphere when
/// `|bc - a(s)| - s lr <= br` for some `s`; the left side is convex in `s`, so its minimum
/// is where its derivative vanishes, clamped to [0, 1]. Exact (no widening needed).
pub(crate) fn cone_meets_sphere(x: Vec3, lc: Vec3, lr: f32, bc: Vec3, br: f32) -> bool {
    Cone::new(x, lc, lr).meets(bc, br)
}

/// The cone of [`cone_meets_sphere`] with the terms every sphere shares found once (a
/// receiver's cone is tested against every swept box's sphere). The minimising `s` is
/// rounded differently from a test that finds it for each sphere (`perp * slope`, not
/// `lr * perp / ...`), in its last bit: a distance minimised over `s` changes to second order
/// with `s`, far inside the test's slack.
pub(crate) struct Cone {
    x: Vec3,
    axis: Vec3,
    lr: f32,
    len: f32,
    /// `lr / (sqrt(len^2 - lr^2) len)` where `lr < len`, else `None` (`s` is 1).
    slope: Option<f32>,
}

impl Cone {
    pub(crate) fn new(x: Vec3, lc: Vec3, lr: f32) -> Cone {
        let axis = lc - x;
        let len = axis.length();
        let slope = (lr < len).then(|| lr / ((len * len - lr * lr).sqrt() * len));
        Cone {
            x,
            axis,
            lr,
            len,
            slope,
        }
    }

    /// Whether the cone meets the sphere `(bc, br)`.
    pub(crate) fn meets(&self, bc: Vec3, br: f32) -> bool {
        let (x, axis, lr, len) = (self.x, self.axis, self.lr, self.len);
        if len <= 1e-20 {
            return (bc - x).length() <= br + lr;
        }
        let s0 = (bc - x).dot(axis) / (len * len);
        let perp = (bc - (x + axis * s0)).length();
        let s = self.slope.map_or(1.0, |k| s0 + perp * k).clamp(0.0, 1.0);
        (bc - (x + axis * s)).length() - s * lr <= br * (1.0 + 1e-5) + 1e-6
    }
}

/// Whether each of the shadow rays `from`, `to` (sets of `s`, one set a receiver) is
/// blocked, casting only the sets `lit` says receive the emitter: a receiver facing away from
/// it has no rays (its segments are empty, and it reads as free). Casting them anyway counted
/// them as rays and left packets half empty: the 77k room's moving sphere faces its light
/// with half its patches, and their empty rays were a tenth of a moving frame's count.
fn occluded_where_lit(
    world: &World,
    (from, to): (&[Vec3], &[Vec3]),
    s: usize,
    lit: impl Fn(usize) -> bool,
) -> Vec<bool> {
    let sets = from.len() / s.max(1);
    let live: Vec<usize> = (0..sets).filter(|&c| lit(c)).collect();
    let mut blocked = vec![false; from.len()];
    if live.len() == sets {
        world.vis.occluded(from, to, world.eps, &[], &mut blocked);
        return blocked;
    }
    let rays = |ends: &[Vec3]| -> Vec<Vec3> {
        (live.iter())
            .flat_map(|&c| ends[c * s..(c + 1) * s].iter().copied())
            .collect()
    };
    let mut cast = vec![false; live.len() * s];
    world
        .vis
        .occluded(&rays(from), &rays(to), world.eps, &[], &mut cast);
    for (&c, outcome) in live.iter().zip(cast.chunks(s.max(1))) {
        blocked[c * s..(c + 1) * s].copy_from_slice(outcome);
    }
    blocked
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    /// A floor cut into four patches of 0.5, a small panel (0.2 on a side, radiance 1) hung
    /// 0.01 over the middle of one of them: the floor cannot receive more than the panel
    /// sends down, `pi L A`. At the patch's centre alone the patch took the panel's full
    /// `pi L` over its whole area, 6.2 times that flux.
    #[test]
    fn a_panel_close_over_a_patch_lights_it_by_the_patch_average_not_its_centre() {
        use shrad_scene::{quad, Material, Object, Role, Scene};
        let floor = quad([
            Vec3::ZERO,
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 0.0),
        ]);
        let (lo, hi, h) = (0.15, 0.35, 0.01);
        let panel = quad([
            Vec3::new(lo, h, lo),
            Vec3::new(hi, h, lo),
            Vec3::new(hi, h, hi),
            Vec3::new(lo, h, hi),
        ]);
        let mut lamp = Material::diffuse(Vec3::ZERO);
        lamp.emitted_radiance = Vec3::ONE;
        let mut objects = vec![
            Object::new("floor", floor, Material::diffuse(Vec3::splat(0.5))),
            Object::new("panel", panel, lamp),
        ];
        objects[0].role = Some(Role::Boundary);
        objects[1].role = Some(Role::Light);
        let scene = Scene {
            source: "near panel".into(),
            objects,
            ..Default::default()
        };
        let world = World::new(
            scene,
            crate::PatchSizing::Size(0.5),
            shrad_vis::Backend::Auto,
        )
        .unwrap();
        let floor: Vec<u32> = world.patches.range(0).map(|i| i as u32).collect();
        assert_eq!(floor.len(), 4);
        let e = direct_irradiance(&world, &floor, 16);
        let received: f32 = (floor.iter().zip(&e))
            .map(|(&i, e)| e.x * world.patches.area[i as usize])
            .sum();
        let sent = PI * (hi - lo) * (hi - lo);
        assert!(received <= 1.01 * sent, "received {received}, sent {sent}");
        assert!(received >= 0.5 * sent, "received {received}, sent {sent}");
    }

    #[test]
    fn polygon_formula_matches_a_disc_like_square_far_away_and_the_full_plane() {
        // A huge square covers the whole hemisphere: E = pi * L.
        let big = 1e5;
        let tri1 = [
            Vec3::new(-big, -big, 1.0),
            Vec3::new(big, -big, 1.0),
            Vec3::new(big, big, 1.0),
        ];
        let tri2 = [
            Vec3::new(-big, -big, 1.0),
            Vec3::new(big, big, 1.0),
            Vec3::new(-big, big, 1.0),
        ];
        let e = polygon_irradiance(Vec3::ZERO, Vec3::Z, &tri1)
            + polygon_irradiance(Vec3::ZERO, Vec3::Z, &tri2);
        assert!((e - PI).abs() < 1e-3, "{e}");
        // A small square of area a at distance d on the axis: E ~ a / d^2.
        let s = 0.01;
        let t1 = [
            Vec3::new(-s, -s, 1.0),
            Vec3::new(s, -s, 1.0),
            Vec3::new(s, s, 1.0),
        ];
        let t2 = [
            Vec3::new(-s, -s, 1.0),
            Vec3::new(s, s, 1.0),
            Vec3::new(-s, s, 1.0),
        ];
        let e = polygon_irradiance(Vec3::ZERO, Vec3::Z, &t1)
            + polygon_irradiance(Vec3::ZERO, Vec3::Z, &t2);
        assert!((e - 4.0 * s * s).abs() < 1e-3 * 4.0 * s * s, "{e}");
        // In the receiver's own plane (a planar light seen from itself): nothing.
        let flat = [
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        assert_eq!(
            polygon_irradiance(Vec3::new(0.1, 0.0, 0.0), Vec3::Z, &flat),
            0.0
        );
        assert_eq!(
            polygon_irradiance(Vec3::new(0.1, 0.0, 0.0), -Vec3::Z, &flat),
            0.0
        );
        // Below the horizon: nothing.
        let t3 = [
            Vec3::new(-1.0, -1.0, -1.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(1.0, 1.0, -1.0),
        ];
        assert_eq!(polygon_irradiance(Vec3::ZERO, Vec3::Z, &t3), 0.0);
    }
}
