//! An object definition's rest transform and keyframed animation.

use glam::{Affine3A, Mat4, Quat, Vec3};

use super::{KeyInterpolation, ObjectDef, Scale};
use crate::{Animation, EmissionKey, Keyframe, ReflectanceKey};

/// Rotation from `rotation_deg` (about X, then Y, then Z, world axes: R = Rz Ry Rx) or
/// `rotation_quat` (`[x, y, z, w]`, normalised).
pub(super) fn rotation(deg: Option<[f32; 3]>, quat: Option<[f32; 4]>) -> Result<Quat, String> {
    match (deg, quat) {
        (Some(_), Some(_)) => Err("give rotation_deg or rotation_quat, not both".into()),
        (Some([x, y, z]), None) => {
            if ![x, y, z].iter().all(|v| v.is_finite()) {
                return Err("rotation_deg must be finite".into());
            }
            Ok(Quat::from_rotation_z(z.to_radians())
                * Quat::from_rotation_y(y.to_radians())
                * Quat::from_rotation_x(x.to_radians()))
        }
        (None, Some(q)) => {
            let q = Quat::from_array(q);
            let len = q.length();
            if !(len.is_finite() && len > 1e-6) {
                return Err(
                    "rotation_quat must be a finite non-zero quaternion [x, y, z, w]".into(),
                );
            }
            Ok(q / len)
        }
        (None, None) => Ok(Quat::IDENTITY),
    }
}

pub(super) fn finite3(v: [f32; 3], what: &str) -> Result<Vec3, String> {
    let v = Vec3::from(v);
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("{what} must be finite"))
    }
}

/// `world_from_object` at rest: `transform`, or `position`, rotation and `scale`.
pub(super) fn rest_transform(o: &ObjectDef) -> Result<Affine3A, String> {
    if let Some(rows) = o.transform {
        let parts = [
            ("position", o.position.is_some()),
            ("rotation_deg", o.rotation_deg.is_some()),
            ("rotation_quat", o.rotation_quat.is_some()),
            ("scale", o.scale.is_some()),
        ];
        if let Some((key, _)) = parts.iter().find(|(_, given)| *given) {
            return Err(format!("give 'transform' or '{key}', not both"));
        }
        return affine_from_rows(rows);
    }
    let position = finite3(o.position.unwrap_or([0.0; 3]), "position")?;
    let rot = rotation(o.rotation_deg, o.rotation_quat)?;
    let scale = match o.scale {
        None => Vec3::ONE,
        Some(Scale::Uniform(s)) => Vec3::splat(s),
        Some(Scale::Axes(s)) => Vec3::from(s),
    };
    // A negative factor mirrors, as a glTF node's or a `transform`'s may (the patches keep
    // their front faces: `shrad::patches`); zero would flatten the object.
    if !(scale.is_finite() && scale.abs().min_element() > 0.0) {
        return Err(format!(
            "scale {scale} must be finite and non-zero on every axis (a negative factor mirrors)"
        ));
    }
    Ok(Affine3A::from_scale_rotation_translation(
        scale, rot, position,
    ))
}

/// A 4x4 matrix given row by row, which must be affine.
fn affine_from_rows(rows: [[f32; 4]; 4]) -> Result<Affine3A, String> {
    if rows[3] != [0.0, 0.0, 0.0, 1.0] {
        return Err(format!(
            "'transform' must be affine (last row [0, 0, 0, 1]), got last row {:?}",
            rows[3]
        ));
    }
    if !rows.iter().flatten().all(|v| v.is_finite()) {
        return Err("'transform' must be finite".into());
    }
    Ok(Affine3A::from_mat4(
        Mat4::from_cols_array_2d(&rows).transpose(),
    ))
}

/// The object's keyframed motion, emission and reflectance, sorted by time; `None`
/// without keys.
pub(super) fn animation(o: &ObjectDef) -> Result<Option<Animation>, String> {
    if o.key.is_empty() && o.emission_key.is_empty() && o.reflectance_key.is_empty() {
        if o.interpolation.is_some() {
            return Err(
                "'interpolation' given without any [[object.key]], [[object.emission_key]] or [[object.reflectance_key]]"
                    .into(),
            );
        }
        return Ok(None);
    }
    let mut keys = Vec::with_capacity(o.key.len());
    for (k, key) in o.key.iter().enumerate() {
        let at = |m: String| format!("key {k}: {m}");
        if !key.time.is_finite() {
            return Err(at("time must be finite".into()));
        }
        keys.push(Keyframe {
            time: key.time,
            translation: finite3(key.translation.unwrap_or([0.0; 3]), "translation").map_err(at)?,
            rotation: rotation(key.rotation_deg, key.rotation_quat).map_err(at)?,
        });
    }
    let mut emission = Vec::with_capacity(o.emission_key.len());
    for (k, key) in o.emission_key.iter().enumerate() {
        let at = |m: String| format!("emission_key {k}: {m}");
        let e = finite3(key.emission, "emission").map_err(at)?;
        if !key.time.is_finite() || e.min_element() < 0.0 {
            return Err(at("time must be finite and emission >= 0".into()));
        }
        emission.push(EmissionKey {
            time: key.time,
            emitted_radiance: e,
        });
    }
    let mut reflectance = Vec::with_capacity(o.reflectance_key.len());
    for (k, key) in o.reflectance_key.iter().enumerate() {
        let at = |m: String| format!("reflectance_key {k}: {m}");
        let r = finite3(key.reflectance, "reflectance").map_err(at)?;
        if !key.time.is_finite() || r.min_element() < 0.0 || r.max_element() > 1.0 {
            return Err(at(
                "time must be finite and reflectance within [0, 1]".into()
            ));
        }
        reflectance.push(ReflectanceKey {
            time: key.time,
            reflectance: r,
        });
    }
    keys.sort_by(|a, b| a.time.total_cmp(&b.time));
    emission.sort_by(|a, b| a.time.total_cmp(&b.time));
    reflectance.sort_by(|a, b| a.time.total_cmp(&b.time));
    // The object's own `emission` (or `reflectance`) beside keys that start after time 0 is
    // its value at time 0, a key there: a lamp of `emission = [10, 10, 10]` with one key at
    // 2 s shone the key's colour from the start, its own emission silently ignored.
    if let (Some(e), Some(first)) = (o.emission, emission.first()) {
        if first.time > 0.0 {
            let emitted_radiance = Vec3::from(e);
            emission.insert(
                0,
                EmissionKey {
                    time: 0.0,
                    emitted_radiance,
                },
            );
        }
    }
    if let (Some(r), Some(first)) = (o.reflectance, reflectance.first()) {
        if first.time > 0.0 {
            let reflectance_at_0 = Vec3::from(r).min(Vec3::ONE);
            reflectance.insert(
                0,
                ReflectanceKey {
                    time: 0.0,
                    reflectance: reflectance_at_0,
                },
            );
        }
    }
    Ok(Some(Animation {
        keys,
        emission,
        reflectance,
        step: o.interpolation == Some(KeyInterpolation::Step),
    }))
}
