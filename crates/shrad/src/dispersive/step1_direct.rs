//! Step 1 of the frame (paper 2.3.2, "计算光源对边界的直接光照"): direct light from the
//! lights on the boundary, and on interior patches when `direct_on_interior` (the paper
//! leaves those to the probes). With it, the frame's bookkeeping of what changed: which
//! objects a mover disturbed (for the scheduler) and the boxes the movers swept.
//!
//! The paper recomputes direct light every frame. Here it is cached and recomputed only for
//! the patches whose view of a light a mover may have changed: a patch is re-lit when the
//! cone from it to a light's bounding sphere meets a swept box's sphere (conservative), or
//! everywhere when a light moved or changed.

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::{Aabb, Role};

use super::{Changes, Dispersive};
use crate::direct::direct_irradiance;
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

    /// Boxes swept by the objects that moved since the last frame (old and new positions),
    /// as bounding spheres; updates the remembered boxes.
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
    /// `direct_on_interior`). The paper recomputes it every frame; here it is cached and
    /// recomputed only for the patches whose view of a light an object's motion may have
    /// changed (all of them when a light moved or changed).
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
        let everything = !self.direct_valid || light_changed;
        let lights: Vec<(Vec3, f32)> = if everything {
            Vec::new()
        } else {
            (0..world.scene.objects.len())
                .filter(|&o| {
                    !p.range(o).is_empty() && world.exitance[p.range(o).start].max_element() > 0.0
                })
                .map(|o| world_box(world, o).bounding_sphere())
                .collect()
        };
        let movers: Vec<(Vec3, f32)> = swept.iter().map(Aabb::bounding_sphere).collect();
        let receivers: Vec<u32> = (0..p.len() as u32)
            .into_par_iter()
            .filter(|&i| match p.role(i as usize) {
                Role::Boundary | Role::Light => true,
                Role::Interior => self.options.direct_on_interior,
            })
            .filter(|&i| world.reflectance[i as usize].max_element() > 0.0)
            .filter(|&i| {
                everything || {
                    let x = p.centre[i as usize];
                    lights.iter().any(|&(lc, lr)| {
                        movers
                            .iter()
                            .any(|&(bc, br)| cone_meets_sphere(x, lc, lr, bc, br))
                    })
                }
            })
            .collect();
        // Interior patches of a moved object always need it (they moved).
        let mut receivers = receivers;
        if !everything && self.options.direct_on_interior {
            for &o in &changes.moved {
                receivers.extend(p.range(o).map(|i| i as u32));
            }
            receivers.sort_unstable();
            receivers.dedup();
        }
        let e = direct_irradiance(world, &receivers, self.options.direct_samples);
        for (&i, e) in receivers.iter().zip(e) {
            self.direct[i as usize] = e;
        }
        self.direct_valid = true;
    }
}

/// World bounding box of object `o` (its rest-frame mesh box, transformed).
pub(super) fn world_box(world: &World, o: usize) -> Aabb {
    match world.patches.shapes[o].bounds() {
        Some(local) => Aabb::from(local).transformed(world.patches.world_from_local[o]),
        None => Aabb::new(Vec3::ZERO, Vec3::ZERO),
    }
}

/// Does the cone from `x` to the sphere `(lc, lr)` (a light) meet the sphere `(bc, br)`?
/// Conservative: the cone is widened linearly from 0 at `x` to `lr` at the light.
fn cone_meets_sphere(x: Vec3, lc: Vec3, lr: f32, bc: Vec3, br: f32) -> bool {
    let axis = lc - x;
    let len2 = axis.length_squared().max(1e-30);
    let s = ((bc - x).dot(axis) / len2).clamp(0.0, 1.0);
    let closest = x + axis * s;
    (bc - closest).length() <= br + lr * s * 1.1 + 1e-6
}
