//! Pictures of a radiosity solution: one primary ray per sample through a pinhole camera;
//! the surface seen shows its outgoing radiance `(rho(x) E(x) + M(x)) / pi` (spec section 2,
//! "Textures"): the irradiance `E_i = (B_i - M_i) / rho_i` of the patches (0 where
//! `rho_i = 0`), flat per patch or smooth (bilinear / barycentric from welded patch corners,
//! area-weighted: Gouraud shading as radiosity systems have always drawn), times the albedo
//! of the texel seen there, plus the emission there. Without textures and vertex colours
//! `rho(x) = rho_i` and this is the patch's `B_i` (interpolated). The back of a single-sided
//! surface is culled: the camera sees what lies behind it.
//!
//! Punctual lights are evaluated per pixel: the patches' irradiance less their punctual
//! part (footprint averages, interpolated like the rest), plus the exact punctual irradiance
//! at the point seen with a shadow ray ([`crate::lights::point_irradiance`]), so a point
//! light's shadow edge is sharp at pixel scale while the indirect light comes from the
//! patches.

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

/// Render `radiosity` (one value per patch) as seen by `camera`. With punctual lights in
/// the world, their part of each patch's irradiance is computed here (16 footprint samples;
/// [`render_with_punctual`] takes the solver's own).
pub fn render(
    world: &World,
    radiosity: &[Vec3],
    camera: &Camera,
    options: &RenderOptions,
) -> Image {
    let punctual = if !crate::lights::has_sources(world) {
        Vec::new()
    } else {
        crate::lights::punctual_irradiance_all(world, 16)
    };
    render_with_punctual(world, radiosity, &punctual, camera, options)
}

/// The exact punctual irradiance at each hit that shows a patch (zero elsewhere; empty
/// without punctual lights).
fn punctual_at_hits(
    world: &World,
    hits: &[shrad_vis::Hit],
    origins: &[Vec3],
    dirs: &[Vec3],
    punctual: &[Vec3],
) -> Vec<Vec3> {
    if !crate::lights::has_sources(world) || punctual.len() != world.patches.len() {
        return Vec::new();
    }
    let seen: Vec<(usize, usize)> = (0..hits.len())
        .filter_map(|k| world.seen_patch(&hits[k]).map(|i| (k, i)))
        .collect();
    let xs: Vec<Vec3> = seen
        .iter()
        .map(|&(k, _)| origins[k] + dirs[k] * hits[k].t)
        .collect();
    let ns: Vec<Vec3> = seen.iter().map(|&(_, i)| world.patches.normal[i]).collect();
    let mut exact = vec![Vec3::ZERO; hits.len()];
    for (&(k, _), e) in seen
        .iter()
        .zip(crate::lights::point_irradiance(world, &xs, &ns))
    {
        exact[k] = e;
    }
    exact
}

/// The primary rays of every sample (`spp` a pixel, stratified) and what each sees, the
/// backs of single-sided surfaces passed through: `(origins, directions, hits)`, an origin
/// moved past the backs it went through.
pub fn primary_hits(
    world: &World,
    camera: &Camera,
    w: u32,
    h: u32,
    spp: u32,
) -> (Vec<Vec3>, Vec<Vec3>, Vec<shrad_vis::Hit>) {
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
    (origins, dirs, hits)
}

/// [`render`] with `punctual`, the punctual lights' part of each patch's irradiance as the
/// solver computed it ([`crate::solver::Solver::punctual_irradiance`]; empty: none), replaced
/// per pixel by its exact value (see the module docs).
pub fn render_with_punctual(
    world: &World,
    radiosity: &[Vec3],
    punctual: &[Vec3],
    camera: &Camera,
    options: &RenderOptions,
) -> Image {
    let (w, h) = (options.width.max(1), options.height.max(1));
    let spp = options.spp.max(1);
    let n = (w * h) as usize;
    let (origins, dirs, hits) = primary_hits(world, camera, w, h, spp);
    let exact = punctual_at_hits(world, &hits, &origins, &dirs, punctual);
    let light = SurfaceLight::new(world, radiosity, punctual, options.shading);
    let per_pixel: Vec<(Vec3, bool)> = (0..n)
        .into_par_iter()
        .map(|pix| {
            let mut sum = Vec3::ZERO;
            let mut emitter = false;
            for s in 0..spp as usize {
                let k = pix * spp as usize + s;
                let Some(i) = world.seen_patch(&hits[k]) else {
                    // A ray that leaves the scene sees the sky.
                    if let Some(sky) = world.sky.as_ref().filter(|_| !hits[k].is_hit()) {
                        sum += sky.radiance(dirs[k]) * std::f32::consts::PI;
                    }
                    continue;
                };
                if world.exitance[i].max_element() > 0.0 {
                    emitter = true;
                }
                let (s, t) = light.params(i, origins[k] + dirs[k] * hits[k].t);
                let e = light.irradiance(i, s, t, exact.get(k).copied());
                let (rho, m) = light.albedo_and_emission(i, s, t);
                sum += rho * e + m;
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

/// The light a picture shows at a surface point, in the pieces a pixel (and a lightmap's
/// texel, [`crate::lightmap`]) reads: the patches' irradiance reconstructed flat or smooth,
/// its punctual part to replace by the exact value there, and the albedo and emission.
pub struct SurfaceLight<'a> {
    world: &'a World,
    shading: Shading,
    /// `E_i` per patch.
    irradiance: Vec<Vec3>,
    /// `E` per shading vertex (smooth only).
    vertex: Vec<Vec3>,
    /// The punctual part of the patches' irradiance: per patch, or per shading vertex when
    /// smooth (empty without punctual lights).
    part: Vec<Vec3>,
}

impl<'a> SurfaceLight<'a> {
    /// The light of `radiosity`, with `punctual` the solver's punctual part per patch
    /// (empty: none).
    pub fn new(
        world: &'a World,
        radiosity: &[Vec3],
        punctual: &[Vec3],
        shading: Shading,
    ) -> SurfaceLight<'a> {
        let irradiance = patch_irradiance(world, radiosity);
        let smooth = shading == Shading::Smooth;
        let vertex = match smooth {
            true => vertex_radiosity(world, &irradiance),
            false => Vec::new(),
        };
        let part = if !crate::lights::has_sources(world) || punctual.len() != world.patches.len() {
            Vec::new()
        } else if smooth {
            vertex_radiosity(world, punctual)
        } else {
            punctual.to_vec()
        };
        SurfaceLight {
            world,
            shading,
            irradiance,
            vertex,
            part,
        }
    }

    /// Whether an exact punctual irradiance is to be given to [`SurfaceLight::irradiance`].
    pub fn has_punctual(&self) -> bool {
        !self.part.is_empty()
    }

    /// Patch `i`'s parameters `(s, t)` at world point `y` on it (bilinear on a cell,
    /// barycentric on a triangle).
    pub fn params(&self, i: usize, y: Vec3) -> (f32, f32) {
        let p = &self.world.patches;
        if self.shading == Shading::Flat && p.corner_attrs(i).is_none() {
            return (0.0, 0.0);
        }
        let c = p.world_corners(i);
        if p.is_quad[i] {
            parallelogram_coords(y, c[0], c[1] - c[0], c[3] - c[0])
        } else {
            let (u, v) = parallelogram_coords(y, c[0], c[1] - c[0], c[2] - c[0]);
            let sum = (u + v).max(1.0);
            (u / sum, v / sum)
        }
    }

    /// The irradiance at parameters `(s, t)` of patch `i`; `exact`: the exact punctual
    /// irradiance there, which replaces the patches' footprint average of it.
    pub fn irradiance(&self, i: usize, s: f32, t: f32, exact: Option<Vec3>) -> Vec3 {
        let p = &self.world.patches;
        let at = |field: &[Vec3], per_vertex: &[Vec3]| match self.shading {
            Shading::Flat => field[i],
            Shading::Smooth => {
                let cv = p.corner_vertex[i].map(|v| per_vertex[v as usize]);
                if p.is_quad[i] {
                    (cv[0] * (1.0 - s) + cv[1] * s) * (1.0 - t)
                        + (cv[3] * (1.0 - s) + cv[2] * s) * t
                } else {
                    cv[0] * (1.0 - s - t) + cv[1] * s + cv[2] * t
                }
            }
        };
        let e = at(&self.irradiance, &self.vertex);
        match exact {
            // The footprint average of the punctual light out, its exact value in.
            Some(x) if self.has_punctual() => (e - at(&self.part, &self.part)).max(Vec3::ZERO) + x,
            _ => e,
        }
    }

    /// The albedo `rho(x)` and emission `M(x)` at parameters `(s, t)` of patch `i`.
    pub fn albedo_and_emission(&self, i: usize, s: f32, t: f32) -> (Vec3, Vec3) {
        let (world, p) = (self.world, &self.world.patches);
        let Some(c) = p.corner_attrs(i) else {
            return (world.reflectance[i], world.exitance[i]);
        };
        let material = &world.scene.objects[p.object[i] as usize].material;
        let a = crate::surface::attr_at(c, p.is_quad[i], s, t);
        let rho = crate::surface::albedo(material, &a);
        let m = match world.emission_texture.get(i) {
            Some(avg) if material.emissive_texture.is_some() => {
                let per = Vec3::select(avg.cmpgt(Vec3::ZERO), world.exitance[i] / *avg, Vec3::ZERO);
                per * crate::surface::emission_scale(material, &a)
            }
            _ => world.exitance[i],
        };
        (rho, m)
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
