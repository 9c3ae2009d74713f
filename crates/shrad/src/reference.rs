//! The reference solver (spec section 7): the converged radiosity of the same patches,
//! `B = M + rho * (E_direct + F (B - M))`.
//!
//! - Direct light comes from [`crate::direct`] (exact unoccluded irradiance times a sampled
//!   visible fraction), so it carries no visible noise; emitters' own exitance is therefore
//!   left out of the gathered term (`B - M`), which avoids counting it twice.
//! - Form factors `F_ij` are estimated by stratified cosine-weighted rays from stratified
//!   points on each patch (area-to-area, not centre-to-area) and stored sparsely (CSR): a
//!   row holds only the patches its rays met, so memory grows with patches x rays, not
//!   patches^2 (100k patches x 128 rays stay well under 1 GiB).
//! - Jacobi iteration, multi-threaded, until `max |dB| <= tolerance * max B`.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::direct::direct_irradiance;
use crate::progress::Progress;
use crate::sampling::{hammersley, hash, square_to_cosine_hemisphere, unit};
use crate::World;

/// Settings of the reference solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReferenceOptions {
    /// Form-factor rays per patch. 256 gives ~3 % noise per patch on the indirect term,
    /// which averages out over a few patches; raise it for per-patch comparisons.
    pub rays_per_patch: u32,
    /// Shadow rays per (patch, emitter) for the visible fraction of direct light.
    pub direct_samples: u32,
    /// Stop when `max |dB| <= tolerance * max B`.
    pub tolerance: f32,
    /// Give up after this many iterations (reported as not converged).
    pub max_iterations: usize,
}

impl ReferenceOptions {
    /// Good enough for pictures and error measurements (the default).
    pub const fn standard() -> Self {
        ReferenceOptions {
            rays_per_patch: 256,
            direct_samples: 64,
            tolerance: 1e-5,
            max_iterations: 10_000,
        }
    }
    /// Fewer rays: for quick looks and tests.
    pub const fn fast() -> Self {
        ReferenceOptions {
            rays_per_patch: 64,
            direct_samples: 16,
            ..Self::standard()
        }
    }
}

impl Default for ReferenceOptions {
    fn default() -> Self {
        Self::standard()
    }
}

/// Sparse form-factor matrix, compressed rows.
#[derive(Clone, Debug, Default)]
pub struct FormFactors {
    /// Row `i` is `col[row[i]..row[i+1]]`.
    pub row: Vec<usize>,
    /// Column (patch seen).
    pub col: Vec<u32>,
    /// Form factor.
    pub val: Vec<f32>,
}

impl FormFactors {
    /// Entries of row `i`.
    pub fn row(&self, i: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        let r = self.row[i]..self.row[i + 1];
        self.col[r.clone()]
            .iter()
            .map(|&c| c as usize)
            .zip(self.val[r].iter().copied())
    }
    /// Sum of row `i` (1 for a patch inside a closed scene).
    pub fn row_sum(&self, i: usize) -> f32 {
        self.row(i).map(|(_, f)| f).sum()
    }
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.row.len() * 8 + self.col.len() * 4 + self.val.len() * 4
    }
}

/// Estimate the form factors of the patches in `rows` (all others get empty rows) with
/// `rays` rays each. Patches with zero reflectance need no row; pass only those you need.
pub fn form_factors(
    world: &World,
    rows: &[u32],
    rays: u32,
    progress: &dyn Progress,
) -> FormFactors {
    form_factors_with(world, rows, rays, &[], progress)
}

/// [`form_factors`] with the objects in `exclude` transparent.
pub fn form_factors_with(
    world: &World,
    rows: &[u32],
    rays: u32,
    exclude: &[u32],
    progress: &dyn Progress,
) -> FormFactors {
    let n = world.patches.len();
    let mut per_patch: Vec<Vec<(u32, f32)>> = vec![Vec::new(); n];
    let rows_out = form_factor_rows(world, rows, rays, exclude, |_| true, progress);
    for (&i, row) in rows.iter().zip(rows_out) {
        per_patch[i as usize] = row;
    }
    let mut ff = FormFactors {
        row: Vec::with_capacity(n + 1),
        ..Default::default()
    };
    ff.row.push(0);
    for row in per_patch {
        for (c, f) in row {
            ff.col.push(c);
            ff.val.push(f);
        }
        ff.row.push(ff.col.len());
    }
    ff
}

/// The `rays` form-factor rays of patch `i` (world space): stratified points on the patch
/// and stratified cosine-weighted directions, paired by a random permutation (a fixed
/// pairing correlates them and biases F). Deterministic: the same rays every call.
pub fn patch_rays(world: &World, i: usize, origins: &mut [Vec3], dirs: &mut [Vec3]) {
    let p = &world.patches;
    let rays = origins.len();
    let nrm = p.normal[i];
    let seed = hash(i as u32);
    let s1 = (unit(seed), unit(hash(seed ^ 1)));
    let s2 = (unit(hash(seed ^ 2)), unit(hash(seed ^ 3)));
    let mut perm: Vec<u32> = (0..rays as u32).collect();
    let mut state = hash(seed ^ 0x2545_f491);
    for k in (1..rays).rev() {
        state = hash(state);
        perm.swap(k, (state as usize) % (k + 1));
    }
    for j in 0..rays {
        let (u, v) = hammersley(perm[j], rays as u32, s1);
        origins[j] = p.sample_point(i, u, v) + nrm * world.eps;
        let (a, b) = hammersley(j as u32, rays as u32, s2);
        dirs[j] = square_to_cosine_hemisphere(a, b, nrm);
    }
}

/// Sparse form-factor rows `(patch seen, F)` of `rows`, keeping the columns `keep` accepts.
pub fn form_factor_rows(
    world: &World,
    rows: &[u32],
    rays: u32,
    exclude: &[u32],
    keep: impl Fn(usize) -> bool + Sync,
    progress: &dyn Progress,
) -> Vec<Vec<(u32, f32)>> {
    let rays = rays.max(1) as usize;
    let chunk = ((1 << 20) / rays).max(1);
    let mut out = Vec::with_capacity(rows.len());
    progress.begin("form factors", rows.len() as u64);
    for ids in rows.chunks(chunk) {
        let mut origins = vec![Vec3::ZERO; ids.len() * rays];
        let mut dirs = vec![Vec3::ZERO; ids.len() * rays];
        origins
            .par_chunks_mut(rays)
            .zip(dirs.par_chunks_mut(rays))
            .zip(ids.par_iter())
            .for_each(|((o, d), &i)| patch_rays(world, i as usize, o, d));
        let mut hits = vec![shrad_vis::Hit::MISS; origins.len()];
        world.vis.closest(&origins, &dirs, 0.0, exclude, &mut hits);
        let w = 1.0 / rays as f32;
        out.par_extend(hits.par_chunks(rays).map(|h| {
            let mut seen: Vec<u32> = h
                .iter()
                .filter_map(|h| world.seen_patch(h))
                .filter(|&j| keep(j))
                .map(|j| j as u32)
                .collect();
            seen.sort_unstable();
            let mut row: Vec<(u32, f32)> = Vec::new();
            for j in seen {
                match row.last_mut() {
                    Some((c, f)) if *c == j => *f += w,
                    _ => row.push((j, w)),
                }
            }
            row
        }));
        progress.advance(ids.len() as u64);
    }
    progress.end();
    out
}

/// What the reference solve did.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct ReferenceStats {
    /// Jacobi iterations run.
    pub iterations: usize,
    /// Final `max |dB| / max B`.
    pub residual: f32,
    /// Did it reach the tolerance?
    pub converged: bool,
    /// Seconds spent on direct light.
    pub direct_seconds: f64,
    /// Seconds spent estimating form factors.
    pub form_factor_seconds: f64,
    /// Seconds spent iterating.
    pub solve_seconds: f64,
    /// Non-zero form factors stored.
    pub form_factor_entries: usize,
    /// Bytes of the form-factor matrix.
    pub form_factor_bytes: usize,
    /// Flux balance of the solution, over every patch (the emitters' absorption included).
    pub energy: crate::energy::EnergyBalance,
    /// Non-finite values reset to 0 (always 0 unless an input was broken).
    pub non_finite: usize,
}

/// One reference frame through the common frame interface: a converged [`solve`] of the
/// world as it is, its statistics as [`SolverStats::Reference`](crate::frame::SolverStats).
pub fn frame(
    world: &World,
    options: &ReferenceOptions,
    frame: u64,
    progress: &dyn Progress,
) -> (Vec<Vec3>, crate::frame::FrameStats) {
    let t = Instant::now();
    let rays_before = world.rays_cast();
    let (radiosity, stats) = solve(world, options, progress);
    let out = crate::frame::FrameStats {
        frame_ms: t.elapsed().as_secs_f64() * 1e3,
        energy: stats.energy,
        diverged: (stats.non_finite > 0).then(|| crate::energy::Divergence {
            message: format!("{} non-finite value(s) reset to 0", stats.non_finite),
            non_finite: stats.non_finite,
        }),
        rays_cast: world.rays_cast() - rays_before,
        ..crate::frame::FrameStats::new(frame, crate::frame::SolverStats::Reference(stats))
    };
    (radiosity, out)
}

/// Solve the radiosity of `world` at its current time.
pub fn solve(
    world: &World,
    options: &ReferenceOptions,
    progress: &dyn Progress,
) -> (Vec<Vec3>, ReferenceStats) {
    let p = &world.patches;
    let n = p.len();
    let mut stats = ReferenceStats::default();
    // Every patch gets its irradiance, also those that reflect nothing: they take no part in
    // the iteration, but the energy meter counts what they absorb.
    let all: Vec<u32> = (0..n as u32).collect();

    // Direct light, noise-free.
    let t = Instant::now();
    progress.begin("direct light", 1);
    let direct: Vec<Vec3> = direct_irradiance(world, &all, options.direct_samples);
    progress.advance(1);
    progress.end();
    stats.direct_seconds = t.elapsed().as_secs_f64();

    // Form factors.
    let t = Instant::now();
    let ff = form_factors(world, &all, options.rays_per_patch, progress);
    stats.form_factor_seconds = t.elapsed().as_secs_f64();
    stats.form_factor_entries = ff.col.len();
    stats.form_factor_bytes = ff.bytes();

    // Jacobi on the reflected part R = B - M: R = rho * (E_direct + F R).
    let t = Instant::now();
    let rho = &world.reflectance;
    let mut reflected: Vec<Vec3> = (0..n).map(|i| rho[i] * direct[i]).collect();
    let mut next = reflected.clone();
    let max_b = |r: &[Vec3]| {
        r.par_iter()
            .zip(world.exitance.par_iter())
            .map(|(r, m)| (*r + *m).max_element())
            .reduce(|| 0.0, f32::max)
    };
    progress.begin("radiosity iterations", options.max_iterations as u64);
    for it in 0..options.max_iterations {
        next.par_iter_mut().enumerate().for_each(|(i, out)| {
            let gathered: Vec3 = ff.row(i).map(|(j, f)| reflected[j] * f).sum();
            *out = rho[i] * (direct[i] + gathered);
        });
        let change = next
            .par_iter()
            .zip(reflected.par_iter())
            .map(|(a, b)| (*a - *b).abs().max_element())
            .reduce(|| 0.0, f32::max);
        std::mem::swap(&mut reflected, &mut next);
        stats.iterations = it + 1;
        let scale = max_b(&reflected).max(f32::MIN_POSITIVE);
        stats.residual = change / scale;
        progress.advance(1);
        if stats.residual <= options.tolerance {
            stats.converged = true;
            break;
        }
    }
    progress.end();
    stats.solve_seconds = t.elapsed().as_secs_f64();
    stats.non_finite = crate::energy::reset_non_finite(&mut reflected);
    let irradiance: Vec<Vec3> = (0..n)
        .into_par_iter()
        .map(|i| direct[i] + ff.row(i).map(|(j, f)| reflected[j] * f).sum::<Vec3>())
        .collect();
    stats.energy = crate::energy::balance(world, &irradiance, |_| true);
    let radiosity = reflected
        .iter()
        .zip(&world.exitance)
        .map(|(r, m)| *r + *m)
        .collect();
    (radiosity, stats)
}
