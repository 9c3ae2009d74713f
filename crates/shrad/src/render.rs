//! Pictures of a radiosity solution: one primary ray per sample through a pinhole camera;
//! the surface seen shows its outgoing radiance `(rho(x) E(x) + M(x)) / pi` (spec section 2,
//! "Textures"): the irradiance `E_i = (B_i - M_i) / rho_i` of the patches (0 where
//! `rho_i = 0`), flat per patch or smooth (bilinear / barycentric from welded patch corners,
//! area-weighted: Gouraud shading as radiosity systems have always drawn), times the albedo
//! of the texel seen there, plus the emission there. Without textures and vertex colours
//! `rho(x) = rho_i` and this is the patch's `B_i` (interpolated). The back of a single-sided
//! surface is culled: the camera sees what lies behind it.

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Camera;

use crate::sampling::{hash2, unit};
use crate::World;

/// How radiosity is shown.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Shading {
    /// One colour per patch.
    Flat,
    /// Interpolated from patch corners (default).
    #[default]
    Smooth,
}

/// Image settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Samples per pixel (stratified; 1 = pixel centre).
    pub spp: u32,
    /// Flat or smooth.
    pub shading: Shading,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            width: 512,
            height: 512,
            spp: 4,
            shading: Shading::Smooth,
        }
    }
}

/// A linear RGB radiance image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Radiance per pixel.
    pub pixels: Vec<Vec3>,
    /// Per pixel: did the primary ray see an emitter? (tone mapping leaves them out)
    pub emitter: Vec<bool>,
}

/// A per-patch value (radiosity, irradiance) at each shading vertex: the area-weighted mean
/// of the patches that share it.
pub fn vertex_radiosity(world: &World, radiosity: &[Vec3]) -> Vec<Vec3> {
    let p = &world.patches;
    let mut sum = vec![Vec3::ZERO; p.shading_vertex_count];
    let mut weight = vec![0f32; p.shading_vertex_count];
    for i in 0..p.len() {
        for k in 0..if p.is_quad[i] { 4 } else { 3 } {
            let v = p.corner_vertex[i][k] as usize;
            sum[v] += radiosity[i] * p.area[i];
            weight[v] += p.area[i];
        }
    }
    sum.iter()
        .zip(&weight)
        .map(|(s, w)| if *w > 0.0 { *s / *w } else { Vec3::ZERO })
        .collect()
}

/// Irradiance of each patch, `E_i = (B_i - M_i) / rho_i` per channel (0 where `rho_i = 0`).
pub fn patch_irradiance(world: &World, radiosity: &[Vec3]) -> Vec<Vec3> {
    radiosity
        .iter()
        .zip(&world.exitance)
        .zip(&world.reflectance)
        .map(|((b, m), rho)| {
            let e = *b - *m;
            Vec3::select(rho.cmpgt(Vec3::ZERO), e / *rho, Vec3::ZERO)
        })
        .collect()
}

/// Primary ray of pixel position `(px, py)` (continuous, pixels) for `camera`.
pub fn camera_ray(camera: &Camera, width: u32, height: u32, px: f32, py: f32) -> (Vec3, Vec3) {
    let aspect = width as f32 / height as f32;
    let tan = (0.5 * camera.yfov).tan();
    let x = (2.0 * px / width as f32 - 1.0) * tan * aspect;
    let y = (1.0 - 2.0 * py / height as f32) * tan;
    let m = camera.world_from_camera;
    let dir = m.transform_vector3(Vec3::new(x, y, -1.0)).normalize();
    (m.translation.into(), dir)
}

/// Render `radiosity` (one value per patch) as seen by `camera`.
pub fn render(
    world: &World,
    radiosity: &[Vec3],
    camera: &Camera,
    options: &RenderOptions,
) -> Image {
    let (w, h) = (options.width.max(1), options.height.max(1));
    let spp = options.spp.max(1);
    let n = (w * h) as usize;
    let side = (spp as f32).sqrt().ceil() as u32;
    let mut origins = vec![Vec3::ZERO; n * spp as usize];
    let mut dirs = vec![Vec3::ZERO; n * spp as usize];
    origins
        .par_chunks_mut(spp as usize)
        .zip(dirs.par_chunks_mut(spp as usize))
        .enumerate()
        .for_each(|(pix, (o, d))| {
            let (x, y) = ((pix as u32 % w) as f32, (pix as u32 / w) as f32);
            for s in 0..spp {
                let (jx, jy) = if spp == 1 {
                    (0.5, 0.5)
                } else {
                    let hsh = hash2(pix as u32, s);
                    (
                        ((s % side) as f32 + unit(hsh)) / side as f32,
                        (((s / side) % side) as f32 + unit(hsh ^ 0x5bd1)) / side as f32,
                    )
                };
                (o[s as usize], d[s as usize]) = camera_ray(camera, w, h, x + jx, y + jy);
            }
        });
    let mut hits = vec![shrad_vis::Hit::MISS; origins.len()];
    world.vis.closest(&origins, &dirs, 0.0, &[], &mut hits);
    // The back of a single-sided surface is transparent to the camera (back-face culling,
    // as in a viewport): a camera outside a closed room sees in through the near wall
    // instead of a black back. Up to 4 such layers per ray.
    for _ in 0..4 {
        let behind: Vec<usize> = (0..hits.len())
            .filter(|&k| hits[k].is_hit() && world.seen_patch(&hits[k]).is_none())
            .collect();
        if behind.is_empty() {
            break;
        }
        let from: Vec<Vec3> = behind
            .iter()
            .map(|&k| origins[k] + dirs[k] * (hits[k].t + world.eps))
            .collect();
        let towards: Vec<Vec3> = behind.iter().map(|&k| dirs[k]).collect();
        let mut again = vec![shrad_vis::Hit::MISS; behind.len()];
        world.vis.closest(&from, &towards, 0.0, &[], &mut again);
        for ((&k, o), h) in behind.iter().zip(from).zip(again) {
            origins[k] = o;
            hits[k] = h;
        }
    }
    let irradiance = patch_irradiance(world, radiosity);
    let vertex = match options.shading {
        Shading::Smooth => vertex_radiosity(world, &irradiance),
        Shading::Flat => Vec::new(),
    };
    let p = &world.patches;
    let per_pixel: Vec<(Vec3, bool)> = (0..n)
        .into_par_iter()
        .map(|pix| {
            let mut sum = Vec3::ZERO;
            let mut emitter = false;
            for s in 0..spp as usize {
                let k = pix * spp as usize + s;
                let Some(i) = world.seen_patch(&hits[k]) else {
                    continue;
                };
                if world.exitance[i].max_element() > 0.0 {
                    emitter = true;
                }
                let attrs = p.corner_attrs(i);
                let (s, t) = if options.shading == Shading::Flat && attrs.is_none() {
                    (0.0, 0.0)
                } else {
                    let y = origins[k] + dirs[k] * hits[k].t;
                    let c = p.world_corners(i);
                    if p.is_quad[i] {
                        parallelogram_coords(y, c[0], c[1] - c[0], c[3] - c[0])
                    } else {
                        let (u, v) = parallelogram_coords(y, c[0], c[1] - c[0], c[2] - c[0]);
                        let sum = (u + v).max(1.0);
                        (u / sum, v / sum)
                    }
                };
                let e = match options.shading {
                    Shading::Flat => irradiance[i],
                    Shading::Smooth => {
                        let cv = p.corner_vertex[i].map(|v| vertex[v as usize]);
                        if p.is_quad[i] {
                            (cv[0] * (1.0 - s) + cv[1] * s) * (1.0 - t)
                                + (cv[3] * (1.0 - s) + cv[2] * s) * t
                        } else {
                            cv[0] * (1.0 - s - t) + cv[1] * s + cv[2] * t
                        }
                    }
                };
                let (rho, m) = match attrs {
                    None => (world.reflectance[i], world.exitance[i]),
                    Some(c) => {
                        let material = &world.scene.objects[p.object[i] as usize].material;
                        let a = crate::surface::attr_at(c, p.is_quad[i], s, t);
                        let rho = crate::surface::albedo(material, &a);
                        let m = match world.emission_texture.get(i) {
                            Some(avg) if material.emissive_texture.is_some() => {
                                let per = Vec3::select(
                                    avg.cmpgt(Vec3::ZERO),
                                    world.exitance[i] / *avg,
                                    Vec3::ZERO,
                                );
                                per * crate::surface::emission_scale(material, &a)
                            }
                            _ => world.exitance[i],
                        };
                        (rho, m)
                    }
                };
                let b = rho * e + m;
                sum += b;
            }
            (sum / (spp as f32 * std::f32::consts::PI), emitter)
        })
        .collect();
    Image {
        width: w,
        height: h,
        pixels: per_pixel.iter().map(|p| p.0).collect(),
        emitter: per_pixel.iter().map(|p| p.1).collect(),
    }
}

/// Coordinates `(u, v)` of `y - o = u * e1 + v * e2` (least squares), clamped to [0,1].
fn parallelogram_coords(y: Vec3, o: Vec3, e1: Vec3, e2: Vec3) -> (f32, f32) {
    let d = y - o;
    let (a, b, c) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (p, q) = (d.dot(e1), d.dot(e2));
    let det = a * c - b * b;
    if det.abs() < 1e-30 {
        return (0.5, 0.5);
    }
    (
        ((c * p - b * q) / det).clamp(0.0, 1.0),
        ((a * q - b * p) / det).clamp(0.0, 1.0),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PatchSizing;
    use shrad_vis::Backend;

    /// A camera outside a closed, inward-facing room sees in through the near wall's back.
    #[test]
    fn camera_outside_a_closed_room_sees_in() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/example.toml");
        let scene = shrad_scene::load(&path, &Default::default()).unwrap();
        let camera = scene.camera.expect("the example has a camera");
        let world = World::new(scene, PatchSizing::Count(2000), Backend::Auto).unwrap();
        // Radiosity 1 everywhere: every pixel that reaches a front face is 1 / pi.
        let b = vec![Vec3::ONE; world.patches.len()];
        let options = RenderOptions {
            width: 16,
            height: 16,
            spp: 1,
            shading: Shading::Flat,
        };
        let image = render(&world, &b, &camera, &options);
        let lit = image.pixels.iter().filter(|p| p.x > 0.3).count();
        assert!(lit > 200, "only {lit} of 256 pixels see a front face");
    }
}
