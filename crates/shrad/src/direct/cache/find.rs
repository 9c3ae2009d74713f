//! Finding the shadow rays a mover may have changed, and re-tracing them against the
//! movers first ([`DirectCache::update`]'s two ray-level parts).

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Aabb;

use super::{DirectCache, Retraces, BLOCK, GROUP};
use crate::direct::blocks::capsule_meets_sphere;
use crate::direct::mover_spheres::{
    padded_with_spheres, segment_meets_sphere, Bounds, Moves, Sphere,
};
use crate::direct::{sample_shift, shadow_segment, Cone, Emitter};
use crate::World;

/// The boxes movers swept, as [`DirectCache::rays_to_retrace`] tests shadow rays against
/// them: where they were (`old`, which may have unblocked a blocked ray) and where they are
/// (`new`, which may block a free one), each also padded for the stored ends' rounding
/// (`*_q`), with a sphere about each mover there (`old_spheres`, `new_spheres`: the tighter
/// of its box's and its own, `mover_spheres.rs`) and all of them (`spheres`) for the
/// receivers' cones.
struct Swept<'a> {
    old: &'a [Aabb],
    new: &'a [Aabb],
    old_q: Vec<Aabb>,
    new_q: Vec<Aabb>,
    old_spheres: &'a [Sphere],
    new_spheres: &'a [Sphere],
    spheres: Vec<Sphere>,
}

impl Swept<'_> {
    /// Where the movers were and where they are: each as (boxes, padded boxes).
    fn sets(&self) -> [(&[Aabb], &[Aabb]); 2] {
        [(self.old, &self.old_q), (self.new, &self.new_q)]
    }

    /// Whether a ray found by the boxes (`blocked`: by where the movers were) meets one of
    /// the movers' spheres there too; else no mover can have changed it.
    fn meets_a_sphere(&self, blocked: bool, (from, to): (Vec3, Vec3)) -> bool {
        let spheres = if blocked {
            self.old_spheres
        } else {
            self.new_spheres
        };
        (spheres.iter()).any(|&s| segment_meets_sphere(from, to, s))
    }
}

impl DirectCache {
    /// The moves whose shadow rays this update finds (`RecentMoves::since_last_turn`):
    /// the objects, and the boxes they left and went to, padded, each with a sphere about
    /// the mover there (`moves`' spheres where this update's moves are `moves` alone; a
    /// box's own where they are unions of several, found in turn).
    pub(super) fn swept_since_last_turn(
        &mut self,
        world: &World,
        movers: &[u32],
        moves: Moves,
        turns: usize,
    ) -> (Vec<u32>, [Bounds; 2]) {
        let (all_movers, left, now) =
            (self.recent_moves).since_last_turn(movers, (moves.old, moves.new), turns);
        let (was, is) = match all_movers.len() == movers.len() && turns == 1 {
            true => (moves.was, moves.is),
            false => (&[][..], &[][..]),
        };
        let eps = world.eps;
        let swept = [
            padded_with_spheres(&left, was, eps),
            padded_with_spheres(&now, is, eps),
        ];
        (all_movers, swept)
    }

    /// The shadow rays (receiver, emitter, sample, from, to) that a mover may have changed:
    /// of the receivers to `find`, those blocked whose segment meets an `old` box and a
    /// sphere about a mover there, those free whose segment meets a `new` one and a sphere
    /// (`spheres`: old and new, aligned with the boxes).
    pub(super) fn rays_to_retrace(
        &self,
        world: &World,
        ems: &[Emitter],
        (old, new): (&[Aabb], &[Aabb]),
        (old_spheres, new_spheres): (&[Sphere], &[Sphere]),
        find: impl Fn(usize) -> bool + Sync,
    ) -> Retraces {
        let swept = Swept {
            old,
            new,
            old_q: self.ends.pad(old),
            new_q: self.ends.pad(new),
            old_spheres,
            new_spheres,
            spheres: old_spheres.iter().chain(new_spheres).copied().collect(),
        };
        let spheres = &swept.spheres[..];
        let n = self.receivers.len();
        // Whole groups and blocks of receivers first: those whose rays to every emitter pass
        // far from every swept box. One list of rays a group (not one a receiver: 2.5k
        // small vectors a frame at 77k), joined once.
        let nb = self.blocks.len();
        let parts: Vec<Retraces> = (0..self.groups.len())
            .into_par_iter()
            .filter(|&g| may_meet(self.groups[g], ems, spheres))
            .map(|g| {
                let mut out = Retraces::default();
                let blocks = (g * GROUP..((g + 1) * GROUP).min(nb))
                    .filter(|&b| may_meet(self.blocks[b], ems, spheres));
                for b in blocks {
                    for k in (b * BLOCK..((b + 1) * BLOCK).min(n)).filter(|&k| find(k)) {
                        for e in 0..ems.len() {
                            self.receiver_rays_to_retrace(world, ems, (k, e), &swept, &mut out);
                        }
                    }
                }
                out
            })
            .collect();
        Retraces::concat(parts)
    }

    /// Push to `out` receiver `k`'s shadow rays to emitter `e` that a swept box may have
    /// changed.
    fn receiver_rays_to_retrace(
        &self,
        world: &World,
        ems: &[Emitter],
        (k, e): (usize, usize),
        swept: &Swept,
        out: &mut Retraces,
    ) {
        let (em, set) = (&ems[e], k * ems.len() + e);
        if self.unoccluded[set] <= 0.0 {
            return;
        }
        let (p, eps, samples) = (&world.patches, world.eps, self.shadows.samples());
        let i = self.receivers[k] as usize;
        let (x, n) = (p.centre[i], p.normal[i]);
        // Every shadow ray lies in the cone from x to the emitter's sphere.
        let (lc, lr) = em.sphere;
        let cone = Cone::new(x, lc, lr);
        if !swept.spheres.iter().any(|&(bc, br)| cone.meets(bc, br)) {
            return;
        }
        let shift = sample_shift(i, em, self.stream);
        // 64 samples at a time: the blocked ones against the old boxes, the free ones
        // against the new, by their stored ends (a superset where they are quantised); the
        // exact segment of each found is re-traced (a ray re-traced that no box meets is
        // traced for nothing, never wrong).
        for j0 in (0..samples).step_by(64) {
            let m = (samples - j0).min(64);
            let blocked = self.shadows.blocked_word(set, j0 as usize / 64);
            let all = u64::MAX >> (64 - m);
            let sample = |j: u32| shadow_segment(em, (x, n), shift, j, samples, eps);
            let at = (set * samples as usize + j0 as usize, x + n * eps);
            let want = [blocked, !blocked & all];
            let mut found = self.samples_meeting(at, (j0, m), swept.sets(), want, &sample);
            while found != 0 {
                let j = j0 + found.trailing_zeros();
                found &= found - 1;
                // The stored end where it is exact (`shadow_segment`'s floats), else the
                // sample again.
                let ray = match self.ends.exact(at.0 + (j - j0) as usize) {
                    Some(end) => (at.1, end),
                    None => sample(j),
                };
                if swept.meets_a_sphere(blocked >> (j - j0) & 1 != 0, ray) {
                    out.push((k as u32, e as u32, j), ray);
                }
            }
        }
    }

    /// Of samples `j0 .. j0 + m` (stored ends from `at.0`, rays from `at.1`), those in
    /// `want[s]` whose segment may meet one of set `s`'s boxes, for both sets (where the
    /// movers were, and where they are): by the stored ends against the padded boxes (both
    /// sets from one decoding), or, where they cannot say, by the exact samples (`sample(j)`)
    /// against the boxes themselves.
    fn samples_meeting(
        &self,
        (at, from): (usize, Vec3),
        (j0, m): (u32, u32),
        [(old, old_q), (new, new_q)]: [(&[Aabb], &[Aabb]); 2],
        want: [u64; 2],
        sample: &impl Fn(u32) -> (Vec3, Vec3),
    ) -> u64 {
        let want = [
            if old.is_empty() { 0 } else { want[0] },
            if new.is_empty() { 0 } else { want[1] },
        ];
        if want == [0, 0] {
            return 0;
        }
        let sets = [
            if want[0] == 0 { &[][..] } else { old_q },
            if want[1] == 0 { &[][..] } else { new_q },
        ];
        if let Some([a, b]) = self.ends.meeting(at, m as usize, from, sets) {
            return (a & want[0]) | (b & want[1]);
        }
        let meets =
            |boxes: &[Aabb], (f, t): (Vec3, Vec3)| boxes.iter().any(|b| b.meets_segment(f, t));
        (0..m)
            .filter(|&j| (want[0] | want[1]) >> j & 1 != 0)
            .filter(|&j| {
                let ray = sample(j0 + j);
                (want[0] >> j & 1 != 0 && meets(old, ray))
                    || (want[1] >> j & 1 != 0 && meets(new, ray))
            })
            .fold(0, |mask, j| mask | 1 << j)
    }

    /// The shadow rays with a stored end kept exact (every one an emitter lights), and of
    /// them those whose end is not the sample they were traced to (`shadow_segment`'s, the
    /// segment re-traced from it): `(checked, off)`, for tests.
    #[cfg(test)]
    pub(crate) fn ends_off_their_samples(&self, world: &World) -> (usize, usize) {
        let (ems, samples) = (crate::direct::emitters(world), self.shadows.samples());
        let p = &world.patches;
        let (mut checked, mut off) = (0, 0);
        for (k, &i) in self.receivers.iter().enumerate() {
            let (x, n) = (p.centre[i as usize], p.normal[i as usize]);
            for (e, em) in ems.iter().enumerate() {
                let set = k * ems.len() + e;
                if self.unoccluded[set] <= 0.0 || self.coarse[k] {
                    continue;
                }
                let shift = sample_shift(i as usize, em, self.stream);
                for j in 0..samples {
                    let Some(end) = self.ends.exact(set * samples as usize + j as usize) else {
                        continue;
                    };
                    checked += 1;
                    let segment = shadow_segment(em, (x, n), shift, j, samples, world.eps);
                    off += usize::from(segment.1 != end);
                }
            }
        }
        (checked, off)
    }

    /// Trace `rays` against the `movers` alone, then against the whole scene those that
    /// were blocked and the movers no longer block (a free ray can only have been blocked by
    /// a mover). Returns whether each is blocked.
    pub(super) fn trace_movers_first(
        &self,
        world: &World,
        movers: &[u32],
        rays: &Retraces,
        ne: usize,
    ) -> Vec<bool> {
        let eps = world.eps;
        let mut blocked = vec![false; rays.len()];
        world
            .vis
            .occluded_among(&rays.from, &rays.to, eps, movers, &mut blocked);
        // Blocked before, and the movers no longer block it: something else may.
        let again: Vec<usize> = (0..rays.len())
            .filter(|&r| {
                let (k, e, j) = rays.which[r];
                !blocked[r] && self.shadows.is_blocked(k as usize * ne + e as usize, j)
            })
            .collect();
        if !again.is_empty() {
            let from: Vec<Vec3> = again.iter().map(|&r| rays.from[r]).collect();
            let to: Vec<Vec3> = again.iter().map(|&r| rays.to[r]).collect();
            let mut b = vec![false; again.len()];
            world.vis.occluded(&from, &to, eps, &[], &mut b);
            for (&r, b) in again.iter().zip(b) {
                blocked[r] = b;
            }
        }
        blocked
    }
}

/// Whether a ray from the sphere `(oc, or)` (a block's or group's receivers) to one of
/// `ems` may meet one of `spheres`.
fn may_meet((oc, or): (Vec3, f32), ems: &[Emitter], spheres: &[(Vec3, f32)]) -> bool {
    ems.iter().any(|em| {
        let (lc, lr) = em.sphere;
        (spheres.iter()).any(|&(bc, br)| capsule_meets_sphere(oc, or, lc, lr, bc, br))
    })
}
