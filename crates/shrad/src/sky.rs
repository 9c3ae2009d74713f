//! The sky (spec section 2, "Lights that are not surfaces"): radiance from outside the
//! scene, a uniform value or an equirectangular map ([`shrad_scene::Environment`]), met by
//! every ray that leaves the scene.
//!
//! Like a punctual light it has no surface, so its light enters where the paper puts every
//! light's, the direct-light step (2.3.2): [`SkyCache`] gives each patch the footprint
//! average of `E = int L(w) V(w) cos(theta) dw` with sampled visibility (one shadow ray a
//! sample, towards `far`), and every later step carries the reflected light unchanged. A
//! uniform sky is sampled by cosine (an unoccluded sample gives exactly `pi L`); a map by a
//! mixture of its luminance (a luminance x `sin(theta)` CDF over the texels, so a small
//! bright sun converges) and cosine, each sample weighted by the mixture's density (unbiased
//! whatever the map). The cache keeps which rays are blocked, so a mover re-traces only the
//! rays that meet a box it swept (exactly what a fresh cache gives); a changed sky re-traces
//! everything. Pictures evaluate the same estimator per pixel ([`point_irradiance`]) and
//! show the sky where a primary ray leaves the scene ([`Sky::radiance`]).
//!
//! Probes do not see the sky: its direct light is on every patch already (as a punctual
//! light's), so a probe that saw it would count it twice.

use std::f32::consts::{PI, TAU};
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Environment;

use crate::direct::mover_spheres::Bounds;
use crate::footprint_cones::{self, FootprintCones};
use crate::sampling::{hammersley, hash, hash2, square_to_cosine_hemisphere, unit};
use crate::shadow_rays::ShadowRays;
use crate::World;

/// The sky ready for lookups and sampling.
#[derive(Debug)]
pub struct Sky {
    /// As the scene gave it.
    pub environment: Environment,
    /// Scaled uniform radiance (no map).
    uniform: Vec3,
    /// Scaled texels, row 0 at the top.
    texels: Vec<Vec3>,
    width: usize,
    height: usize,
    /// `(sin, cos)` of the rotation about +Y.
    rot: (f32, f32),
    /// Cumulative row weights (`height + 1`, last = 1).
    marginal: Vec<f32>,
    /// Per row, cumulative texel weights (`width + 1` each, last = 1).
    conditional: Vec<f32>,
    /// Per texel, its probability.
    prob: Vec<f32>,
}

fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// Index of the interval of the cumulative `cdf` (ascending, first 0) holding `u`.
fn find(cdf: &[f32], u: f32) -> usize {
    let k = cdf.partition_point(|&c| c <= u);
    k.clamp(1, cdf.len() - 1) - 1
}

impl Sky {
    /// The sky of `environment` (checked by [`Environment::problem`] where it was made).
    pub fn new(environment: &Environment) -> Sky {
        let s = environment.scale;
        let r = environment.rotate_deg.to_radians();
        let mut sky = Sky {
            environment: environment.clone(),
            uniform: environment.radiance * s,
            texels: Vec::new(),
            width: 0,
            height: 0,
            rot: r.sin_cos(),
            marginal: Vec::new(),
            conditional: Vec::new(),
            prob: Vec::new(),
        };
        if let Some(map) = &environment.map {
            let (w, h) = (map.width as usize, map.height as usize);
            sky.texels = map.texels.iter().map(|t| *t * s).collect();
            sky.width = w;
            sky.height = h;
            sky.build_cdf();
        }
        sky
    }

    fn build_cdf(&mut self) {
        let (w, h) = (self.width, self.height);
        let mut weights = vec![0.0f64; w * h];
        for y in 0..h {
            let st = (PI * (y as f32 + 0.5) / h as f32).sin() as f64;
            for x in 0..w {
                weights[y * w + x] = luminance(self.texels[y * w + x]).max(0.0) as f64 * st;
            }
        }
        let total: f64 = weights.iter().sum();
        if total <= 0.0 {
            return;
        }
        self.prob = weights.iter().map(|&x| (x / total) as f32).collect();
        self.conditional = vec![0.0; h * (w + 1)];
        self.marginal = vec![0.0; h + 1];
        let mut acc_rows = 0.0f64;
        for y in 0..h {
            let row: f64 = weights[y * w..(y + 1) * w].iter().sum();
            let c = &mut self.conditional[y * (w + 1)..(y + 1) * (w + 1)];
            let mut acc = 0.0f64;
            for x in 0..w {
                acc += weights[y * w + x];
                c[x + 1] = if row > 0.0 {
                    (acc / row) as f32
                } else {
                    (x + 1) as f32 / w as f32
                };
            }
            c[w] = 1.0;
            acc_rows += row;
            self.marginal[y + 1] = (acc_rows / total) as f32;
        }
        self.marginal[h] = 1.0;
    }

    /// Is it a uniform sky (no map)?
    pub fn is_uniform(&self) -> bool {
        self.width == 0
    }

    /// Does it send no light?
    pub fn is_black(&self) -> bool {
        if self.is_uniform() {
            self.uniform.max_element() <= 0.0
        } else {
            self.prob.is_empty()
        }
    }

    /// The map's `(u, v)` in [0, 1)^2 of the world direction `d` (unit).
    fn uv(&self, d: Vec3) -> (f32, f32) {
        // World = R_y(rot) local: local = R_y(-rot) world.
        let (s, c) = self.rot;
        let lx = c * d.x - s * d.z;
        let lz = s * d.x + c * d.z;
        let u = lx.atan2(-lz) / TAU;
        let u = if u < 0.0 { u + 1.0 } else { u };
        (u.min(0.999_999), d.y.clamp(-1.0, 1.0).acos() / PI)
    }

    /// World direction of the map's `(u, v)`.
    fn direction(&self, u: f32, v: f32) -> Vec3 {
        let (sp, cp) = (TAU * u).sin_cos();
        let (st, ct) = (PI * v).sin_cos();
        let (lx, ly, lz) = (sp * st, ct, -cp * st);
        let (s, c) = self.rot;
        Vec3::new(c * lx + s * lz, ly, -s * lx + c * lz)
    }

    fn texel(&self, u: f32, v: f32) -> usize {
        let x = ((u * self.width as f32) as usize).min(self.width - 1);
        let y = ((v * self.height as f32) as usize).min(self.height - 1);
        y * self.width + x
    }

    /// Radiance arriving from the world direction `d` (unit): what a ray leaving the scene
    /// along `d` sees.
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        if self.is_uniform() {
            return self.uniform;
        }
        let (u, v) = self.uv(d);
        self.texels[self.texel(u, v)]
    }

    /// Solid-angle density of [`Sky::sample_map`] at `d`.
    fn map_pdf(&self, d: Vec3) -> f32 {
        if self.prob.is_empty() {
            return 0.0;
        }
        let (u, v) = self.uv(d);
        let st = (PI * v).sin();
        if st <= 0.0 {
            return 0.0;
        }
        self.prob[self.texel(u, v)] * (self.width * self.height) as f32 / (2.0 * PI * PI * st)
    }

    /// A direction drawn by the map's luminance from `(a, b)` in [0, 1)^2.
    fn sample_map(&self, a: f32, b: f32) -> Vec3 {
        let y = find(&self.marginal, a);
        let (m0, m1) = (self.marginal[y], self.marginal[y + 1]);
        let fy = if m1 > m0 { (a - m0) / (m1 - m0) } else { 0.5 };
        let c = &self.conditional[y * (self.width + 1)..(y + 1) * (self.width + 1)];
        let x = find(c, b);
        let fx = if c[x + 1] > c[x] {
            (b - c[x]) / (c[x + 1] - c[x])
        } else {
            0.5
        };
        let u = (x as f32 + fx.clamp(0.0, 1.0)) / self.width as f32;
        let v = (y as f32 + fy.clamp(0.0, 1.0)) / self.height as f32;
        self.direction(u, v)
    }

    /// Sample `j` of an estimate of the irradiance at a point of unit normal `n` from
    /// `(a, b)` in [0, 1)^2: the direction and its weight `L cos / pdf` (zero below the
    /// horizon). A uniform sky is sampled by cosine; a map by its luminance for even `j`
    /// and by cosine for odd `j`, weighted by the mixture of the two densities.
    pub fn sample(&self, n: Vec3, j: u32, a: f32, b: f32) -> (Vec3, Vec3) {
        if self.is_uniform() {
            return (square_to_cosine_hemisphere(a, b, n), self.uniform * PI);
        }
        if self.prob.is_empty() {
            return (n, Vec3::ZERO);
        }
        let d = if j % 2 == 0 {
            self.sample_map(a, b)
        } else {
            square_to_cosine_hemisphere(a, b, n)
        };
        let cos = n.dot(d);
        if cos <= 1e-6 {
            return (d, Vec3::ZERO);
        }
        let pdf = 0.5 * self.map_pdf(d) + 0.5 * cos / PI;
        if pdf <= 0.0 {
            return (d, Vec3::ZERO);
        }
        (d, self.radiance(d) * (cos / pdf))
    }
}

/// The world's sky, if it has one that sends light.
fn lit(world: &World) -> Option<&Arc<Sky>> {
    world.sky.as_ref().filter(|s| !s.is_black())
}

/// Sample `j` of `samples` on receiver `i`: (footprint point, direction, weight).
fn receiver_sample(world: &World, sky: &Sky, i: usize, j: u32, samples: u32) -> (Vec3, Vec3, Vec3) {
    let seed = hash(i as u32 ^ 0x5c4e_9d1b);
    let (u, v) = hammersley(j, samples, (unit(seed), unit(hash(seed))));
    let x = world.patches.sample_point(i, u, v);
    let (d, w) = sample_direction(world, sky, i, j, samples);
    (x, d, w)
}

/// The direction and weight of [`receiver_sample`] (not its point).
fn sample_direction(world: &World, sky: &Sky, i: usize, j: u32, samples: u32) -> (Vec3, Vec3) {
    let seed = hash(i as u32 ^ 0x5c4e_9d1b);
    // The direction from a second, independent stratified pair.
    let s2 = hash2(seed, 0x2f6b_11a3);
    let (a, b) = hammersley(
        (j.wrapping_mul(7919)) % samples,
        samples,
        (unit(s2), unit(hash(s2))),
    );
    sky.sample(world.patches.normal[i], j, a, b)
}

/// The sky's direct irradiance of a set of patches with the rays it was made of (see the
/// module docs).
#[derive(Clone, Debug, Default)]
pub struct SkyCache {
    sky: Option<Arc<Sky>>,
    receivers: Vec<u32>,
    /// Set `k`: receiver `k`'s rays.
    shadows: ShadowRays,
    /// `[k]`: the irradiance.
    irradiance: Vec<Vec3>,
    /// `[k * samples + j]`: the direction of receiver `k`'s ray `j`, kept
    /// ([`footprint_cones::encode`]) so that a mover's cones reject most rays without
    /// regenerating them ([`SkyCache::retrace_near`]); empty above [`MAX_KEPT_DIRECTIONS`]
    /// rays (every sample is regenerated then).
    directions: Vec<[u16; 2]>,
    /// `[k]`: whether receiver `k`'s directions are kept as it stands (a receiver that
    /// moved has them again when a mover next makes it look).
    directions_kept: Vec<bool>,
}

/// The most sky rays whose directions [`SkyCache`] keeps (4 bytes each: 32 MB; the 77k room's
/// 4.6M take 18 MB).
const MAX_KEPT_DIRECTIONS: usize = 1 << 23;

impl SkyCache {
    /// Trace the sky's direct irradiance of `receivers` with `samples` rays each (an empty
    /// cache when the world has no sky that sends light).
    pub fn new(world: &World, receivers: &[u32], samples: u32) -> SkyCache {
        let n = receivers.len();
        let mut cache = SkyCache {
            sky: lit(world).cloned(),
            receivers: receivers.to_vec(),
            shadows: ShadowRays::new(n, samples),
            irradiance: vec![Vec3::ZERO; n],
            directions: Vec::new(),
            directions_kept: vec![false; n],
        };
        if cache.sky.is_some() {
            let all: Vec<usize> = (0..n).collect();
            cache.trace(world, &all, None);
            if n * samples as usize <= MAX_KEPT_DIRECTIONS {
                cache.directions = vec![[0; 2]; n * samples as usize];
                cache.keep_directions(world, &all);
            }
        }
        cache
    }

    /// Irradiance of each receiver (aligned with the receivers given).
    pub fn irradiance(&self) -> &[Vec3] {
        &self.irradiance
    }

    /// Is this the sky the world has now?
    pub fn same_sky(&self, world: &World) -> bool {
        match (&self.sky, lit(world)) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }

    /// Bring the cache to the world's state after occluders moved (`swept`: where they were
    /// and are, as [`crate::shadow_rays::padded_move`] gives them; `None` when nothing moved):
    /// receivers `whole_ks` are traced whole (they moved, and their light is read now or they
    /// rest: [`crate::lights::PunctualCache::update`] decides, for the sky as for the lights)
    /// and `coarse_ks` (moving, read now) with `coarse` samples, the rays of the others not
    /// in `skip` (ascending: those traced, and those that moved and wait) are amended where a
    /// swept box meets them; a changed sky re-traces everything. Returns the receivers whose
    /// irradiance changed, ascending.
    pub(crate) fn update(
        &mut self,
        world: &World,
        swept: Option<&(Bounds, Bounds)>,
        (whole_ks, coarse_ks, coarse): (&[usize], &[usize], Option<u32>),
        skip: &[usize],
    ) -> Vec<usize> {
        let n = self.receivers.len();
        if !self.same_sky(world) {
            *self = SkyCache::new(world, &self.receivers, self.shadows.samples());
            return (0..n).collect();
        }
        if self.sky.is_none() {
            return Vec::new();
        }
        self.trace(world, whole_ks, None);
        self.trace(world, coarse_ks, coarse);
        let mut touched = [whole_ks, coarse_ks].concat();
        touched.extend(self.retrace_near(world, swept, skip));
        touched.sort_unstable();
        touched.dedup();
        touched
    }

    /// Re-trace the rays of receivers not in `skip` that a mover's old box (blocked rays) or
    /// new box (free rays) meets; returns the receivers whose irradiance changed. Where the
    /// rays' directions are kept, only those in a cone from the receiver's footprint to a
    /// box's sphere are regenerated and tested ([`FootprintCones`]: the same rays found).
    fn retrace_near(
        &mut self,
        world: &World,
        swept: Option<&(Bounds, Bounds)>,
        skip: &[usize],
    ) -> Vec<usize> {
        let (Some(sky), Some((old, new))) = (self.sky.clone(), swept) else {
            return Vec::new();
        };
        let eps = world.eps;
        let (samples, far) = (self.shadows.samples(), world.far());
        let sets: Vec<usize> = (0..self.receivers.len())
            .filter(|k| skip.binary_search(k).is_err())
            .collect();
        if !self.directions.is_empty() {
            let moved: Vec<usize> = (sets.iter())
                .filter(|&&k| !self.directions_kept[k])
                .copied()
                .collect();
            self.keep_directions(world, &moved);
        }
        let spheres = [&old.1[..], &new.1[..]];
        let this = &*self;
        let rays = self.shadows.near_movers(&sets, old, new, |k| {
            let i = this.receivers[k] as usize;
            let n = world.patches.normal[i];
            // The footprint holds every ray's start (a point of the patch, lifted by eps).
            let footprint = (
                world.patches.centre[i],
                world.patches.radius(i) * 1.001 + 2.0 * eps,
            );
            let kept = (!this.directions.is_empty()).then(|| {
                let s = samples as usize;
                &this.directions[k * s..(k + 1) * s]
            });
            // Bit `j` of word `j / 64` set where ray `j` may meet a box, 64 at a time (a
            // blocked ray the boxes where the movers were, a free one where they are).
            // A receiver's words in place (no vector a receiver: 72k a frame at 77k); more
            // than 256 samples are all regenerated.
            let candidates: Option<[u64; 4]> = kept.filter(|k| k.len() <= 256).and_then(|kept| {
                let cones = FootprintCones::new(footprint, spheres)?;
                let mut words = [0u64; 4];
                for (w, kept) in kept.chunks(64).enumerate() {
                    words[w] = cones.meeting(kept, this.shadows.blocked_word(k, w));
                }
                Some(words)
            });
            let sky = &sky;
            move |j| {
                if let Some(words) = &candidates {
                    if words[j as usize / 64] >> (j % 64) & 1 == 0 {
                        return None;
                    }
                }
                let (x, d, w) = receiver_sample(world, sky, i, j, samples);
                (w.max_element() > 0.0).then(|| (x + n * eps, x + d * far))
            }
        });
        let changed = self.shadows.retrace(world, &rays);
        // Side by side: under an open sky a mover's shadow may change thousands of
        // receivers, each summing its free samples' weights again.
        let sums: Vec<Vec3> = (changed.par_iter())
            .map(|&k| self.sum(world, &sky, k))
            .collect();
        for (&k, e) in changed.iter().zip(sums) {
            self.irradiance[k] = e;
        }
        changed
    }

    /// Keep the directions of receivers `ks`' rays as they stand.
    fn keep_directions(&mut self, world: &World, ks: &[usize]) {
        let (Some(sky), s) = (self.sky.as_ref(), self.shadows.samples()) else {
            return;
        };
        let receivers = &self.receivers;
        let kept: Vec<[u16; 2]> = (ks.par_iter())
            .flat_map_iter(|&k| {
                let i = receivers[k] as usize;
                (0..s)
                    .map(move |j| footprint_cones::encode(sample_direction(world, sky, i, j, s).0))
            })
            .collect();
        let s = s as usize;
        for (&k, kept) in ks.iter().zip(kept.chunks(s)) {
            self.directions[k * s..(k + 1) * s].copy_from_slice(kept);
            self.directions_kept[k] = true;
        }
    }

    /// Irradiance of receiver `k` from its cached blocked bits.
    fn sum(&self, world: &World, sky: &Sky, k: usize) -> Vec3 {
        let i = self.receivers[k] as usize;
        let samples = self.shadows.samples();
        let mut e = Vec3::ZERO;
        for j in 0..samples {
            if !self.shadows.is_blocked(k, j) {
                e += sample_direction(world, sky, i, j, samples).1;
            }
        }
        e / samples as f32
    }

    /// Trace receivers `ks` from scratch; with `coarse`, that many samples each, keeping
    /// only their sums (the receivers' rays are traced whole later).
    fn trace(&mut self, world: &World, ks: &[usize], coarse: Option<u32>) {
        let Some(sky) = self.sky.clone() else {
            return;
        };
        let (eps, far) = (world.eps, world.far());
        let samples = coarse.unwrap_or(self.shadows.samples());
        let receivers = &self.receivers;
        // A sample of no weight casts no ray (its bit stays clear).
        let ray = |k: usize, j: u32| {
            let i = receivers[k] as usize;
            let n = world.patches.normal[i];
            let (x, d, w) = receiver_sample(world, &sky, i, j, samples);
            (w.max_element() > 0.0).then(|| (x + n * eps, x + d * far, w))
        };
        let sums = match coarse {
            None => self.shadows.trace(world, ks, ray),
            Some(samples) => ShadowRays::trace_sums(world, ks, samples, ray),
        };
        for (&k, (_, free)) in ks.iter().zip(sums) {
            self.irradiance[k] = free / samples as f32;
            // A receiver traced again has moved (or is new): its rays' directions are kept
            // again when a mover next makes it look (`retrace_near`).
            self.directions_kept[k] = false;
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.receivers.len() * 17 + self.shadows.bytes() + self.directions.len() * 4
    }
}

/// Rays a picture casts per pixel towards the sky.
pub const PIXEL_SAMPLES: u32 = 32;

/// Points whose sky rays [`point_irradiance`] casts at once: its rays and their outcomes take
/// about 2 MB a thousand points. All at once, a 512 x 512 picture of the courtyard (9 samples
/// a pixel) took 1.4 GB and a 1024 x 1024 one 5.4 GB.
const POINTS_AT_ONCE: usize = 16_384;

/// The sky's direct irradiance at the points `xs` (unit normals `ns`), [`PIXEL_SAMPLES`]
/// rays each: what a picture shows per pixel. Zero without a sky.
pub fn point_irradiance(world: &World, xs: &[Vec3], ns: &[Vec3]) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; xs.len()];
    let Some(sky) = lit(world) else {
        return out;
    };
    for (c, chunk) in out.chunks_mut(POINTS_AT_ONCE).enumerate() {
        let first = c * POINTS_AT_ONCE;
        let points = first..first + chunk.len();
        point_irradiance_into(world, sky, (&xs[points.clone()], &ns[points]), first, chunk);
    }
    out
}

/// [`point_irradiance`] of the points `xs` (normals `ns`) under `sky`, the first of which is
/// point `first` of the whole (its samples' seed), added to `out`.
fn point_irradiance_into(
    world: &World,
    sky: &Sky,
    (xs, ns): (&[Vec3], &[Vec3]),
    first: usize,
    out: &mut [Vec3],
) {
    let (eps, far, s) = (world.eps, world.far(), PIXEL_SAMPLES);
    let rays: Vec<(Vec3, Vec3, Vec3)> = (0..xs.len())
        .into_par_iter()
        .flat_map_iter(|k| {
            let (x, n) = (xs[k], ns[k]);
            let seed = hash((first + k) as u32 ^ 0x7a3d_c5e1);
            (0..s).map(move |j| {
                let (a, b) = hammersley(j, s, (unit(seed), unit(hash(seed))));
                let (d, w) = sky.sample(n, j, a, b);
                (x + n * eps, x + d * far, w)
            })
        })
        .collect();
    let from: Vec<Vec3> = rays.iter().map(|r| r.0).collect();
    let to: Vec<Vec3> = rays.iter().map(|r| r.1).collect();
    let mut blocked = vec![false; rays.len()];
    world.vis.occluded(&from, &to, eps, &[], &mut blocked);
    for (r, (ray, b)) in rays.iter().zip(blocked).enumerate() {
        if !b {
            out[r / s as usize] += ray.2 / s as f32;
        }
    }
}
