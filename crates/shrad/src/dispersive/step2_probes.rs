//! Step 2 of the frame (paper 2.3.3, "计算选定的场景内部物体的光照"): light each object the
//! scheduler picked from the 8 probes at the corners of its box. Capture a cube map at each
//! probe (2.3.3 Step 2), project it to SH (Step 3), interpolate the SH trilinearly to each
//! patch with the weights precomputed in 2.3.1, and dot with the patch's clamped-cosine lobe
//! (Step 4).
//!
//! Beyond the paper, each switchable (docs/results.md): probes that see mostly back faces
//! are invalid and dropped or moved inward (`ProbeRepair`); the object may be transparent to
//! its own probes (`see_through_self`); faces resting on another surface are darkened by
//! their *contact openness*; and a concave object shadows itself through a transfer vector
//! with self-visibility plus its self form factors (`setup::self_transfer`, precomputed with the
//! object at rest, the precomputed radiance transfer the paper cites).

use std::time::Instant;

use glam::{Affine3A, Vec3, Vec3A};
use rayon::prelude::*;
use shrad_sh::{cosine_lobe_sh, num_coeffs, ShRgb, MAX_COEFFS};
use shrad_vis::Hit;

use super::caches::{ProbeCache, ProbeHits, MAX_PROBE_BYTES, SEES_BACK, SEES_NOTHING, SEES_STALE};
use super::object_state::ObjectLight;
use super::{ms, Dispersive, DispersiveStats, ProbeRepair};
use crate::probes::{ProbeCamera, Seen};
use crate::World;

impl Dispersive {
    /// Object `k`'s light from its 8 corner probes (2.3.3 Steps 2-4), per patch, before its
    /// contact openness.
    pub(super) fn object_light(
        &mut self,
        world: &World,
        k: usize,
        steps: &mut DispersiveStats,
    ) -> ObjectLight {
        let t = Instant::now();
        let m = world.patches.world_from_local[self.objects[k].object];
        self.near_field_follows(world, k);
        let tt = Instant::now();
        let (probes, scale) = self.capture_corner_probes(world, k, m, steps);
        super::tr("capture_corner_probes", tt);
        let tt = Instant::now();
        self.objects[k].probe_scale = scale;
        self.refresh_probe_visibility(world, k, m, || true);
        let probes = self.probes_in_object_frame(k, m, probes);
        let e = self.interpolate_probes(world, k, &probes);
        super::tr("interpolate", tt);
        ObjectLight { e, ms: ms(t) }
    }

    /// Measure which probes object `k`'s patches see where it is not current
    /// (`probe_visibility.rs`), for the probes where they stand now (`m`: the object's
    /// place), until `more()` says there is no time left (the update itself measures it
    /// all). Returns whether it is all current. Nothing to do in a coarse update (the object
    /// moves: its probes move with it, and every probe is read as in the paper).
    pub(super) fn refresh_probe_visibility(
        &mut self,
        world: &World,
        k: usize,
        m: Affine3A,
        more: impl FnMut() -> bool,
    ) -> bool {
        if !self.reads_probe_visibility(k) {
            return true;
        }
        let ob = &mut self.objects[k];
        let places = std::array::from_fn(|c| m.transform_point3(ob.probe_local(c)));
        ob.probe_vis.refresh(world, ob.object, &places, more)
    }

    /// Whether object `k`'s update reads (and so measures) which probes its patches see:
    /// with `probe_visibility`, except in a coarse update.
    fn reads_probe_visibility(&self, k: usize) -> bool {
        self.options.probe_visibility && !self.cameras_for(k).2
    }

    /// With transfer vectors (object frame) the probes are rotated into the object's frame
    /// once: rotation is linear, so this equals rotating every patch's interpolated SH.
    /// Without, they stay in the world frame.
    fn probes_in_object_frame(
        &self,
        k: usize,
        m: glam::Affine3A,
        probes: Vec<Option<ShRgb>>,
    ) -> Vec<Option<ShRgb>> {
        if self.objects[k].transfer.is_empty() {
            return probes;
        }
        let bands = self.options.bands;
        let (_, rotation, _) = m.to_scale_rotation_translation();
        let to_local = shrad_sh::ShRotation::from_quat(bands, rotation.inverse());
        probes
            .iter()
            .map(|sh| {
                sh.as_ref().map(|sh| {
                    let mut local = ShRgb::zeros(bands);
                    to_local.rotate_rgb(sh, &mut local);
                    local
                })
            })
            .collect()
    }

    /// Each patch of object `k` lit from the probes (paper 2.3.3 Step 4): the SH interpolated
    /// trilinearly (renormalised over the valid probes), dotted with the patch's transfer
    /// vector or clamped-cosine lobe, plus the object's own light in the directions it
    /// blocks (self form factors).
    fn interpolate_probes(&self, world: &World, k: usize, probes: &[Option<ShRgb>]) -> Vec<Vec3> {
        let p = &world.patches;
        let nc = num_coeffs(self.options.bands);
        let ob = &self.objects[k];
        let kk = k;
        let seen_light = self.near_seen_light(world, k);
        let range = p.range(ob.object);
        let with_transfer = !ob.transfer.is_empty();
        let use_visibility = self.reads_probe_visibility(kk);
        // The probes' coefficients as SIMD vectors once, not per patch: the sum below is
        // 8 probes x `nc` coefficients a patch (the same products and sums, lane by lane).
        let probes: Vec<Option<[Vec3A; MAX_COEFFS]>> = (probes.iter())
            .map(|sh| sh.as_ref().map(|sh| simd_coeffs(sh, nc)))
            .collect();
        range
            .clone()
            .into_par_iter()
            .map(|i| {
                let k = i - range.start;
                // The probes another object hides from this patch are left out (none hidden
                // while it is not measured).
                let hidden = match use_visibility {
                    true => ob.probe_vis.hidden(k),
                    false => 0,
                };
                let mut l = [Vec3A::ZERO; MAX_COEFFS];
                let mut sum_w = 0.0;
                for (c, (sh, &wc)) in probes.iter().zip(&ob.weights[k]).enumerate() {
                    if let Some(sh) = sh.as_ref().filter(|_| hidden >> c & 1 == 0) {
                        for (a, &b) in l[..nc].iter_mut().zip(&sh[..nc]) {
                            *a += b * wc;
                        }
                        sum_w += wc;
                    }
                }
                // No probe it may read: every valid one hidden (a buried patch gets no
                // probe light, but its near field and its own), or none valid.
                if sum_w <= 0.0 && hidden == 0 {
                    return Vec3::ZERO;
                }
                let mut lobe = [0f32; MAX_COEFFS];
                if with_transfer {
                    lobe[..nc].copy_from_slice(&ob.transfer[k * nc..(k + 1) * nc]);
                } else {
                    cosine_lobe_sh(self.options.bands, p.normal[i], &mut lobe[..nc]);
                };
                // The near field's directions are gathered below, not read from the probes.
                let (near_lobe, near) = match ob.near.lobe.is_empty() {
                    true => (&[][..], Vec3::ZERO),
                    false => (
                        &ob.near.lobe[k * nc..(k + 1) * nc],
                        self.near_light(kk, k, &seen_light),
                    ),
                };
                for (a, b) in lobe.iter_mut().zip(near_lobe) {
                    *a -= b;
                }
                let dot: Vec3 = match sum_w > 0.0 {
                    true => {
                        let dot = (l[..nc].iter().zip(&lobe[..nc])).map(|(a, &b)| *a * b);
                        Vec3::from(dot.sum::<Vec3A>()) / sum_w
                    }
                    false => Vec3::ZERO,
                };
                let own: Vec3 = if with_transfer {
                    ob.self_view(k)
                        .iter()
                        .map(|&(q, f)| {
                            let q = range.start + q as usize;
                            (self.radiosity[q] - world.exitance[q]) * f
                        })
                        .sum()
                } else {
                    Vec3::ZERO
                };
                dot.max(Vec3::ZERO) + own + near
            })
            .collect()
    }

    /// Per patch of object `k`, the (cosine-weighted) fraction of its hemisphere that is not
    /// closed off right in front of it: rays start just *inside* the surface (the object
    /// itself transparent) and look for anything within 2 % of the object's box diagonal.
    /// A face resting on the floor gets 0 — the probes, a box-size apart, cannot see that
    /// contact and would light it with the floor's radiance.
    pub(super) fn contact_openness(&self, world: &World, k: usize) -> Vec<f32> {
        let p = &world.patches;
        let ob = &self.objects[k];
        let o = ob.object;
        let m = p.world_from_local[o];
        let reach = 0.02 * m.transform_vector3(ob.probe_box.size()).length();
        let rays = self.options.contact_rays as usize;
        let range = p.range(o);
        let mut origins = vec![Vec3::ZERO; range.len() * rays];
        let mut dirs = vec![Vec3::ZERO; range.len() * rays];
        origins
            .par_chunks_mut(rays)
            .zip(dirs.par_chunks_mut(rays))
            .enumerate()
            .for_each(|(k, (org, dir))| {
                let i = range.start + k;
                let n = p.normal[i];
                let shift = (crate::sampling::unit(crate::sampling::hash(i as u32)), 0.5);
                for j in 0..rays {
                    let (u, v) = crate::sampling::hammersley(j as u32, rays as u32, shift);
                    org[j] = p.centre[i] - n * world.eps;
                    dir[j] = crate::sampling::square_to_cosine_hemisphere(u, v, n);
                }
            });
        // Only whether something lies within `reach` matters: short shadow rays over the
        // segment (0, reach] of each ray (`occluded` shortens a segment by `eps` at both
        // ends, so it is extended by `eps` on both sides), which stop at the first hit.
        let eps = world.eps;
        let from: Vec<Vec3> = origins
            .par_iter()
            .zip(&dirs)
            .map(|(&o, &d)| o - d * eps)
            .collect();
        let to: Vec<Vec3> = origins
            .par_iter()
            .zip(&dirs)
            .map(|(&o, &d)| o + d * (reach + eps))
            .collect();
        let mut blocked = vec![false; from.len()];
        world
            .vis
            .occluded(&from, &to, eps, &[o as u32], &mut blocked);
        blocked
            .chunks(rays)
            .map(|b| b.iter().filter(|&&b| !b).count() as f32 / rays as f32)
            .collect()
    }

    /// The SH radiance of the 8 probes of object `k` (paper 2.3.3 Steps 2-3); `None` for a
    /// probe dropped as invalid. A probe whose hits are cached (`caches.rs`) is only shaded
    /// and projected again; the others are captured, checked and, if invalid, repaired.
    fn capture_corner_probes(
        &mut self,
        world: &World,
        k: usize,
        m: Affine3A,
        steps: &mut DispersiveStats,
    ) -> (Vec<Option<ShRgb>>, [Vec3; 8]) {
        // A coarse capture is of a moving object, which the next frame moves again, or in
        // place of a full update being prepared in the cache (`prepare.rs`): it neither
        // reads nor keeps the cache.
        let mut cache = match self.cameras_for(k).2 {
            true => ProbeCache::default(),
            false => std::mem::take(&mut self.objects[k].probe_cache),
        };
        let (camera, _, coarse) = self.cameras_for(k);
        let ob = &self.objects[k];
        let o = ob.object as u32;
        if cache.key != Some((m, ob.probe_scale)) {
            cache = ProbeCache::default();
        }
        let exclude = self.probes_see_through(world, k);
        let limit = self.options.invalid_back_fraction;
        let repair = self.options.repair;
        // The eight probes side by side: each one's stale texels are a few hundred rays, and
        // its back fraction a pass over its texels (one after the other, the second worker
        // mostly waited).
        steps.probe_texels_retraced += (cache.probes.iter().flatten())
            .map(|h| h.stale.len())
            .sum::<usize>();
        cache.probes.par_iter_mut().for_each(|slot| {
            let Some(h) = slot.as_mut().filter(|h| !h.stale.is_empty()) else {
                return;
            };
            self.retrace_stale_texels(world, h, &exclude, o);
            // A probe that turned invalid is captured afresh below, to be moved inward from
            // where it stands, as an uncached update would.
            if h.back_fraction > limit && repair.moves() {
                *slot = None;
            }
        });
        // Capture the probes not cached, all in one batch.
        let missing: Vec<usize> = (0..8).filter(|&c| cache.probes[c].is_none()).collect();
        let mut scale = ob.probe_scale;
        let mut slots = std::mem::take(&mut cache.probes);
        self.capture_probes(
            world,
            k,
            m,
            camera,
            (&mut slots, &mut scale),
            &missing,
            steps,
        );
        let valid = |h: &ProbeHits| h.back_fraction <= limit || repair == ProbeRepair::None;
        // Shade every texel from the current radiosity and project to SH.
        let projector = &camera.projector;
        let out: Vec<Option<ShRgb>> = slots
            .par_iter()
            .map(|h| {
                let h = h.as_ref().filter(|h| valid(h))?;
                Some(projector.project_indexed(|t| match h.seen[t] {
                    // Stale texels were all traced again above.
                    SEES_NOTHING | SEES_BACK | SEES_STALE => Vec3::ZERO,
                    j => self.texel_radiance(world, j as usize),
                }))
            })
            .collect();
        // Keep what a later update can reuse: not a probe MoveInward failed to repair.
        if self.caching && !coarse && 8 * 8 * self.camera.texels() <= MAX_PROBE_BYTES {
            for h in &mut slots {
                if h.as_ref().is_some_and(|h| !valid(h)) {
                    *h = None;
                }
            }
            cache.key = Some((m, scale));
            cache.probes = slots;
            self.objects[k].probe_cache = cache;
        }
        (out, scale)
    }

    /// Capture probes `which` of object `k` at `m` with `camera`, in one batch, into
    /// `slots`; an invalid one is repaired (moved, its `scale` changed) as the options say.
    pub(super) fn capture_probes(
        &self,
        world: &World,
        k: usize,
        m: Affine3A,
        camera: &ProbeCamera,
        (slots, scale): (&mut [Option<ProbeHits>; 8], &mut [Vec3; 8]),
        which: &[usize],
        steps: &mut DispersiveStats,
    ) {
        let ob = &self.objects[k];
        let o = ob.object as u32;
        let exclude = self.probes_see_through(world, k);
        let (limit, repair) = (self.options.invalid_back_fraction, self.options.repair);
        let points: Vec<Vec3> = which
            .iter()
            .map(|&c| m.transform_point3(ob.probe_at(c, scale[c])))
            .collect();
        let fresh = self.probe_hits(world, camera, &points, &exclude, o);
        steps.probes_captured += points.len();
        for (&c, hits) in which.iter().zip(fresh) {
            if hits.back_fraction > limit {
                steps.probes_invalid += 1;
            }
            if hits.back_fraction > limit && repair.moves() {
                let tries = self.repair_tries(m, camera, &hits, scale[c]);
                for s in tries {
                    let q = m.transform_point3(ob.probe_at(c, s));
                    let again = self.probe_hits(world, camera, &[q], &exclude, o).pop();
                    steps.probes_captured += 1;
                    if let Some(again) = again.filter(|h| h.back_fraction <= limit) {
                        slots[c] = Some(again);
                        scale[c] = s;
                        steps.probes_repaired += 1;
                        break;
                    }
                }
                if slots[c].is_none() {
                    slots[c] = Some(hits);
                }
            } else {
                slots[c] = Some(hits);
            }
        }
    }

    /// Where an invalid probe of object `k` is tried next, in order, as per-axis scales of
    /// its place from the box centre (`ObjectProbes::probe_at`), each inward of `scale`:
    /// `MoveInward` along the diagonal (the whole scale shrinks); `MoveOut` first along the
    /// one box axis nearest the direction of the closest back face it sees (through the
    /// floor it is buried in: it stays beside its object, where a probe moved inward along
    /// the diagonal sees the dark floor under the object), then along the diagonal.
    fn repair_tries(
        &self,
        m: Affine3A,
        camera: &ProbeCamera,
        hits: &ProbeHits,
        scale: Vec3,
    ) -> Vec<Vec3> {
        const STEPS: [f32; 4] = [0.8, 0.6, 0.4, 0.2];
        let mut tries = Vec::new();
        let closest_back = (hits.seen.iter().zip(&hits.t).enumerate())
            .filter(|(_, (&s, _))| s == SEES_BACK)
            .min_by(|a, b| a.1 .1.total_cmp(b.1 .1));
        if let (ProbeRepair::MoveOut, Some((t, _))) = (self.options.repair, closest_back) {
            // (A corner whose face lies outward along that axis finds no valid place on
            // it and goes on along the diagonal.)
            let d = m.inverse().transform_vector3(camera.cube.directions[t]);
            let a = d.abs().max_position();
            for s in STEPS.into_iter().filter(|&s| s < scale[a]) {
                let mut v = scale;
                v[a] = s;
                tries.push(v);
            }
        }
        let diagonal = scale.min_element();
        tries.extend(STEPS.into_iter().filter(|&s| s < diagonal).map(Vec3::splat));
        tries
    }

    /// Trace again the texels of a cached probe that a mover's box marked stale
    /// (`forget_stale_caches`): the same rays a full capture casts, only fewer.
    fn retrace_stale_texels(&self, world: &World, h: &mut ProbeHits, exclude: &[u32], o: u32) {
        let dirs: Vec<Vec3> = h
            .stale
            .iter()
            .map(|&t| self.camera.cube.directions[t as usize])
            .collect();
        let mut hits = vec![Hit::MISS; dirs.len()];
        world
            .vis
            .capture(&[h.origin], &dirs, 0.0, exclude, &mut hits);
        for (&t, hit) in h.stale.iter().zip(&hits) {
            h.seen[t as usize] = self.seen_code(world, hit, o);
            h.t[t as usize] = if hit.is_hit() { hit.t } else { f32::INFINITY };
        }
        h.stale.clear();
        h.back_fraction = back_fraction(&h.seen, &self.camera.cube.solid_angles);
    }

    /// Capture a cube map at each of `points` and keep, per texel, what shading needs: the
    /// patch seen (as [`Dispersive::shade_probe_texel`] decides) and the distance.
    fn probe_hits(
        &self,
        world: &World,
        camera: &ProbeCamera,
        points: &[Vec3],
        exclude: &[u32],
        o: u32,
    ) -> Vec<ProbeHits> {
        let n = camera.texels();
        let solid_angles = &camera.cube.solid_angles;
        let hits = camera.capture_hits(world, points, exclude);
        hits.par_chunks(n)
            .zip(points)
            .map(|(h, &origin)| {
                let seen: Vec<u32> = h.iter().map(|h| self.seen_code(world, h, o)).collect();
                let t: Vec<f32> = h
                    .iter()
                    .map(|h| if h.is_hit() { h.t } else { f32::INFINITY })
                    .collect();
                ProbeHits {
                    origin,
                    back_fraction: back_fraction(&seen, solid_angles),
                    seen,
                    t,
                    stale: Vec::new(),
                }
            })
            .collect()
    }

    /// What a probe texel of object `o` sees, as a code (see `caches.rs`): the same
    /// decisions as [`Dispersive::shade_probe_texel`].
    pub(super) fn seen_code(&self, world: &World, h: &Hit, o: u32) -> u32 {
        if !h.is_hit() || h.object == o {
            return SEES_NOTHING;
        }
        match world.seen_patch(h) {
            Some(j) if !self.outer_side[j] => j as u32,
            _ => SEES_BACK,
        }
    }

    /// Radiance a probe texel that sees patch `j` receives.
    pub(super) fn texel_radiance(&self, world: &World, j: usize) -> Vec3 {
        let b = if self.options.direct_on_interior {
            self.radiosity[j] - world.exitance[j]
        } else {
            self.radiosity[j]
        };
        b * std::f32::consts::FRAC_1_PI
    }

    /// The objects interior object `k`'s probes see through: its own (`see_through_self`)
    /// and those within its near reach (`see_through_near`, `Dispersive::near_objects`).
    pub(super) fn probes_see_through(&self, world: &World, k: usize) -> Vec<u32> {
        let own = self.objects[k].object as u32;
        let mut exclude = Vec::new();
        if self.options.see_through_self {
            exclude.push(own);
        }
        exclude.extend(self.near_objects(world, k));
        exclude
    }

    /// Radiance a probe texel of object `o` sees (paper 2.3.3: its own texels are 0).
    pub(super) fn shade_probe_texel(&self, world: &World, h: &Hit, o: u32) -> Seen {
        match self.seen_code(world, h, o) {
            SEES_NOTHING => Seen::Radiance(Vec3::ZERO),
            SEES_BACK => Seen::BackFace,
            j => Seen::Radiance(self.texel_radiance(world, j as usize)),
        }
    }
}

/// Fraction of the sphere (by solid angle) whose texels see back faces.
fn back_fraction(seen: &[u32], solid_angles: &[f32]) -> f32 {
    let back: f32 = seen
        .iter()
        .zip(solid_angles)
        .filter(|(&s, _)| s == SEES_BACK)
        .map(|(_, &sa)| sa)
        .sum();
    back / (4.0 * std::f32::consts::PI)
}

/// An SH's first `nc` coefficients as SIMD vectors (the rest zero).
fn simd_coeffs(sh: &ShRgb, nc: usize) -> [Vec3A; MAX_COEFFS] {
    let mut out = [Vec3A::ZERO; MAX_COEFFS];
    for (a, &b) in out[..nc].iter_mut().zip(sh.coeffs()) {
        *a = b.into();
    }
    out
}
