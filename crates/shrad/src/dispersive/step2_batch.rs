//! Step 2's batch (paper 2.3.3): the objects the scheduler picked lit one after another
//! from their probes (`step2_probes.rs`) and stored, under a budget's deadline; the first
//! one lit beside Step 1 (`Dispersive::direct_beside_first_object`), since what it reads of
//! Step 1 (its patches' direct light) is read only when it is stored.

use std::time::Instant;

use glam::Vec3;

use super::object_state::{FirstObject, ObjectLight};
use super::{ms, Batch, Dispersive, DispersiveStats, FrameStats};
use crate::World;

impl Dispersive {
    /// Step 2 (paper 2.3.3): light each object of the batch from its 8 corner probes.
    /// Returns the objects lit. Under a budget (`deadline`: when the objects' share of the
    /// frame ends) an object whose geometry is measured again may wait: see
    /// [`Dispersive::prepare_update`]. When the frame prepared and lit the batch's first
    /// object beside Step 1 (`first`), it is stored here.
    pub(super) fn light_selected_objects(
        &mut self,
        world: &World,
        (batch, first): (Batch, FirstObject),
        stats: &mut FrameStats,
        steps: &mut DispersiveStats,
        deadline: Option<Instant>,
    ) -> Vec<usize> {
        let mut lit = Vec::with_capacity(batch.0.len());
        // The expected Step 3 of the objects lit so far (ms), still to come in this frame.
        let mut step3_owed = 0.0;
        let mut first = Some(first);
        for (n, &k) in batch.0.iter().enumerate() {
            let o = self.objects[k].object;
            let expected = self.scheduler.expected_cost(k);
            let light = match first.take() {
                Some(FirstObject::Lit(light)) if n == 0 => light,
                _ => {
                    // Once what is left of the objects' share of the frame is less than an
                    // object's expected cost, the rest of the batch waits (if it may): the
                    // scheduler picked it before the first ones prepared their updates
                    // (`prepare.rs`), which it does not count.
                    let until =
                        |d: Instant| Instant::now() + super::secs(step3_owed + expected) >= d;
                    let late = deadline.is_some_and(until);
                    if late && !lit.is_empty() && self.scheduler.may_wait(k, self.frame) {
                        continue;
                    }
                    self.prepared_object_light(world, k, deadline, steps)
                }
            };
            let Some(light) = light else {
                continue;
            };
            let t = Instant::now();
            self.objects[k].coarse_light = self.cameras_for(k).2;
            self.object_change[k] = self.store_object_light(world, k, light.e);
            // Its cost for the scheduler is the update's, without what was prepared.
            let cost = light.ms + ms(t);
            self.scheduler.updated(k, self.frame, cost);
            step3_owed += (expected - cost).max(0.0);
            stats.objects_updated.push(o);
            lit.push(k);
        }
        lit
    }

    /// The batch's first object prepared ([`Dispersive::prepare_update`]) and lit from its
    /// probes, not stored: what Step 2 does before it reads Step 1's light, so that it runs
    /// beside Step 1. `None` when there is no object or its update is not ready.
    pub(super) fn light_first_object(
        &mut self,
        world: &World,
        batch: &Batch,
        steps: &mut DispersiveStats,
        deadline: Option<Instant>,
    ) -> Option<ObjectLight> {
        let &k = batch.0.first()?;
        self.prepared_object_light(world, k, deadline, steps)
    }

    /// Object `k`'s update prepared, then its light from its probes (`None`: not ready).
    fn prepared_object_light(
        &mut self,
        world: &World,
        k: usize,
        deadline: Option<Instant>,
        steps: &mut DispersiveStats,
    ) -> Option<ObjectLight> {
        let tt = Instant::now();
        let ready = self.prepare_update(world, k, deadline, steps);
        super::tr("prepare", tt);
        ready.then(|| self.object_light(world, k, steps))
    }

    /// Store object `k`'s new light `e` (probe irradiance, before contact openness) and its
    /// radiosity; returns how much the update changed its light (`sleep.rs`: area weighted,
    /// relative).
    fn store_object_light(&mut self, world: &World, k: usize, e: Vec<Vec3>) -> f64 {
        let p = &world.patches;
        let range = p.range(self.objects[k].object);
        self.touched.range(range.clone());
        let openness = &self.objects[k].openness;
        let (mut changed, mut total) = (0f64, 0f64);
        for ((i, e), &v) in range.zip(e).zip(openness) {
            let e = e * v;
            self.probe_irradiance[i] = e;
            // The light surfaces' direct light when `direct_on_interior`, the punctual
            // lights' always (a probe cannot see them): Step 1 leaves 0 otherwise.
            let direct = self.direct[i];
            let b = world.exitance[i] + world.reflectance[i] * (e + direct);
            let a = p.area[i] as f64;
            changed += a * (b - self.radiosity[i]).abs().element_sum() as f64;
            total += a * b.element_sum() as f64;
            self.radiosity[i] = b;
        }
        if total > 0.0 {
            changed / total
        } else if changed > 0.0 {
            f64::INFINITY
        } else {
            0.0
        }
    }
}
