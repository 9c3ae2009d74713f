//! Step 3 of the frame (paper 2.3.4, "计算所选择的物体对边界的间接光照"): each object lit in
//! Step 2 sends its reflected light to the boundary as an SH emitter, replacing its previous
//! contribution (the paper: only the current object's share of each boundary patch is
//! updated). Each patch adds its reflected flux to the emitter's SH along its exit direction
//! (2.3.4 Step 1, halfway between "from the centre" and the normal); the emitter then lights
//! the boundary either by the paper's cube map, each texel's flux splatted on the patch it
//! sees (2.3.4 Step 2, [`splat_to_boundary`]), or by a gather, the SH intensity evaluated
//! towards every boundary patch with one shadow ray each (2.3.4 Step 3 updates the boundary
//! only).
//!
//! Beyond the paper: one emitter per face direction (`setup::emitter_groups`), split across
//! large faces for their near receivers, the gather (`gather.rs`), splat smoothing over edge
//! neighbours (`setup::Neighbours`), and a guard that damps an object that would send more
//! than it reflects.

use glam::Vec3;
use rayon::prelude::*;
use shrad_sh::{cosine_lobe, eval_basis, num_coeffs, ShRgb};
use shrad_vis::Hit;

use super::caches::{
    EmitterCache, EmitterRays, SplatTexels, LANDS_NOWHERE, MAX_STEP3_BYTES, UNKNOWN,
};
use super::object_state::CrossedAhead;
use super::setup::{receives_as_boundary, EmitterGroup, Reach};
use super::{Dispersive, ToBoundary};
use crate::probes::ProbeCamera;
use crate::World;

impl Dispersive {
    /// Step 3 (paper 2.3.4): each lit object sends its reflected light to the boundary as one
    /// SH emitter at its centre, replacing its previous contribution; a still one whose
    /// emitted light is within `amend_within` of what it sent may send only the light paths
    /// a mover crossed (`resend.rs`; 0: always the whole). Returns the flux sent.
    /// `ahead`: the first object's crossed paths, found beside Step 1 (`resend.rs`).
    pub(super) fn objects_to_boundary(
        &mut self,
        world: &World,
        lit: Vec<usize>,
        (amend_within, mut ahead): (f64, Option<CrossedAhead>),
    ) -> f64 {
        let mut flux_sent = 0.0;
        for k in lit {
            let started = std::time::Instant::now();
            let mine = ahead.take_if(|a| a.k == k);
            let resent = self.resend_crossed_paths(world, k, amend_within, mine);
            if let Some((moved, ahead_ms)) = resent {
                flux_sent += moved;
                let cost = super::ms(started) + ahead_ms;
                self.scheduler.add_cost(k, cost, false);
                super::tr("resend_crossed", started);
                continue;
            }
            let tt = std::time::Instant::now();
            let pieces = self.emit(world, k);
            super::tr("emit", tt);
            let tt = std::time::Instant::now();
            let contribution = self.pieces_to_irradiance(world, pieces);
            let contribution = self.within_reflected(world, k, contribution);
            flux_sent += self.replace_contribution(world, k, contribution);
            let sent_len = self.objects[k].to_boundary.len();
            self.objects[k].emitter_cache.sent_len = sent_len;
            // An object's cost, for a budget: its Step 2 and its Step 3.
            // A coarse update (while it moves) says little of what a full one costs.
            let full = !self.cameras_for(k).2;
            self.scheduler.add_cost(k, super::ms(started), full);
            self.objects[k].coarse_now = false;
            super::tr("sum_and_replace", tt);
        }
        if let Some(a) = ahead {
            flux_sent += self.amend_ahead(world, a);
        }
        flux_sent
    }

    /// Object `k`'s emitters lit from its current radiosity, sent to the boundary: pieces
    /// (boundary patch, value), several per patch, irradiance from a gather and flux from a
    /// splat. The emitters' geometry and rays are cached between updates (`caches.rs`).
    fn emit(&mut self, world: &World, k: usize) -> Vec<(u32, Vec3)> {
        let p = &world.patches;
        let o = self.objects[k].object;
        let m = p.world_from_local[o];
        let method = self.to_boundary_method();
        let coarse = self.cameras_for(k).2;
        // While it moves (coarse), one emitter at the box centre as in the paper instead of
        // one per face direction: a sixth of the splat's rays and pieces, for light that is
        // wrong by the motion anyway; per face again as soon as it rests.
        let merged =
            coarse && self.options.one_emitter_while_moving && self.objects[k].emitters.len() > 1;
        let emitters = if merged {
            1
        } else {
            self.objects[k].emitters.len()
        };
        // A coarse update neither reads nor keeps the cache (see `capture_corner_probes`).
        let mut cache = match coarse {
            true => EmitterCache::default(),
            false => std::mem::take(&mut self.objects[k].emitter_cache),
        };
        if cache.key != Some(m) || cache.rays.len() != emitters {
            cache = self.emitter_geometry(world, k, m, method, merged);
        }
        let ob = &self.objects[k];
        let intensities = self.emitter_intensities(world, k, &cache.lobes);
        let pieces = if merged {
            // The whole faces' emitters hold every patch once; their split cells again.
            let whole = |e: &&EmitterGroup| !matches!(e.2, Reach::Within { .. });
            let mut total = ShRgb::zeros(self.options.bands);
            (ob.emitters.iter().zip(&intensities))
                .filter(|(e, _)| whole(e))
                .for_each(|(_, i)| total.add(i));
            let members = ob.emitters.iter().filter(whole).flat_map(|(_, m, _)| m);
            let soften = self.soften(world, k, members);
            self.emit_one(world, k, &mut cache.rays[0], &total, soften)
        } else {
            // The emitters in parallel: each has its own rays.
            let each: Vec<Vec<(u32, Vec3)>> = ob
                .emitters
                .par_iter()
                .zip(cache.rays.par_iter_mut())
                .zip(&intensities)
                .map(|(((_, members, _), rays), intensity)| {
                    self.emit_one(world, k, rays, intensity, self.soften(world, k, members))
                })
                .collect();
            each.concat()
        };
        // Kept unless the caches are off or it would be too large (then it is rebuilt at
        // every update, as the uncached code would), with the light it sent (`resend.rs`).
        if self.caching && !coarse && cache.bytes() <= MAX_STEP3_BYTES {
            cache.sent = if merged { Vec::new() } else { intensities };
            // Every emitter's rays for its light now are traced (`prepare.rs`).
            cache.prepared = cache.rays.len();
            self.objects[k].emitter_cache = cache;
        }
        pieces
    }

    /// The outgoing intensity of each emitter of object `k`, from its members' `lobes`.
    pub(super) fn emitter_intensities(
        &self,
        world: &World,
        k: usize,
        lobes: &[Vec<f32>],
    ) -> Vec<ShRgb> {
        let ob = &self.objects[k];
        (ob.emitters.iter().zip(lobes))
            .map(|((_, members, _), lobes)| self.emitter_intensity(world, k, members, lobes))
            .collect()
    }

    /// The outgoing intensity of one emitter of object `k` in SH:
    /// `sum_i (rho_i E_i) A_i / pi * A_l Y_k(d_i)` over its `members` (2.3.4 Step 1).
    pub(super) fn emitter_intensity(
        &self,
        world: &World,
        k: usize,
        members: &[u32],
        lobes: &[f32],
    ) -> ShRgb {
        let p = &world.patches;
        let nc = num_coeffs(self.options.bands);
        let range = p.range(self.objects[k].object);
        let mut intensity = vec![Vec3::ZERO; nc];
        for (&m, lobe) in members.iter().zip(lobes.chunks_exact(nc)) {
            let i = range.start + m as usize;
            let reflected = self.radiosity[i] - world.exitance[i];
            let scale = reflected * p.area[i] * std::f32::consts::FRAC_1_PI;
            for c in 0..nc {
                intensity[c] += scale * lobe[c];
            }
        }
        ShRgb::from_coeffs(intensity)
    }

    /// A gather emitter's `1 / r^2` regularisation ([`Self::gather`]): members' area / pi.
    pub(super) fn soften<'a>(
        &self,
        world: &World,
        k: usize,
        members: impl IntoIterator<Item = &'a u32>,
    ) -> f32 {
        if !self.options.emitter_per_face {
            return 0.0;
        }
        let p = &world.patches;
        let start = p.range(self.objects[k].object).start;
        let area: f32 = members
            .into_iter()
            .map(|&m| p.area[start + m as usize])
            .sum();
        area * std::f32::consts::FRAC_1_PI
    }

    /// One emitter of object `k` sent along its cached rays.
    pub(super) fn emit_one(
        &self,
        world: &World,
        k: usize,
        rays: &mut EmitterRays,
        intensity: &ShRgb,
        soften: f32,
    ) -> Vec<(u32, Vec3)> {
        let o = self.objects[k].object;
        match rays {
            EmitterRays::Splat(texels) => {
                self.splat(world, self.cameras_for(k).1, o, texels, intensity)
            }
            EmitterRays::Gather(entries) => self.gather(world, o, entries, intensity, soften),
        }
    }

    /// Pieces summed to one irradiance per boundary patch: a gather's as they are, a splat's
    /// flux over the patch's area, or spread over its edge neighbourhood in proportion to
    /// area (`splat_smoothing`).
    pub(super) fn pieces_to_irradiance(
        &mut self,
        world: &World,
        pieces: Vec<(u32, Vec3)>,
    ) -> Vec<(u32, Vec3)> {
        let area = &world.patches.area;
        match self.to_boundary_method() {
            ToBoundary::Gather => sum_by_patch(&mut self.scratch, pieces),
            _ if self.options.splat_smoothing => self.spread_over_neighbours(pieces),
            _ => {
                let by_area = pieces.into_iter().map(|(j, f)| (j, f / area[j as usize]));
                sum_by_patch(&mut self.scratch, by_area)
            }
        }
    }

    /// An object cannot send the boundary more than it reflects: a contribution beyond that
    /// (patches measured in the wrong units, a splat that aliases) is damped to it, and the
    /// frame says so.
    fn within_reflected(
        &mut self,
        world: &World,
        k: usize,
        mut contribution: Vec<(u32, Vec3)>,
    ) -> Vec<(u32, Vec3)> {
        let p = &world.patches;
        let o = self.objects[k].object;
        let reflected: f64 = p
            .range(o)
            .map(|i| ((self.radiosity[i] - world.exitance[i]) * p.area[i]).element_sum() as f64)
            .sum::<f64>()
            / 3.0;
        let sent: f64 = contribution
            .iter()
            .map(|&(j, e)| (e * p.area[j as usize]).element_sum() as f64)
            .sum::<f64>()
            / 3.0;
        if sent <= reflected * crate::energy::BOUND_TOLERANCE + f64::MIN_POSITIVE {
            return contribution;
        }
        let s = if sent.is_finite() && sent > 0.0 {
            (reflected.max(0.0) / sent) as f32
        } else {
            0.0
        };
        contribution.iter_mut().for_each(|(_, e)| *e *= s);
        // Amending a damped contribution texel by texel would undo the damping.
        self.objects[k].emitter_cache.sent.clear();
        let note = format!(
            "object '{}' sent {sent:.4e} to the boundary but reflects only {reflected:.4e}: its contribution was damped by {s:.3}",
            world.scene.objects[o].name
        );
        self.step_warnings.push(note);
        contribution
    }

    /// Replace object `k`'s previous contribution to the boundary by `contribution` (paper:
    /// "只更新当前物体对它的影响"); returns the flux it sends now.
    fn replace_contribution(
        &mut self,
        world: &World,
        k: usize,
        contribution: Vec<(u32, Vec3)>,
    ) -> f64 {
        let area = &world.patches.area;
        for &(j, e) in &self.objects[k].to_boundary {
            self.indirect[j as usize] -= e;
            self.touched.patch(j as usize);
        }
        let mut flux = 0.0;
        for &(j, e) in &contribution {
            self.indirect[j as usize] += e;
            self.touched.patch(j as usize);
            flux += (e * area[j as usize]).element_sum() as f64 / 3.0;
        }
        self.objects[k].to_boundary = contribution;
        flux
    }

    /// How objects reach the boundary: the option, with `Auto` resolved. Gather while it
    /// costs about what a splat does (up to 2 x 6R^2 boundary patches, and at least up to
    /// 32k: a coarse splat aliases), splat beyond, so that the cost of Step 3 stays bounded
    /// however large the boundary grows.
    pub(super) fn to_boundary_method(&self) -> ToBoundary {
        method_for(
            self.options.to_boundary,
            self.boundary_patches.len(),
            self.emitter_camera.texels(),
        )
    }

    /// What Step 3 of object `k` at `m` needs of geometry (`caches.rs`): per emitter, its
    /// patches' lobes along their world exit directions (2.3.4 Step 1) and the rays to the
    /// boundary, none cast yet.
    pub(super) fn emitter_geometry(
        &self,
        world: &World,
        k: usize,
        m: glam::Affine3A,
        method: ToBoundary,
        merged: bool,
    ) -> EmitterCache {
        let p = &world.patches;
        let bands = self.options.bands;
        let nc = num_coeffs(bands);
        let ob = &self.objects[k];
        let range = p.range(ob.object);
        let mut basis = [0f32; 64];
        let lobes = ob
            .emitters
            .iter()
            .map(|(_, members, _)| {
                let mut lobes = Vec::with_capacity(members.len() * nc);
                for &k in members {
                    let i = range.start + k as usize;
                    let local = if self.options.emitter_per_face {
                        p.normal_local[i]
                    } else {
                        ob.exit_local[k as usize]
                    };
                    let d = m.transform_vector3(local).normalize_or_zero();
                    eval_basis(bands, d, &mut basis[..nc]);
                    lobes.extend((0..nc).map(|c| cosine_lobe(shrad_sh::band_of(c)) * basis[c]));
                }
                lobes
            })
            .collect();
        // One emitter at the box centre when `merged`, else one per group.
        let centres: Vec<(Vec3, Reach)> = match merged {
            true => vec![(ob.centre_local(), Reach::All)],
            false => ob.emitters.iter().map(|(c, _, r)| (*c, *r)).collect(),
        };
        let local_from_world = m.inverse();
        let rays = centres
            .iter()
            .map(|(centre_local, reach)| {
                let centre = m.transform_point3(*centre_local);
                match method {
                    ToBoundary::Gather => {
                        let takes = |x: Vec3| reach.takes(local_from_world.transform_point3(x));
                        EmitterRays::Gather(Box::new(self.gather_entries(world, centre, takes)))
                    }
                    _ => {
                        let n = self.cameras_for(k).1.texels();
                        EmitterRays::Splat(SplatTexels::new(centre, n))
                    }
                }
            })
            .collect();
        EmitterCache {
            key: Some(m),
            lobes,
            rays,
            ..Default::default()
        }
    }

    /// The paper's Step 3 from one emitter (see [`splat_to_boundary`]), tracing only the
    /// texels that carry flux and are not cached.
    fn splat(
        &self,
        world: &World,
        camera: &ProbeCamera,
        o: usize,
        texels: &mut SplatTexels,
        intensity: &ShRgb,
    ) -> Vec<(u32, Vec3)> {
        let (cube, projector) = (&camera.cube, &camera.projector);
        // Flux through every texel at once (`texel_values`: the floats of `texel_value`).
        let mut values = vec![Vec3::ZERO; cube.directions.len()];
        projector.texel_values(intensity, &mut values);
        let flux: Vec<(usize, Vec3)> = values
            .into_iter()
            .enumerate()
            .filter_map(|(t, f)| {
                let f = f.max(Vec3::ZERO);
                (f.max_element() > 0.0).then_some((t, f))
            })
            .collect();
        let unknown: Vec<usize> = flux
            .iter()
            .map(|&(t, _)| t)
            .filter(|&t| texels.seen[t] == UNKNOWN)
            .collect();
        trace_texels(world, camera, o, texels, &unknown);
        // What the boundary holds from now on, texel by texel (`resend.rs`).
        texels.sent_to.fill(LANDS_NOWHERE);
        texels.forgotten.clear();
        flux.into_iter()
            .filter_map(|(t, f)| {
                let j = texels.seen[t];
                let lands = j != LANDS_NOWHERE && receives_as_boundary(world, j as usize);
                lands.then(|| {
                    texels.sent_to[t] = j;
                    (j, f)
                })
            })
            .collect()
    }
}

/// The Step 3 method `chosen` comes to for a boundary of `boundary` patches and an emitter
/// cube map of `texels`: `Auto` gathers on small boundaries and splats on large ones.
pub(super) fn method_for(chosen: ToBoundary, boundary: usize, texels: usize) -> ToBoundary {
    match chosen {
        ToBoundary::Auto if boundary > (2 * texels).max(1 << 15) => ToBoundary::Splat,
        ToBoundary::Auto => ToBoundary::Gather,
        m => m,
    }
}

/// The paper's Step 3 (2.3.4) from one SH emitter: a cube map of `camera` at `centre` (object
/// `own` transparent), each texel's flux (intensity times solid angle) onto the boundary
/// patch it sees. Returns one (patch, flux) piece per texel that lands on the boundary; the
/// rest of the flux leaves through the scene's openings or lands on other objects.
pub fn splat_to_boundary(
    world: &World,
    camera: &ProbeCamera,
    own: u32,
    centre: Vec3,
    intensity: &ShRgb,
) -> Vec<(u32, Vec3)> {
    let (cube, projector) = (&camera.cube, &camera.projector);
    // Only texels the emitter sends light into are traced: a face emitter's lobe is zero
    // over the half of the sphere behind it. (Flux through a texel: the intensity times the
    // texel's solid angle, read off the projector's table without evaluating Y_k.)
    let flux: Vec<(usize, Vec3)> = (0..cube.directions.len())
        .into_par_iter()
        .filter_map(|t| {
            let f = projector.texel_value(intensity, t).max(Vec3::ZERO);
            (f.max_element() > 0.0).then_some((t, f))
        })
        .collect();
    let dirs: Vec<Vec3> = flux.iter().map(|&(t, _)| cube.directions[t]).collect();
    let mut hits = vec![Hit::MISS; dirs.len()];
    // Still in texel order, so the capture's ray packets stay coherent.
    world.vis.capture(&[centre], &dirs, 0.0, &[own], &mut hits);
    let covered = covered_by(world, own as usize, centre, &dirs, &hits);
    hits.iter()
        .zip(&flux)
        .zip(covered)
        .filter_map(|((h, &(_, f)), covered)| {
            let j = world.seen_patch(h)?;
            (receives_as_boundary(world, j) && !covered).then_some((j as u32, f))
        })
        .collect()
}

/// Of splat rays from `centre` in directions `dirs` with their boundary `hits`, those that land
/// on a patch object `o` covers: the hit lies within the object's box (its own frame's
/// bounds, a hair larger) and the object's surface touches it along the ray (met within 1 %
/// of the box's diagonal back towards `centre`: the floor under a box resting on it, not the
/// floor under a table's top). The object's light cannot reach such a patch (the reference
/// leaves it dark); a splat from inside the object would light it through the object (under a
/// sky, with the bottom faces lit from below the floor, the 77k room's floor under two boxes:
/// 12 % error against the reference, 2.4 % with the gather).
fn covered_by(world: &World, o: usize, centre: Vec3, dirs: &[Vec3], hits: &[Hit]) -> Vec<bool> {
    let mut covered = vec![false; hits.len()];
    let Some(local) = world.patches.shape_bounds(o) else {
        return covered;
    };
    let m = world.patches.world_from_local[o];
    let (eps, local_from_world) = (world.eps, m.inverse());
    let inside = local.padded(local.size() * 1e-4 + Vec3::splat(eps));
    let contact = 0.01 * m.transform_vector3(local.size()).length();
    let at = |r: usize| centre + dirs[r] * hits[r].t;
    let candidates: Vec<usize> = (0..hits.len())
        .filter(|&r| hits[r].is_hit() && inside.contains(local_from_world.transform_point3(at(r))))
        .collect();
    if candidates.is_empty() {
        return covered;
    }
    // From just past the hit (through a surface the object rests on) back towards the centre,
    // against the object alone.
    let from: Vec<Vec3> = (candidates.iter())
        .map(|&r| at(r) + dirs[r] * (2.0 * eps))
        .collect();
    let to: Vec<Vec3> = (candidates.iter())
        .map(|&r| at(r) - dirs[r] * contact)
        .collect();
    let mut touches = vec![false; candidates.len()];
    (world.vis).occluded_among(&from, &to, eps, &[o as u32], &mut touches);
    for (&r, t) in candidates.iter().zip(touches) {
        covered[r] = t;
    }
    covered
}

/// Trace the splat texels `which` of object `o` (in texel order, so the capture's ray
/// packets stay coherent) and cache where they land.
pub(super) fn trace_texels(
    world: &World,
    camera: &ProbeCamera,
    o: usize,
    texels: &mut SplatTexels,
    which: &[usize],
) {
    if which.is_empty() {
        return;
    }
    let dirs: Vec<Vec3> = which.iter().map(|&t| camera.cube.directions[t]).collect();
    let mut hits = vec![Hit::MISS; dirs.len()];
    world
        .vis
        .capture(&[texels.centre], &dirs, 0.0, &[o as u32], &mut hits);
    let covered = covered_by(world, o, texels.centre, &dirs, &hits);
    for ((&t, h), covered) in which.iter().zip(&hits).zip(covered) {
        let seen = world.seen_patch(h).filter(|_| !covered);
        texels.seen[t] = seen.map_or(LANDS_NOWHERE, |j| j as u32);
        texels.t[t] = if h.is_hit() { h.t } else { f32::INFINITY };
    }
}

/// Sum irradiance pieces per patch: one entry per patch, in order of first appearance.
/// `scratch` (one value per patch, all zero) is left all zero.
pub(super) fn sum_by_patch(
    scratch: &mut [Vec3],
    pieces: impl IntoIterator<Item = (u32, Vec3)>,
) -> Vec<(u32, Vec3)> {
    let mut touched: Vec<u32> = Vec::new();
    for (j, e) in pieces {
        let s = &mut scratch[j as usize];
        if *s == Vec3::ZERO {
            touched.push(j);
        }
        *s += e;
    }
    // A patch whose pieces cancelled to exactly zero would be listed twice: drop repeats.
    touched
        .into_iter()
        .filter_map(|j| {
            let e = std::mem::take(&mut scratch[j as usize]);
            (e != Vec3::ZERO).then_some((j, e))
        })
        .collect()
}
