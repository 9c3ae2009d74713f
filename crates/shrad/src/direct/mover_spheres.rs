//! Where movers were and where they are, as boxes and as spheres about them
//! ([`crate::Patches::world_sphere`]), as every cache of rays takes a move (the light
//! surfaces', the lamps', the sky's shadow rays; the probes' and emitters' cached rays,
//! `dispersive/stale.rs`): a ray a mover changed meets its surface where it was or where it
//! is, so it meets both the box and the sphere there.
//! For a box-like object the sphere adds nothing, but a ball fills only half the rays its
//! box lets through: of the 11.6k shadow rays a frame the 77k room's moving ball's boxes
//! found, 6.4k met its spheres.
//! The caller remembers where each object was (the dispersive solver's Step 1:
//! `DirectSync`); a cache is told the move, and keeps no memory of its own.

use glam::Vec3;
use shrad_scene::Aabb;

pub use super::blocks::Sphere;

/// A box a mover swept, with a sphere about the mover there where it is known.
pub(crate) type SweptBox = (Aabb, Option<Sphere>);

/// Boxes where movers were (or are), padded, each with a sphere about its mover there.
pub(crate) type Bounds = (Vec<Aabb>, Vec<Sphere>);

/// Where movers were and are: their boxes (aligned with the movers) and spheres about them
/// there (aligned with the boxes; `None`, or missing, where not known: then a box's own).
#[derive(Clone, Copy, Debug)]
pub struct Moves<'a> {
    /// Where each mover was.
    pub old: &'a [Aabb],
    /// Where each mover is.
    pub new: &'a [Aabb],
    /// A sphere about each mover where it was.
    pub was: &'a [Option<Sphere>],
    /// A sphere about each mover where it is.
    pub is: &'a [Option<Sphere>],
}

impl<'a> Moves<'a> {
    /// Movers known by their boxes alone.
    pub fn boxes(old: &'a [Aabb], new: &'a [Aabb]) -> Moves<'a> {
        Moves {
            old,
            new,
            was: &[],
            is: &[],
        }
    }
}

/// The boxes movers swept, with a little slack on every side (the empty ones left out: a hit
/// on a mover's surface is within float noise of its box, and a ray that grazes a padded
/// box is only re-traced for nothing), each with the tighter of its padded box's own
/// bounding sphere and its mover's sphere (`spheres`, aligned with `boxes`) padded by as
/// much (a box without one keeps its own). Shared by every cache of shadow rays (the light
/// surfaces', the punctual lights', the sky's).
pub(crate) fn padded_with_spheres(boxes: &[Aabb], spheres: &[Option<Sphere>], eps: f32) -> Bounds {
    (boxes.iter().enumerate())
        .map(|(k, &b)| (b, spheres.get(k).copied().flatten()))
        .filter(|(b, _)| !b.is_empty())
        .map(|swept| {
            let (b, s) = padded(swept, 4.0 * eps + 1e-5 * swept.0.diagonal());
            (b, tighter_sphere(b, s))
        })
        .unzip()
}

/// A swept box and its sphere, each grown by `pad` (a hit on a mover's surface lies on them
/// up to rounding).
pub(crate) fn padded((b, s): SweptBox, pad: f32) -> SweptBox {
    (b.padded(Vec3::splat(pad)), s.map(|(c, r)| (c, r + pad)))
}

/// The tighter of `aabb`'s own bounding sphere and `sphere` (about the mover in it, where
/// known): a ray the mover changed meets both the box and it.
pub(crate) fn tighter_sphere(aabb: Aabb, sphere: Option<Sphere>) -> Sphere {
    let own = aabb.bounding_sphere();
    match sphere {
        Some(s) if s.1 < own.1 => s,
        _ => own,
    }
}

/// Whether the segment `from`-`to` meets the sphere.
pub(crate) fn segment_meets_sphere(from: Vec3, to: Vec3, (c, r): Sphere) -> bool {
    let d = to - from;
    ray_meets_sphere(from, d, d.length_squared(), 1.0, c, r * r)
}

/// Whether the segment `o + s d`, `s` in `[0, t]`, comes within `sqrt(r2)` of `c` (`d2` is
/// `|d|^2`, given by callers that test one ray against many spheres).
#[inline]
pub(crate) fn ray_meets_sphere(o: Vec3, d: Vec3, d2: f32, t: f32, c: Vec3, r2: f32) -> bool {
    let w = c - o;
    let s = match d2 > 0.0 {
        true => (w.dot(d) / d2).clamp(0.0, t),
        false => 0.0,
    };
    (w - d * s).length_squared() <= r2
}

/// One object's move, as tests make and give it: where it was and is, by box and sphere.
#[cfg(test)]
pub(crate) struct OneMove {
    old: [Aabb; 1],
    new: [Aabb; 1],
    was: [Option<Sphere>; 1],
    is: [Option<Sphere>; 1],
}

#[cfg(test)]
impl OneMove {
    /// Slide object `o` of `world` by `step`.
    pub(crate) fn slide(world: &mut crate::World, o: usize, step: Vec3) -> OneMove {
        let p = &world.patches;
        let (old, was) = (p.world_box(o), p.world_sphere(o));
        let m = p.world_from_local[o] * glam::Affine3A::from_mat3(p.local_from_object[o]);
        world
            .move_object(o, glam::Affine3A::from_translation(step) * m)
            .unwrap();
        let p = &world.patches;
        OneMove {
            old: [old],
            new: [p.world_box(o)],
            was: [was],
            is: [p.world_sphere(o)],
        }
    }

    /// The move with its spheres.
    pub(crate) fn with_spheres(&self) -> Moves<'_> {
        Moves {
            old: &self.old,
            new: &self.new,
            was: &self.was,
            is: &self.is,
        }
    }

    /// The move by its boxes alone.
    pub(crate) fn boxes_only(&self) -> Moves<'_> {
        Moves::boxes(&self.old, &self.new)
    }
}
