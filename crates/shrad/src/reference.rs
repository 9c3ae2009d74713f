//! The reference solver (spec section 7): the converged radiosity of the same patches,
//! `B = M + rho * (E_direct + F (B - M))`.
//!
//! - Direct light comes from [`crate::direct`] (exact unoccluded irradiance times a sampled
//!   visible fraction) and, for punctual lights, [`crate::lights`] (exact irradiance with a
//!   shadow ray per footprint sample), so it carries no visible noise; emitters' own exitance is therefore
//!   left out of the gathered term (`B - M`), which avoids counting it twice.
//! - Form factors `F_ij` come from the shared transport code [`crate::form_factors`]
//!   (stratified cosine-weighted rays from stratified points on each patch, stored as sparse
//!   rows), which the dispersive wall exchange uses too; re-exported here.
//! - Jacobi iteration, multi-threaded, until `max |dB| <= tolerance * max B`.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use crate::direct::direct_irradiance_independent;
pub use crate::form_factors::{
    form_factor_rows, form_factors, form_factors_with, patch_rays, FormFactors,
};
use crate::progress::{check, uninterrupted, Progress, Unstoppable};
use crate::{Error, World};

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

pub use crate::frame::ReferenceStats;

/// One reference frame through the common frame interface: a converged [`solve`] of the
/// world as it is, its statistics as [`SolverStats::Reference`](crate::frame::SolverStats).
/// [`Error::Interrupted`] when `progress` asks to stop ([`try_solve`]).
pub fn frame(
    world: &World,
    options: &ReferenceOptions,
    frame: u64,
    progress: &dyn Progress,
) -> Result<(Vec<Vec3>, Vec<Vec3>, crate::frame::FrameStats), Error> {
    let t = Instant::now();
    let rays_before = world.rays_cast();
    let (radiosity, punctual, stats) = solve_parts(world, options, progress)?;
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
    Ok((radiosity, punctual, out))
}

/// Solve the radiosity of `world` at its current time, reporting to `progress` (it never
/// stops this: [`try_solve`] does).
pub fn solve(
    world: &World,
    options: &ReferenceOptions,
    progress: &dyn Progress,
) -> (Vec<Vec3>, ReferenceStats) {
    uninterrupted(try_solve(world, options, &Unstoppable(progress)))
}

/// [`solve`], or [`Error::Interrupted`] when `progress` asks to stop: asked after the direct
/// light, before each chunk of form-factor rays and each iteration.
pub fn try_solve(
    world: &World,
    options: &ReferenceOptions,
    progress: &dyn Progress,
) -> Result<(Vec<Vec3>, ReferenceStats), Error> {
    let (radiosity, _, stats) = solve_parts(world, options, progress)?;
    Ok((radiosity, stats))
}

/// [`try_solve`], with the punctual lights' direct irradiance of every patch (what a
/// picture replaces by its per-pixel value).
pub fn solve_parts(
    world: &World,
    options: &ReferenceOptions,
    progress: &dyn Progress,
) -> Result<(Vec<Vec3>, Vec<Vec3>, ReferenceStats), Error> {
    check(progress)?;
    let p = &world.patches;
    let n = p.len();
    let mut stats = ReferenceStats::default();
    // Every patch gets its irradiance, also those that reflect nothing: they take no part in
    // the iteration, but the energy meter counts what they absorb.
    let all: Vec<u32> = (0..n as u32).collect();

    // Direct light, noise-free.
    let t = Instant::now();
    progress.begin("direct light", 1);
    let punctual = crate::lights::punctual_irradiance_all(world, options.direct_samples);
    // From shadow rays no solver casts: an error against the reference sees the solvers'
    // sampling noise (`direct_irradiance_independent`).
    let direct: Vec<Vec3> = direct_irradiance_independent(world, &all, options.direct_samples)
        .into_iter()
        .zip(&punctual)
        .map(|(a, b)| a + *b)
        .collect();
    progress.advance(1);
    progress.end();
    stats.direct_seconds = t.elapsed().as_secs_f64();
    check(progress)?;

    // Form factors.
    let t = Instant::now();
    let ff = form_factors(world, &all, options.rays_per_patch, progress)?;
    stats.form_factor_seconds = t.elapsed().as_secs_f64();
    stats.form_factor_entries = ff.entries();
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
        check(progress).inspect_err(|_| progress.end())?;
        next.par_iter_mut().enumerate().for_each(|(i, out)| {
            let gathered: Vec3 = ff
                .row(i)
                .iter()
                .map(|&(j, f)| reflected[j as usize] * f)
                .sum();
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
        .map(|i| {
            direct[i]
                + ff.row(i)
                    .iter()
                    .map(|&(j, f)| reflected[j as usize] * f)
                    .sum::<Vec3>()
        })
        .collect();
    stats.energy = crate::energy::balance(world, |i| irradiance[i], &punctual, |_| true);
    let radiosity = reflected
        .iter()
        .zip(&world.exitance)
        .map(|(r, m)| *r + *m)
        .collect();
    Ok((radiosity, punctual, stats))
}
