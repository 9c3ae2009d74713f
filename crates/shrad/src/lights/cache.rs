//! The punctual lights' direct irradiance of a set of patches with what it was made of, so
//! that a frame re-traces only what changed (the dispersive solver's Step 1, paper 2.3.2,
//! keeps its shadow rays the same way for light surfaces: `direct.rs`).
//!
//! Per (receiver, light): the footprint average of the unoccluded geometry term, the average
//! over the samples whose shadow ray is free, and which rays are blocked. The sample points
//! depend on the receiver alone, so rays are regenerated identically when needed. What a
//! change costs:
//! - a light's strength (colour, intensity): nothing traced, its term rescaled;
//! - a light moved (or turned, or its range or cone changed): its own column re-traced;
//! - an occluder moved: only the shadow rays whose segment meets a box it swept (a blocked
//!   ray its old box, a free one its new box; receivers whose bundle of rays misses every
//!   box are skipped at once), and every ray of the receivers that moved themselves.
//!
//! The result equals a fresh cache of the same state (`lights/tests.rs`).

use glam::Vec3;
use rayon::prelude::*;

use super::LightState;
use crate::direct::blocks::{self, group_sphere, BLOCK, GROUP};
use crate::direct::mover_spheres::{Bounds, Moves};
use crate::sampling::{hammersley, hash, unit};
use crate::shadow_rays::{padded_move, ShadowRays};
use crate::World;

/// See the module docs.
#[derive(Clone, Debug, Default)]
pub struct PunctualCache {
    receivers: Vec<u32>,
    /// Whether `receivers` ascend (then an object's receivers are found by binary search).
    ascending: bool,
    /// The lights as traced (`None`: a light that was dark, whose column is zero).
    lights: Vec<Option<LightState>>,
    /// `[k * lights + l]`: mean over receiver `k`'s samples of light `l`'s geometry term.
    reach: Vec<f32>,
    /// `[k * lights + l]`: the same over the samples whose shadow ray is free.
    visible: Vec<f32>,
    /// Set `k * lights + l`: receiver `k`'s shadow rays towards light `l`.
    shadows: ShadowRays,
    /// `[k]`: the irradiance.
    irradiance: Vec<Vec3>,
    /// The sky's part, kept the same way (`crate::sky`).
    sky: crate::sky::SkyCache,
    /// Receivers that moved and were not traced since, ascending: a moving receiver is traced
    /// only when its light is read after the update (`update`'s `read`), or once it rests.
    unread: Vec<usize>,
    /// `[b]`: a sphere holding the footprints of receivers `b * BLOCK ..` (consecutive
    /// receivers are patches of one object, near one another), so that a mover no light's
    /// bundle to it meets rejects the whole block at once (`retrace_near`).
    blocks: Vec<(Vec3, f32)>,
    /// `[g]`: a sphere holding the spheres of blocks `g * GROUP ..`.
    groups: Vec<(Vec3, f32)>,
}

/// Sample `j` of `samples` on receiver `i`: (ray start, geometry point).
fn sample(world: &World, i: usize, j: u32, samples: u32) -> Vec3 {
    let seed = hash(i as u32 ^ 0x51ed_270b);
    let (u, v) = hammersley(j, samples, (unit(seed), unit(hash(seed))));
    world.patches.sample_point(i, u, v)
}

/// Centre and radius (plus `pad`) of receiver `i`'s footprint.
fn footprint(world: &World, i: usize, pad: f32) -> (Vec3, f32) {
    (world.patches.centre[i], world.patches.radius(i) + pad)
}

impl PunctualCache {
    /// Trace the punctual direct irradiance of `receivers` with `samples` points each.
    pub fn new(world: &World, receivers: Vec<u32>, samples: u32) -> PunctualCache {
        let samples = samples.max(1);
        let nl = world.lights.len();
        let n = receivers.len();
        let mut cache = PunctualCache {
            lights: world.lights.clone(),
            reach: vec![0.0; n * nl],
            visible: vec![0.0; n * nl],
            shadows: ShadowRays::new(n * nl, samples),
            irradiance: vec![Vec3::ZERO; n],
            sky: crate::sky::SkyCache::new(world, &receivers, samples),
            unread: Vec::new(),
            blocks: Vec::new(),
            groups: Vec::new(),
            ascending: receivers.is_sorted(),
            receivers,
        };
        cache.blocks = (cache.receivers.chunks(BLOCK))
            .map(|ks| footprints_sphere(world, ks))
            .collect();
        cache.groups = cache.blocks.chunks(GROUP).map(group_sphere).collect();
        let all: Vec<usize> = (0..n).collect();
        for l in 0..nl {
            cache.trace(world, l, &all, None);
        }
        cache.evaluate(&all);
        cache
    }

    /// The receivers, as given to [`PunctualCache::new`].
    pub fn receivers(&self) -> &[u32] {
        &self.receivers
    }

    /// Irradiance of each receiver (aligned with [`PunctualCache::receivers`]).
    pub fn irradiance(&self) -> &[Vec3] {
        &self.irradiance
    }

    /// Sample points (shadow rays) per (receiver, light).
    pub fn samples(&self) -> u32 {
        self.shadows.samples()
    }

    /// The lights as last traced.
    pub fn lights(&self) -> &[Option<LightState>] {
        &self.lights
    }

    /// Whether receivers that moved wait to be traced (they are once they rest).
    pub fn catching_up(&self) -> bool {
        !self.unread.is_empty()
    }

    /// Does it hold the same number of lights as the world?
    pub fn same_lights(&self, world: &World) -> bool {
        self.lights.len() == world.lights.len()
    }

    /// Bring the cache to the world's state after the occluders moved (`moves`: their boxes,
    /// and spheres about them where known) and the patches of objects `moved` with them, and whatever the lights did. A
    /// receiver that moved is traced now if `read` says its light is read after this update
    /// (the dispersive solver's Step 2 lights its object this frame), else it keeps what it
    /// had until it is read or rests ([`PunctualCache::catching_up`]): the 77k room's
    /// largest object, with a point light, traced its 4,512 patches every moving frame
    /// though Step 2 lights it one frame in three. Traced while it moves, it takes
    /// `moving_samples` rays a light (fewer than the cache's, say: `coarse_while_moving`),
    /// and every sample once it rests: the courtyard's sliding block took 6-10 ms of its
    /// lit frames with all 16. The sky's part follows the same choices.
    /// Returns the receivers whose irradiance changed, ascending.
    pub fn update(
        &mut self,
        world: &World,
        moves: Moves,
        (moved, moving_samples): (&[usize], u32),
        read: impl Fn(u32) -> bool + Sync,
    ) -> Vec<usize> {
        debug_assert!(self.same_lights(world));
        let n = self.receivers.len();
        // Every receiver, only when a light changed (a list of the 1M-patch room's receivers
        // is 8 MB).
        let all = || (0..n).collect::<Vec<usize>>();
        let mut touched: Vec<usize> = Vec::new();
        let mut moved_lights = vec![false; self.lights.len()];
        for (l, now) in world.lights.iter().enumerate() {
            let then = self.lights[l];
            if then == *now {
                continue;
            }
            if touched.len() != n {
                touched = all();
            }
            self.lights[l] = *now;
            match (then, now) {
                (Some(a), Some(b)) if a.same_geometry(b) => {}
                _ => moved_lights[l] = true,
            }
        }
        for (l, _) in moved_lights.iter().enumerate().filter(|m| *m.1) {
            self.trace(world, l, &all(), None);
        }
        let moving = self.receivers_of(world, moved);
        let coarse = (moving_samples < self.shadows.samples()).then_some(moving_samples.max(1));
        let (whole_ks, coarse_ks) = self.traced_now(&moving, &read, coarse.is_some());
        for l in (0..self.lights.len()).filter(|&l| !moved_lights[l]) {
            self.trace(world, l, &whole_ks, None);
            self.trace(world, l, &coarse_ks, coarse);
        }
        let spheres = (&mut self.blocks[..], &mut self.groups[..]);
        let moving_ks = (&self.receivers[..], &moving[..]);
        blocks::refresh(spheres, moving_ks, |ks| footprints_sphere(world, ks));
        touched.extend(whole_ks.iter().chain(&coarse_ks));
        // Neither those traced whole nor those still waiting (the coarse ones too) have rays
        // worth amending.
        let mut skip = [&whole_ks[..], &self.unread[..]].concat();
        skip.sort_unstable();
        // Padded once for the lamps' rays and the sky's.
        let swept = padded_move(moves, world.eps);
        touched.extend(self.retrace_near(world, swept.as_ref(), &skip, &moved_lights));
        let traced = (&whole_ks[..], &coarse_ks[..], coarse);
        touched.extend(self.sky.update(world, swept.as_ref(), traced, &skip));
        touched.sort_unstable();
        touched.dedup();
        self.evaluate(&touched);
        touched
    }

    /// The indices of the receivers that are patches of `objects`, ascending: where the
    /// receivers ascend (the solvers' do), by the objects' ranges, not by a pass over every
    /// receiver (2.7 ms of the 1M-patch room's moving frame with a point light).
    fn receivers_of(&self, world: &World, objects: &[usize]) -> Vec<usize> {
        let p = &world.patches;
        if objects.is_empty() {
            return Vec::new();
        }
        if !self.ascending {
            return (0..self.receivers.len())
                .into_par_iter()
                .filter(|&k| objects.contains(&(p.object[self.receivers[k] as usize] as usize)))
                .collect();
        }
        p.positions_in(&self.receivers, objects.iter().copied())
    }

    /// Of the receivers that moved (`moving`, ascending) and those waiting since they last
    /// moved, those traced now, ascending: whole, the ones at rest (and the ones read after
    /// this update, unless `coarse`); with fewer samples, the ones read that move, if
    /// `coarse`. The ones that move wait (`unread`) to be traced whole once they rest.
    fn traced_now(
        &mut self,
        moving: &[usize],
        read: impl Fn(u32) -> bool,
        coarse: bool,
    ) -> (Vec<usize>, Vec<usize>) {
        let mut candidates = [moving, &self.unread[..]].concat();
        candidates.sort_unstable();
        candidates.dedup();
        let (mut whole, mut coarse_ks, mut wait) = (Vec::new(), Vec::new(), Vec::new());
        for k in candidates {
            let moves = moving.binary_search(&k).is_ok();
            match (moves, moves && read(self.receivers[k])) {
                (false, _) => whole.push(k),
                (true, true) if !coarse => whole.push(k),
                (true, true) => {
                    coarse_ks.push(k);
                    wait.push(k);
                }
                (true, false) => wait.push(k),
            }
        }
        self.unread = wait;
        (whole, coarse_ks)
    }

    /// Re-trace the shadow rays that a mover's old box (blocked rays) or new box (free rays)
    /// meets, of the receivers not in `skip` (ascending) and the lights not `moved` (both
    /// already traced whole). Returns the receivers whose rays changed.
    fn retrace_near(
        &mut self,
        world: &World,
        swept: Option<&(Bounds, Bounds)>,
        skip: &[usize],
        moved: &[bool],
    ) -> Vec<usize> {
        let eps = world.eps;
        let Some((old, new)) = swept else {
            return Vec::new();
        };
        let spheres: Vec<(Vec3, f32)> = old.1.iter().chain(&new.1).copied().collect();
        let (nl, samples) = (self.lights.len(), self.shadows.samples());
        let far = world.far();
        // The (receiver, light) sets whose bundle of rays may meet a box: whole groups and
        // blocks of receivers first (a pass over every receiver of the 77k room was 8 ms of
        // one thread a frame with one point light).
        let (lights, reach) = (&self.lights, &self.reach);
        let meets = |(c, r): (Vec3, f32), l: usize| {
            lights[l].filter(|_| !moved[l]).is_some_and(|light| {
                (spheres.iter()).any(|&(bc, br)| bundle_meets_sphere(&light, c, r, far, bc, br))
            })
        };
        let (n, nb) = (self.receivers.len(), self.blocks.len());
        let sets: Vec<usize> = (0..self.groups.len())
            .into_par_iter()
            .filter(|&g| (0..nl).any(|l| meets(self.groups[g], l)))
            .flat_map_iter(|g| {
                let blocks = (g * GROUP..((g + 1) * GROUP).min(nb))
                    .filter(|&b| (0..nl).any(|l| meets(self.blocks[b], l)));
                let ks = blocks.flat_map(|b| b * BLOCK..((b + 1) * BLOCK).min(n));
                ks.filter(|k| skip.binary_search(k).is_err())
                    .flat_map(|k| {
                        let at = footprint(world, self.receivers[k] as usize, 2.0 * eps);
                        (0..nl)
                            .filter(move |&l| reach[k * nl + l] > 0.0 && meets(at, l))
                            .map(move |l| k * nl + l)
                    })
                    .collect::<Vec<usize>>()
            })
            .collect();
        let rays = self.shadows.near_movers(&sets, old, new, |set| {
            let i = self.receivers[set / nl] as usize;
            let light = self.lights[set % nl];
            let n = world.patches.normal[i];
            move |j| {
                let light = light?;
                let x = sample(world, i, j, samples);
                (light.geometry(x, n, eps) > 0.0).then(|| (x + n * eps, light.shadow_end(x, far)))
            }
        });
        let changed = self.shadows.retrace(world, &rays);
        for &set in &changed {
            let (k, l) = (set / nl, set % nl);
            self.visible[set] = self.sum(world, k, l).1;
        }
        let mut ks: Vec<usize> = changed.into_iter().map(|set| set / nl).collect();
        ks.dedup();
        ks
    }

    /// `(reach, visible)` of receiver `k` and light `l` from the cached blocked bits.
    fn sum(&self, world: &World, k: usize, l: usize) -> (f32, f32) {
        let Some(light) = self.lights[l] else {
            return (0.0, 0.0);
        };
        let i = self.receivers[k] as usize;
        let n = world.patches.normal[i];
        let (set, samples) = (k * self.lights.len() + l, self.shadows.samples());
        let (mut reach, mut visible) = (0.0, 0.0);
        for j in 0..samples {
            let g = light.geometry(sample(world, i, j, samples), n, world.eps);
            reach += g;
            if !self.shadows.is_blocked(set, j) {
                visible += g;
            }
        }
        let s = samples as f32;
        (reach / s, visible / s)
    }

    /// Trace light `l`'s shadow rays of receivers `ks` from scratch; with `coarse`, that many
    /// samples each, keeping only their sums (the receivers' rays are traced whole later).
    fn trace(&mut self, world: &World, l: usize, ks: &[usize], coarse: Option<u32>) {
        let nl = self.lights.len();
        let sets: Vec<usize> = ks.iter().map(|&k| k * nl + l).collect();
        let Some(light) = self.lights[l] else {
            for &set in &sets {
                self.reach[set] = 0.0;
                self.visible[set] = 0.0;
                self.shadows.clear(set);
            }
            return;
        };
        let (far, eps) = (world.far(), world.eps);
        let samples = coarse.unwrap_or(self.shadows.samples());
        let receivers = &self.receivers;
        // A sample the light does not reach casts no ray (its bit stays clear).
        let ray = |set: usize, j: u32| {
            let i = receivers[set / nl] as usize;
            let n = world.patches.normal[i];
            let x = sample(world, i, j, samples);
            let g = light.geometry(x, n, eps);
            (g > 0.0).then(|| (x + n * eps, light.shadow_end(x, far), g))
        };
        let sums = match coarse {
            None => self.shadows.trace(world, &sets, ray),
            Some(samples) => ShadowRays::trace_sums(world, &sets, samples, ray),
        };
        for (&set, (reach, visible)) in sets.iter().zip(sums) {
            self.reach[set] = reach / samples as f32;
            self.visible[set] = visible / samples as f32;
        }
    }

    /// Irradiance of receivers `ks` from what is cached.
    fn evaluate(&mut self, ks: &[usize]) {
        let nl = self.lights.len();
        for &k in ks {
            self.irradiance[k] = self
                .lights
                .iter()
                .enumerate()
                .filter_map(|(l, s)| s.map(|s| s.strength * self.visible[k * nl + l]))
                .sum::<Vec3>()
                + self.sky.irradiance().get(k).copied().unwrap_or(Vec3::ZERO);
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.receivers.len() * 16
            + (self.reach.len() + self.visible.len()) * 4
            + self.shadows.bytes()
            + self.sky.bytes()
    }

    /// Is the sky it traced the world's?
    pub fn same_sky(&self, world: &World) -> bool {
        self.sky.same_sky(world)
    }
}

/// A sphere holding the footprints of `receivers` (padded as `retrace_near` pads them), so
/// that a bundle of rays from it holds each one's bundle.
fn footprints_sphere(world: &World, receivers: &[u32]) -> (Vec3, f32) {
    let spheres: Vec<(Vec3, f32)> = (receivers.iter())
        .map(|&i| footprint(world, i as usize, 2.0 * world.eps))
        .collect();
    group_sphere(&spheres)
}

/// Can a shadow ray of `light` from a point of the sphere `(c, r)` meet the sphere
/// `(bc, br)`? For a point or spot light the rays fill the cone from the light to the
/// footprint's sphere (exact test: `cone_meets_sphere`); for a directional light the
/// footprint's sphere swept `far` against the light's direction (a capsule).
fn bundle_meets_sphere(light: &LightState, c: Vec3, r: f32, far: f32, bc: Vec3, br: f32) -> bool {
    if !light.is_directional() {
        return crate::direct::cone_meets_sphere(light.position, c, r, bc, br);
    }
    let axis = -light.direction;
    let s = (bc - c).dot(axis).clamp(0.0, far);
    (bc - (c + axis * s)).length() <= (r + br) * (1.0 + 1e-5) + 1e-6
}
