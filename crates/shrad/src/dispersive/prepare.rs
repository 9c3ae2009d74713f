//! An object's update prepared over several frames under a budget (beyond the paper, which
//! updates one object a frame and so takes whatever that object costs).
//!
//! The update of an object that has just come to rest is the most expensive one it makes:
//! its geometry is all new at full resolution. In the 77k room, the frame the 4,512-patch
//! sphere came to rest under a 20 ms budget took 64-77 ms: its near field, its 8 probes
//! captured at full resolution (14-17 ms) and the rays of its 30 split emitters' splats
//! (30-33 ms). All three are geometry: they do not depend on the light, so they can be
//! measured ahead of the update, a piece at a time, into the caches the update reads
//! (`caches.rs`), where the stale test keeps them right if something else moves meanwhile.
//! The object keeps its last light until they are whole, within the staleness bound.

use std::time::Instant;

use super::caches::{ProbeCache, MAX_PROBE_BYTES, MAX_STEP3_BYTES};
use super::{Dispersive, DispersiveStats};
use crate::World;

/// The near-field rays an update measures again at most while something moves, of the
/// patches a neighbour's move made stale (`Dispersive::measure_openness`): the rest wait
/// for the object's next updates, all of them once nothing moves. The Cornell box's short
/// block dragged beside the tall one (example `drag_frames`, 300 frames): its p90 frame
/// 44 ms measuring them all, 16 ms at this, 24 at twice it, 11 at a quarter; the interior
/// error at the drag's end 3.16 % all, 3.44 % at this, 3.29 / 5.33 %; the same as all once
/// still.
pub(super) const NEAR_RAYS_WHILE_NEIGHBOURS_MOVE: usize = 32_768;

/// Probes captured at a time while an update is prepared: one full resolution probe is a
/// twelfth to a sixth of a 20 ms budget at 77k.
const PROBES_AT_ONCE: usize = 1;

/// Whether a stage of the preparation is whole, and whether it worked in this frame.
struct Stage {
    whole: bool,
    worked: bool,
}

impl Stage {
    const NOTHING_TO_DO: Stage = Stage {
        whole: true,
        worked: false,
    };
}

impl Dispersive {
    /// Whether object `k` can be updated now. Its near field and contact openness are
    /// measured where it is now, if they are not yet (it moved, or something moved within
    /// their reach): geometry, measured before its probes are interpolated, which read the
    /// near field. Under a deadline (when the objects' share of the frame ends), with the
    /// caches on, that is done a chunk of patches at a time, and so are the capture of its
    /// probes and the rays of its emitters, and the object waits (false) until a frame in
    /// which all are whole with time left. Meanwhile its light is the last update's.
    ///
    /// An object that may not wait longer (the staleness bound) goes now: at full
    /// resolution, measuring what is left in one go; or, if its light is coarse (it came
    /// to rest from a drag) and its full update is not prepared after one more piece, with
    /// a coarse update as while it moved (`coarse_now`), cheap, and the full one is
    /// prepared on.
    /// Without a deadline the update measures what it needs itself, as it always did: the
    /// light is the same either way.
    pub(super) fn prepare_update(
        &mut self,
        world: &World,
        k: usize,
        deadline: Option<Instant>,
        steps: &mut DispersiveStats,
    ) -> bool {
        let Some(deadline) = deadline.filter(|_| self.caching) else {
            return self.measure_openness(world, k, None).whole;
        };
        if !self.scheduler.may_wait(k, self.frame) {
            let ob = &self.objects[k];
            if !(self.options.coarse_while_moving && ob.coarse_light && !ob.moving) {
                return self.measure_openness(world, k, None).whole;
            }
            // A piece of the preparation all the same (an object that only ever goes over
            // the bound, under a budget far below its cost, is prepared in the end), in what
            // time the coarse update (its last cost) leaves.
            let coarse_ms = super::secs(self.scheduler.last_cost(k));
            let until = deadline.checked_sub(coarse_ms).unwrap_or(deadline);
            if !self.prepare_within(world, k, until, steps) {
                self.objects[k].coarse_now = true;
            }
            return true;
        }
        self.prepare_within(world, k, deadline, steps)
    }

    /// Whether object `k`'s full update is prepared with time left before `deadline`, after
    /// preparing on until then (at least a piece).
    fn prepare_within(
        &mut self,
        world: &World,
        k: usize,
        deadline: Instant,
        steps: &mut DispersiveStats,
    ) -> bool {
        let near = self.measure_openness(world, k, Some(deadline));
        if !near.whole {
            return false;
        }
        // Each stage goes on from where the last one stopped, with what time is left.
        let probes = self.capture_probes_within(world, k, (deadline, near.worked), steps);
        let worked = near.worked || probes.worked;
        if !probes.whole {
            return false;
        }
        // Where the probes now stand (repaired), which of them each patch sees.
        let visibility = self.measure_visibility_within(world, k, (deadline, worked));
        let worked = worked || visibility.worked;
        if !visibility.whole {
            return false;
        }
        let emitters = self.trace_emitters_within(world, k, (deadline, worked));
        let worked = worked || emitters.worked;
        // What was measured in this frame may have taken the time the update needed.
        emitters.whole && (!worked || Instant::now() < deadline)
    }

    /// Object `k`'s near field and contact openness, the near field on from where an
    /// earlier frame left it ([`Dispersive::near_field_within`]) until `deadline`.
    fn measure_openness(&mut self, world: &World, k: usize, deadline: Option<Instant>) -> Stage {
        let p = &world.patches;
        let patches = p.range(self.objects[k].object).len();
        if self.objects[k].openness_current {
            return Stage::NOTHING_TO_DO;
        }
        let stale = self.objects[k].near_stale.len();
        if stale * 2 > patches && !self.scheduler.something_moves() {
            // Most of it: measured whole (as cheap, and in pieces under a deadline).
            self.objects[k].forget_openness();
        } else if stale > 0 {
            // Only the patches a neighbour's move came within reach of (`stale.rs`); while
            // something moves, a slice of them an update, the others standing as they were
            // measured until their turn (the Cornell box's tall block, its short block
            // dragged beside it: 1.6-1.9k of its 2.8k patches stale at each of its updates,
            // 35 ms measured whole, one frame in four).
            let rays = self.options.near_rays.max(1) as usize;
            let at_most = (self.scheduler.something_moves())
                .then(|| (NEAR_RAYS_WHILE_NEIGHBOURS_MOVE / rays).max(1));
            self.near_field_again(world, k, at_most);
            let ob = &mut self.objects[k];
            ob.openness_current = ob.near_stale.is_empty();
            return Stage {
                whole: true,
                worked: true,
            };
        }
        let mut progress = self.objects[k].near_pending.take().unwrap_or_default();
        let (started, from) = (Instant::now(), progress.1);
        let whole = self.near_field_within(world, k, &mut progress, deadline);
        let measured = progress.1.max(from) - from;
        if measured > 0 {
            self.near_ms_per_patch = started.elapsed().as_secs_f64() * 1e3 / measured as f64;
        }
        if !whole {
            self.objects[k].near_pending = Some(progress);
            return Stage {
                whole: false,
                worked: true,
            };
        }
        let near = progress.0;
        // The near field, when measured, stands in for contact openness.
        let measured = !near.lobe.is_empty();
        self.objects[k].near = near;
        self.objects[k].openness = if self.options.contact_rays > 0 && !measured {
            self.contact_openness(world, k)
        } else {
            vec![1.0; patches]
        };
        self.objects[k].openness_current = true;
        Stage {
            whole: true,
            worked: true,
        }
    }

    /// The probes of object `k` not in its cache, captured [`PROBES_AT_ONCE`] at a time until
    /// `deadline` (at least once unless the preparation already `worked` in this frame),
    /// into the cache its update reads (`capture_corner_probes`). Not while its updates are
    /// coarse (their probes are not kept), nor when the cache would be too large to keep.
    fn capture_probes_within(
        &mut self,
        world: &World,
        k: usize,
        (deadline, mut worked): (Instant, bool),
        steps: &mut DispersiveStats,
    ) -> Stage {
        let (camera, _, coarse) = self.cameras_for(k);
        if coarse || 8 * 8 * camera.texels() > MAX_PROBE_BYTES {
            return Stage::NOTHING_TO_DO;
        }
        let m = world.patches.world_from_local[self.objects[k].object];
        let mut scale = self.objects[k].probe_scale;
        let mut cache = std::mem::take(&mut self.objects[k].probe_cache);
        let camera = self.cameras_for(k).0;
        if cache.key != Some((m, scale)) {
            cache = ProbeCache::default();
        }
        let worked_before = worked;
        loop {
            let missing: Vec<usize> = (0..8).filter(|&c| cache.probes[c].is_none()).collect();
            if missing.is_empty() || (worked && Instant::now() >= deadline) {
                break;
            }
            let which = &missing[..missing.len().min(PROBES_AT_ONCE)];
            let slots = (&mut cache.probes, &mut scale);
            self.capture_probes(world, k, m, camera, slots, which, steps);
            worked = true;
        }
        let whole = cache.probes.iter().all(Option::is_some);
        // A repaired probe moved: the cache is keyed by where the probes are.
        cache.key = Some((m, scale));
        self.objects[k].probe_scale = scale;
        self.objects[k].probe_cache = cache;
        Stage {
            whole,
            worked: worked && !worked_before,
        }
    }

    /// Which probes object `k`'s patches see (`probe_visibility.rs`), a probe's segments at
    /// a time until `deadline` (at least one unless the preparation already `worked` in this
    /// frame).
    fn measure_visibility_within(
        &mut self,
        world: &World,
        k: usize,
        (deadline, worked): (Instant, bool),
    ) -> Stage {
        let m = world.patches.world_from_local[self.objects[k].object];
        let (mut first, mut pieces) = (!worked, 0);
        let whole = self.refresh_probe_visibility(world, k, m, || {
            let go = std::mem::take(&mut first) || Instant::now() < deadline;
            pieces += usize::from(go);
            go
        });
        Stage {
            whole,
            worked: pieces > 0,
        }
    }

    /// The rays of object `k`'s emitters, one emitter at a time until `deadline` (at least
    /// one unless the preparation already `worked` in this frame), into the cache its Step 3
    /// reads (`emit`): the rays its light as it is now sends light along, which its next
    /// update's light differs from only a little (a ray that update needs and that is not
    /// traced is traced then). Not while its updates are coarse (one merged emitter, not
    /// kept), nor when the cache would be too large to keep.
    fn trace_emitters_within(
        &mut self,
        world: &World,
        k: usize,
        (deadline, mut worked): (Instant, bool),
    ) -> Stage {
        if self.cameras_for(k).2 || self.objects[k].emitters.is_empty() {
            return Stage::NOTHING_TO_DO;
        }
        let m = world.patches.world_from_local[self.objects[k].object];
        let mut cache = std::mem::take(&mut self.objects[k].emitter_cache);
        let emitters = self.objects[k].emitters.len();
        if cache.key != Some(m) || cache.rays.len() != emitters {
            cache = self.emitter_geometry(world, k, m, self.to_boundary_method(), false);
        }
        if cache.bytes() > MAX_STEP3_BYTES {
            // Too large to keep: the update traces its rays.
            self.objects[k].emitter_cache = cache;
            return Stage::NOTHING_TO_DO;
        }
        let worked_before = worked;
        while cache.prepared < emitters && !(worked && Instant::now() >= deadline) {
            let e = cache.prepared;
            let (_, members, _) = &self.objects[k].emitters[e];
            let intensity = self.emitter_intensity(world, k, members, &cache.lobes[e]);
            let soften = self.soften(world, k, members);
            // Only the rays: the pieces are sent by the update.
            self.emit_one(world, k, &mut cache.rays[e], &intensity, soften);
            cache.prepared += 1;
            worked = true;
        }
        let whole = cache.prepared == emitters;
        self.objects[k].emitter_cache = cache;
        Stage {
            whole,
            worked: worked && !worked_before,
        }
    }
}
