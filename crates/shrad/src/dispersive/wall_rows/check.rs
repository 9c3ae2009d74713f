//! Checking the wall rows against the movers: which rays a move may have changed (the
//! module's docs say why these are all of them), marked dirty for [`WallRows::retrace`].

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Aabb;

use super::{patch_sphere, WallRows, FRONT, MISS};
use crate::form_factors::patch_rays;
use crate::segments::{self, Offsets, LANES};
use crate::World;

/// The movers one row is checked against: the objects that moved since its last check.
struct MovedSince {
    objects: Vec<usize>,
    /// Bit `o % 64` set for each of `objects` (as [`WallRows`]'s `objects_hit`).
    mask: u64,
    /// Their padded boxes now (the empty ones left out).
    boxes: Vec<Aabb>,
}

impl WallRows {
    /// Note this frame's movers (see [`WallRows::check`]). Once a frame.
    pub(super) fn note_moves(&mut self, moved: &[usize]) {
        self.frame += 1;
        for &o in moved {
            self.moved_at[o] = self.frame;
        }
    }

    /// Check up to `budget` rows that have not
    /// been checked since an object moved, from a cursor that goes round: mark dirty the rays
    /// a move may have changed (see the module's docs): those that hit an object that moved
    /// since the row's last check, those whose segment meets such an object's box now
    /// (`boxes`: every object's world box at this frame), and every ray of the rows of
    /// patches on such an object (their origins moved). [`WallRows::retrace`] re-traces
    /// them.
    /// May run several times a frame (a deadline checks a few rows at a time); returns the
    /// rows checked.
    pub(super) fn check(
        &mut self,
        world: &World,
        boundary: &[u32],
        boxes: &[Aabb],
        budget: usize,
    ) -> usize {
        let last = self.moved_at.iter().copied().max().unwrap_or(0);
        if boundary.is_empty() || last <= self.checked_all {
            return 0;
        }
        let rows = self.rows_to_check(boundary.len(), last, budget);
        if rows.is_empty() {
            return 0;
        }
        // Slack for the float noise of hits on a mover's surface (a ray that grazes a padded
        // box is only re-traced for nothing).
        let padded: Vec<Aabb> = boxes
            .iter()
            .map(|b| b.padded(Vec3::splat(4.0 * world.eps + 1e-5 * b.diagonal())))
            .collect();
        // The movers since each row's last check: one set per frame a row was last checked
        // at (few), not one per row.
        let mut since: Vec<u64> = rows.iter().map(|&k| self.checked_at[k]).collect();
        since.sort_unstable();
        since.dedup();
        let moved: Vec<MovedSince> = since
            .iter()
            .map(|&f| self.moved_since(f, &padded))
            .collect();
        let marks: Vec<(usize, Vec<u64>)> = rows
            .par_iter()
            .filter_map(|&k| {
                let m = &moved[since.binary_search(&self.checked_at[k]).ok()?];
                let bits = self.newly_dirty(world, boundary[k] as usize, m, k)?;
                Some((k, bits))
            })
            .collect();
        let words = self.words;
        for (k, bits) in marks {
            let w = &mut self.dirty[k * words..(k + 1) * words];
            w.iter_mut().zip(&bits).for_each(|(w, b)| *w |= b);
            // Its rays' hits were right at its last check.
            self.note_dirty_row(k, self.checked_at[k]);
        }
        for &k in &rows {
            self.checked_at[k] = self.frame;
        }
        rows.len()
    }

    /// Up to `budget` of the `n` rows not checked since the last move (`last`), from the
    /// cursor round; the cursor moves past them. When the scan goes round, these are all the
    /// rows left to check, so every row is checked against every move up to `last`.
    fn rows_to_check(&mut self, n: usize, last: u64, budget: usize) -> Vec<usize> {
        let mut rows: Vec<usize> = Vec::new();
        let start = self.mark_cursor % n;
        let mut next = start;
        for step in 0..n {
            let k = (start + step) % n;
            next = (k + 1) % n;
            if self.checked_at[k] < last {
                rows.push(k);
                if rows.len() >= budget.max(1) {
                    break;
                }
            }
        }
        if rows.len() < budget.max(1) {
            self.checked_all = last;
        }
        if !rows.is_empty() {
            self.mark_cursor = next;
        }
        rows
    }

    /// The objects that moved after frame `since`, with their boxes (`padded`: every
    /// object's padded box now).
    fn moved_since(&self, since: u64, padded: &[Aabb]) -> MovedSince {
        let objects: Vec<usize> = (0..self.moved_at.len())
            .filter(|&o| self.moved_at[o] > since)
            .collect();
        let mask = objects.iter().fold(0u64, |m, &o| m | 1 << (o % 64));
        let boxes = objects
            .iter()
            .map(|&o| padded[o])
            .filter(|b| !b.is_empty())
            .collect();
        MovedSince {
            objects,
            mask,
            boxes,
        }
    }

    /// The rays of row `k` (from boundary patch `i`) that a move since its last check may
    /// have changed and that are not dirty yet, as dirty bits; `None` when there are none.
    fn newly_dirty(
        &self,
        world: &World,
        i: usize,
        moved: &MovedSince,
        k: usize,
    ) -> Option<Vec<u64>> {
        let p = &world.patches;
        let (rays, words) = (self.rays, self.words);
        let bits = &self.dirty[k * words..(k + 1) * words];
        if moved.objects.contains(&(p.object[i] as usize)) {
            // The patch itself moved: every ray's origin did.
            let mut all = vec![u64::MAX; words];
            if rays % 64 != 0 {
                all[words - 1] = u64::MAX >> (words * 64 - rays);
            }
            return (all != bits).then_some(all);
        }
        let mut out = vec![0u64; words];
        let clean = |out: &[u64], j: usize| (out[j / 64] | bits[j / 64]) & (1 << (j % 64)) == 0;
        // (1) Rays that hit a mover.
        if self.objects_hit[k] & moved.mask != 0 {
            let hits = &self.hit[k * rays..(k + 1) * rays];
            for (j, &h) in hits.iter().enumerate() {
                if h != MISS
                    && clean(&out, j)
                    && moved
                        .objects
                        .contains(&(p.object[(h & !FRONT) as usize] as usize))
                {
                    out[j / 64] |= 1 << (j % 64);
                }
            }
        }
        // (2) Rays with a mover's new place in front of their hit.
        let inside = moved
            .boxes
            .iter()
            .all(|b| self.space.contains(b.min) && self.space.contains(b.max));
        if !inside && self.leaves[k] {
            // A mover outside the quantised space: the whole rays, regenerated.
            let mut o = vec![Vec3::ZERO; rays];
            let mut d = vec![Vec3::ZERO; rays];
            patch_rays(world, i, &mut o, &mut d);
            for j in 0..rays {
                if clean(&out, j) && moved.boxes.iter().any(|b| b.meets_ray(o[j], d[j])) {
                    out[j / 64] |= 1 << (j % 64);
                }
            }
            return out.iter().any(|&w| w != 0).then_some(out);
        }
        let (c, r) = patch_sphere(world, i);
        let pad = Vec3::splat(r) + self.step();
        let near: Vec<Aabb> = moved
            .boxes
            .iter()
            .map(|b| b.padded(pad))
            .filter(|b| b.meets_box(&self.bounds[k]))
            .collect();
        if !near.is_empty() {
            // 64 rays at a time, from the patch's centre to their stored ends.
            let (lo, step) = (self.space.min - c, self.step());
            for (w, ends) in self.end[k * rays..(k + 1) * rays].chunks(LANES).enumerate() {
                let mut d: Offsets = [[0f32; LANES]; 3];
                for (j, e) in ends.iter().enumerate() {
                    for a in 0..3 {
                        d[a][j] = lo[a] + e[a] as f32 * step[a];
                    }
                }
                out[w] |= segments::meeting(c, &d, ends.len(), &near) & !bits[w];
            }
        }
        out.iter().any(|&w| w != 0).then_some(out)
    }
}
