//! Lights that are not surfaces: glTF's `KHR_lights_punctual` point, spot and directional
//! lights (spec section 2, "Lights that are not surfaces").
//!
//! A [`Light`] keeps the extension's photometric units as the file gave them (candela for
//! point and spot, lux for directional, times `color`) and converts to shrad's radiometric
//! units with [`LUMENS_PER_WATT`], as Blender's glTF importer and exporter do in their
//! standard lighting mode: a Blender point lamp of `P` W exports as `P * 683 / (4 pi)` cd,
//! a radiant intensity of `P / (4 pi)` W/sr, which is what Cycles gives that lamp.
//!
//! A light shines along its node's local -Z and follows the node's transform (scale ignored
//! but for its effect on position and orientation, as the extension says) and animation.

use glam::{Affine3A, Vec3};

/// The luminous efficacy used to turn lumens into watts (the 555 nm maximum, as Blender's
/// glTF exporter uses in its standard mode).
pub const LUMENS_PER_WATT: f32 = 683.0;

/// What kind of punctual light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Emits equally in every direction from a point; intensity in candela.
    Point,
    /// A point light restricted to a cone about its -Z axis; intensity in candela inside the
    /// inner cone, falling off smoothly to 0 at the outer cone (angles from the axis, radians).
    Spot {
        /// Where the falloff begins, in [0, outer).
        inner_cone_angle: f32,
        /// Where the light ends, in (inner, pi/2].
        outer_cone_angle: f32,
    },
    /// Infinitely far, shining along -Z; intensity is illuminance in lux.
    Directional,
}

impl LightKind {
    /// "point", "spot" or "directional", as in glTF.
    pub fn name(&self) -> &'static str {
        match self {
            LightKind::Point => "point",
            LightKind::Spot { .. } => "spot",
            LightKind::Directional => "directional",
        }
    }
}

/// How a spot's light falls off between its inner and outer cones.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ConeFalloff {
    /// The extension's recommended `t^2`, `t = clamp((cos a - cos outer) / (cos inner -
    /// cos outer), 0, 1)`.
    #[default]
    Gltf,
    /// Blender's (Cycles' `spot_attenuation`): `smoothstep((cos a - cos outer) / ((1 - cos
    /// outer) b))` with the spot's blend `b = 1 - inner / outer`, as Blender's exporter
    /// writes a blend into the inner angle and its importer reads it back. A blend of 0
    /// (equal cones) is a hard edge. What a spot in a file Blender wrote means: with the
    /// extension's falloff, Blender 5's spot of blend 0.3 lit a room 26 % less than Cycles
    /// does (docs/results.md §6, "An eighth pass").
    Blender,
}

/// One punctual light.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Name (from the file, or generated).
    pub name: String,
    /// Point, spot or directional.
    pub kind: LightKind,
    /// Linear RGB colour (glTF `color`, default white).
    pub color: Vec3,
    /// Photometric intensity as the extension defines it: candela (point, spot) or lux
    /// (directional).
    pub intensity: f32,
    /// Distance beyond which a point or spot light is ignored (`None`: infinite); the
    /// falloff is windowed by `max(min(1 - (d / range)^4, 1), 0)` as the extension
    /// recommends.
    pub range: Option<f32>,
    /// The node's transform at rest: the light sits at its origin and shines along its -Z.
    pub world_from_light: Affine3A,
    /// Motion of the glTF node holding the light, if it or an ancestor is animated.
    pub node_animation: Option<crate::NodeAnimation>,
    /// Its animated colour, intensity, range or cone angles (`KHR_animation_pointer`).
    pub tracks: Option<crate::LightTracks>,
    /// A spot's falloff between its cones (the extension's, unless Blender wrote the file
    /// or the scene file gives a `blend`).
    pub cone_falloff: ConeFalloff,
}

impl Light {
    /// A white light of `kind` with photometric `intensity`, at the origin shining along -Z.
    pub fn new(name: impl Into<String>, kind: LightKind, intensity: f32) -> Light {
        Light {
            name: name.into(),
            kind,
            color: Vec3::ONE,
            intensity,
            range: None,
            world_from_light: Affine3A::IDENTITY,
            node_animation: None,
            tracks: None,
            cone_falloff: ConeFalloff::Gltf,
        }
    }

    /// A spot's blend as Blender has it, `1 - inner / outer` in [0, 1] (how Blender's
    /// importer reads it back from the cones); `None` for other kinds.
    pub fn spot_blend(&self) -> Option<f32> {
        match self.kind {
            LightKind::Spot {
                inner_cone_angle: inner,
                outer_cone_angle: outer,
            } => Some((1.0 - inner / outer.max(f32::MIN_POSITIVE)).clamp(0.0, 1.0)),
            _ => None,
        }
    }

    /// The radiometric strength, RGB: radiant intensity in W/sr (point, spot) or irradiance
    /// in W/m^2 (directional), `color * intensity / 683`.
    pub fn radiometric(&self) -> Vec3 {
        self.color * (self.intensity / LUMENS_PER_WATT)
    }

    /// The node transform at time `t` (the animation's, else the rest one).
    pub fn world_from_light_at(&self, t: f32) -> Affine3A {
        self.node_animation
            .as_ref()
            .map_or(self.world_from_light, |n| n.world_from_object_at(t))
    }

    /// Where the light is under `world_from_light` (meaningless for a directional light).
    pub fn position(world_from_light: &Affine3A) -> Vec3 {
        world_from_light.translation.into()
    }

    /// The unit direction the light travels along under `world_from_light`: the node's -Z
    /// (scale and shear affect only the orientation). `None` when the transform collapses it.
    pub fn direction(world_from_light: &Affine3A) -> Option<Vec3> {
        let d = world_from_light.transform_vector3(-Vec3::Z);
        let len = d.length();
        (len.is_finite() && len > 1e-12).then(|| d / len)
    }

    /// Why this light's values are not usable, if they are not: a negative or non-finite
    /// intensity or colour, a range that is not positive, cone angles out of order or beyond
    /// pi/2, a transform that is not finite.
    pub fn problem(&self) -> Option<String> {
        if !(self.intensity.is_finite() && self.intensity >= 0.0) {
            return Some(format!(
                "intensity {} must be finite and >= 0",
                self.intensity
            ));
        }
        if !self.color.is_finite() || self.color.min_element() < 0.0 {
            return Some(format!("color {} must be finite and >= 0", self.color));
        }
        let most = crate::MAX_RADIANCE * LUMENS_PER_WATT;
        if self.intensity * self.color.max_element() > most {
            return Some(format!(
                "intensity {:.3e} (x colour {}) is beyond the {most:.1e} (cd or lux) a solve can hold",
                self.intensity, self.color
            ));
        }
        if let Some(r) = self.range {
            if !(r.is_finite() && r > 0.0) {
                return Some(format!("range {r} must be > 0"));
            }
        }
        if let LightKind::Spot {
            inner_cone_angle: inner,
            outer_cone_angle: outer,
        } = self.kind
        {
            // In degrees, as a scene file writes them (a glTF file's radians are checked,
            // by their own names, where it is read: `gltf_io/lights.rs`). Up to four
            // decimals, trimmed: 30 deg read back from radians is 30.000002, and 90.0001 deg
            // must not read "90 deg is beyond 90 deg".
            let deg = |a: f32| {
                let text = format!("{:.4}", a.to_degrees());
                text.trim_end_matches('0').trim_end_matches('.').to_string()
            };
            let (i, o) = (deg(inner), deg(outer));
            if !(inner.is_finite() && outer.is_finite()) {
                return Some(format!(
                    "the cone angles must be finite (inner {i} deg, outer {o} deg)"
                ));
            }
            // The outer angle first: it is the one given (a blend derives the inner from it).
            if outer <= 0.0 {
                return Some(format!(
                    "the outer cone angle {o} deg must be > 0 (a spot of no cone lights nothing)"
                ));
            }
            if outer > std::f32::consts::FRAC_PI_2 * (1.0 + 1e-6) {
                return Some(format!(
                    "the outer cone angle {o} deg is beyond 90 deg (a spot light lights at most a hemisphere)"
                ));
            }
            if inner < 0.0 {
                return Some(format!("the inner cone angle {i} deg must be >= 0"));
            }
            // Blender's blend of 0 gives equal cones: a hard edge, not a fault.
            let equal_allowed = self.cone_falloff == ConeFalloff::Blender && inner == outer;
            if inner >= outer && !equal_allowed {
                return Some(format!(
                    "the inner cone angle {i} deg must be less than the outer {o} deg"
                ));
            }
        }
        let m = self.world_from_light;
        if !(m.matrix3.is_finite() && m.translation.is_finite()) {
            return Some("its transform is not finite".into());
        }
        if self.kind != LightKind::Point && Light::direction(&m).is_none() {
            return Some("its transform collapses its direction (-Z)".into());
        }
        // As an object's coordinates (`MAX_COORDINATE`): a lamp at 1e13 loaded and lit the
        // floor 100 times too dimly (its irradiance below f32's normal numbers).
        let p = Light::position(&m);
        if self.kind != LightKind::Directional && p.abs().max_element() > crate::MAX_COORDINATE {
            return Some(format!(
                "its position {p} is beyond the {:.0e} that 32-bit arithmetic of distances can hold",
                crate::MAX_COORDINATE
            ));
        }
        None
    }

    /// The light's colour, intensity, range and cone angles at time `t`: its tracks'
    /// values (kept valid, see [`crate::LightTracks::apply`]), else its own. The place is
    /// [`Light::world_from_light_at`]'s.
    pub fn at(&self, t: f32) -> Light {
        match &self.tracks {
            Some(tracks) => tracks.apply(self, t),
            None => self.clone(),
        }
    }

    /// Does anything about the light change over time?
    pub fn is_animated(&self) -> bool {
        self.node_animation.is_some() || self.tracks.as_ref().is_some_and(|k| !k.is_empty())
    }

    /// Time of the last key of the node animation or the property tracks (0 for a static
    /// light).
    pub fn duration(&self) -> f32 {
        let node = self
            .node_animation
            .as_ref()
            .map_or(0.0, crate::NodeAnimation::duration);
        node.max(self.tracks.as_ref().map_or(0.0, crate::LightTracks::end))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f32::consts::PI;

    #[test]
    fn a_blender_lamp_of_p_watts_has_p_over_4pi_watts_per_steradian() {
        // Blender's exporter writes a point lamp of P W as P * 683 / (4 pi) cd.
        let p = 100.0;
        let l = Light::new("lamp", LightKind::Point, p * LUMENS_PER_WATT / (4.0 * PI));
        let i = l.radiometric();
        assert!(
            (i - Vec3::splat(p / (4.0 * PI))).abs().max_element() < 1e-4,
            "{i}"
        );
    }

    #[test]
    fn bad_values_are_named() {
        let mut l = Light::new("l", LightKind::Point, -1.0);
        assert!(l.problem().unwrap().contains("intensity"));
        l.intensity = 1.0;
        assert!(l.problem().is_none());
        l.range = Some(0.0);
        assert!(l.problem().unwrap().contains("range"));
        l.range = None;
        l.kind = LightKind::Spot {
            inner_cone_angle: 0.5,
            outer_cone_angle: 0.5,
        };
        assert!(l.problem().unwrap().contains("must be less than the outer"));
        l.kind = LightKind::Spot {
            inner_cone_angle: 0.5,
            outer_cone_angle: 2.0,
        };
        assert!(l.problem().unwrap().contains("beyond 90 deg"));
        l.kind = LightKind::Directional;
        l.world_from_light = Affine3A::from_scale(Vec3::ZERO);
        assert!(l.problem().unwrap().contains("direction"));
    }

    #[test]
    fn a_light_shines_along_its_nodes_minus_z() {
        let m = Affine3A::from_rotation_x(-PI / 2.0) * Affine3A::from_scale(Vec3::splat(3.0));
        let d = Light::direction(&m).unwrap();
        assert!((d - -Vec3::Y).length() < 1e-6, "{d}");
    }
}
