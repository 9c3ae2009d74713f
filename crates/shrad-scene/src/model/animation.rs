//! Keyframed rigid motion and emission changes (the scene file's `[[object.keys]]`).

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

/// Keyframed rigid animation: translation interpolated linearly, rotation by slerp; before
/// the first key and after the last the end keys hold.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Animation {
    /// Keys sorted by time.
    pub keys: Vec<Keyframe>,
    /// Emission keys sorted by time (empty: the material's emission holds).
    pub emission: Vec<EmissionKey>,
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
        let first = self.emission.first()?;
        let last = self.emission.last()?;
        if t <= first.time {
            return Some(first.emitted_radiance);
        }
        if t >= last.time {
            return Some(last.emitted_radiance);
        }
        let i = self.emission.partition_point(|k| k.time <= t);
        let (a, b) = (self.emission[i - 1], self.emission[i]);
        if self.step {
            return Some(a.emitted_radiance);
        }
        let s = (t - a.time) / (b.time - a.time).max(f32::MIN_POSITIVE);
        Some(a.emitted_radiance.lerp(b.emitted_radiance, s))
    }

    /// Time of the last key (0 for a static object).
    pub fn duration(&self) -> f32 {
        let k = self.keys.last().map_or(0.0, |k| k.time);
        let e = self.emission.last().map_or(0.0, |k| k.time);
        k.max(e)
    }
}
