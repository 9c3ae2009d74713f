//! Textured and vertex-coloured surfaces on patches (spec section 2, "Textures"): the
//! reflectance field `rho(x) = factor * base_color_texture(uv(x)) * colour(x)` and the
//! emission field `M(x) = pi * L_e * emissive_texture(uv(x))`.
//!
//! A patch's `rho_i` is the area average of `rho(x)` over the patch's own footprint, found
//! by supersampling: a stratified grid of `k x k` points of the cell (or `k^2` equal
//! sub-triangles' centroids), `k` 64 times the patch's longest edge in texels (a texel edge
//! crossing the patch is placed to 1/64 of a texel; a patch inside one texel needs few), at most
//! [`MAX_K`] (and less when the scene has very many textured patches, so that setting up
//! stays around 2^24 texture samples). Everything is linear RGB. Pictures sample the same
//! fields at the pixel's point ([`albedo_at`]).

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use shrad_scene::{Material, Scene, Texture};

use crate::patches::{CornerAttr, Patches};

/// Largest supersampling grid side per patch.
pub const MAX_K: usize = 32;

pub use shrad_scene::MAX_REFLECTANCE;

/// The attributes at patch parameters `(s, t)`: a parallelogram's bilinear coordinates, or
/// a triangle's barycentric ones (weights of corners 1 and 2).
#[inline]
pub fn attr_at(corners: &[CornerAttr; 4], is_quad: bool, s: f32, t: f32) -> CornerAttr {
    if is_quad {
        CornerAttr::bilinear(corners, s, t)
    } else {
        CornerAttr::barycentric(corners, s, t)
    }
}

/// `rho(x)` at a point with attributes `a` of a surface of material `m`.
#[inline]
pub fn albedo(m: &Material, a: &CornerAttr) -> Vec3 {
    let tex = m
        .base_color_texture
        .as_ref()
        .map_or(Vec3::ONE, |t| t.sample(a.uv[0]));
    (m.reflectance * tex * a.color).clamp(Vec3::ZERO, Vec3::splat(MAX_REFLECTANCE))
}

/// The emissive texture's value at a point with attributes `a` (1 without one).
#[inline]
pub fn emission_scale(m: &Material, a: &CornerAttr) -> Vec3 {
    m.emissive_texture
        .as_ref()
        .map_or(Vec3::ONE, |t| t.sample(a.uv[1]).max(Vec3::ZERO))
}

/// `rho(x)` on patch `p` at parameters `(s, t)`; the patch's own `rho_i` where the object
/// has no texture and no vertex colours.
#[inline]
pub fn albedo_at(scene: &Scene, patches: &Patches, rho_i: Vec3, p: usize, s: f32, t: f32) -> Vec3 {
    match patches.corner_attrs(p) {
        None => rho_i,
        Some(c) => {
            let m = &scene.objects[patches.object[p] as usize].material;
            albedo(m, &attr_at(c, patches.is_quad[p], s, t))
        }
    }
}

/// Longest edge of a patch in texels of texture `t` reading texture-coordinate slot `slot`.
fn footprint(t: &Texture, c: &[CornerAttr; 4], is_quad: bool, slot: usize) -> f32 {
    let n = if is_quad { 4 } else { 3 };
    let p: Vec<Vec2> = c[..n].iter().map(|a| t.texel_coords(a.uv[slot])).collect();
    (0..n)
        .map(|k| (p[(k + 1) % n] - p[k]).length())
        .fold(0.0, f32::max)
}

/// The mean of `f` over patch `p` (corners `c`) with a `k x k` stratified grid.
fn patch_mean(
    c: &[CornerAttr; 4],
    is_quad: bool,
    k: usize,
    f: impl Fn(&CornerAttr) -> Vec3,
) -> Vec3 {
    let kf = k as f32;
    let mut sum = Vec3::ZERO;
    if is_quad {
        for j in 0..k {
            for i in 0..k {
                let (s, t) = ((i as f32 + 0.5) / kf, (j as f32 + 0.5) / kf);
                sum += f(&CornerAttr::bilinear(c, s, t));
            }
        }
    } else {
        // The k^2 equal sub-triangles of the k-subdivision, at their centroids.
        for j in 0..k {
            for i in 0..k - j {
                let (u, v) = ((i as f32 + 1.0 / 3.0) / kf, (j as f32 + 1.0 / 3.0) / kf);
                sum += f(&CornerAttr::barycentric(c, u, v));
                if i + j + 1 < k {
                    let (u, v) = ((i as f32 + 2.0 / 3.0) / kf, (j as f32 + 2.0 / 3.0) / kf);
                    sum += f(&CornerAttr::barycentric(c, u, v));
                }
            }
        }
    }
    sum / (kf * kf)
}

/// The grid side for a patch whose longest edge covers `texels` texels.
fn grid_side(texels: f32, cap: usize) -> usize {
    if texels.is_finite() {
        ((64.0 * texels).ceil() as usize).clamp(1, cap)
    } else {
        cap
    }
}

/// Per patch: the area average of `rho(x)` (the material's reflectance for objects without
/// textures and vertex colours), and of the emissive texture (empty when no material of the
/// scene has one; else 1 on patches without).
pub fn patch_fields(scene: &Scene, patches: &Patches) -> (Vec<Vec3>, Vec<Vec3>) {
    let cap = sample_cap(patches);
    let emissive = scene
        .objects
        .iter()
        .any(|o| o.material.emissive_texture.is_some());
    let fields: Vec<(Vec3, Vec3)> = (0..patches.len())
        .into_par_iter()
        .map(|p| {
            let m = &scene.objects[patches.object[p] as usize].material;
            let glow = match (patches.corner_attrs(p), &m.emissive_texture) {
                (Some(c), Some(t)) => {
                    let k = grid_side(footprint(t, c, patches.is_quad[p], 1), cap);
                    patch_mean(c, patches.is_quad[p], k, |a| emission_scale(m, a))
                }
                _ => Vec3::ONE,
            };
            (patch_reflectance(m, patches, p, cap), glow)
        })
        .collect();
    let rho = fields.iter().map(|f| f.0).collect();
    let glow = if emissive {
        fields.iter().map(|f| f.1).collect()
    } else {
        Vec::new()
    };
    (rho, glow)
}

/// The area average of `rho(x)` over each patch of object `o` with material `m` (its base
/// colour changed: [`crate::World::set_reflectance`]), as [`patch_fields`] gives it.
pub fn object_reflectance(m: &Material, patches: &Patches, o: usize) -> Vec<Vec3> {
    let cap = sample_cap(patches);
    (patches.range(o).into_par_iter())
        .map(|p| patch_reflectance(m, patches, p, cap))
        .collect()
}

/// The largest supersampling grid side: [`MAX_K`], less when the scene has very many
/// textured patches, so that setting up stays around 2^24 texture samples.
fn sample_cap(patches: &Patches) -> usize {
    let with_attrs = patches.corner_attr.len().max(1);
    let cap = (((1usize << 24) / with_attrs) as f64).sqrt() as usize;
    cap.clamp(2, MAX_K)
}

/// Patch `p`'s `rho_i` with material `m`: the area average of `rho(x)`.
fn patch_reflectance(m: &Material, patches: &Patches, p: usize, cap: usize) -> Vec3 {
    let Some(c) = patches.corner_attrs(p) else {
        return m.reflectance;
    };
    let k = m.base_color_texture.as_ref().map_or(1, |t| {
        grid_side(footprint(t, c, patches.is_quad[p], 0), cap)
    });
    let rho = patch_mean(c, patches.is_quad[p], k, |a| albedo(m, a));
    rho.min(Vec3::splat(MAX_REFLECTANCE))
}
