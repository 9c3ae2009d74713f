//! The values of a channel's keys as tracks take them: vectors, scales that never collapse
//! a surface, rotations normalised and sign-continuous.

use glam::{Quat, Vec3};

use super::Sampler;
use crate::Interpolation;

/// Output elements per key: 3 for CUBICSPLINE (in-tangent, value, out-tangent), else 1.
pub(super) fn keys_per_value(sampler: &Sampler) -> usize {
    if sampler.interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    }
}

pub(super) fn vec3s(values: &[f32]) -> Vec<Vec3> {
    values.chunks_exact(3).map(Vec3::from_slice).collect()
}

/// RGBA values (or tangents) as their RGB.
pub(super) fn rgbs(values: &[f32]) -> Vec<Vec3> {
    values.chunks_exact(4).map(Vec3::from_slice).collect()
}

/// Scale values with a component under 1e-4 raised to it (keeping the sign); whether any
/// was. Tangents may be zero; only values must not collapse a surface.
pub(super) fn raise_collapsed_scales(v: &mut [Vec3], per_key: usize) -> bool {
    let mut raised = false;
    for (e, s) in v.iter_mut().enumerate() {
        let is_value = per_key == 1 || e % 3 == 1;
        if is_value && s.abs().min_element() < 1e-4 {
            raised = true;
            *s = Vec3::select(
                s.abs().cmplt(Vec3::splat(1e-4)),
                Vec3::splat(1e-4).copysign(*s),
                *s,
            );
        }
    }
    raised
}

/// Rotation keys as quaternions: values normalised (a zero one is an error naming the key
/// of accessor `output`), cubic-spline keys made sign-continuous.
pub(super) fn rotations(
    values: &[f32],
    per_key: usize,
    sh: &str,
    output: usize,
) -> Result<Vec<Quat>, String> {
    let mut v = Vec::with_capacity(values.len() / 4);
    for (e, q) in values.chunks_exact(4).enumerate() {
        let q = Quat::from_slice(q);
        let is_value = per_key == 1 || e % 3 == 1;
        if !is_value {
            v.push(q);
        } else if q.length() < 1e-6 {
            return Err(format!(
                "{sh}: rotation key {} of accessor {output} is a zero quaternion",
                e / per_key
            ));
        } else {
            v.push(q.normalize());
        }
    }
    if per_key == 3 {
        hemisphere_continuous(&mut v);
    }
    Ok(v)
}

/// Cubic-spline rotation keys (in-tangent, value, out-tangent per key) made sign-continuous:
/// a key whose value lies in the other hemisphere from the one before (q and -q are the
/// same rotation) is negated with its tangents. Blender's exporter writes such keys with
/// tangents that point to the continuous sign (a box turning 90 -> 200 deg about Z keyed at
/// (0, .71, 0, .71) then (.03, -.97, .17, .17), out-tangent towards the negated one); taken
/// literally the spline cuts through the origin of quaternion space, a half-turn off
/// Blender's pose between the keys. A file already continuous is unchanged; LINEAR keys
/// need nothing (slerp takes the short way, as the specification says).
pub(super) fn hemisphere_continuous(keys: &mut [Quat]) {
    for k in 1..keys.len() / 3 {
        if keys[3 * k + 1].dot(keys[3 * k - 2]) < 0.0 {
            for q in &mut keys[3 * k..3 * k + 3] {
                *q = -*q;
            }
        }
    }
}
