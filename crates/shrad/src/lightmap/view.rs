//! A lightmap rendered back as an engine would draw it: at each pixel centre, the texel
//! value at the point seen (bilinear, as a GPU filters) times the albedo there, plus the
//! emission: for comparing with shrad's own picture of the same state.

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Camera;

use super::texel::bilinear;
use super::Layout;
use crate::render::{primary_hits, Image, Shading, SurfaceLight};
use crate::World;

/// The picture (one sample a pixel, at its centre) of lightmap `texels` (`E / pi` per
/// texel, `layout.width x layout.height`) laid out by `layout`, from `camera`.
pub fn render_back(
    world: &World,
    layout: &Layout,
    texels: &[Vec3],
    camera: &Camera,
    width: u32,
    height: u32,
) -> Image {
    let (origins, dirs, hits) = primary_hits(world, camera, width, height, 1);
    // Only for the points' parameters, albedo and emission: the light is the texture's.
    let surface = SurfaceLight::new(
        world,
        &vec![Vec3::ZERO; world.patches.len()],
        &[],
        Shading::Smooth,
    );
    let pixels: Vec<(Vec3, bool)> = (0..hits.len())
        .into_par_iter()
        .map(|k| {
            let Some(i) = world.seen_patch(&hits[k]) else {
                return (Vec3::ZERO, false);
            };
            let y = origins[k] + dirs[k] * hits[k].t;
            let (s, t) = surface.params(i, y);
            let e = bilinear(
                texels,
                layout.width,
                layout.height,
                layout.atlas_at(i, s, t),
            );
            let (rho, m) = surface.albedo_and_emission(i, s, t);
            let emitter = world.exitance[i].max_element() > 0.0;
            (rho * e + m / std::f32::consts::PI, emitter)
        })
        .collect();
    Image {
        width,
        height,
        pixels: pixels.iter().map(|p| p.0).collect(),
        emitter: pixels.iter().map(|p| p.1).collect(),
    }
}

/// Relative RMSE of `b`'s 8x8-block means against `a`'s (RGB averaged), over blocks with
/// no emitter pixel in `a`.
pub fn block_rmse(a: &Image, b: &Image) -> f64 {
    let (w, h) = (a.width as usize, a.height as usize);
    let (mut num, mut den) = (0.0, 0.0);
    for by in 0..h / 8 {
        for bx in 0..w / 8 {
            let pixels = || (0..64).map(|k| (by * 8 + k / 8) * w + bx * 8 + k % 8);
            if pixels().any(|p| a.emitter[p]) {
                continue;
            }
            let mean = |img: &Image| {
                pixels()
                    .map(|p| img.pixels[p].dot(Vec3::ONE) as f64 / 3.0)
                    .sum::<f64>()
                    / 64.0
            };
            let (x, y) = (mean(a), mean(b));
            num += (x - y) * (x - y);
            den += x * x;
        }
    }
    (num / den.max(1e-30)).sqrt()
}
