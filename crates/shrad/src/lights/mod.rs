//! Punctual lights (glTF `KHR_lights_punctual`: point, spot, directional) at the world's
//! current time, and their direct light (spec section 2, "Lights that are not surfaces").
//!
//! A punctual light has no surface: no probe, form factor or picture ray can meet it, so
//! its light enters only where the paper puts every light's, the direct-light step
//! (paper 2.3.2). There it is exact: a point or spot light of radiant intensity `I` gives a
//! visible point at distance `d` the irradiance `E = I f cos(theta) / d^2` (`f` the spot's
//! cone falloff times the range window), a directional light of irradiance `E0` gives
//! `E0 cos(theta)`. A patch's irradiance is that averaged over its footprint with one shadow
//! ray per sample point ([`PunctualCache`]), so a shadow edge across a patch gives the patch
//! the lit fraction of its area, and every later step (probes, SH emitters, wall exchange,
//! form factors) carries the reflected light with no change. Pictures evaluate the same
//! formula per pixel (`render.rs`), so shadow edges are sharp at pixel scale.
//!
//! The falloffs are the extension's recommended ones: the range window
//! `max(min(1 - (d / range)^4, 1), 0)` and the spot's `t^2`,
//! `t = clamp((cos a - cos outer) / (cos inner - cos outer), 0, 1)`, `a` the angle from the
//! spot's axis; or, for a spot Blender wrote, Blender's ([`shrad_scene::ConeFalloff`]).

mod cache;
#[cfg(test)]
mod tests;

pub use cache::PunctualCache;

use glam::Vec3;
use shrad_scene::{ConeFalloff, Light, LightKind};

/// One punctual light in world space at the current time, in radiometric units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightState {
    /// Point, spot or directional (with the cone angles).
    pub kind: LightKind,
    /// Where a point or spot light is.
    pub position: Vec3,
    /// Unit direction the light travels (the node's -Z); a point light ignores it.
    pub direction: Vec3,
    /// Radiant intensity (W/sr) of a point or spot light, irradiance (W/m^2) of a
    /// directional one, RGB.
    pub strength: Vec3,
    /// Range of a point or spot light (`None`: infinite).
    pub range: Option<f32>,
    /// A spot's falloff between its cones (none for other kinds).
    cone: SpotCone,
}

/// A spot's falloff as a function of `cos a`, `a` the angle from its axis.
#[derive(Clone, Copy, Debug, PartialEq)]
enum SpotCone {
    /// Not a spot: 1 everywhere.
    None,
    /// The extension's `t^2`, `t = clamp((cos a - cos_outer) / (cos_inner - cos_outer))`.
    Gltf { cos_inner: f32, cos_outer: f32 },
    /// Blender's: `smoothstep((cos a - cos_outer) * scale)`, `scale = 1 / ((1 - cos_outer)
    /// blend)` (infinite for a blend of 0: a hard edge).
    Blender { cos_outer: f32, scale: f32 },
}

impl LightState {
    /// `light` under the node transform `world_from_light`; `None` when that transform
    /// collapses what the light needs (a directional or spot light's direction) or is not
    /// finite.
    pub fn new(light: &Light, world_from_light: &glam::Affine3A) -> Option<LightState> {
        let position = Light::position(world_from_light);
        if !position.is_finite() {
            return None;
        }
        let direction = match Light::direction(world_from_light) {
            Some(d) => d,
            None if light.kind == LightKind::Point => -Vec3::Z,
            None => return None,
        };
        let cone = match (light.kind, light.cone_falloff) {
            (
                LightKind::Spot {
                    inner_cone_angle: inner,
                    outer_cone_angle: outer,
                },
                ConeFalloff::Gltf,
            ) => SpotCone::Gltf {
                cos_inner: inner.cos(),
                cos_outer: outer.cos(),
            },
            (
                LightKind::Spot {
                    outer_cone_angle: outer,
                    ..
                },
                ConeFalloff::Blender,
            ) => {
                let blend = light.spot_blend().unwrap_or(0.0);
                let cos_outer = outer.cos();
                SpotCone::Blender {
                    cos_outer,
                    scale: 1.0 / ((1.0 - cos_outer) * blend),
                }
            }
            _ => SpotCone::None,
        };
        Some(LightState {
            kind: light.kind,
            position,
            direction,
            strength: light.radiometric(),
            range: light.range,
            cone,
        })
    }

    /// Is this a directional light (no position, no falloff)?
    pub fn is_directional(&self) -> bool {
        self.kind == LightKind::Directional
    }

    /// Same place, direction, kind and range: shadow rays and geometry still hold (only the
    /// strength may differ).
    pub fn same_geometry(&self, other: &LightState) -> bool {
        self.kind == other.kind
            && self.position == other.position
            && self.direction == other.direction
            && self.range == other.range
    }

    /// The spot's cone falloff for the unit direction `from_light` (1 for other kinds).
    pub fn cone(&self, from_light: Vec3) -> f32 {
        if !matches!(self.kind, LightKind::Spot { .. }) {
            return 1.0;
        }
        self.cone_cos(self.direction.dot(from_light))
    }

    /// The extension's range window at distance `d` (1 without a range).
    pub fn window(&self, d: f32) -> f32 {
        match self.range {
            Some(r) => (1.0 - (d / r).powi(4)).clamp(0.0, 1.0),
            None => 1.0,
        }
    }

    /// Unoccluded irradiance at `x` (unit normal `n`, front side) per unit strength:
    /// `f cos(theta) / d^2` for a point or spot, `cos(theta)` for a directional light. `eps`
    /// bounds `d` below (a light on the surface itself).
    pub fn geometry(&self, x: Vec3, n: Vec3, eps: f32) -> f32 {
        if self.is_directional() {
            return (-n.dot(self.direction)).max(0.0);
        }
        let w = self.position - x;
        let d2 = w.length_squared().max(eps * eps);
        let d = d2.sqrt();
        let to_light = w / d;
        let cos = n.dot(to_light);
        if cos <= 0.0 {
            return 0.0;
        }
        cos * self.cone(-to_light) * self.window(d) / d2
    }

    /// Where the shadow ray from `x` ends: the light, or `far` away towards a directional
    /// light.
    pub fn shadow_end(&self, x: Vec3, far: f32) -> Vec3 {
        if self.is_directional() {
            x - self.direction * far
        } else {
            self.position
        }
    }

    /// Flux the light sends out (W, RGB averaged): `4 pi I` for a point light, the cone's
    /// integral of `I f` for a spot, infinite for a directional light (whose input is what
    /// reaches the patches). For `shrad info` and docs; the energy meter counts what reaches
    /// the patches.
    pub fn emitted_flux(&self) -> f64 {
        let i = self.strength.element_sum() as f64 / 3.0;
        match self.kind {
            LightKind::Point => 4.0 * std::f64::consts::PI * i,
            LightKind::Directional => f64::INFINITY,
            LightKind::Spot { .. } => {
                // Integrate f over the cone numerically (f depends on the angle only).
                let n = 4096;
                let outer = match self.cone {
                    SpotCone::Gltf { cos_outer, .. } | SpotCone::Blender { cos_outer, .. } => {
                        cos_outer
                    }
                    SpotCone::None => -1.0,
                };
                let mut sum = 0.0;
                for k in 0..n {
                    let c = outer + (1.0 - outer) * (k as f32 + 0.5) / n as f32;
                    sum += self.cone_cos(c) as f64;
                }
                2.0 * std::f64::consts::PI * i * sum * (1.0 - outer as f64) / n as f64
            }
        }
    }

    /// The spot falloff at `cos a = c`.
    fn cone_cos(&self, c: f32) -> f32 {
        match self.cone {
            SpotCone::None => 1.0,
            SpotCone::Gltf {
                cos_inner,
                cos_outer,
            } => {
                let t = ((c - cos_outer) / (cos_inner - cos_outer).max(1e-6)).clamp(0.0, 1.0);
                t * t
            }
            SpotCone::Blender { cos_outer, scale } => {
                if c <= cos_outer {
                    return 0.0;
                }
                // (c - cos_outer) * inf is inf for a blend of 0: the full light.
                let x = ((c - cos_outer) * scale).min(1.0);
                x * x * (3.0 - 2.0 * x)
            }
        }
    }
}

/// The scene's lights at time `t` (a light whose transform collapses is `None`: dark).
pub fn states_at(lights: &[Light], t: f32) -> Vec<Option<LightState>> {
    lights
        .iter()
        .map(|l| LightState::new(&l.at(t), &l.world_from_light_at(t)))
        .collect()
}

/// Direct irradiance of each patch of `receivers` (front side) from the world's punctual
/// lights, averaged over each patch's footprint with `samples` shadow rays a light.
pub fn punctual_irradiance(world: &crate::World, receivers: &[u32], samples: u32) -> Vec<Vec3> {
    PunctualCache::new(world, receivers.to_vec(), samples)
        .irradiance()
        .to_vec()
}

/// [`punctual_irradiance`] of every patch (zero where the world has no punctual light).
pub fn punctual_irradiance_all(world: &crate::World, samples: u32) -> Vec<Vec3> {
    let n = world.patches.len();
    if !has_sources(world) {
        return vec![Vec3::ZERO; n];
    }
    let all: Vec<u32> = (0..n as u32).collect();
    punctual_irradiance(world, &all, samples)
}

/// Are there lights without a surface: punctual lights or a sky? (Their direct light is
/// this module's, and [`PunctualCache`] holds the sky's part too.)
pub fn has_sources(world: &crate::World) -> bool {
    !world.lights.is_empty() || world.sky.is_some()
}

/// Exact direct irradiance at the point `x` (unit normal `n`) from every punctual light,
/// with one shadow ray each, plus the sky's sampled ([`crate::sky::point_irradiance`]):
/// what a picture shows per pixel.
pub fn point_irradiance(world: &crate::World, xs: &[Vec3], ns: &[Vec3]) -> Vec<Vec3> {
    let mut out = crate::sky::point_irradiance(world, xs, ns);
    let far = world.far();
    for l in world.lights.iter().flatten() {
        let g: Vec<f32> = xs
            .iter()
            .zip(ns)
            .map(|(&x, &n)| l.geometry(x, n, world.eps))
            .collect();
        let lit: Vec<usize> = (0..xs.len()).filter(|&k| g[k] > 0.0).collect();
        let from: Vec<Vec3> = lit.iter().map(|&k| xs[k] + ns[k] * world.eps).collect();
        let to: Vec<Vec3> = lit.iter().map(|&k| l.shadow_end(xs[k], far)).collect();
        let mut blocked = vec![false; lit.len()];
        world.vis.occluded(&from, &to, world.eps, &[], &mut blocked);
        for (&k, b) in lit.iter().zip(blocked) {
            if !b {
                out[k] += l.strength * g[k];
            }
        }
    }
    out
}
