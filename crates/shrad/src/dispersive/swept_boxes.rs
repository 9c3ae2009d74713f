//! The boxes swept since an object's caches were last checked (`stale.rs`), tested against
//! a cached ray as a two-level hierarchy.
//!
//! An object is checked when it is next updated, against every box swept since its last
//! check: one or two boxes in a room of a few objects, but up to [`super::stale`]'s log cap
//! in a room of many, where an object waits many frames for its turn. Tested box by box,
//! every cached ray paid for every box: in a 40k room of 128 objects with one box dragged,
//! checking one object's Step 3 rays grew from 0.1 ms to 1.3 ms a frame over 64 frames of
//! the drag, as the boxes since its check grew to 34. Consecutive frames of a drag sweep
//! boxes that lie together, so the boxes are grouped by [`GROUP`] in the order they were
//! swept, and a ray is tested against a group's union before its members: most rays miss
//! every group, and cost a test per group rather than per box.

use std::ops::Range;

use glam::Vec3;
use shrad_scene::Aabb;

use crate::direct::mover_spheres::{ray_meets_sphere, tighter_sphere, Sphere, SweptBox};

/// Boxes per group; with no more boxes than this there is one level.
const GROUP: usize = 8;

/// A box a mover swept with a sphere that holds the mover there (the box's own, or the
/// tighter one about the mover: `direct/mover_spheres.rs`), for a quick rejection before
/// the slab test: a ray the mover changed meets both.
#[derive(Clone, Copy, Debug)]
struct Bound {
    aabb: Aabb,
    /// Centre, radius and radius squared of the sphere.
    centre: Vec3,
    r: f32,
    r2: f32,
}

impl Bound {
    /// `aabb` with the tighter of its bounding sphere and `sphere` (about its mover).
    fn new(aabb: Aabb, sphere: Option<Sphere>) -> Self {
        let (centre, r) = tighter_sphere(aabb, sphere);
        Bound {
            aabb,
            centre,
            r,
            r2: r * r,
        }
    }

    /// Whether the segment `o + s d`, `s` in `[0, t]`, meets the box (`d2` is `|d|^2`).
    fn meets(&self, o: Vec3, d: Vec3, d2: f32, t: f32) -> bool {
        ray_meets_sphere(o, d, d2, t, self.centre, self.r2) && self.aabb.meets_ray_within(o, d, t)
    }
}

/// Boxes swept since a check, grouped for the ray test (see the module's notes).
pub(super) struct SweptBoxes {
    boxes: Vec<Bound>,
    /// The groups' unions and their members (ranges of `boxes`); empty when there are at
    /// most [`GROUP`] boxes.
    groups: Vec<(Bound, Range<usize>)>,
}

impl SweptBoxes {
    /// The boxes in the order they were swept, each with a sphere about its mover where it
    /// is known.
    pub(super) fn new(boxes: &[SweptBox]) -> Self {
        let groups = match boxes.len() > GROUP {
            false => Vec::new(),
            true => (0..boxes.len())
                .step_by(GROUP)
                .map(|start| {
                    let members = start..(start + GROUP).min(boxes.len());
                    let union = boxes[members.clone()]
                        .iter()
                        .fold(Aabb::EMPTY, |u, b| u.union(b.0));
                    (Bound::new(union, None), members)
                })
                .collect(),
        };
        SweptBoxes {
            boxes: (boxes.iter()).map(|&(b, s)| Bound::new(b, s)).collect(),
            groups,
        }
    }

    /// The boxes, one by one.
    pub(super) fn boxes(&self) -> impl Iterator<Item = &Aabb> + '_ {
        self.boxes.iter().map(|b| &b.aabb)
    }

    /// Spheres (centre, radius) that hold every mover where it swept, for the chunks' cones
    /// (`caches.rs`): the boxes' (each the tighter of its own and its mover's), or the
    /// groups' when there are groups, fewer and looser.
    pub(super) fn spheres(&self) -> Vec<(Vec3, f32)> {
        match self.groups.is_empty() {
            true => (self.boxes.iter()).map(|b| (b.centre, b.r)).collect(),
            false => (self.groups.iter())
                .map(|(g, _)| g.aabb.bounding_sphere())
                .collect(),
        }
    }

    /// Whether the segment from `o` along `d` for `t` (in units of `d`) meets a box.
    pub(super) fn meet(&self, o: Vec3, d: Vec3, t: f32) -> bool {
        let d2 = d.length_squared().max(1e-30);
        let any_of =
            |members: Range<usize>| self.boxes[members].iter().any(|b| b.meets(o, d, d2, t));
        match self.groups.is_empty() {
            true => any_of(0..self.boxes.len()),
            false => (self.groups.iter())
                .any(|(g, members)| g.meets(o, d, d2, t) && any_of(members.clone())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::test_rng;

    /// Grouped or not, a segment meets the boxes exactly when it meets one of them.
    #[test]
    fn grouped_test_equals_box_by_box() {
        let mut rng = test_rng(7);
        let mut point = |scale: f32| Vec3::new(rng(), rng(), rng()) * scale;
        for count in [1, 3, GROUP, GROUP + 1, 40] {
            // A drag: boxes along a path, as a mover sweeps them.
            let boxes: Vec<Aabb> = (0..count)
                .map(|k| {
                    let at = Vec3::new(k as f32 * 0.05, 0.3, 0.4) + point(0.02);
                    Aabb::new(at, at + Vec3::splat(0.1) + point(0.05))
                })
                .collect();
            let with: Vec<SweptBox> = boxes.iter().map(|&b| (b, None)).collect();
            let swept = SweptBoxes::new(&with);
            assert_eq!(swept.groups.is_empty(), count <= GROUP);
            let (mut met, mut missed) = (0, 0);
            for _ in 0..4000 {
                // Segments from anywhere towards somewhere near the path, some short of it.
                let o = point(3.0) - Vec3::splat(1.0);
                let near = Vec3::new(count as f32 * 0.05 * point(1.0).x, 0.3, 0.4) + point(0.3);
                let (d, t) = (near - o, point(1.5).x);
                let want = boxes.iter().any(|b| b.meets_ray_within(o, d, t));
                assert_eq!(swept.meet(o, d, t), want, "{count} boxes, {o} {d} {t}");
                match want {
                    true => met += 1,
                    false => missed += 1,
                }
            }
            assert!(
                met > 50 && missed > 50,
                "{count}: {met} met, {missed} missed"
            );
            // Every box lies in one of the spheres the cones are tested against.
            let spheres = swept.spheres();
            for b in &boxes {
                let corners = (0..8).map(|k| {
                    Vec3::select(
                        glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0),
                        b.max,
                        b.min,
                    )
                });
                let inside =
                    |&(c, r): &(Vec3, f32)| corners.clone().all(|x| (x - c).length() <= r * 1.0001);
                assert!(spheres.iter().any(inside), "{b:?} outside every sphere");
            }
        }
    }
}
