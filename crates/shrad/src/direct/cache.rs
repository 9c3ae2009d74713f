//! [`DirectCache`]: direct light kept with its shadow rays' outcomes, so that an update
//! re-traces only what a mover may have changed (the dispersive solver's Step 1).

use glam::Vec3;
use rayon::prelude::*;

use super::blocks::{self, block_sphere, group_sphere, BLOCK, GROUP};
use super::mover_spheres::Moves;
use super::recent_moves::RecentMoves;
use super::sample_ends::SampleEnds;
use super::{
    emitters, emitting_objects, occluded_where_lit, patch_unoccluded_irradiance, sample_shift,
    shadow_sample, visible_fraction, weighted_fraction, Emitter,
};
use crate::shadow_rays::ShadowRays;
use crate::World;

mod find;

/// Direct irradiance of a set of receivers with what it was made of, so that it can be
/// updated exactly when only occluders move (the dispersive solver's Step 1, paper 2.3.2):
/// per (receiver, emitter) the unoccluded irradiance and which shadow rays were blocked.
/// Where each ray ends is kept (`SampleEnds`): exactly up to 8M rays; above, quantised,
/// and a ray found is regenerated, identically (its seed depends on the receiver and the
/// emitter only).
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
    /// The coarse receivers, ascending (so that an update need not look at every receiver).
    coarse_ks: Vec<usize>,
    /// `[k * emitters + e]`: the visible fraction of a coarse receiver's last trace, which
    /// the frames between its traces hold ([`DirectCache::update`]'s `whole_stride`).
    held: Vec<f32>,
    /// Which of every `whole_stride` moving receivers the next update traces (and which of
    /// every `whole_stride` receivers has its shadow rays found).
    phase: usize,
    /// The moves of the last updates, while receivers' shadow rays are found in turn.
    recent_moves: RecentMoves,
    /// Shadow rays the last update found, or would have found had every receiver taken its
    /// turn (an estimate: those found times the turns).
    shadow_rays_found: usize,
    /// [`SHADOW_RAYS_AT_ONCE`] (lower in tests).
    shadow_rays_at_once: usize,
    /// Where each shadow ray ends ([`SampleEnds`]), so that finding the rays a mover may
    /// have changed is a segment test per ray, not a regenerated sample.
    ends: SampleEnds,
    /// `[(k * emitters + e) * samples + j]`: each shadow ray's weight (`cos cos / r^2`, the
    /// floats [`shadow_sample`] gives), kept beside its end up to [`MAX_WEIGHTS`] rays (else
    /// empty, and the samples are regenerated), so that a receiver whose rays a mover changed
    /// has its visible fraction summed again without regenerating its samples (the 77k
    /// room's moving frame summed 340 receivers' 64 samples again: 0.24 ms of one thread's
    /// Step 1).
    weights: Vec<f32>,
    /// Which sample stream the shadow rays are drawn from ([`sample_shift`]): 0 for the
    /// solvers, [`INDEPENDENT_STREAM`] for the reference an error is measured against.
    stream: u32,
    /// `[b]`: a sphere holding the shadow rays' origins of receivers `b * BLOCK ..` (their
    /// patches' centres), so that a mover far from a block's rays rejects the whole block.
    blocks: Vec<(Vec3, f32)>,
    /// `[g]`: a sphere holding the spheres of blocks `g * GROUP ..`.
    groups: Vec<(Vec3, f32)>,
}

/// Above this many shadow rays a mover may have changed in one update (the last update's,
/// see [`DirectCache::update`]), receivers take turns while it moves: about 3 ms of finding
/// and re-tracing on 2 cores. The 77k and 129k rooms' largest movers change 14k and 23k a
/// frame and stay exact; the 1M room's 43k-patch mover changes 160k (38 ms), a quarter
/// of them found per frame.
pub const SHADOW_RAYS_AT_ONCE: usize = 1 << 15;

/// While it moves, at most about this many of a mover's own patches have their direct light
/// traced an update (the rest are held in turn; `DirectCache::update`).
pub const MOVER_PATCHES_AT_ONCE: usize = 4096;

/// At most this many receivers traced coarse while they moved are traced again with every
/// sample in one update once they rest (as many rays as [`MOVER_PATCHES_AT_ONCE`] at a
/// quarter of the samples): the 77k room's 4,512-patch sphere took 8-14 ms of the first frame
/// after it stopped, in one go; the others wait for the next updates (`catching_up`).
pub const SETTLED_AT_ONCE: usize = 1024;

/// At most this many shadow rays' weights are kept (32 MB: the 77k and 129k rooms' 4.9M
/// and 7.7M rays; the 1M room's 16M would be 64 MB more where its peak memory is at issue
/// 24's bound, so it regenerates its samples).
pub const MAX_WEIGHTS: usize = 1 << 23;

/// Shadow rays to re-trace, as arrays (the segments go to the backend as they are): per ray
/// its (receiver, emitter, sample) and its segment.
#[derive(Default)]
struct Retraces {
    which: Vec<(u32, u32, u32)>,
    from: Vec<Vec3>,
    to: Vec<Vec3>,
}

impl Retraces {
    fn len(&self) -> usize {
        self.which.len()
    }

    fn push(&mut self, which: (u32, u32, u32), (from, to): (Vec3, Vec3)) {
        self.which.push(which);
        self.from.push(from);
        self.to.push(to);
    }

    /// One list of all of `parts`, in order.
    fn concat(parts: Vec<Retraces>) -> Retraces {
        let n = parts.iter().map(Retraces::len).sum();
        let mut all = Retraces {
            which: Vec::with_capacity(n),
            from: Vec::with_capacity(n),
            to: Vec::with_capacity(n),
        };
        for p in parts {
            all.which.extend(p.which);
            all.from.extend(p.from);
            all.to.extend(p.to);
        }
        all
    }
}

impl DirectCache {
    /// Compute the direct irradiance of `receivers` with `samples` shadow rays per
    /// (receiver, emitter).
    pub fn new(world: &World, receivers: Vec<u32>, samples: u32) -> DirectCache {
        DirectCache::new_in_stream(world, receivers, samples, 0)
    }

    /// [`DirectCache::new`] with its shadow rays from sample stream `stream` (0: the
    /// solvers'; [`super::INDEPENDENT_STREAM`]: the reference's).
    pub fn new_in_stream(
        world: &World,
        receivers: Vec<u32>,
        samples: u32,
        stream: u32,
    ) -> DirectCache {
        let ems = emitters(world);
        let samples = samples.max(1);
        let ne = ems.len();
        let mut cache = DirectCache {
            objects: ems.iter().map(|e| e.object).collect(),
            unoccluded: vec![0.0; receivers.len() * ne],
            shadows: ShadowRays::new(receivers.len() * ne, samples),
            irradiance: vec![Vec3::ZERO; receivers.len()],
            coarse: vec![false; receivers.len()],
            coarse_ks: Vec::new(),
            held: vec![1.0; receivers.len() * ne],
            phase: 0,
            recent_moves: Default::default(),
            shadow_rays_found: 0,
            shadow_rays_at_once: SHADOW_RAYS_AT_ONCE,
            ends: SampleEnds::new(world, receivers.len() * ne * samples as usize),
            weights: Vec::new(),
            stream,
            blocks: receivers
                .chunks(BLOCK)
                .map(|b| block_sphere(world, b))
                .collect(),
            groups: Vec::new(),
            receivers,
        };
        cache.groups = cache.blocks.chunks(GROUP).map(group_sphere).collect();
        if cache.ends.len() > 0 && cache.ends.len() <= MAX_WEIGHTS {
            cache.weights = vec![0.0; cache.ends.len()];
        }
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
        !self.coarse_ks.is_empty()
    }

    /// Whether the next [`DirectCache::update`] has work even if nothing moves: a coarse
    /// receiver to trace whole, or receivers whose shadow rays were not found since an
    /// object moved (found in turn while it moved).
    pub fn catching_up(&self) -> bool {
        self.has_coarse() || !self.recent_moves.is_empty()
    }

    /// Receivers take turns above `rays` shadow rays an update instead of
    /// [`SHADOW_RAYS_AT_ONCE`] (for tests on small scenes).
    #[cfg(test)]
    pub(crate) fn take_turns_above(&mut self, rays: usize) {
        self.shadow_rays_at_once = rays;
    }

    /// The (receiver, emitter) pairs that receive light (a shadow ray a sample each), and
    /// all of them, for tests.
    #[cfg(test)]
    pub(crate) fn lit_sets(&self) -> (usize, usize) {
        let lit = self.unoccluded.iter().filter(|&&u| u > 0.0).count();
        (lit, self.unoccluded.len())
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
            + self.ends.bytes()
            + self.weights.len() * 4
            + (self.blocks.len() + self.groups.len()) * 16
    }

    /// After the objects `movers` moved from the boxes `moves.old` to the boxes `moves.new`
    /// (each also within a sphere there where `moves` knows one: a ray is then re-traced
    /// only if it meets both, `mover_spheres.rs`): re-trace the shadow rays that may have
    /// changed, and recompute whole the receivers that are the
    /// movers' own patches. A blocked ray can only be freed if its blocker moved, so if its
    /// segment meets an old box; a free ray can only be blocked by a mover's new place, so if
    /// its segment meets a new box. The movers' own receivers are traced with `whole_samples`
    /// shadow rays (fewer than the cache's: the light of a moving receiver, whole again with
    /// every sample once it rests). Those rays are first traced against the `movers` alone (the
    /// objects that moved): a free ray can only be blocked by them, and a blocked ray they
    /// still block stays blocked; only a blocked ray they no longer block is traced against
    /// the whole scene. With `whole_samples` below the cache's and `whole_stride` above 1,
    /// only one in `whole_stride` of the movers' receivers is traced (in turn, a different
    /// one each update), or fewer for a mover of more than [`MOVER_PATCHES_AT_ONCE`]
    /// receivers; the others keep the visible fraction of their last trace under their
    /// exact unoccluded irradiance where they are now (a moving object's shadows lag by at
    /// most `whole_stride - 1` updates, or by its receivers over
    /// [`MOVER_PATCHES_AT_ONCE`]; whole again, with every sample, once it rests).
    /// Likewise the other receivers, when the last update found more than
    /// [`SHADOW_RAYS_AT_ONCE`] shadow rays to re-trace: one in `whole_stride` has its shadow
    /// rays found and re-traced each update (in turn), against every move since its last
    /// turn, so the shadow a mover casts lags by at most `whole_stride - 1` updates too, and
    /// every receiver is exact again at the first update without a mover.
    /// A mover's receivers that would be held are held only when the mover is in `read_now`
    /// (whose light is read after this update: the dispersive solver's Step 2 updates it
    /// this frame) or when they were exact until now; the others keep what they had (they
    /// are coarse already, and held or traced when next read, or whole once they rest).
    /// A mover lit in a frame whose Step 1 a budget carried to the next reads what was held
    /// when it was last lit (its light lags a few frames more, as Step 1's does then).
    /// Returns the indices of the receivers whose irradiance was recomputed, ascending;
    /// [`DirectCache::irradiance`] holds the new values.
    pub fn update(
        &mut self,
        world: &World,
        (movers, read_now): (&[u32], &[u32]),
        moves: Moves,
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
        let stride = match whole_samples < samples && !movers.is_empty() {
            true => whole_stride.max(1),
            false => 1,
        };
        let phase = self.phase;
        self.phase = self.phase.wrapping_add(1);
        // The shadow rays of one receiver in `turns` are found (in turn) when the last update
        // found more than `SHADOW_RAYS_AT_ONCE`, against every move since that receiver's
        // last turn (`all_movers`, `left`, `now`).
        let turns = match self.shadow_rays_found > self.shadow_rays_at_once {
            true => stride,
            false => 1,
        };
        let (all_movers, [(old, old_spheres), (new, new_spheres)]) =
            self.swept_since_last_turn(world, movers, moves, turns);
        // The movers' own patches are traced whole (they moved), and so are coarse receivers
        // that rest now, with every sample, [`SETTLED_AT_ONCE`] an update.
        let whole_ks = self.receivers_of(world, movers);
        let mut settled_ks: Vec<usize> = (self.coarse_ks.iter())
            .filter(|&k| whole_ks.binary_search(k).is_err())
            .copied()
            .collect();
        let still_coarse = settled_ks.split_off(settled_ks.len().min(SETTLED_AT_ONCE));
        // A large mover's own patches take more turns (the 1M-patch room's largest object
        // has 43k: a quarter of them a frame was 10 ms of its moving frame).
        let own_stride = match stride {
            1 => 1,
            _ => stride.max(whole_ks.len().div_ceil(MOVER_PATCHES_AT_ONCE)),
        };
        // The movers' receivers are a few ranges: most receivers are outside their span.
        let whole_span =
            whole_ks.first().copied().unwrap_or(1)..=whole_ks.last().copied().unwrap_or(0);
        let is_whole = |k: usize| {
            self.coarse[k] || (whole_span.contains(&k) && whole_ks.binary_search(&k).is_ok())
        };
        let find = |k: usize| k % turns == phase % turns && !is_whole(k);
        let t = std::time::Instant::now();
        let spheres = (&old_spheres[..], &new_spheres[..]);
        let rays = self.rays_to_retrace(world, &ems, (&old, &new), spheres, find);
        crate::trace_part("    find_rays_to_retrace", t);
        self.shadow_rays_found = rays.len() * turns;
        let t = std::time::Instant::now();
        let blocked = self.trace_movers_first(world, &all_movers, &rays, ne);
        crate::trace_part("    retrace", t);
        let outcomes = rays.which.iter().zip(blocked);
        let changed = self
            .shadows
            .keep(outcomes.map(|(&(k, e, j), b)| (k as usize * ne + e as usize, j, b)));
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
        let t = std::time::Instant::now();
        let own = (&whole_ks[..], read_now);
        let moved = self.movers_own(world, &ems, own, (whole_samples, own_stride, phase));
        self.recompute(world, &ems, &settled_ks, samples);
        crate::trace_part("    movers_own_patches", t);
        let spheres = (&mut self.blocks[..], &mut self.groups[..]);
        let whole = (&self.receivers[..], &whole_ks[..]);
        blocks::refresh(spheres, whole, |ks| block_sphere(world, ks));
        self.coarse_ks = whole_ks
            .iter()
            .copied()
            .filter(|&k| self.coarse[k])
            .chain(still_coarse)
            .collect();
        self.coarse_ks.sort_unstable();
        touched.extend(moved.iter().chain(&settled_ks));
        touched.sort_unstable();
        touched.dedup();
        touched
    }

    /// The movers' receivers `ks`: one in `stride` traced with `samples` shadow rays (in turn,
    /// by `phase`), the others held ([`DirectCache::hold`]) if they were exact until now or
    /// are patches of `read_now` (objects whose light is read after this update), else left
    /// as they were (coarse already: held or traced when next read, whole once they rest).
    /// Returns the receivers recomputed.
    fn movers_own(
        &mut self,
        world: &World,
        ems: &[Emitter],
        (ks, read_now): (&[usize], &[u32]),
        (samples, stride, phase): (u32, usize, usize),
    ) -> Vec<usize> {
        let (mut traced, held): (Vec<usize>, Vec<usize>) =
            ks.iter().partition(|&&k| k % stride == phase % stride);
        // Held light is read only when its object is lit (Step 2 reads its patches' direct
        // light; the 77k room's mover is lit one frame in three, and holding its other
        // receivers every frame was 0.38 ms of one thread's 8).
        let read_ks = self.receivers_of(world, read_now);
        let held: Vec<usize> = (held.into_iter())
            .filter(|&k| !self.coarse[k] || read_ks.binary_search(&k).is_ok())
            .collect();
        self.recompute(world, ems, &traced, samples);
        self.hold(world, ems, &held);
        traced.extend(held);
        traced
    }

    /// The indices of the receivers (ascending) that are patches of `objects`, ascending.
    fn receivers_of(&self, world: &World, objects: &[u32]) -> Vec<usize> {
        (world.patches).positions_in(&self.receivers, objects.iter().map(|&o| o as usize))
    }

    /// Receivers `ks` (which moved) not traced this update: their exact unoccluded
    /// irradiance where they are now, under the visible fraction of their last trace (held
    /// from a coarse trace, or from the cache's full one). They are coarse from now on.
    fn hold(&mut self, world: &World, ems: &[Emitter], ks: &[usize]) {
        let p = &world.patches;
        let ne = ems.len();
        let this = &*self;
        // Per receiver and emitter (unoccluded, fraction), in one array (not a vector a
        // receiver: 3.4k small vectors a frame for the 77k room's mover).
        let mut per = vec![(0.0f32, 0.0f32); ks.len() * ne];
        let values: Vec<Vec3> = (per.par_chunks_mut(ne.max(1)).zip(ks))
            .map(|(per, &k)| {
                let i = this.receivers[k] as usize;
                let (x, n, reach) = (p.centre[i], p.normal[i], p.radius(i));
                let mut e_total = Vec3::ZERO;
                for ((e, em), out) in ems.iter().enumerate().zip(per) {
                    let unoccluded = patch_unoccluded_irradiance(em, world, i, reach);
                    let fraction = match this.coarse[k] {
                        true => this.held[k * ne + e],
                        false => {
                            let blocked = |j: u32| this.shadows.is_blocked(k * ne + e, j);
                            let shift = sample_shift(i, em, this.stream);
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
                    *out = (unoccluded, fraction);
                }
                e_total
            })
            .collect();
        for ((&k, value), per) in ks.iter().zip(values).zip(per.chunks(ne.max(1))) {
            for (e, &(unoccluded, fraction)) in per.iter().enumerate() {
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
            let reach: Vec<f32> = (ks.par_iter())
                .map(|&k| p.radius(self.receivers[k] as usize))
                .collect();
            for (e, em) in ems.iter().enumerate() {
                // Unoccluded irradiance, exact.
                let unoccluded: Vec<f32> = (ks.par_iter().zip(&reach))
                    .map(|(&k, &reach)| {
                        let i = self.receivers[k] as usize;
                        patch_unoccluded_irradiance(em, world, i, reach)
                    })
                    .collect();
                // Shadow rays to stratified points on the emitter.
                let mut from = vec![Vec3::ZERO; ks.len() * s];
                let mut to = vec![Vec3::ZERO; ks.len() * s];
                // The samples' weights, for a coarse receiver's visible fraction below (found
                // again per sample after the trace, one receiver after another, they were a
                // third of a large mover's own patches).
                let mut weight = vec![0.0f32; ks.len() * s];
                from.par_chunks_mut(s)
                    .zip(to.par_chunks_mut(s))
                    .zip(weight.par_chunks_mut(s))
                    .enumerate()
                    .for_each(|(c, ((f, t), w))| {
                        if unoccluded[c] <= 0.0 {
                            return;
                        }
                        let i = self.receivers[ks[c]] as usize;
                        let (x, n) = (p.centre[i], p.normal[i]);
                        let shift = sample_shift(i, em, self.stream);
                        for j in 0..s {
                            (f[j], t[j], w[j]) =
                                shadow_sample(em, x, n, shift, j as u32, samples, eps);
                        }
                    });
                let lit = |c: usize| unoccluded[c] > 0.0;
                let blocked = occluded_where_lit(world, (&from, &to), s, lit);
                if coarse {
                    for (c, &k) in ks.iter().enumerate() {
                        self.unoccluded[k * ne + e] = unoccluded[c];
                        self.coarse[k] = true;
                        let samples = c * s..(c + 1) * s;
                        let fraction = weighted_fraction(
                            (weight[samples.clone()].iter().copied())
                                .zip(blocked[samples].iter().copied()),
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
                    if !self.weights.is_empty() {
                        self.weights[first..first + s].copy_from_slice(&weight[c * s..(c + 1) * s]);
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
            let (set, samples) = (k * ne + e, self.shadows.samples());
            let blocked = |j: u32| self.shadows.is_blocked(set, j);
            let fraction = match self.weights.is_empty() {
                true => {
                    let shift = sample_shift(i, em, self.stream);
                    visible_fraction(em, (x, n), shift, samples, world.eps, blocked)
                }
                false => {
                    let first = set * samples as usize;
                    let weights = &self.weights[first..first + samples as usize];
                    weighted_fraction((weights.iter().copied()).zip((0..samples).map(blocked)))
                }
            };
            out += em.radiance * (u * fraction);
        }
        out
    }
}
