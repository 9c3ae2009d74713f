//! The texels of a lightmap: which patch point each texel shows, its light (the picture's
//! [`SurfaceLight`], the punctual part exact with a shadow ray per texel), and dilation into
//! the padding.

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use super::Layout;
use crate::render::SurfaceLight;
use crate::World;

/// Texels whose centre is at most this far (texels) outside their chart's patches are
/// evaluated at the nearest patch point; the rest of the padding is dilated.
const REACH: f32 = 0.75;

/// A lightmap's texels (row-major from the top-left).
#[derive(Clone, Debug)]
pub struct Texels {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Irradiance over pi, `E / pi` (W/m^2/sr): the radiance of a white surface there;
    /// times the albedo it is the surface's reflected radiance.
    pub irradiance: Vec<Vec3>,
    /// The outgoing radiance `(rho E + M) / pi` (the lightmap times the albedo, plus the
    /// emission): what a picture shows there.
    pub radiance: Vec<Vec3>,
    /// Whether the texel was evaluated on a patch (the rest is dilation or empty).
    pub covered: Vec<bool>,
}

/// A texel's surface point: its patch, the patch's parameters and the point (world).
#[derive(Clone, Copy, Debug)]
struct Sample {
    texel: usize,
    patch: usize,
    st: (f32, f32),
    point: Vec3,
}

/// The point of patch `i` at parameters `(s, t)` (as [`SurfaceLight::params`] reads them).
fn patch_point(world: &World, i: usize, (s, t): (f32, f32)) -> Vec3 {
    let c = world.patches.world_corners(i);
    let far = if world.patches.is_quad[i] { c[3] } else { c[2] };
    c[0] + (c[1] - c[0]) * s + (far - c[0]) * t
}

/// The point of polygon `q` (convex, either winding) nearest to `x`.
fn nearest_in(q: &[Vec2], x: Vec2) -> Vec2 {
    let n = q.len();
    let side = |k: usize| (q[(k + 1) % n] - q[k]).perp_dot(x - q[k]);
    let sides: Vec<f32> = (0..n).map(side).collect();
    if sides.iter().all(|&d| d >= 0.0) || sides.iter().all(|&d| d <= 0.0) {
        return x;
    }
    let on_edge = |k: usize| {
        let (a, e) = (q[k], q[(k + 1) % n] - q[k]);
        a + e * ((x - a).dot(e) / e.length_squared().max(f32::MIN_POSITIVE)).clamp(0.0, 1.0)
    };
    (0..n)
        .map(on_edge)
        .min_by(|a, b| a.distance_squared(x).total_cmp(&b.distance_squared(x)))
        .unwrap_or(x)
}

/// The samples of patch `i`: each texel whose centre is within [`REACH`] texels of the
/// patch's atlas polygon, at the patch point there (texels past the edge: the nearest one),
/// with its distance in texels (0 inside).
fn patch_samples(world: &World, layout: &Layout, i: usize) -> Vec<(f32, Sample)> {
    let n = if world.patches.is_quad[i] { 4 } else { 3 };
    let q = &layout.corners[i][..n];
    let (a, e1, e2) = (q[0], q[1] - q[0], q[n - 1] - q[0]);
    let det = e1.perp_dot(e2);
    if det.abs() < 1e-12 {
        return Vec::new();
    }
    let lo = q.iter().fold(Vec2::INFINITY, |a, &b| a.min(b)) - Vec2::splat(REACH);
    let hi = q.iter().fold(Vec2::NEG_INFINITY, |a, &b| a.max(b)) + Vec2::splat(REACH);
    let xs = (lo.x.floor().max(0.0) as u32)..(hi.x.ceil().max(0.0) as u32).min(layout.width);
    let ys = (lo.y.floor().max(0.0) as u32)..(hi.y.ceil().max(0.0) as u32).min(layout.height);
    let mut out = Vec::new();
    for ty in ys {
        for tx in xs.clone() {
            let x = Vec2::new(tx as f32 + 0.5, ty as f32 + 0.5);
            let near = nearest_in(q, x);
            let d = near.distance(x);
            if d > REACH {
                continue;
            }
            // Invert `near = a + s e1 + t e2`.
            let r = near - a;
            let st = (r.perp_dot(e2) / det, e1.perp_dot(r) / det);
            let st = (st.0.clamp(0.0, 1.0), st.1.clamp(0.0, 1.0));
            let sample = Sample {
                texel: (ty * layout.width + tx) as usize,
                patch: i,
                st,
                point: patch_point(world, i, st),
            };
            out.push((d, sample));
        }
    }
    out
}

/// Every texel's sample: the nearest patch's (ties: the first), of the patches of its own
/// chart only (a chart's rectangle holds its padding, so charts never compete).
fn samples(world: &World, layout: &Layout) -> Vec<Sample> {
    let per_patch: Vec<Vec<(f32, Sample)>> = (0..world.patches.len())
        .into_par_iter()
        .map(|i| patch_samples(world, layout, i))
        .collect();
    let mut best: Vec<(f32, Option<Sample>)> =
        vec![(f32::INFINITY, None); (layout.width * layout.height) as usize];
    for (d, s) in per_patch.into_iter().flatten() {
        if d < best[s.texel].0 {
            best[s.texel] = (d, Some(s));
        }
    }
    best.into_iter().filter_map(|b| b.1).collect()
}

/// Bake the texels of `layout` with the light `light` of `world`.
pub fn bake(world: &World, light: &SurfaceLight, layout: &Layout) -> Texels {
    let samples = samples(world, layout);
    let exact = if light.has_punctual() {
        let xs: Vec<Vec3> = samples.iter().map(|s| s.point).collect();
        let ns: Vec<Vec3> = samples
            .iter()
            .map(|s| world.patches.normal[s.patch])
            .collect();
        crate::lights::point_irradiance(world, &xs, &ns)
    } else {
        Vec::new()
    };
    let n = (layout.width * layout.height) as usize;
    let mut out = Texels {
        width: layout.width,
        height: layout.height,
        irradiance: vec![Vec3::ZERO; n],
        radiance: vec![Vec3::ZERO; n],
        covered: vec![false; n],
    };
    let values: Vec<(Vec3, Vec3)> = samples
        .par_iter()
        .enumerate()
        .map(|(k, s)| {
            let (i, (u, v)) = (s.patch, s.st);
            let e = light.irradiance(i, u, v, exact.get(k).copied());
            let (rho, m) = light.albedo_and_emission(i, u, v);
            let pi = std::f32::consts::PI;
            (e / pi, (rho * e + m) / pi)
        })
        .collect();
    for (s, (e, b)) in samples.iter().zip(values) {
        out.irradiance[s.texel] = e;
        out.radiance[s.texel] = b;
        out.covered[s.texel] = true;
    }
    dilate(&mut out, layout.padding + 1);
    out
}

/// Fill texels next to filled ones with the mean of their filled 8-neighbours, `rounds`
/// times: the padding around each chart repeats its edge, so bilinear filtering at a
/// chart's edge reads no black.
pub fn dilate(t: &mut Texels, rounds: u32) {
    let (w, h) = (t.width as i64, t.height as i64);
    let mut filled = t.covered.clone();
    for _ in 0..rounds {
        let mut next = filled.clone();
        for y in 0..h {
            for x in 0..w {
                let k = (y * w + x) as usize;
                if filled[k] {
                    continue;
                }
                let (mut e, mut b, mut count) = (Vec3::ZERO, Vec3::ZERO, 0.0);
                for (dx, dy) in [
                    (-1, -1),
                    (0, -1),
                    (1, -1),
                    (-1, 0),
                    (1, 0),
                    (-1, 1),
                    (0, 1),
                    (1, 1),
                ] {
                    let (nx, ny) = (x + dx, y + dy);
                    if nx < 0 || ny < 0 || nx >= w || ny >= h || !filled[(ny * w + nx) as usize] {
                        continue;
                    }
                    let j = (ny * w + nx) as usize;
                    (e, b, count) = (e + t.irradiance[j], b + t.radiance[j], count + 1.0);
                }
                if count > 0.0 {
                    t.irradiance[k] = e / count;
                    t.radiance[k] = b / count;
                    next[k] = true;
                }
            }
        }
        filled = next;
    }
}

/// Bilinear sample (texture filtering, clamp to edge) of `values` at atlas coordinates
/// `xy` (texels from the top-left corner).
pub fn bilinear(values: &[Vec3], width: u32, height: u32, xy: Vec2) -> Vec3 {
    let p = xy - Vec2::splat(0.5);
    let (fx, fy) = (p.x.floor(), p.y.floor());
    let (ax, ay) = (p.x - fx, p.y - fy);
    let at = |x: f32, y: f32| {
        let x = (x as i64).clamp(0, width as i64 - 1) as u32;
        let y = (y as i64).clamp(0, height as i64 - 1) as u32;
        values[(y * width + x) as usize]
    };
    let top = at(fx, fy) * (1.0 - ax) + at(fx + 1.0, fy) * ax;
    let bottom = at(fx, fy + 1.0) * (1.0 - ax) + at(fx + 1.0, fy + 1.0) * ax;
    top * (1.0 - ay) + bottom * ay
}
