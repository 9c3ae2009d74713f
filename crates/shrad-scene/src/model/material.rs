//! The Lambertian material: reflectance, emitted radiance and their textures.

use glam::Vec3;
use std::f32::consts::PI;

use crate::Texture;

/// Reflectance never reaches 1 (energy conservation, spec section 2): a factor of 1, or
/// more, is read as this.
pub const MAX_REFLECTANCE: f32 = 0.999;

/// A Lambertian material. With textures (and vertex colours) the reflectance is a field
/// `rho(x) = reflectance * base_color_texture(uv(x)) * colour(x)` and the emitted radiance
/// `L_e(x) = emitted_radiance * emissive_texture(uv(x))` (spec section 2, "Textures").
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Diffuse reflectance `rho` (linear RGB, each in [0,1)): the factor the base-colour
    /// texture and the vertex colours multiply.
    pub reflectance: Vec3,
    /// Emitted radiance `L_e` of the front side (linear RGB, W/(m^2 sr)); the emissive
    /// texture multiplies it.
    pub emitted_radiance: Vec3,
    /// Reflects (and emits) on both sides.
    pub double_sided: bool,
    /// Base-colour texture (sRGB-decoded), read through the mesh's `uvs[tex_coord]`.
    pub base_color_texture: Option<Texture>,
    /// Emissive texture (sRGB-decoded), read through the mesh's `uvs[tex_coord]`.
    pub emissive_texture: Option<Texture>,
}

impl Material {
    /// A non-emissive single-sided material.
    pub const fn diffuse(reflectance: Vec3) -> Self {
        Material {
            reflectance,
            emitted_radiance: Vec3::ZERO,
            double_sided: false,
            base_color_texture: None,
            emissive_texture: None,
        }
    }
    /// Is the reflectance a field (a base-colour texture)?
    pub fn is_textured(&self) -> bool {
        self.base_color_texture.is_some() || self.emissive_texture.is_some()
    }
    /// Emitted exitance `M = pi * L_e` (W/m^2).
    pub fn exitance(&self) -> Vec3 {
        self.emitted_radiance * PI
    }
    /// Does it emit at all?
    pub fn is_emissive(&self) -> bool {
        self.emitted_radiance.max_element() > 0.0
    }
}

impl Default for Material {
    fn default() -> Self {
        Material::diffuse(Vec3::splat(0.5))
    }
}
