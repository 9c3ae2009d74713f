//! Step 1 of the frame (paper 2.3.2, "计算光源对边界的直接光照"): direct light from the
//! lights on the boundary, and on interior patches when `direct_on_interior` (the paper
//! leaves those to the probes). With it, the frame's bookkeeping of what changed: which
//! objects a mover disturbed (for the scheduler) and the boxes the movers swept.
//!
//! The paper recomputes direct light every frame. Here it is cached with its shadow rays
//! ([`DirectCache`]) and only the shadow rays a mover may have changed are re-traced: a
//! blocked ray whose segment meets a mover's old box, a free one whose segment meets its new
//! box (receivers whose cone to a light misses every box are skipped at once). The result is
//! what a full recomputation with the same samples gives. Everything is recomputed when a
//! light moved or changed.

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::{Aabb, Role};

use super::setup::world_box;
use super::{Changes, Dispersive};
use crate::direct::DirectCache;
use crate::World;

impl Dispersive {
    /// Mark objects near what moved (or every object, when a light changed) as disturbed.
    pub(super) fn note_changes(&mut self, world: &World, changes: &Changes) {
        let p = &world.patches;
        let lights_changed = changes
            .relit
            .iter()
            .chain(&changes.moved)
            .any(|&o| p.object_role[o] == Role::Light);
        let boxes: Vec<(Vec3, f32)> = changes
            .moved
            .iter()
            .filter_map(|&o| {
                let r = p.range(o);
                let pts = r.map(|i| p.centre[i]);
                let (lo, hi) = pts.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), c| {
                    (a.min(c), b.max(c))
                });
                lo.is_finite()
                    .then(|| (0.5 * (lo + hi), 0.5 * (hi - lo).length()))
            })
            .collect();
        for (k, ob) in self.objects.iter_mut().enumerate() {
            if changes.moved.contains(&ob.object) {
                self.scheduler.disturb(k, 4.0);
                // Its surroundings changed: probes go back to the corners and are re-checked.
                ob.probe_scale = [1.0; 8];
                ob.openness.clear();
                continue;
            }
            if lights_changed {
                self.scheduler.disturb(k, 2.0);
            }
            let m = p.world_from_local[ob.object];
            let c = m.transform_point3(ob.centre_local());
            let r = 0.5 * m.transform_vector3(ob.probe_box.size()).length();
            // A neighbour: within three times the two radii.
            if boxes
                .iter()
                .any(|(bc, br)| (c - *bc).length() < 3.0 * (r + br))
            {
                self.scheduler.disturb(k, 2.0);
                ob.openness.clear();
            }
        }
    }

    /// Boxes swept by the objects that moved since the last frame: for each, in order, its
    /// old box then its new one. Updates the remembered boxes.
    pub(super) fn swept_boxes(&mut self, world: &World, changes: &Changes) -> Vec<Aabb> {
        let mut swept = Vec::new();
        for &o in &changes.moved {
            let old = self.object_boxes[o];
            let new = world_box(world, o);
            swept.push(old);
            swept.push(new);
            self.object_boxes[o] = new;
        }
        swept
    }

    /// Step 1 (paper 2.3.2): direct light on the boundary (and interior patches when
    /// `direct_on_interior`). The paper recomputes it every frame; here it is cached with its
    /// shadow rays ([`DirectCache`]): when only occluders moved, only the shadow rays that
    /// meet a box they swept are re-traced (exactly what a full recomputation would give),
    /// and everything is recomputed when a light moved or changed.
    pub(super) fn direct_to_boundary(&mut self, world: &World, changes: &Changes, swept: &[Aabb]) {
        if self.direct_valid && changes.moved.is_empty() && changes.relit.is_empty() {
            return;
        }
        let p = &world.patches;
        let light_changed = !changes.relit.is_empty()
            || changes.moved.iter().any(|&o| {
                p.object_role[o] == Role::Light
                    || world.exitance[p.range(o).start].max_element() > 0.0
            });
        let everything = !self.direct_valid
            || light_changed
            || self.direct_cache.samples() != self.options.direct_samples.max(1)
            || !self.direct_cache.same_emitters(world);
        if everything {
            let receivers: Vec<u32> = (0..p.len() as u32)
                .into_par_iter()
                .filter(|&i| match p.role(i as usize) {
                    Role::Boundary | Role::Light => true,
                    Role::Interior => self.options.direct_on_interior,
                })
                .filter(|&i| world.reflectance[i as usize].max_element() > 0.0)
                .collect();
            self.direct_cache = DirectCache::new(world, receivers, self.options.direct_samples);
            for (&i, &e) in self
                .direct_cache
                .receivers()
                .iter()
                .zip(self.direct_cache.irradiance())
            {
                self.direct[i as usize] = e;
            }
        } else {
            // Patches of a moved object moved themselves: recomputed whole.
            let moved: Vec<usize> = changes.moved.clone();
            // `swept` holds each mover's old box then its new one.
            let old: Vec<Aabb> = swept.iter().step_by(2).copied().collect();
            let new: Vec<Aabb> = swept.iter().skip(1).step_by(2).copied().collect();
            let changed = self.direct_cache.update(world, &old, &new, |i| {
                moved.contains(&(p.object[i as usize] as usize))
            });
            let (receivers, e) = (
                self.direct_cache.receivers(),
                self.direct_cache.irradiance(),
            );
            for k in changed {
                self.direct[receivers[k] as usize] = e[k];
            }
        }
        self.direct_valid = true;
    }
}
