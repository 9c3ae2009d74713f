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
use shrad_scene::Aabb;

use super::LightState;
use crate::direct::padded_swept;
use crate::sampling::{hammersley, hash, unit};
use crate::World;

/// See the module docs.
#[derive(Clone, Debug, Default)]
pub struct PunctualCache {
    samples: u32,
    words: usize,
    receivers: Vec<u32>,
    /// The lights as traced (`None`: a light that was dark, whose column is zero).
    lights: Vec<Option<LightState>>,
    /// `[k * lights + l]`: mean over receiver `k`'s samples of light `l`'s geometry term.
    reach: Vec<f32>,
    /// `[k * lights + l]`: the same over the samples whose shadow ray is free.
    visible: Vec<f32>,
    /// `[(k * lights + l) * words ..]`: bit `j` set when shadow ray `j` is blocked.
    blocked: Vec<u64>,
    /// `[k]`: the irradiance.
    irradiance: Vec<Vec3>,
    /// The sky's part, kept the same way (`crate::sky`).
    sky: crate::sky::SkyCache,
}

/// Sample `j` of `samples` on receiver `i`: (ray start, geometry point).
fn sample(world: &World, i: usize, j: u32, samples: u32) -> Vec3 {
    let seed = hash(i as u32 ^ 0x51ed_270b);
    let (u, v) = hammersley(j, samples, (unit(seed), unit(hash(seed))));
    world.patches.sample_point(i, u, v)
}

/// Centre and radius (plus `pad`) of receiver `i`'s footprint.
fn footprint(world: &World, i: usize, pad: f32) -> (Vec3, f32) {
    let c = world.patches.centre[i];
    let r = world
        .patches
        .world_corners(i)
        .iter()
        .map(|q| (*q - c).length())
        .fold(0.0, f32::max);
    (c, r + pad)
}

impl PunctualCache {
    /// Trace the punctual direct irradiance of `receivers` with `samples` points each.
    pub fn new(world: &World, receivers: Vec<u32>, samples: u32) -> PunctualCache {
        let samples = samples.max(1);
        let words = (samples as usize).div_ceil(64);
        let nl = world.lights.len();
        let n = receivers.len();
        let mut cache = PunctualCache {
            samples,
            words,
            lights: world.lights.clone(),
            reach: vec![0.0; n * nl],
            visible: vec![0.0; n * nl],
            blocked: vec![0; n * nl * words],
            irradiance: vec![Vec3::ZERO; n],
            sky: crate::sky::SkyCache::new(world, &receivers, samples),
            receivers,
        };
        let all: Vec<usize> = (0..n).collect();
        for l in 0..nl {
            cache.trace(world, l, &all);
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
        self.samples
    }

    /// The lights as last traced.
    pub fn lights(&self) -> &[Option<LightState>] {
        &self.lights
    }

    /// Does it hold the same number of lights as the world?
    pub fn same_lights(&self, world: &World) -> bool {
        self.lights.len() == world.lights.len()
    }

    /// Bring the cache to the world's state after the occluders `old -> new` moved (their
    /// boxes) and the receivers `whole` accepts moved themselves, and whatever the lights
    /// did. Returns the receivers whose irradiance changed, ascending.
    pub fn update(
        &mut self,
        world: &World,
        old: &[Aabb],
        new: &[Aabb],
        whole: impl Fn(u32) -> bool + Sync,
    ) -> Vec<usize> {
        debug_assert!(self.same_lights(world));
        let n = self.receivers.len();
        let all: Vec<usize> = (0..n).collect();
        let mut touched: Vec<usize> = Vec::new();
        let mut moved_lights = vec![false; self.lights.len()];
        for (l, now) in world.lights.iter().enumerate() {
            let then = self.lights[l];
            if then == *now {
                continue;
            }
            touched.clone_from(&all);
            self.lights[l] = *now;
            match (then, now) {
                (Some(a), Some(b)) if a.same_geometry(b) => {}
                _ => moved_lights[l] = true,
            }
        }
        for (l, _) in moved_lights.iter().enumerate().filter(|m| *m.1) {
            self.trace(world, l, &all);
        }
        let whole_ks: Vec<usize> = (0..n)
            .into_par_iter()
            .filter(|&k| whole(self.receivers[k]))
            .collect();
        for l in (0..self.lights.len()).filter(|&l| !moved_lights[l]) {
            self.trace(world, l, &whole_ks);
        }
        touched.extend(&whole_ks);
        touched.extend(self.retrace_near(world, old, new, &whole_ks, &moved_lights));
        touched.extend(self.sky.update(world, old, new, &whole));
        touched.sort_unstable();
        touched.dedup();
        self.evaluate(&touched);
        touched
    }

    /// Re-trace the shadow rays that a mover's old box (blocked rays) or new box (free rays)
    /// meets, of the receivers not in `skip` and the lights not `moved` (both already
    /// traced whole). Returns the receivers whose rays changed.
    fn retrace_near(
        &mut self,
        world: &World,
        old: &[Aabb],
        new: &[Aabb],
        skip: &[usize],
        moved: &[bool],
    ) -> Vec<usize> {
        let eps = world.eps;
        let (old, new) = (padded_swept(old, eps), padded_swept(new, eps));
        if old.is_empty() && new.is_empty() {
            return Vec::new();
        }
        let spheres: Vec<(Vec3, f32)> = old.iter().chain(&new).map(Aabb::bounding_sphere).collect();
        let (nl, samples, words) = (self.lights.len(), self.samples, self.words);
        let far = world.far();
        // Rays to re-trace: (receiver, light, sample, from, to).
        let rays: Vec<(u32, u32, u32, Vec3, Vec3)> = (0..self.receivers.len())
            .into_par_iter()
            .filter(|k| skip.binary_search(k).is_err())
            .flat_map_iter(|k| {
                let i = self.receivers[k] as usize;
                let n = world.patches.normal[i];
                let (c, r) = footprint(world, i, 2.0 * eps);
                let mut out = Vec::new();
                for (l, light) in self.lights.iter().enumerate() {
                    let Some(light) = light.filter(|_| !moved[l]) else {
                        continue;
                    };
                    if self.reach[k * nl + l] <= 0.0
                        || !spheres
                            .iter()
                            .any(|&(bc, br)| bundle_meets_sphere(&light, c, r, far, bc, br))
                    {
                        continue;
                    }
                    let bits = &self.blocked[(k * nl + l) * words..];
                    for j in 0..samples {
                        let blocked = bits[j as usize / 64] & (1 << (j % 64)) != 0;
                        let boxes = if blocked { &old } else { &new };
                        let x = sample(world, i, j, samples);
                        if light.geometry(x, n, eps) <= 0.0 {
                            continue;
                        }
                        let (from, to) = (x + n * eps, light.shadow_end(x, far));
                        if boxes.iter().any(|b| b.meets_segment(from, to)) {
                            out.push((k as u32, l as u32, j, from, to));
                        }
                    }
                }
                out.into_iter()
            })
            .collect();
        let from: Vec<Vec3> = rays.iter().map(|r| r.3).collect();
        let to: Vec<Vec3> = rays.iter().map(|r| r.4).collect();
        let mut blocked = vec![false; rays.len()];
        world.vis.occluded(&from, &to, eps, &[], &mut blocked);
        let mut changed: Vec<(usize, usize)> = Vec::new();
        for (&(k, l, j, ..), &b) in rays.iter().zip(&blocked) {
            let (k, l) = (k as usize, l as usize);
            let w = &mut self.blocked[(k * nl + l) * words + j as usize / 64];
            let bit = 1u64 << (j % 64);
            if b != (*w & bit != 0) {
                *w ^= bit;
                changed.push((k, l));
            }
        }
        changed.sort_unstable();
        changed.dedup();
        for &(k, l) in &changed {
            self.visible[k * nl + l] = self.sum(world, k, l).1;
        }
        let mut ks: Vec<usize> = changed.into_iter().map(|c| c.0).collect();
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
        let bits = &self.blocked[(k * self.lights.len() + l) * self.words..];
        let (mut reach, mut visible) = (0.0, 0.0);
        for j in 0..self.samples {
            let g = light.geometry(sample(world, i, j, self.samples), n, world.eps);
            reach += g;
            if bits[j as usize / 64] & (1 << (j % 64)) == 0 {
                visible += g;
            }
        }
        let s = self.samples as f32;
        (reach / s, visible / s)
    }

    /// Trace light `l`'s shadow rays of receivers `ks` from scratch.
    fn trace(&mut self, world: &World, l: usize, ks: &[usize]) {
        let (nl, words, samples) = (self.lights.len(), self.words, self.samples);
        let s = samples as usize;
        let Some(light) = self.lights[l] else {
            for &k in ks {
                self.reach[k * nl + l] = 0.0;
                self.visible[k * nl + l] = 0.0;
                self.blocked[(k * nl + l) * words..(k * nl + l + 1) * words].fill(0);
            }
            return;
        };
        let far = world.far();
        let eps = world.eps;
        const CHUNK: usize = 4096;
        for ks in ks.chunks(CHUNK) {
            // Per sample: (from, to, geometry); a sample the light does not reach casts no
            // ray (its segment is degenerate and its bit stays clear).
            let rays: Vec<(Vec3, Vec3, f32)> = ks
                .par_iter()
                .flat_map_iter(|&k| {
                    let i = self.receivers[k] as usize;
                    let n = world.patches.normal[i];
                    (0..samples).map(move |j| {
                        let x = sample(world, i, j, samples);
                        let g = light.geometry(x, n, eps);
                        if g > 0.0 {
                            (x + n * eps, light.shadow_end(x, far), g)
                        } else {
                            (x, x, 0.0)
                        }
                    })
                })
                .collect();
            let from: Vec<Vec3> = rays.iter().map(|r| r.0).collect();
            let to: Vec<Vec3> = rays.iter().map(|r| r.1).collect();
            let mut blocked = vec![false; rays.len()];
            world.vis.occluded(&from, &to, eps, &[], &mut blocked);
            for (c, &k) in ks.iter().enumerate() {
                let bits = &mut self.blocked[(k * nl + l) * words..(k * nl + l + 1) * words];
                bits.fill(0);
                let (mut reach, mut visible) = (0.0, 0.0);
                for j in 0..s {
                    let g = rays[c * s + j].2;
                    if g <= 0.0 {
                        continue;
                    }
                    reach += g;
                    if blocked[c * s + j] {
                        bits[j / 64] |= 1 << (j % 64);
                    } else {
                        visible += g;
                    }
                }
                self.reach[k * nl + l] = reach / s as f32;
                self.visible[k * nl + l] = visible / s as f32;
            }
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
            + self.blocked.len() * 8
            + self.sky.bytes()
    }

    /// Is the sky it traced the world's?
    pub fn same_sky(&self, world: &World) -> bool {
        self.sky.same_sky(world)
    }
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
