//! Direct light from emitters, computed without visible noise: the unoccluded irradiance
//! from each emitter triangle is exact (Lambert's polygon formula, the emitter clipped to the
//! receiver's upper hemisphere), and it is scaled by the fraction of the emitter that the
//! receiver sees, estimated with stratified shadow rays weighted by their contribution
//! (`cos cos / r^2`). Fully lit and fully shadowed patches are therefore exact; only
//! penumbrae carry (small, structured) estimation error.
//!
//! The reference solver uses it for its direct term; the dispersive solver uses it for
//! Step 1 (paper 2.3.2, direct light on the boundary) and, beyond the paper, for direct light
//! on interior patches.

use glam::Vec3;
use rayon::prelude::*;

use crate::sampling::{hammersley, hash, unit};
use crate::World;

/// One emitting object, in world space at the current time.
struct Emitter {
    triangles: Vec<[Vec3; 3]>,
    normals: Vec<Vec3>,
    /// Cumulative area of the triangles, normalised to end at 1.
    cdf: Vec<f32>,
    radiance: Vec3,
    double_sided: bool,
    object: usize,
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
        out.push(Emitter {
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
    let emitters = emitters(world);
    let mut out = vec![Vec3::ZERO; receivers.len()];
    if emitters.is_empty() {
        return out;
    }
    let samples = samples.max(1);
    let p = &world.patches;
    let eps = world.eps;
    const CHUNK: usize = 2048;
    for (chunk_index, (ids, out)) in receivers
        .chunks(CHUNK)
        .zip(out.chunks_mut(CHUNK))
        .enumerate()
    {
        for em in &emitters {
            // Unoccluded irradiance, exact.
            let unoccluded: Vec<f32> = ids
                .par_iter()
                .map(|&i| {
                    let (x, n) = (p.centre[i as usize], p.normal[i as usize]);
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
                })
                .collect();
            // Shadow rays to stratified points on the emitter.
            let s = samples as usize;
            let mut from = vec![Vec3::ZERO; ids.len() * s];
            let mut to = vec![Vec3::ZERO; ids.len() * s];
            let mut weight = vec![0f32; ids.len() * s];
            from.par_chunks_mut(s)
                .zip(to.par_chunks_mut(s))
                .zip(weight.par_chunks_mut(s))
                .enumerate()
                .for_each(|(k, ((f, t), w))| {
                    let i = ids[k] as usize;
                    if unoccluded[k] <= 0.0 {
                        return;
                    }
                    let (x, n) = (p.centre[i], p.normal[i]);
                    let seed =
                        hash(i as u32 ^ hash(em.object as u32 + 0x9e37 * chunk_index as u32));
                    let shift = (unit(seed), unit(hash(seed)));
                    for j in 0..s {
                        let (u, v) = hammersley(j as u32, samples, shift);
                        let ti = em
                            .cdf
                            .partition_point(|&c| c < u)
                            .min(em.triangles.len() - 1);
                        let lo = if ti == 0 { 0.0 } else { em.cdf[ti - 1] };
                        let u2 = ((u - lo) / (em.cdf[ti] - lo).max(1e-12)).clamp(0.0, 1.0);
                        let [a, b, c] = em.triangles[ti];
                        let su = u2.sqrt();
                        let y = a * (1.0 - su) + b * (su * (1.0 - v)) + c * (su * v);
                        let d = y - x;
                        let r2 = d.length_squared().max(1e-30);
                        let dir = d / r2.sqrt();
                        let cos_e = -em.normals[ti].dot(dir);
                        let cos_e = if em.double_sided {
                            cos_e.abs()
                        } else {
                            cos_e.max(0.0)
                        };
                        f[j] = x + n * eps;
                        t[j] = y;
                        w[j] = n.dot(dir).max(0.0) * cos_e / r2;
                    }
                });
            let mut blocked = vec![false; from.len()];
            world.vis.occluded(&from, &to, eps, &[], &mut blocked);
            out.par_iter_mut()
                .zip(unoccluded.par_iter())
                .enumerate()
                .for_each(|(k, (e, &u))| {
                    if u <= 0.0 {
                        return;
                    }
                    let (mut total, mut seen) = (0.0, 0.0);
                    for j in k * s..(k + 1) * s {
                        total += weight[j];
                        if !blocked[j] {
                            seen += weight[j];
                        }
                    }
                    let fraction = if total > 0.0 { seen / total } else { 1.0 };
                    *e += em.radiance * (u * fraction);
                });
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

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
