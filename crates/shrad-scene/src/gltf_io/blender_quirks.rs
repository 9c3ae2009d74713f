//! What Blender's glTF exporter (5.0) writes otherwise than the specification says, and
//! how shrad reads it, in files whose `asset.generator` names Blender. Each is recognised
//! by what the file itself holds, not by a version, so that a file from a Blender that gets
//! it right is read as written; each correction is said in a warning naming the light.
//!
//! Both are in the lamps' `KHR_animation_pointer` keys (Blender's "Animation Pointer"
//! export; `tests/data/blender/animated_lights.py` builds such a file):
//! - a point or spot lamp's keyed power is written as `P * 683`, where its static export
//!   writes the extension's candela, `P * 683 / (4 pi)`: taken as written the lamp is 4 pi
//!   times too bright while it is animated. Recognised by a key at 4 pi times the light's
//!   static intensity and none at the static intensity itself (the exporter writes the
//!   static light as it is at the frame it exports at, which is one of the keys' frames);
//! - a spot's keyed blend is written as its inner cone angle's keys, the blend's values
//!   themselves (its cache computes the angle and then exports the raw value). Recognised
//!   by a key at the static light's blend, `1 - inner / outer`, and none at its inner
//!   angle; read as the blend (`LightTracks::blend`).

use crate::{Interpolation, Light, LightKind, LightTracks, Track};

/// Whether `track` has a key (a value, not a cubic spline's tangent) within 1e-3 of `target`.
fn has_key(track: &Track<f32>, target: f32) -> bool {
    let step = match track.interpolation {
        Interpolation::CubicSpline => 3,
        _ => 1,
    };
    (track.values.iter().skip(step / 2).step_by(step))
        .any(|&k| (k - target).abs() <= 1e-3 * target.abs().max(1e-3))
}

/// Blender's keyed point and spot intensities and spot blends read as Blender means them
/// (see the module's notes) in a file Blender wrote (`generator`); `tracks[l]` goes with
/// `lights[l]`.
pub(super) fn animated_lights(
    tracks: &mut [LightTracks],
    lights: &[Option<Light>],
    generator: Option<&str>,
    warnings: &mut Vec<String>,
) {
    if !generator.is_some_and(|g| g.contains("Blender")) {
        return;
    }
    for (tracks, light) in tracks.iter_mut().zip(lights) {
        let Some(light) = light else { continue };
        intensity(tracks, light, warnings);
        blend(tracks, light, warnings);
    }
}

fn intensity(tracks: &mut LightTracks, light: &Light, warnings: &mut Vec<String>) {
    let four_pi = 4.0 * std::f32::consts::PI;
    let Some(track) = tracks.intensity.as_mut() else {
        return;
    };
    if light.kind == LightKind::Directional
        || !has_key(track, four_pi * light.intensity)
        || has_key(track, light.intensity)
    {
        return;
    }
    track.values.iter_mut().for_each(|v| *v /= four_pi);
    warnings.push(format!(
        "light '{}': its intensity keys are 4 pi times its intensity (Blender's exporter writes a lamp's animated power without the 1 / (4 pi) of its static export): read divided by 4 pi",
        light.name
    ));
}

fn blend(tracks: &mut LightTracks, light: &Light, warnings: &mut Vec<String>) {
    let LightKind::Spot {
        inner_cone_angle: inner,
        outer_cone_angle: outer,
    } = light.kind
    else {
        return;
    };
    let Some(track) = tracks.inner_cone_angle.as_ref() else {
        return;
    };
    if !has_key(track, 1.0 - inner / outer) || has_key(track, inner) {
        return;
    }
    tracks.blend = tracks.inner_cone_angle.take();
    warnings.push(format!(
        "light '{}': its innerConeAngle keys are Blender's spot blend, not angles (Blender's exporter writes the blend's values): read as the blend, the inner angle the outer one times 1 - blend",
        light.name
    ));
}

#[cfg(test)]
mod tests {
    use super::*;

    fn keys(values: &[f32]) -> Track<f32> {
        Track {
            times: (0..values.len()).map(|k| k as f32).collect(),
            values: values.to_vec(),
            interpolation: Interpolation::Linear,
        }
    }

    fn spot() -> Light {
        let kind = LightKind::Spot {
            inner_cone_angle: 0.36,
            outer_cone_angle: 0.4,
        };
        Light::new("spot", kind, 100.0)
    }

    fn read(tracks: LightTracks, generator: &str) -> (LightTracks, Vec<String>) {
        let mut t = [tracks];
        let mut warnings = Vec::new();
        animated_lights(&mut t, &[Some(spot())], Some(generator), &mut warnings);
        let [t] = t;
        (t, warnings)
    }

    #[test]
    fn blenders_units_are_recognised_and_a_right_file_is_read_as_written() {
        let four_pi = 4.0 * std::f32::consts::PI;
        let blenders = LightTracks {
            intensity: Some(keys(&[100.0 * four_pi, 300.0 * four_pi])),
            inner_cone_angle: Some(keys(&[0.1, 0.3])),
            ..Default::default()
        };
        let (t, warnings) = read(blenders.clone(), "Khronos glTF Blender I/O v5.0.21");
        assert_eq!(warnings.len(), 2, "{warnings:?}");
        assert!((t.intensity.as_ref().unwrap().values[1] - 300.0).abs() < 1e-3);
        assert!(t.inner_cone_angle.is_none() && t.blend.is_some());
        let LightKind::Spot {
            inner_cone_angle, ..
        } = t.apply(&spot(), 1.0).kind
        else {
            panic!()
        };
        assert!((inner_cone_angle - 0.4 * 0.7).abs() < 1e-6);
        // Another exporter's file, or Blender's with the keys right, is read as written.
        let (t, warnings) = read(blenders.clone(), "three.js GLTFExporter");
        assert!(warnings.is_empty() && t == blenders);
        let right = LightTracks {
            intensity: Some(keys(&[100.0, 300.0])),
            inner_cone_angle: Some(keys(&[0.36, 0.2])),
            ..Default::default()
        };
        let (t, warnings) = read(right.clone(), "Khronos glTF Blender I/O v9");
        assert!(warnings.is_empty() && t == right);
    }
}
