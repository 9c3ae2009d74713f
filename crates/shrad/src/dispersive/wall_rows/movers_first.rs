//! Re-tracing the wall rows' dirty rays against the movers first (the way Step 1 re-traces
//! its shadow rays). A dirty ray's stored hit was right when its row was last known clean
//! (`valid_at`); since then only the objects that moved (`movers`) can have changed it. If
//! it did not hit one of them, the rest of the scene still puts its closest hit where it was,
//! so a trace against the movers alone settles it: a mover hit in front of the stored hit is
//! the new closest hit; no mover hit before it, and the stored hit stands. Only the rays that
//! hit a mover (which may have left), those of a row whose own patch moved, and those the
//! stored end is too coarse to settle are traced against the whole scene. The rows stay what
//! a fresh trace gives; the 77k room's wall rays (long closest hits across the room, 2.5-3
//! Mrays/s on one thread) mostly become short ones against one object.

use glam::Vec3;
use shrad_vis::Hit;

use super::retrace::exit_distance;
use super::{WallRows, FRONT, MISS};
use crate::World;

/// `valid_at` of a row whose dirty rays' stored hits say nothing (never traced, or forgotten):
/// every one is traced against the whole scene.
pub(super) const UNKNOWN: u64 = u64::MAX;

impl WallRows {
    /// The closest hit of each dirty ray `which[r]` (its row's index in `picked`, its ray),
    /// regenerated as `o[r] + t d[r]`: `Some(hit)` where traced again, `None` where the
    /// stored hit stands (see the module's docs).
    pub(super) fn trace_movers_first(
        &self,
        world: &World,
        (boundary, picked): (&[u32], &[usize]),
        which: &[(usize, usize)],
        (o, d): (&[Vec3], &[Vec3]),
    ) -> Vec<Option<Hit>> {
        let p = &world.patches;
        let movers = self.movers_since(picked);
        let is_mover = |o: u32| movers.binary_search(&o).is_ok();
        // A row known clean since some frame, whose own patch did not move since.
        let settles: Vec<bool> = (picked.iter())
            .map(|&k| self.valid_at[k] != UNKNOWN && !is_mover(p.object[boundary[k] as usize]))
            .collect();
        // Rays whose stored hit is not on a mover: a trace against the movers settles them.
        let first: Vec<usize> = (0..which.len())
            .filter(|&r| {
                let (c, j) = which[r];
                let h = self.hit[picked[c] * self.rays + j];
                settles[c] && (h == MISS || !is_mover(p.object[(h & !FRONT) as usize]))
            })
            .collect();
        let mut out: Vec<Option<Hit>> = vec![None; which.len()];
        let mut whole = vec![true; which.len()];
        if !movers.is_empty() && !first.is_empty() {
            let others: Vec<u32> = (0..world.vis.object_count() as u32)
                .filter(|&o| !is_mover(o))
                .collect();
            let fo: Vec<Vec3> = first.iter().map(|&r| o[r]).collect();
            let fd: Vec<Vec3> = first.iter().map(|&r| d[r]).collect();
            let mut hits = vec![Hit::MISS; first.len()];
            world.vis.closest(&fo, &fd, 0.0, &others, &mut hits);
            for (&r, h) in first.iter().zip(hits) {
                let (c, j) = which[r];
                let at = picked[c] * self.rays + j;
                let (lo, hi) = self.stored_t(o[r], d[r], self.hit[at], self.end[at]);
                if h.is_hit() && h.t < lo {
                    (out[r], whole[r]) = (Some(h), false);
                } else if !h.is_hit() || h.t > hi {
                    whole[r] = false;
                }
            }
        } else {
            // Nothing moved since these rows were known clean: their stored hits stand.
            first.iter().for_each(|&r| whole[r] = false);
        }
        let rest: Vec<usize> = (0..which.len()).filter(|&r| whole[r]).collect();
        let ro: Vec<Vec3> = rest.iter().map(|&r| o[r]).collect();
        let rd: Vec<Vec3> = rest.iter().map(|&r| d[r]).collect();
        let mut hits = vec![Hit::MISS; rest.len()];
        world.vis.closest(&ro, &rd, 0.0, &[], &mut hits);
        for (&r, h) in rest.iter().zip(hits) {
            out[r] = Some(h);
        }
        out
    }

    /// The objects that moved after the earliest frame one of rows `picked` is known clean
    /// since (ascending).
    fn movers_since(&self, picked: &[usize]) -> Vec<u32> {
        let known = picked.iter().map(|&k| self.valid_at[k]);
        let Some(since) = known.filter(|&f| f != UNKNOWN).min() else {
            return Vec::new();
        };
        (0..self.moved_at.len() as u32)
            .filter(|&o| self.moved_at[o as usize] > since)
            .collect()
    }

    /// Bounds `(lo, hi)` on the distance along `o + t d` of a ray's stored hit `hit`, from its
    /// stored `end` (quantised: within half a step of the true end, and clipped to `space`,
    /// so `hi` is infinite where the end may be the clip); both infinite for a miss.
    fn stored_t(&self, o: Vec3, d: Vec3, hit: u32, end: [u16; 3]) -> (f32, f32) {
        if hit == MISS {
            return (f32::INFINITY, f32::INFINITY);
        }
        let exit = exit_distance(&self.space, o, d);
        if exit <= 0.0 {
            // An origin outside `space` stored no usable end: only "no mover hit" settles.
            return (f32::NEG_INFINITY, f32::INFINITY);
        }
        let len = d.length().max(f32::MIN_POSITIVE);
        let t = (self.decode(end) - o).length() / len;
        // Half a quantisation step, and the float noise of the distances involved.
        let err = 0.5 * self.step().length() / len + 1e-5 * (t + exit);
        let hi = if t + err < exit {
            t + err
        } else {
            f32::INFINITY
        };
        (t - err, hi)
    }
}

#[cfg(test)]
mod tests {
    use glam::{Affine3A, Vec3};

    use crate::dispersive::tests::{cornell, object_named};
    use crate::dispersive::{Changes, Dispersive, DispersiveOptions};

    /// Two blocks moving in turn, each move one frame, so that rows marked by one are still
    /// dirty when the other moves (a row's movers are those since it was known clean, and
    /// one call's are the earliest such row's): once everything is traced the rows are what
    /// a fresh trace gives (up to rays that meet two surfaces at one distance).
    #[test]
    fn rows_stay_a_fresh_traces_when_movers_take_turns() {
        let mut world = cornell(3000);
        let blocks = [
            object_named(&world, "short_block"),
            object_named(&world, "tall_block"),
        ];
        let rest = blocks.map(|o| {
            let p = &world.patches;
            p.world_from_local[o] * Affine3A::from_mat3(p.local_from_object[o])
        });
        let options = DispersiveOptions::improved();
        let mut d = Dispersive::new(&world, options).unwrap();
        d.step(&world, &Changes::default());
        let start = d.wall_rows.as_ref().unwrap().rows().clone();
        let size = world.scene.bounds().unwrap().size().x;
        let plan = [
            (0, Vec3::new(0.06, 0.0, 0.0)),
            (1, Vec3::new(0.0, 0.0, -0.05)),
            (0, Vec3::new(0.08, 0.0, 0.04)),
            (1, Vec3::new(-0.04, 0.0, -0.08)),
            (0, Vec3::ZERO),
        ];
        for (b, offset) in plan {
            let m = Affine3A::from_translation(offset * size) * rest[b];
            assert!(world.move_object(blocks[b], m).unwrap());
            let moved = Changes {
                moved: vec![blocks[b]],
                ..Default::default()
            };
            d.step(&world, &moved);
        }
        let waiting = |d: &Dispersive| {
            let rows = d.wall_rows.as_ref().unwrap();
            rows.dirty_rays() > 0 || rows.unchecked_rows() > 0
        };
        let mut frames = 0;
        while waiting(&d) {
            d.step(&world, &Changes::default());
            frames += 1;
            assert!(frames < 200, "the rows never settled");
        }
        let mut fresh = Dispersive::new(&world, options).unwrap();
        fresh.step(&world, &Changes::default());
        let (a, b) = (
            d.wall_rows.as_ref().unwrap(),
            fresh.wall_rows.as_ref().unwrap(),
        );
        let n = a.rows().len();
        let differ = (0..n)
            .filter(|&k| a.row(k) != b.row(k) && !a.differ_only_in_ties(b, k))
            .count();
        assert_eq!(
            differ, 0,
            "{differ} of {n} wall rows differ from a fresh trace"
        );
        // The moves changed what the walls see: the test exercised the re-trace.
        let changed = (0..n).filter(|&k| a.row(k) != start.row(k)).count();
        assert!(changed > 100, "only {changed} rows changed");
    }
}
