//! [`DirectCache`]: direct light kept with its shadow rays' outcomes, so that an update
//! re-traces only what a mover may have changed (the dispersive solver's Step 1).

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Aabb;

use super::sample_ends::SampleEnds;
use super::{
    cone_meets_sphere, emitters, emitting_objects, padded_swept, sample_shift, shadow_sample,
    unoccluded_irradiance, visible_fraction, Emitter,
};
use crate::shadow_rays::ShadowRays;
use crate::World;

/// Direct irradiance of a set of receivers with what it was made of, so that it can be
/// updated exactly when only occluders move (the dispersive solver's Step 1, paper 2.3.2):
/// per (receiver, emitter) the unoccluded irradiance and which shadow rays were blocked.
/// The rays themselves are regenerated, identically, when needed (their seed depends on the
/// receiver and the emitter only); only where they end is kept, quantised ([`SampleEnds`]).
///
/// An update re-traces only the shadow rays whose segment meets a box an occluder swept; a
/// ray that meets none sees the same geometry as before, so the result equals a full
/// recomputation with the same samples. Valid while the emitters (their shapes, places and
/// emission) and the receivers' places stay as they were at [`DirectCache::new`].
#[derive(Clone, Debug, Default)]
pub struct DirectCache {
    /// The emitting objects, in order.
    objects: Vec<usize>,
    receivers: Vec<u32>,
    /// `[k * emitters + e]`: unoccluded irradiance of receiver `k` from emitter `e` (unit
    /// radiance).
    unoccluded: Vec<f32>,
    /// Set `k * emitters + e`: which shadow rays of receiver `k` to emitter `e` are blocked.
    shadows: ShadowRays,
    /// `[k]`: the direct irradiance.
    irradiance: Vec<Vec3>,
    /// `[k]`: its irradiance is from fewer samples (a moving receiver's, see
    /// [`DirectCache::update`]) and its blocked bits are not kept: it is traced whole, with
    /// every sample, at the first update where it does not move.
    coarse: Vec<bool>,
    /// `[k * emitters + e]`: the visible fraction of a coarse receiver's last trace, which
    /// the frames between its traces hold ([`DirectCache::update`]'s `whole_stride`).
    held: Vec<f32>,
    /// Which of every `whole_stride` moving receivers the next update traces.
    phase: usize,
    /// Where each shadow ray ends, quantised ([`SampleEnds`]), so that finding the rays a
    /// mover may have changed is a segment test per ray, not a regenerated sample.
    ends: SampleEnds,
    /// `[b]`: a sphere holding the shadow rays' origins of receivers `b * BLOCK ..` (their
    /// patches' centres), so that a mover far from a block's rays rejects the whole block.
    blocks: Vec<(Vec3, f32)>,
}

/// A shadow ray to re-trace: (receiver, emitter, sample, from, to).
type Retrace = (u32, u32, u32, Vec3, Vec3);

/// Receivers per block of [`DirectCache`]'s rejection test (consecutive receivers are
/// patches of one object, near one another). At the 77k room with its largest object moving,
/// 7.7k receivers are left for the per-receiver cone test with blocks of 16, 25k with 64.
const BLOCK: usize = 16;

/// Bounding sphere of the centres of `receivers` (padded by the shadow rays' offset).
fn block_sphere(world: &World, receivers: &[u32]) -> (Vec3, f32) {
    let p = &world.patches;
    let pts = receivers.iter().map(|&i| p.centre[i as usize]);
    let (lo, hi) = pts
        .clone()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), c| {
            (a.min(c), b.max(c))
        });
    let c = 0.5 * (lo + hi);
    let r = pts.map(|q| (q - c).length()).fold(0.0, f32::max);
    (c, r + 2.0 * world.eps)
}

/// Whether a shadow ray from anywhere in the sphere `(oc, or)` to anywhere in the sphere
/// `(lc, lr)` may meet the sphere `(bc, br)`. The ray's point at `s` in [0, 1] is
/// `(1 - s) y0 + s y1` with `y0` within `or` of `oc` and `y1` within `lr` of `lc`: within
/// `(1 - s) or + s lr` of the axis point `a(s) = oc + s (lc - oc)`. So it may meet the sphere
/// when `|bc - a(s)| - (1 - s) or - s lr <= br` for some `s`; the left side is convex in
/// `s`, and its minimum is found as in [`cone_meets_sphere`] (a tapered capsule: near a
/// block of receivers it is as thin as the block, not as wide as the light).
fn capsule_meets_sphere(oc: Vec3, or: f32, lc: Vec3, lr: f32, bc: Vec3, br: f32) -> bool {
    let axis = lc - oc;
    let len = axis.length();
    let slack = br + 1e-6 * (1.0 + len);
    if len <= 1e-20 {
        return (bc - oc).length() <= slack + or.max(lr);
    }
    // d(s) = |bc - a(s)|, the radius r(s) = or + s (lr - or); minimise d(s) - r(s).
    let s0 = (bc - oc).dot(axis) / (len * len);
    let perp = (bc - (oc + axis * s0)).length();
    let grow = (lr - or) / len;
    let s = if grow.abs() < 1.0 {
        s0 + grow * perp / ((1.0 - grow * grow).sqrt() * len)
    } else if grow > 0.0 {
        1.0
    } else {
        0.0
    }
    .clamp(0.0, 1.0);
    (bc - (oc + axis * s)).length() - (or + s * (lr - or)) <= slack
}

impl DirectCache {
    /// Compute the direct irradiance of `receivers` with `samples` shadow rays per
    /// (receiver, emitter).
    pub fn new(world: &World, receivers: Vec<u32>, samples: u32) -> DirectCache {
        let ems = emitters(world);
        let samples = samples.max(1);
        let ne = ems.len();
        let mut cache = DirectCache {
            objects: ems.iter().map(|e| e.object).collect(),
            unoccluded: vec![0.0; receivers.len() * ne],
            shadows: ShadowRays::new(receivers.len() * ne, samples),
            irradiance: vec![Vec3::ZERO; receivers.len()],
            coarse: vec![false; receivers.len()],
            held: vec![1.0; receivers.len() * ne],
            phase: 0,
            ends: SampleEnds::new(world, receivers.len() * ne * samples as usize),
            blocks: receivers
                .chunks(BLOCK)
                .map(|b| block_sphere(world, b))
                .collect(),
            receivers,
        };
        if ne > 0 {
            let all: Vec<usize> = (0..cache.receivers.len()).collect();
            cache.recompute(world, &ems, &all, samples);
        }
        cache
    }

    /// The receivers, as given to [`DirectCache::new`].
    pub fn receivers(&self) -> &[u32] {
        &self.receivers
    }

    /// Direct irradiance of each receiver (aligned with [`DirectCache::receivers`]).
    pub fn irradiance(&self) -> &[Vec3] {
        &self.irradiance
    }

    /// Whether some receiver's irradiance is from fewer samples than the cache's (it moved
    /// at its last update); the next [`DirectCache::update`] traces it whole.
    pub fn has_coarse(&self) -> bool {
        self.coarse.iter().any(|&c| c)
    }

    /// Shadow rays per (receiver, emitter).
    pub fn samples(&self) -> u32 {
        self.shadows.samples()
    }

    /// Whether the world's emitting objects are still those the cache was made with (their
    /// places and emission are the caller's to watch).
    pub fn same_emitters(&self, world: &World) -> bool {
        emitting_objects(world).eq(self.objects.iter().copied())
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.receivers.len() * 4
            + self.unoccluded.len() * 4
            + self.shadows.bytes()
            + self.irradiance.len() * 12
            + self.coarse.len()
            + self.held.len() * 4
            + self.ends.end.len() * 6
            + self.blocks.len() * 16
    }

    /// After the objects `movers` moved from the boxes `old` to the boxes `new`: re-trace the
    /// shadow rays that may have changed, and recompute whole the receivers that are the
    /// movers' own patches. A blocked ray can only be freed if its blocker moved, so if its
    /// segment meets an old box; a free ray can only be blocked by a mover's new place, so if
    /// its segment meets a new box. The movers' own receivers are traced with `whole_samples`
    /// shadow rays (fewer than the cache's: the light of a moving receiver, whole again with
    /// every sample once it rests). Those rays are first traced against the `movers` alone (the
    /// objects that moved): a free ray can only be blocked by them, and a blocked ray they
    /// still block stays blocked; only a blocked ray they no longer block is traced against
    /// the whole scene. With `whole_samples` below the cache's and `whole_stride` above 1,
    /// only one in `whole_stride` of the movers' receivers is traced (in turn, a different
    /// one each update); the others keep the visible fraction of their last trace under
    /// their exact unoccluded irradiance where they are now (a moving object's shadows lag
    /// by at most `whole_stride - 1` updates; whole again, with every sample, once it rests).
    /// Returns the indices of the receivers whose irradiance was recomputed, ascending;
    /// [`DirectCache::irradiance`] holds the new values.
    pub fn update(
        &mut self,
        world: &World,
        movers: &[u32],
        (old, new): (&[Aabb], &[Aabb]),
        whole_samples: u32,
        whole_stride: usize,
    ) -> Vec<usize> {
        let ems = emitters(world);
        if ems.is_empty() || self.receivers.is_empty() {
            return Vec::new();
        }
        debug_assert!(self.same_emitters(world));
        let ne = ems.len();
        let samples = self.shadows.samples();
        let eps = world.eps;
        let (old, new) = (padded_swept(old, eps), padded_swept(new, eps));
        let spheres: Vec<(Vec3, f32)> = old.iter().chain(&new).map(Aabb::bounding_sphere).collect();
        // The movers' own patches are traced whole (they moved), and so are coarse receivers
        // that rest now, with every sample.
        let whole_ks = self.receivers_of(world, movers);
        let mut is_whole = self.coarse.clone();
        whole_ks.iter().for_each(|&k| is_whole[k] = true);
        let settled_ks: Vec<usize> = (self.coarse.iter().enumerate())
            .filter(|&(k, &c)| c && whole_ks.binary_search(&k).is_err())
            .map(|(k, _)| k)
            .collect();
        let is_whole = |k: usize| is_whole[k];
        let t = std::time::Instant::now();
        let rays = self.rays_to_retrace(world, &ems, (&old, &new), &spheres, is_whole);
        crate::trace_part("    find_rays_to_retrace", t);
        let t = std::time::Instant::now();
        let blocked = self.trace_movers_first(world, movers, &rays, ne);
        crate::trace_part("    retrace", t);
        let outcomes = rays.iter().zip(blocked);
        let changed = self
            .shadows
            .keep(outcomes.map(|(&(k, e, j, ..), b)| (k as usize * ne + e as usize, j, b)));
        let mut touched: Vec<usize> = changed.into_iter().map(|set| set / ne).collect();
        touched.dedup();
        // The receivers whose rays changed: their visible fractions again.
        let values: Vec<Vec3> = touched
            .par_iter()
            .map(|&k| self.value(world, &ems, k))
            .collect();
        for (&k, v) in touched.iter().zip(values) {
            self.irradiance[k] = v;
        }
        // The receivers that moved, and the coarse ones that rest now: everything again.
        let stride = match whole_samples < samples {
            true => whole_stride.max(1),
            false => 1,
        };
        let phase = self.phase % stride;
        self.phase = self.phase.wrapping_add(1);
        let (traced, held): (Vec<usize>, Vec<usize>) =
            whole_ks.iter().partition(|&&k| k % stride == phase);
        let t = std::time::Instant::now();
        self.recompute(world, &ems, &traced, whole_samples);
        self.hold(world, &ems, &held);
        self.recompute(world, &ems, &settled_ks, samples);
        crate::trace_part("    movers_own_patches", t);
        self.refresh_blocks(world, &whole_ks);
        touched.extend(whole_ks.iter().chain(&settled_ks));
        touched.sort_unstable();
        touched.dedup();
        touched
    }

    /// The indices of the receivers that are patches of `objects`, ascending: a binary
    /// search per object (receivers ascend, and an object's patches are a range), not a pass
    /// over every receiver.
    fn receivers_of(&self, world: &World, objects: &[u32]) -> Vec<usize> {
        debug_assert!(self.receivers.is_sorted());
        let mut out: Vec<usize> = Vec::new();
        for &o in objects {
            let r = world.patches.range(o as usize);
            let lo = self.receivers.partition_point(|&i| (i as usize) < r.start);
            let hi = self.receivers.partition_point(|&i| (i as usize) < r.end);
            out.extend(lo..hi);
        }
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The shadow rays (receiver, emitter, sample, from, to) that a mover may have changed:
    /// of the receivers not traced whole, those blocked whose segment meets an `old` box,
    /// those free whose segment meets a `new` one (`spheres`: the boxes' bounding spheres).
    fn rays_to_retrace(
        &self,
        world: &World,
        ems: &[Emitter],
        (old, new): (&[Aabb], &[Aabb]),
        spheres: &[(Vec3, f32)],
        is_whole: impl Fn(usize) -> bool + Sync,
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
        (0..self.blocks.len())
            .into_par_iter()
            .filter(|&b| block_may_meet(b))
            .flat_map_iter(|b| b * BLOCK..((b + 1) * BLOCK).min(n))
            .filter(|&k| !is_whole(k))
            .flat_map_iter(|k| {
                let i = self.receivers[k] as usize;
                let (x, n) = (p.centre[i], p.normal[i]);
                let mut out = Vec::new();
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
                    for j in 0..samples {
                        let (boxes, padded) = if self.shadows.is_blocked(set, j) {
                            (&old, &old_q)
                        } else {
                            (&new, &new_q)
                        };
                        if boxes.is_empty() {
                            continue;
                        }
                        // The stored end first (a cheap superset), then the exact sample.
                        let from = x + n * eps;
                        if let Some(end) = self.ends.get(first + j as usize) {
                            if !padded.iter().any(|b| b.meets_segment(from, end)) {
                                continue;
                            }
                        }
                        let (from, to, _) = shadow_sample(em, x, n, shift, j, samples, eps);
                        if boxes.iter().any(|b| b.meets_segment(from, to)) {
                            out.push((k as u32, e as u32, j, from, to));
                        }
                    }
                }
                out.into_iter()
            })
            .collect()
    }

    /// The spheres of the blocks holding receivers `ks` (which moved), where they are now.
    fn refresh_blocks(&mut self, world: &World, ks: &[usize]) {
        let mut blocks: Vec<usize> = ks.iter().map(|&k| k / BLOCK).collect();
        blocks.dedup();
        for b in blocks {
            let ks = &self.receivers[b * BLOCK..((b + 1) * BLOCK).min(self.receivers.len())];
            self.blocks[b] = block_sphere(world, ks);
        }
    }

    /// Trace `rays` (receiver, emitter, sample, from, to) against the `movers` alone, then
    /// against the whole scene those that were blocked and the movers no longer block (a
    /// free ray can only have been blocked by a mover). Returns whether each is blocked.
    fn trace_movers_first(
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

    /// Receivers `ks` (which moved) not traced this update: their exact unoccluded
    /// irradiance where they are now, under the visible fraction of their last trace (held
    /// from a coarse trace, or from the cache's full one). They are coarse from now on.
    fn hold(&mut self, world: &World, ems: &[Emitter], ks: &[usize]) {
        let p = &world.patches;
        let ne = ems.len();
        let this = &*self;
        let parts: Vec<(Vec3, Vec<(f32, f32)>)> = ks
            .par_iter()
            .map(|&k| {
                let i = this.receivers[k] as usize;
                let (x, n) = (p.centre[i], p.normal[i]);
                let mut e_total = Vec3::ZERO;
                let per_emitter = (ems.iter().enumerate())
                    .map(|(e, em)| {
                        let unoccluded = unoccluded_irradiance(em, x, n);
                        let fraction = match this.coarse[k] {
                            true => this.held[k * ne + e],
                            false => {
                                let blocked = |j: u32| this.shadows.is_blocked(k * ne + e, j);
                                let shift = sample_shift(i, em);
                                visible_fraction(
                                    em,
                                    (x, n),
                                    shift,
                                    this.shadows.samples(),
                                    world.eps,
                                    blocked,
                                )
                            }
                        };
                        e_total += em.radiance * (unoccluded * fraction);
                        (unoccluded, fraction)
                    })
                    .collect();
                (e_total, per_emitter)
            })
            .collect();
        for (&k, (value, per_emitter)) in ks.iter().zip(parts) {
            for (e, (unoccluded, fraction)) in per_emitter.into_iter().enumerate() {
                self.unoccluded[k * ne + e] = unoccluded;
                self.held[k * ne + e] = fraction;
            }
            self.irradiance[k] = value;
            self.coarse[k] = true;
        }
    }

    /// Trace receivers `ks` from scratch (unoccluded irradiance, shadow rays, irradiance)
    /// with `samples` shadow rays per emitter: the cache's count, or fewer for a coarse
    /// receiver, whose irradiance is then kept but not its rays.
    fn recompute(&mut self, world: &World, ems: &[Emitter], ks: &[usize], samples: u32) {
        let p = &world.patches;
        let eps = world.eps;
        let ne = ems.len();
        let coarse = samples < self.shadows.samples();
        let samples = samples.clamp(1, self.shadows.samples());
        let s = samples as usize;
        let mut coarse_value = vec![Vec3::ZERO; if coarse { ks.len() } else { 0 }];
        const CHUNK: usize = 2048;
        for ks in ks.chunks(CHUNK) {
            for (e, em) in ems.iter().enumerate() {
                // Unoccluded irradiance, exact.
                let unoccluded: Vec<f32> = ks
                    .par_iter()
                    .map(|&k| {
                        let i = self.receivers[k] as usize;
                        unoccluded_irradiance(em, p.centre[i], p.normal[i])
                    })
                    .collect();
                // Shadow rays to stratified points on the emitter.
                let mut from = vec![Vec3::ZERO; ks.len() * s];
                let mut to = vec![Vec3::ZERO; ks.len() * s];
                from.par_chunks_mut(s)
                    .zip(to.par_chunks_mut(s))
                    .enumerate()
                    .for_each(|(c, (f, t))| {
                        if unoccluded[c] <= 0.0 {
                            return;
                        }
                        let i = self.receivers[ks[c]] as usize;
                        let (x, n) = (p.centre[i], p.normal[i]);
                        let shift = sample_shift(i, em);
                        for j in 0..s {
                            (f[j], t[j], _) =
                                shadow_sample(em, x, n, shift, j as u32, samples, eps);
                        }
                    });
                let mut blocked = vec![false; from.len()];
                world.vis.occluded(&from, &to, eps, &[], &mut blocked);
                if coarse {
                    for (c, &k) in ks.iter().enumerate() {
                        self.unoccluded[k * ne + e] = unoccluded[c];
                        self.coarse[k] = true;
                        let i = self.receivers[k] as usize;
                        let fraction = visible_fraction(
                            em,
                            (p.centre[i], p.normal[i]),
                            sample_shift(i, em),
                            samples,
                            eps,
                            |j| blocked[c * s + j as usize],
                        );
                        self.held[k * ne + e] = fraction;
                        coarse_value[c] += em.radiance * (unoccluded[c] * fraction);
                    }
                    continue;
                }
                for (c, &k) in ks.iter().enumerate() {
                    self.coarse[k] = false;
                    self.unoccluded[k * ne + e] = unoccluded[c];
                    let first = (k * ne + e) * s;
                    for (j, &end) in to[c * s..(c + 1) * s].iter().enumerate() {
                        self.ends.put(first + j, end);
                    }
                    self.shadows.put(k * ne + e, &blocked[c * s..(c + 1) * s]);
                }
            }
            if coarse {
                for (&k, v) in ks.iter().zip(&coarse_value) {
                    self.irradiance[k] = *v;
                }
                coarse_value.iter_mut().for_each(|v| *v = Vec3::ZERO);
                continue;
            }
            let values: Vec<Vec3> = ks.par_iter().map(|&k| self.value(world, ems, k)).collect();
            for (&k, v) in ks.iter().zip(values) {
                self.irradiance[k] = v;
            }
        }
    }

    /// Irradiance of receiver `k` from what is cached: per emitter, the unoccluded
    /// irradiance times the weighted fraction of shadow rays not blocked.
    fn value(&self, world: &World, ems: &[Emitter], k: usize) -> Vec3 {
        let p = &world.patches;
        let i = self.receivers[k] as usize;
        let (x, n) = (p.centre[i], p.normal[i]);
        let ne = ems.len();
        let mut out = Vec3::ZERO;
        for (e, em) in ems.iter().enumerate() {
            let u = self.unoccluded[k * ne + e];
            if u <= 0.0 {
                continue;
            }
            let fraction = visible_fraction(
                em,
                (x, n),
                sample_shift(i, em),
                self.shadows.samples(),
                world.eps,
                |j| self.shadows.is_blocked(k * ne + e, j),
            );
            out += em.radiance * (u * fraction);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The tapered capsule is conservative: any segment from a point of the first sphere to
    /// a point of the second that passes within the third is accepted; and it is tighter
    /// than the plain capsule: a sphere beside the thin end is rejected.
    #[test]
    fn capsule_test_accepts_every_segment_that_meets_the_sphere() {
        let mut seed = 12345u64;
        let mut rnd = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((seed >> 40) as f32) / (1u64 << 24) as f32
        };
        let mut v = |s: f32| Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * s;
        let mut accepted = 0;
        for _ in 0..20_000 {
            let (oc, or) = (v(4.0), 0.5 * v(1.0).x.abs());
            let (lc, lr) = (v(4.0) + Vec3::Y * 3.0, 2.0 * v(1.0).x.abs());
            let (t, r) = (v(1.0) + Vec3::splat(0.5), v(3.0));
            let (bc, br) = (oc.lerp(lc, t.x) + r, 0.2 + 0.5 * t.y);
            let unit = |mut d: Vec3| {
                while d.length() > 0.5 {
                    d *= 0.5;
                }
                d * 2.0
            };
            let y0 = oc + unit(v(1.0)) * or;
            let y1 = lc + unit(v(1.0)) * lr;
            // Closest point of the segment y0 y1 to bc.
            let d = y1 - y0;
            let t = ((bc - y0).dot(d) / d.length_squared().max(1e-30)).clamp(0.0, 1.0);
            if (bc - (y0 + d * t)).length() <= br {
                accepted += 1;
                assert!(
                    capsule_meets_sphere(oc, or, lc, lr, bc, br),
                    "{oc} {or} {lc} {lr} {bc} {br} {y0} {y1}"
                );
            }
        }
        assert!(accepted > 1000, "only {accepted} segments met the sphere");
        // Beside the thin end (radius 0.1 at the origin), 1.5 away, with a wide light far
        // above: the plain capsule (radius 5 everywhere) would accept it.
        let (oc, lc) = (Vec3::ZERO, Vec3::Y * 20.0);
        assert!(!capsule_meets_sphere(oc, 0.1, lc, 5.0, Vec3::X * 1.5, 0.2));
        assert!(capsule_meets_sphere(
            oc,
            0.1,
            lc,
            5.0,
            Vec3::new(1.5, 10.0, 0.0),
            0.2
        ));
    }
}
