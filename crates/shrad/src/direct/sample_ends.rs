//! Where each cached shadow ray ends, quantised: finding the rays a mover's box meets is
//! then a slab test per ray, not a regenerated sample ([`super::cache::DirectCache`]).

use glam::Vec3;
use shrad_scene::Aabb;

use crate::World;

/// `[(k * emitters + e) * samples + j]`: the end of shadow ray `j` of receiver `k` towards
/// emitter `e` (a point on the emitter), quantised to 16 bits an axis in `space` (6 bytes a
/// ray; 7 MB at the 77k room). Finding the rays a mover's box meets then costs a slab test
/// per ray against the box padded by the quantisation step (a superset: each ray found is
/// regenerated and tested exactly before it is re-traced). Left empty above
/// [`SampleEnds::MAX_RAYS`] rays, where the samples are regenerated instead.
#[derive(Clone, Debug, Default)]
pub(super) struct SampleEnds {
    space: Option<Aabb>,
    pub(super) end: Vec<[u16; 3]>,
}

impl SampleEnds {
    /// At most this many rays' ends are kept (192 MB; the 1M room's 16M rays take 96 MB).
    pub(super) const MAX_RAYS: usize = 1 << 25;

    pub(super) fn new(world: &World, rays: usize) -> SampleEnds {
        let space = world.scene.bounds().filter(|_| rays <= Self::MAX_RAYS);
        let space = space.map(|b| b.padded(Vec3::splat(1e-3) + 0.01 * b.size()));
        SampleEnds {
            end: vec![[0; 3]; if space.is_some() { rays } else { 0 }],
            space,
        }
    }

    /// Quantisation step, per axis.
    pub(super) fn step(space: &Aabb) -> Vec3 {
        space.size().max(Vec3::splat(1e-6)) / 65535.0
    }

    pub(super) fn put(&mut self, at: usize, p: Vec3) {
        if let Some(space) = &self.space {
            if !space.contains(p) {
                // An end outside (an emitter beyond the scene's bounds): keep none.
                *self = SampleEnds::default();
                return;
            }
            let q = ((p - space.min) / Self::step(space)).round();
            let q = q.clamp(Vec3::ZERO, Vec3::splat(65535.0));
            self.end[at] = [q.x as u16, q.y as u16, q.z as u16];
        }
    }

    pub(super) fn get(&self, at: usize) -> Option<Vec3> {
        let space = self.space.as_ref()?;
        let e = self.end[at];
        Some(space.min + Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32) * Self::step(space))
    }

    /// `boxes` padded by the quantisation step: a segment to a stored end misses them only
    /// if the segment to the exact end misses the boxes unpadded.
    pub(super) fn pad(&self, boxes: &[Aabb]) -> Vec<Aabb> {
        let q = self.space.as_ref().map_or(Vec3::ZERO, Self::step);
        boxes.iter().map(|b| b.padded(q)).collect()
    }
}
