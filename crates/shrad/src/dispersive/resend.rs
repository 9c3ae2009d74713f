//! Step 3 while another object moves (beyond the paper, `resend_tolerance`) or the scene
//! settles: a still object that the scheduler updates because a mover came near it sends
//! the boundary nearly the light it sent before. What changed is where some of its light paths land: the texels of
//! its splat, or the entries of its gather, whose rays the mover's swept box crossed, which
//! the stale test forgot (`stale.rs`). Unless the light it emits changed by more than the
//! tolerance since it was sent, only those are traced again: a texel's flux, as it was sent,
//! is moved from the patch it went to onto the patch it reaches now; an entry's irradiance,
//! as it was sent, is taken off its patch if its ray is blocked now, or put on if it is
//! clear now (`gather::crossed_entries`, which keeps the softening's rescaling as it was
//! sent). This is the paper's "only the current object's share is updated", 2.3.4 Step 3,
//! narrowed to the share that changed. After a light changed, or when the emitted light
//! changed more, the whole contribution is sent again (`step3_to_boundary.rs`). While the
//! scene settles (nothing moves) the tolerance is `sleep_tolerance` instead: an object whose
//! light changed by less than that since it sent it would sleep with that contribution
//! anyway, so a scene that settles converges to the same light as without this, within the
//! tolerance it sleeps at ([`Dispersive::amend_tolerance`]; with the walls' doze, `sleep.rs`,
//! the 77k room's awake still frames without rays went from 7.7-7.9 ms to 0.9-1.0 ms median).
//!
//! Why: in the 1M-patch room a still neighbour's full splat reaches 355k boundary patches
//! (13 ms of Step 3, and Step 4 and the meter then visit every chunk it touched), while the
//! texels a mover crosses in a frame are a few hundred. In the 40k objects rooms (the
//! gather) a still box's full send evaluated 213k-269k entries, 5-6 ms of one thread; the
//! amendment takes 0.4-0.6 ms.

use glam::Vec3;
use rayon::prelude::*;
use shrad_sh::ShRgb;

use super::caches::{EmitterRays, LANDS_NOWHERE, UNKNOWN};
use super::gather::crossed_entries;
use super::object_state::CrossedAhead;
use super::setup::receives_as_boundary;
use super::step3_to_boundary::trace_texels;
use super::Dispersive;
use crate::World;

impl Dispersive {
    /// The change [`Dispersive::resend_crossed_paths`] would send for object `k`, found
    /// before its light is stored: what its crossed paths carry is what it sent (`sent`), so
    /// it needs neither Step 1 nor Step 2, and the frame finds it beside Step 1 (the 77k
    /// room's still neighbour re-traces a few hundred texels a frame, 0.3-0.4 ms that ran
    /// after the join mostly on one core: its emitters facing the mover hold most of them).
    /// `None` when the object may not be amended. If Step 3 then sends it whole (its light
    /// changed more than `tolerance`), the texels traced here are where the whole send finds
    /// them (a fresh trace of the same scene) and nothing else was changed.
    pub(super) fn crossed_ahead(
        &mut self,
        world: &World,
        k: usize,
        tolerance: f64,
    ) -> Option<CrossedAhead> {
        if tolerance <= 0.0 || !self.may_resend_crossed_paths(world, k) {
            return None;
        }
        let started = std::time::Instant::now();
        let pieces = self.crossed_pieces(world, k);
        let change = self.pieces_to_irradiance(world, pieces);
        let ms = super::ms(started);
        Some(CrossedAhead { k, change, ms })
    }

    /// Send the boundary only what changed in object `k`'s light paths, when it may (see
    /// the module's docs) and the light it emits is within `tolerance` of what it sent;
    /// whether it did (with `ahead` when its change was found ahead of Step 3). Returns the
    /// flux moved (net), and the time finding the change took ahead (ms), when it did.
    pub(super) fn resend_crossed_paths(
        &mut self,
        world: &World,
        k: usize,
        tolerance: f64,
        ahead: Option<CrossedAhead>,
    ) -> Option<(f64, f64)> {
        if tolerance <= 0.0 || !self.may_resend_crossed_paths(world, k) {
            return None;
        }
        let cache = &self.objects[k].emitter_cache;
        let now = self.emitter_intensities(world, k, &cache.lobes);
        if relative_change(&now, &cache.sent) > tolerance {
            return None;
        }
        let (change, ahead_ms) = match ahead {
            Some(a) => (a.change, a.ms),
            None => {
                let pieces = self.crossed_pieces(world, k);
                (self.pieces_to_irradiance(world, pieces), 0.0)
            }
        };
        Some((self.amend(world, k, change), ahead_ms))
    }

    /// Object `k`'s crossed paths found ahead that Step 3 did not read (it did not light
    /// the object): the change is sent anyway, since the texels it moved are no longer
    /// listed as forgotten (the light as sent lands where it lands now). Returns the flux.
    pub(super) fn amend_ahead(&mut self, world: &World, ahead: CrossedAhead) -> f64 {
        self.amend(world, ahead.k, ahead.change)
    }

    /// Add `change` (irradiance per boundary patch) to object `k`'s contribution; the net
    /// flux it moved.
    fn amend(&mut self, world: &World, k: usize, change: Vec<(u32, Vec3)>) -> f64 {
        let area = &world.patches.area;
        let mut flux = 0.0;
        for &(j, e) in &change {
            self.indirect[j as usize] += e;
            self.touched.patch(j as usize);
            flux += (e * area[j as usize]).element_sum() as f64 / 3.0;
        }
        // Kept as further pieces of its contribution, which the next full send removes.
        self.objects[k].to_boundary.extend(change);
        flux
    }

    /// How close to what it sent an object's emitted light must be for Step 3 to amend its
    /// contribution rather than send it whole: `resend_tolerance` while another object moves;
    /// `sleep_tolerance` while the scene settles (nothing moves, no light changed), the
    /// change below which the object would sleep with that contribution anyway; 0 (always
    /// whole) when a light changed.
    pub(super) fn amend_tolerance(&self, changes: &super::Changes) -> f64 {
        match (changes.light_changed(), changes.moved.is_empty()) {
            (true, _) => 0.0,
            (false, false) => self.options.resend_tolerance as f64,
            (false, true) => self.options.sleep_tolerance as f64,
        }
    }

    /// Whether object `k`'s contribution can be amended rather than sent again: it does not
    /// move, its light is at full resolution, and
    /// the boundary holds a contribution sent from its current place with these emitters.
    fn may_resend_crossed_paths(&self, world: &World, k: usize) -> bool {
        let ob = &self.objects[k];
        let cache = &ob.emitter_cache;
        let m = world.patches.world_from_local[ob.object];
        self.caching
            && !ob.moving
            && !self.cameras_for(k).2
            && cache.key == Some(m)
            && !cache.sent.is_empty()
            && cache.sent.len() == cache.rays.len()
            // Amendments pile up in `to_boundary`: beyond twice its size, send it whole.
            && ob.to_boundary.len() <= 2 * cache.sent_len.max(1024)
    }

    /// Per emitter of object `k`, the texels forgotten since its contribution was sent, traced
    /// again: (patch, flux) pieces that take each one's flux, as sent, off the patch it went
    /// to and onto the one it reaches now.
    fn crossed_pieces(&mut self, world: &World, k: usize) -> Vec<(u32, Vec3)> {
        let o = self.objects[k].object;
        // Full resolution: `may_resend_crossed_paths` leaves coarse light to a full send.
        let camera = &self.emitter_camera;
        let softens: Vec<f32> = (self.objects[k].emitters.iter())
            .map(|(_, members, _)| self.soften(world, k, members))
            .collect();
        let mut cache = std::mem::take(&mut self.objects[k].emitter_cache);
        let each: Vec<Vec<(u32, Vec3)>> = cache
            .rays
            .par_iter_mut()
            .zip(&cache.sent)
            .zip(&softens)
            .map(|((rays, sent), &soften)| {
                let texels = match rays {
                    EmitterRays::Splat(texels) => texels,
                    EmitterRays::Gather(g) => return crossed_entries(world, o, g, sent, soften),
                };
                // A texel forgotten twice is listed twice.
                let mut which = std::mem::take(&mut texels.forgotten);
                which.sort_unstable();
                which.dedup();
                // Only texels that carried flux: the boundary never held the others.
                let flux: Vec<(usize, Vec3)> = which
                    .into_iter()
                    .map(|t| t as usize)
                    .filter(|&t| texels.seen[t] == UNKNOWN)
                    .filter_map(|t| {
                        let f = camera.projector.texel_value(sent, t).max(Vec3::ZERO);
                        (f.max_element() > 0.0).then_some((t, f))
                    })
                    .collect();
                let trace: Vec<usize> = flux.iter().map(|&(t, _)| t).collect();
                trace_texels(world, camera, o, texels, &trace);
                let mut pieces = Vec::new();
                for (t, f) in flux {
                    let j = texels.seen[t];
                    let lands = j != LANDS_NOWHERE && receives_as_boundary(world, j as usize);
                    let now = if lands { j } else { LANDS_NOWHERE };
                    let was = std::mem::replace(&mut texels.sent_to[t], now);
                    if now == was {
                        continue;
                    }
                    if was != LANDS_NOWHERE {
                        pieces.push((was, -f));
                    }
                    if now != LANDS_NOWHERE {
                        pieces.push((now, f));
                    }
                }
                pieces
            })
            .collect();
        self.objects[k].emitter_cache = cache;
        each.concat()
    }
}

/// `sum |now - sent| / sum |sent|` over every emitter's coefficients and channels (0 when
/// both are zero; infinite when only `sent` is).
fn relative_change(now: &[ShRgb], sent: &[ShRgb]) -> f64 {
    let (mut diff, mut total) = (0f64, 0f64);
    for (a, b) in now.iter().zip(sent) {
        for (x, y) in a.coeffs().iter().zip(b.coeffs()) {
            diff += (*x - *y).abs().element_sum() as f64;
            total += y.abs().element_sum() as f64;
        }
    }
    if diff == 0.0 {
        0.0
    } else if total > 0.0 {
        diff / total
    } else {
        f64::INFINITY
    }
}
