//! Animated properties that are not transforms: a punctual light's colour, intensity, range
//! and cone angles, and a material's emission, as glTF's `KHR_animation_pointer` animates
//! them (Blender's exporter writes a lamp's keyed power, colour and spot size, and a
//! material's keyed emission strength, this way). A camera's keyed field of view is one
//! track of its own (`Scene::camera_yfov`).
//!
//! Each property is a [`Track`] of its own (the sampler's interpolation, cubic splines
//! included); a property without a track keeps its value at rest. The values a track
//! gives are kept valid when they are read (a cubic spline may overshoot below zero
//! between keys that are not): colours, intensities and strengths at least 0, a range
//! above 0, a spot's cone angles in order within a hemisphere.

use glam::Vec3;

use crate::{Light, LightKind, Track};

/// The animated properties of one punctual light (`None`: the value at rest holds).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightTracks {
    /// Linear RGB colour (`/extensions/KHR_lights_punctual/lights/{}/color`).
    pub color: Option<Track<Vec3>>,
    /// Photometric intensity, candela or lux (`.../intensity`).
    pub intensity: Option<Track<f32>>,
    /// Range (`.../range`).
    pub range: Option<Track<f32>>,
    /// A spot's inner cone angle, radians (`.../spot/innerConeAngle`).
    pub inner_cone_angle: Option<Track<f32>>,
    /// A spot's outer cone angle, radians (`.../spot/outerConeAngle`).
    pub outer_cone_angle: Option<Track<f32>>,
    /// A spot's blend as Blender has it, in place of `inner_cone_angle`: the inner angle is
    /// the outer one times `1 - blend`. Blender's exporter (5.0) writes its spot blend's keys
    /// as the inner cone angle's (see the glTF reader's `blender_quirks`).
    pub blend: Option<Track<f32>>,
}

impl LightTracks {
    /// Whether no property is animated.
    pub fn is_empty(&self) -> bool {
        self.color.is_none()
            && self.intensity.is_none()
            && self.range.is_none()
            && self.inner_cone_angle.is_none()
            && self.outer_cone_angle.is_none()
            && self.blend.is_none()
    }

    /// Time of the last key of any track.
    pub fn end(&self) -> f32 {
        let scalars = [
            &self.intensity,
            &self.range,
            &self.inner_cone_angle,
            &self.outer_cone_angle,
            &self.blend,
        ];
        let color = self.color.as_ref().map_or(0.0, Track::end);
        scalars
            .into_iter()
            .flatten()
            .map(Track::end)
            .fold(color, f32::max)
    }

    /// `light` with its animated properties at time `t`, kept valid (see the module's
    /// notes): the result never fails [`Light::problem`] for what the tracks set.
    pub fn apply(&self, light: &Light, t: f32) -> Light {
        let mut out = light.clone();
        if let Some(c) = &self.color {
            out.color = c.sample(t).max(Vec3::ZERO);
        }
        if let Some(i) = &self.intensity {
            out.intensity = i.sample(t).max(0.0);
        }
        if let (Some(r), Some(_)) = (&self.range, out.range) {
            out.range = Some(r.sample(t).max(f32::MIN_POSITIVE));
        }
        if let LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } = light.kind
        {
            let at = |track: &Option<Track<f32>>, rest: f32| {
                track.as_ref().map_or(rest, |k| k.sample(t))
            };
            let half_pi = std::f32::consts::FRAC_PI_2;
            let outer = at(&self.outer_cone_angle, outer_cone_angle).clamp(1e-4, half_pi);
            let inner = match &self.blend {
                Some(blend) => outer * (1.0 - blend.sample(t)),
                None => at(&self.inner_cone_angle, inner_cone_angle),
            };
            let inner = inner.clamp(0.0, outer * (1.0 - 1e-4));
            out.kind = LightKind::Spot {
                inner_cone_angle: inner,
                outer_cone_angle: outer,
            };
        }
        out
    }
}

/// A material's animated properties: its emission, emitted radiance `factor * strength`
/// (glTF's `emissiveFactor` times `KHR_materials_emissive_strength`), each the track's value
/// at a time or, without a track, its value at rest; and its base colour (the reflectance
/// factor, `baseColorFactor`'s RGB).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MaterialTracks {
    /// `emissiveFactor` at rest.
    pub rest_factor: Vec3,
    /// `emissiveStrength` at rest (1 without the extension).
    pub rest_strength: f32,
    /// `/materials/{}/emissiveFactor`.
    pub factor: Option<Track<Vec3>>,
    /// `/materials/{}/extensions/KHR_materials_emissive_strength/emissiveStrength`.
    pub strength: Option<Track<f32>>,
    /// `/materials/{}/pbrMetallicRoughness/baseColorFactor` (its RGB; alpha changes nothing
    /// diffuse).
    pub base_color: Option<Track<Vec3>>,
}

impl MaterialTracks {
    /// Emitted radiance at time `t` (at least 0).
    pub fn emitted_radiance_at(&self, t: f32) -> Vec3 {
        let factor = self
            .factor
            .as_ref()
            .map_or(self.rest_factor, |f| f.sample(t));
        let strength = self
            .strength
            .as_ref()
            .map_or(self.rest_strength, |s| s.sample(t));
        (factor * strength).max(Vec3::ZERO)
    }

    /// The reflectance factor at time `t`, within `[0, MAX_REFLECTANCE]` (a cubic's
    /// overshoot, or a key of 1, kept a reflectance that conserves energy); `None` without a
    /// track.
    pub fn reflectance_at(&self, t: f32) -> Option<Vec3> {
        let f = self.base_color.as_ref()?.sample(t);
        Some(f.clamp(Vec3::ZERO, Vec3::splat(super::material::MAX_REFLECTANCE)))
    }

    /// Time of the last key of any track.
    pub fn end(&self) -> f32 {
        let f = self.factor.as_ref().map_or(0.0, Track::end);
        let s = self.strength.as_ref().map_or(0.0, Track::end);
        let b = self.base_color.as_ref().map_or(0.0, Track::end);
        f.max(s).max(b)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Interpolation;

    fn linear<T>(times: &[f32], values: Vec<T>) -> Track<T> {
        Track {
            times: times.to_vec(),
            values,
            interpolation: Interpolation::Linear,
        }
    }

    #[test]
    fn a_light_takes_its_tracks_values_and_keeps_the_rest() {
        let mut light = Light::new("lamp", LightKind::Point, 100.0);
        light.color = Vec3::new(1.0, 0.5, 0.25);
        let tracks = LightTracks {
            intensity: Some(linear(&[0.0, 2.0], vec![100.0, 300.0])),
            ..Default::default()
        };
        let at = tracks.apply(&light, 1.0);
        assert_eq!(at.intensity, 200.0);
        assert_eq!(at.color, light.color);
        assert_eq!(tracks.end(), 2.0);
        assert!(at.problem().is_none());
    }

    #[test]
    fn a_spot_whose_cone_tracks_cross_stays_valid() {
        let mut light = Light::new(
            "spot",
            LightKind::Spot {
                inner_cone_angle: 0.2,
                outer_cone_angle: 0.4,
            },
            10.0,
        );
        light.range = Some(5.0);
        // The inner angle passes the outer one, and a cubic spline dips below zero.
        let tracks = LightTracks {
            inner_cone_angle: Some(linear(&[0.0, 1.0], vec![0.2, 0.8])),
            outer_cone_angle: Some(linear(&[0.0, 1.0], vec![0.4, 3.0])),
            intensity: Some(Track {
                times: vec![0.0, 1.0],
                values: vec![0.0, 1.0, -50.0, 50.0, 1.0, 0.0],
                interpolation: Interpolation::CubicSpline,
            }),
            range: Some(linear(&[0.0, 1.0], vec![5.0, -1.0])),
            ..Default::default()
        };
        for t in [0.0, 0.3, 0.6, 1.0] {
            let l = tracks.apply(&light, t);
            assert!(l.problem().is_none(), "t {t}: {:?}", l.problem());
        }
        let LightKind::Spot {
            outer_cone_angle, ..
        } = tracks.apply(&light, 1.0).kind
        else {
            panic!("a spot stays a spot");
        };
        assert_eq!(outer_cone_angle, std::f32::consts::FRAC_PI_2);
    }

    #[test]
    fn emission_is_factor_times_strength_each_from_its_track_or_rest() {
        let e = MaterialTracks {
            rest_factor: Vec3::new(1.0, 0.5, 0.0),
            rest_strength: 2.0,
            factor: None,
            strength: Some(linear(&[1.0, 3.0], vec![1.0, 5.0])),
            base_color: None,
        };
        assert_eq!(e.emitted_radiance_at(0.0), Vec3::new(1.0, 0.5, 0.0));
        assert_eq!(e.emitted_radiance_at(2.0), Vec3::new(3.0, 1.5, 0.0));
        assert_eq!(e.end(), 3.0);
        // Before its first key a track holds that key's value, not the value at rest.
        let f = MaterialTracks {
            factor: Some(linear(&[0.0, 1.0], vec![Vec3::ONE, Vec3::ZERO])),
            ..e
        };
        assert_eq!(f.emitted_radiance_at(0.5), Vec3::splat(0.5));
        let g = MaterialTracks {
            strength: None,
            ..f
        };
        assert_eq!(g.emitted_radiance_at(0.5), Vec3::splat(0.5) * 2.0);
    }

    #[test]
    fn the_base_colour_is_kept_a_reflectance_and_its_keys_count_in_the_end() {
        let none = MaterialTracks::default();
        assert_eq!(none.reflectance_at(1.0), None);
        // Keys of -0.5 and 2 (a cubic's overshoot would give such values too).
        let keyed = MaterialTracks {
            base_color: Some(linear(
                &[0.0, 4.0],
                vec![Vec3::splat(-0.5), Vec3::splat(2.0)],
            )),
            ..none
        };
        assert_eq!(keyed.reflectance_at(0.0), Some(Vec3::ZERO));
        assert_eq!(keyed.reflectance_at(1.0), Some(Vec3::splat(0.125)));
        let top = crate::MAX_REFLECTANCE;
        assert_eq!(keyed.reflectance_at(4.0), Some(Vec3::splat(top)));
        assert_eq!(keyed.end(), 4.0);
    }
}
