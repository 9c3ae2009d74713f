//! Keyframed rigid motion, emission and reflectance changes (the scene file's
//! `[[object.key]]`, `[[object.emission_key]]` and `[[object.reflectance_key]]`).

use glam::{Quat, Vec3};

/// One key of a rigid animation: the motion applied on top of the rest transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    /// Time in seconds.
    pub time: f32,
    /// Translation added to the object's rest position (world units).
    pub translation: Vec3,
    /// Rotation about the centre of the object's rest bounding box (world axes).
    pub rotation: Quat,
}

/// A key of an emission change (lights switching colour or intensity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionKey {
    /// Time in seconds.
    pub time: f32,
    /// Emitted radiance `L_e` from this time on (interpolated linearly to the next key).
    pub emitted_radiance: Vec3,
}

/// A key of a reflectance change (a surface painted another colour).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReflectanceKey {
    /// Time in seconds.
    pub time: f32,
    /// Reflectance factor from this time on (interpolated linearly to the next key; the
    /// base-colour texture and vertex colours multiply it).
    pub reflectance: Vec3,
}

/// Keyframed rigid animation: translation interpolated linearly, rotation by slerp; before
/// the first key and after the last the end keys hold.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    /// Keys sorted by time.
    pub keys: Vec<Keyframe>,
    /// Emission keys sorted by time (empty: the material's emission holds).
    pub emission: Vec<EmissionKey>,
    /// Reflectance keys sorted by time (empty: the material's reflectance holds).
    pub reflectance: Vec<ReflectanceKey>,
    /// Step (hold each key until the next) instead of linear / slerp interpolation.
    pub step: bool,
}

impl Animation {
    /// `(translation, rotation)` at time `t`.
    pub fn motion_at(&self, t: f32) -> (Vec3, Quat) {
        let (Some(first), Some(last)) = (self.keys.first(), self.keys.last()) else {
            return (Vec3::ZERO, Quat::IDENTITY);
        };
        if t <= first.time {
            return (first.translation, first.rotation);
        }
        if t >= last.time {
            return (last.translation, last.rotation);
        }
        let i = self.keys.partition_point(|k| k.time <= t);
        let (a, b) = (self.keys[i - 1], self.keys[i]);
        if self.step {
            return (a.translation, a.rotation);
        }
        let s = (t - a.time) / (b.time - a.time).max(f32::MIN_POSITIVE);
        (
            a.translation.lerp(b.translation, s),
            a.rotation.slerp(b.rotation, s),
        )
    }

    /// Emitted radiance at time `t`, or `None` when the animation does not change it.
    pub fn emission_at(&self, t: f32) -> Option<Vec3> {
        colour_at(
            &self.emission,
            |k| (k.time, k.emitted_radiance),
            self.step,
            t,
        )
    }

    /// Reflectance factor at time `t`, or `None` when the animation does not change it.
    pub fn reflectance_at(&self, t: f32) -> Option<Vec3> {
        colour_at(&self.reflectance, |k| (k.time, k.reflectance), self.step, t)
    }

    /// Time of the last key (0 for a static object).
    pub fn duration(&self) -> f32 {
        let k = self.keys.last().map_or(0.0, |k| k.time);
        let e = self.emission.last().map_or(0.0, |k| k.time);
        let r = self.reflectance.last().map_or(0.0, |k| k.time);
        k.max(e).max(r)
    }
}

/// The value at time `t` of colour keys sorted by time (`key`: a key's time and value): the
/// end keys hold before the first and after the last, each key holds until the next when
/// `step`, else linear in between; `None` without keys.
fn colour_at<K>(keys: &[K], key: impl Fn(&K) -> (f32, Vec3), step: bool, t: f32) -> Option<Vec3> {
    let (first, last) = (key(keys.first()?), key(keys.last()?));
    if t <= first.0 {
        return Some(first.1);
    }
    if t >= last.0 {
        return Some(last.1);
    }
    let i = keys.partition_point(|k| key(k).0 <= t);
    let (a, b) = (key(&keys[i - 1]), key(&keys[i]));
    if step {
        return Some(a.1);
    }
    let s = (t - a.0) / (b.0 - a.0).max(f32::MIN_POSITIVE);
    Some(a.1.lerp(b.1, s))
}
