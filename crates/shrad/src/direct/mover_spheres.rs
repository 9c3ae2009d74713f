//! Where each object was at a cache of rays' last update (the light surfaces', the lamps',
//! the sky's shadow rays; the probes' and emitters' cached rays, `dispersive/stale.rs`), as a
//! sphere about it ([`crate::Patches::world_sphere`]) beside its box: a ray a mover changed
//! meets its surface where it was or where it is, so it meets both the box and the sphere
//! there.
//! For a box-like object the sphere adds nothing, but a ball fills only half the rays its
//! box lets through: of the 11.6k shadow rays a frame the 77k room's moving ball's boxes
//! found, 6.4k met its spheres.

use glam::Vec3;
use shrad_scene::Aabb;

use crate::World;

pub(crate) use super::blocks::Sphere;

/// A box a mover swept, with a sphere about the mover there where it is known.
pub(crate) type SweptBox = (Aabb, Option<Sphere>);

/// Boxes where movers were (or are), padded, each with a sphere about its mover there.
pub(crate) type Bounds = (Vec<Aabb>, Vec<Sphere>);

/// Where movers were and are: their boxes (as the caller has them, aligned with the movers)
/// and spheres about them (`None` where not known: then a box's own).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Moves<'a> {
    pub(crate) old: &'a [Aabb],
    pub(crate) new: &'a [Aabb],
    pub(crate) was: &'a [Option<Sphere>],
    pub(crate) is: &'a [Option<Sphere>],
}

/// Per object, the box and sphere where the cache last saw it (`None` for a shape without
/// vertices).
#[derive(Clone, Debug, Default)]
pub(crate) struct MoverSpheres(Vec<Option<(Aabb, Sphere)>>);

impl MoverSpheres {
    /// Every object of `world` where it is now.
    pub(crate) fn new(world: &World) -> MoverSpheres {
        let p = &world.patches;
        MoverSpheres(
            (0..p.object_role.len())
                .map(|o| Some((p.world_box(o), p.world_sphere(o)?)))
                .collect(),
        )
    }

    /// `movers` moved from the boxes `old`: their spheres there and where they are now,
    /// each `None` where the box the cache last saw the mover at is not that `old` box (the
    /// caller's idea of where it was is not the cache's: only its boxes are then trusted).
    /// Remembers where they are.
    pub(crate) fn moved(
        &mut self,
        world: &World,
        movers: &[u32],
        old: &[Aabb],
    ) -> (Vec<Option<Sphere>>, Vec<Option<Sphere>>) {
        let p = &world.patches;
        (movers.iter().zip(old))
            .map(|(&o, old)| {
                let o = o as usize;
                let now = p.world_sphere(o).map(|s| (p.world_box(o), s));
                let Some(memory) = self.0.get_mut(o) else {
                    return (None, None);
                };
                let was = std::mem::replace(memory, now);
                match was {
                    Some((b, s)) if b == *old => (Some(s), now.map(|n| n.1)),
                    _ => (None, None),
                }
            })
            .unzip()
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
        .map(|(k, b)| (b, spheres.get(k).copied().flatten()))
        .filter(|(b, _)| !b.is_empty())
        .map(|(b, s)| {
            let pad = 4.0 * eps + 1e-5 * b.diagonal();
            let padded = b.padded(Vec3::splat(pad));
            let own = padded.bounding_sphere();
            let sphere = match s {
                Some((c, r)) if r + pad < own.1 => (c, r + pad),
                _ => own,
            };
            (padded, sphere)
        })
        .unzip()
}

/// Whether the segment `from`-`to` meets the sphere.
pub(crate) fn segment_meets_sphere(from: Vec3, to: Vec3, (c, r): Sphere) -> bool {
    let d = to - from;
    let d2 = d.length_squared();
    let s = match d2 > 0.0 {
        true => ((c - from).dot(d) / d2).clamp(0.0, 1.0),
        false => 0.0,
    };
    (from + d * s - c).length_squared() <= r * r
}
