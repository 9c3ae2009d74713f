//! The paper's baseline (spec section 5; Nijasure, Pattanaik and Goel 2003 as the paper
//! describes it in sections 1 and 3): a uniform `G x G x G` grid of SH probes at the cell
//! centres of the scene's box, every probe captured and projected every frame, every patch
//! lit by trilinear interpolation of the 8 probes around it. Light arrives only through the
//! probes; one bounce per frame. A probe inside an object sees only back faces and goes dark
//! ("采样点失效", the paper's Figure 1): that failure is part of the baseline and shows.

use glam::Vec3;
use rayon::prelude::*;
use shrad_sh::{cosine_lobe_sh, num_coeffs, trilinear_weights, ShRgb};

use crate::direct::Moves;
use crate::frame::{Changes, FrameStats, GridStats, SolverStats};
use crate::probes::{ProbeCamera, Seen};
use crate::World;

/// Footprint samples (shadow rays) per patch and punctual light: the reference's fast
/// preset's `direct_samples`.
const GRID_PUNCTUAL_SAMPLES: u32 = 16;

/// Settings of the grid baseline.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridOptions {
    /// Probes per axis (paper: 4 and 5).
    pub per_axis: usize,
    /// Cube-map face resolution (paper: 128).
    pub cube_res: usize,
    /// SH bands (paper: 4).
    pub bands: usize,
}

impl GridOptions {
    /// The paper's 4 x 4 x 4 grid.
    pub const fn paper(per_axis: usize) -> Self {
        GridOptions {
            per_axis,
            cube_res: 128,
            bands: 4,
        }
    }
}

impl Default for GridOptions {
    fn default() -> Self {
        Self::paper(5)
    }
}

/// The grid solver's state.
pub struct Grid {
    options: GridOptions,
    camera: ProbeCamera,
    lo: Vec3,
    extent: Vec3,
    probes: Vec<Vec3>,
    radiosity: Vec<Vec3>,
    frame: u64,
    /// The reflected flux of the last frame within the bound (the guard lets the light held
    /// from before a light dimmed drain: [`crate::energy::over_bound`]).
    light_held: crate::energy::LightHeld,
    /// Direct light of the punctual lights (a probe cannot see a light without a surface;
    /// paper 2.3.2's direct step lights every patch instead), re-traced when anything moved.
    punctual: crate::lights::PunctualCache,
    /// Its irradiance per patch (empty without punctual lights).
    punctual_by_patch: Vec<Vec3>,
}

impl Grid {
    /// Place the probes over the scene's box at rest. `options` are taken as checked, as for
    /// [`crate::dispersive::Dispersive::new`] (`Solver::new` checks them).
    pub fn new(world: &World, options: GridOptions) -> Result<Grid, crate::Error> {
        let coefficients = shrad_sh::num_coeffs(options.bands);
        crate::limits::check_cube_maps(options.cube_res, None, coefficients)?;
        let g = options.per_axis.max(1);
        let bounds = world
            .scene
            .bounds()
            .unwrap_or(shrad_scene::Aabb::new(Vec3::ZERO, Vec3::ONE));
        let lo = bounds.min;
        let extent = bounds.size().max(Vec3::splat(1e-6));
        let mut probes = Vec::with_capacity(g * g * g);
        for k in 0..g {
            for j in 0..g {
                for i in 0..g {
                    let cell = (Vec3::new(i as f32, j as f32, k as f32) + 0.5) / g as f32;
                    probes.push(lo + cell * extent);
                }
            }
        }
        Ok(Grid {
            camera: ProbeCamera::new(options.cube_res, options.bands),
            options,
            lo,
            extent,
            probes,
            radiosity: world.exitance.clone(),
            frame: 0,
            light_held: Default::default(),
            punctual: Default::default(),
            punctual_by_patch: Vec::new(),
        })
    }

    /// Probe positions (x fastest, then y, then z).
    pub fn probes(&self) -> &[Vec3] {
        &self.probes
    }

    /// Current radiosity of every patch.
    pub fn radiosity(&self) -> &[Vec3] {
        &self.radiosity
    }

    /// The 8 probes around `x` and their trilinear weights (clamped at the grid's edge).
    fn cell(&self, x: Vec3) -> ([usize; 8], [f32; 8]) {
        let g = self.options.per_axis.max(1);
        if g == 1 {
            return ([0; 8], [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        }
        let u = (x - self.lo) / self.extent * g as f32 - 0.5;
        let i0 = u.floor().clamp(Vec3::ZERO, Vec3::splat((g - 2) as f32));
        let t = (u - i0).clamp(Vec3::ZERO, Vec3::ONE);
        let i0 = i0.as_uvec3();
        let ids = std::array::from_fn(|c| {
            let (dx, dy, dz) = ((c & 1) as u32, ((c >> 1) & 1) as u32, ((c >> 2) & 1) as u32);
            let (i, j, k) = (
                (i0.x + dx) as usize,
                (i0.y + dy) as usize,
                (i0.z + dz) as usize,
            );
            (k * g + j) * g + i
        });
        (ids, trilinear_weights(t))
    }

    /// The punctual lights' direct irradiance per patch (empty without punctual lights).
    pub fn punctual_irradiance(&self) -> &[Vec3] {
        &self.punctual_by_patch
    }

    /// Bring the punctual lights' direct light up to date: re-traced whole when an object
    /// moved (the grid keeps no boxes), only what a light's change needs otherwise.
    fn update_punctual(&mut self, world: &World, changes: &Changes) {
        let n = world.patches.len();
        if !crate::lights::has_sources(world) {
            self.punctual_by_patch.clear();
            return;
        }
        let fresh = self.punctual_by_patch.len() != n
            || !changes.moved.is_empty()
            || !self.punctual.same_lights(world);
        let ks = if fresh {
            let all: Vec<u32> = (0..n as u32).collect();
            self.punctual = crate::lights::PunctualCache::new(world, all, GRID_PUNCTUAL_SAMPLES);
            (0..n).collect()
        } else {
            self.punctual.update(
                world,
                Moves::boxes(&[], &[]),
                (&[], GRID_PUNCTUAL_SAMPLES),
                |_| true,
            )
        };
        self.punctual_by_patch.resize(n, Vec3::ZERO);
        for k in ks {
            self.punctual_by_patch[self.punctual.receivers()[k] as usize] =
                self.punctual.irradiance()[k];
        }
    }

    /// One frame: capture every probe, light every patch.
    pub fn step(&mut self, world: &World, changes: &Changes) -> FrameStats {
        let start = std::time::Instant::now();
        let rays_before = world.rays_cast();
        self.update_punctual(world, changes);
        let radiosity = &self.radiosity;
        // Capture and project every probe (nothing left out).
        let captured =
            self.camera
                .capture(world, &self.probes, &[], |h| match world.seen_patch(h) {
                    Some(j) => Seen::Radiance(radiosity[j] * std::f32::consts::FRAC_1_PI),
                    None if h.is_hit() => Seen::BackFace,
                    None => Seen::Radiance(Vec3::ZERO),
                });
        let capture_ms = start.elapsed().as_secs_f64() * 1e3;
        // Interpolate to every patch and shade.
        let t = std::time::Instant::now();
        let bands = self.options.bands;
        let nc = num_coeffs(bands);
        let p = &world.patches;
        let irradiance: Vec<Vec3> = (0..p.len())
            .into_par_iter()
            .map(|i| {
                let (ids, w) = self.cell(p.centre[i]);
                let probes: [&ShRgb; 8] = std::array::from_fn(|c| &captured.sh[ids[c]]);
                let l = ShRgb::lerp8(&probes, &w);
                let mut lobe = [0f32; 64];
                cosine_lobe_sh(bands, p.normal[i], &mut lobe[..nc]);
                l.dot(&lobe[..nc]).max(Vec3::ZERO)
                    + self.punctual_by_patch.get(i).copied().unwrap_or(Vec3::ZERO)
            })
            .collect();
        // The energy meter and its guard: a non-finite or diverged state is repaired before
        // it is published (spec 2).
        let mut irradiance = irradiance;
        let non_finite = crate::energy::reset_non_finite(&mut irradiance);
        let mut energy =
            crate::energy::balance(world, |i| irradiance[i], &self.punctual_by_patch, |_| true);
        let mut diverged = (non_finite > 0).then(|| crate::energy::Divergence {
            message: format!("{non_finite} non-finite irradiance value(s) reset to 0"),
            non_finite,
        });
        if let Some(s) = crate::energy::over_bound(&energy, self.light_held.get()) {
            irradiance.iter_mut().for_each(|e| *e *= s as f32);
            let message = format!(
                "reflected flux {:.4e} exceeds the bound {:.4e} that the lights can sustain; probe light damped by {s:.3}",
                energy.reflected, energy.reflected_bound
            );
            energy =
                crate::energy::balance(world, |i| irradiance[i], &self.punctual_by_patch, |_| true);
            diverged = Some(crate::energy::Divergence {
                message: diverged.map_or(message.clone(), |d| d.message + "; " + &message),
                non_finite,
            });
        }
        self.light_held.note(&energy);
        self.radiosity = (0..p.len())
            .map(|i| world.exitance[i] + world.reflectance[i] * irradiance[i])
            .collect();
        let shade_ms = t.elapsed().as_secs_f64() * 1e3;
        let stats = FrameStats {
            frame_ms: start.elapsed().as_secs_f64() * 1e3,
            energy,
            diverged,
            rays_cast: world.rays_cast() - rays_before,
            ..FrameStats::new(
                self.frame,
                SolverStats::Grid(GridStats {
                    capture_ms,
                    shade_ms,
                    probes: self.probes.len(),
                    probes_invalid: captured.back_fraction.iter().filter(|&&f| f > 0.25).count(),
                }),
            )
        };
        self.frame += 1;
        stats
    }
}
