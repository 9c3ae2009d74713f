//! Finding the shadow rays a mover may have changed, and re-tracing them against the
//! movers first ([`DirectCache::update`]'s two ray-level parts).

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Aabb;

use super::{DirectCache, Retrace, BLOCK};
use crate::direct::blocks::capsule_meets_sphere;
use crate::direct::{cone_meets_sphere, sample_shift, shadow_sample, Emitter};
use crate::World;

impl DirectCache {
    /// The shadow rays (receiver, emitter, sample, from, to) that a mover may have changed:
    /// of the receivers to `find`, those blocked whose segment meets an `old` box, those
    /// free whose segment meets a `new` one (`spheres`: the boxes' bounding spheres).
    pub(super) fn rays_to_retrace(
        &self,
        world: &World,
        ems: &[Emitter],
        (old, new): (&[Aabb], &[Aabb]),
        spheres: &[(Vec3, f32)],
        find: impl Fn(usize) -> bool + Sync,
    ) -> Vec<Retrace> {
        let ne = ems.len();
        let samples = self.shadows.samples();
        let p = &world.patches;
        let eps = world.eps;
        let (old_q, new_q) = (self.ends.pad(old), self.ends.pad(new));
        // Whole blocks of receivers first: those whose rays to every emitter pass far from
        // every swept box.
        let block_may_meet = |b: usize| {
            let (oc, or) = self.blocks[b];
            ems.iter().any(|em| {
                let (lc, lr) = em.sphere;
                spheres
                    .iter()
                    .any(|&(bc, br)| capsule_meets_sphere(oc, or, lc, lr, bc, br))
            })
        };
        let n = self.receivers.len();
        // One vector of rays a block (not one a receiver: 2.5k small vectors a frame at 77k).
        (0..self.blocks.len())
            .into_par_iter()
            .filter(|&b| block_may_meet(b))
            .flat_map_iter(|b| {
                let mut out = Vec::new();
                for k in (b * BLOCK..((b + 1) * BLOCK).min(n)).filter(|&k| find(k)) {
                    let i = self.receivers[k] as usize;
                    let (x, n) = (p.centre[i], p.normal[i]);
                    for (e, em) in ems.iter().enumerate() {
                        if self.unoccluded[k * ne + e] <= 0.0 {
                            continue;
                        }
                        // Every shadow ray lies in the cone from x to the emitter's sphere.
                        let (lc, lr) = em.sphere;
                        if !spheres
                            .iter()
                            .any(|&(bc, br)| cone_meets_sphere(x, lc, lr, bc, br))
                        {
                            continue;
                        }
                        let shift = sample_shift(i, em);
                        let set = k * ne + e;
                        let first = set * samples as usize;
                        let from = x + n * eps;
                        // 64 samples at a time: the blocked ones against the old boxes, the
                        // free ones against the new, by their stored ends (a superset); the
                        // exact sample of each found is re-traced (a ray re-traced that no
                        // box meets is traced for nothing, never wrong).
                        for j0 in (0..samples).step_by(64) {
                            let m = (samples - j0).min(64);
                            let blocked = self.shadows.blocked_bits(set, j0, m);
                            let at = first + j0 as usize;
                            let meets = |boxes: &[Aabb], padded: &[Aabb], want: u64| {
                                if boxes.is_empty() || want == 0 {
                                    return 0;
                                }
                                match self.ends.meeting(at, m as usize, from, padded) {
                                    Some(mask) => mask & want,
                                    None => (0..m)
                                        .filter(|&j| want >> j & 1 != 0)
                                        .filter(|&j| {
                                            let (f, t, _) = shadow_sample(
                                                em,
                                                x,
                                                n,
                                                shift,
                                                j0 + j,
                                                samples,
                                                eps,
                                            );
                                            boxes.iter().any(|b| b.meets_segment(f, t))
                                        })
                                        .fold(0, |mask, j| mask | 1 << j),
                                }
                            };
                            let all = u64::MAX >> (64 - m);
                            let mut found =
                                meets(old, &old_q, blocked) | meets(new, &new_q, !blocked & all);
                            while found != 0 {
                                let j = j0 + found.trailing_zeros();
                                found &= found - 1;
                                let (from, to, _) = shadow_sample(em, x, n, shift, j, samples, eps);
                                out.push((k as u32, e as u32, j, from, to));
                            }
                        }
                    }
                }
                out.into_iter()
            })
            .collect()
    }

    /// Trace `rays` (receiver, emitter, sample, from, to) against the `movers` alone, then
    /// against the whole scene those that were blocked and the movers no longer block (a
    /// free ray can only have been blocked by a mover). Returns whether each is blocked.
    pub(super) fn trace_movers_first(
        &self,
        world: &World,
        movers: &[u32],
        rays: &[(u32, u32, u32, Vec3, Vec3)],
        ne: usize,
    ) -> Vec<bool> {
        let eps = world.eps;
        let from: Vec<Vec3> = rays.iter().map(|r| r.3).collect();
        let to: Vec<Vec3> = rays.iter().map(|r| r.4).collect();
        let mut blocked = vec![false; rays.len()];
        world
            .vis
            .occluded_among(&from, &to, eps, movers, &mut blocked);
        // Blocked before, and the movers no longer block it: something else may.
        let again: Vec<usize> = (0..rays.len())
            .filter(|&r| {
                let (k, e, j, ..) = rays[r];
                !blocked[r] && self.shadows.is_blocked(k as usize * ne + e as usize, j)
            })
            .collect();
        if !again.is_empty() {
            let from: Vec<Vec3> = again.iter().map(|&r| rays[r].3).collect();
            let to: Vec<Vec3> = again.iter().map(|&r| rays[r].4).collect();
            let mut b = vec![false; again.len()];
            world.vis.occluded(&from, &to, eps, &[], &mut b);
            for (&r, b) in again.iter().zip(b) {
                blocked[r] = b;
            }
        }
        blocked
    }
}
