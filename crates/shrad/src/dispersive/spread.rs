//! Step 3's smoothing of a splat (`splat_smoothing`): the flux each boundary patch received
//! spread over its edge neighbourhood in proportion to area, so that a splat coarser than
//! the patches does not alias (paper 2.3.4 Step 2, beyond the paper).

use glam::Vec3;
use rayon::prelude::*;

use super::Dispersive;

impl Dispersive {
    /// Each patch's flux spread over its neighbourhood in proportion to area: patch `i`
    /// receives `sum_k f_k / A(near(k))` over the flux patches `k` whose neighbourhood holds
    /// it. Scattered from the flux patches, so the cost is their neighbourhoods' size: a
    /// still object's full splat in the 1M room lands on 70k patches and reaches 355k; the
    /// gather at every patch reached that this replaces read 3.2M neighbours (30-44 ms of a
    /// frame, now 14-18, measured under load). `pieces`: flux, several pieces per patch.
    pub(super) fn spread_over_neighbours(&mut self, pieces: Vec<(u32, Vec3)>) -> Vec<(u32, Vec3)> {
        // The pieces summed per patch in place (a list of the patches first took a third of
        // a full splat's 3 ms at 77k).
        let mut patches = 0;
        for &(k, f) in &pieces {
            let s = &mut self.scratch[k as usize];
            patches += usize::from(*s == Vec3::ZERO);
            *s += f;
        }
        // Flux on a large part of the boundary (a full splat at 77k): a gather at every
        // boundary patch, in parallel, costs less than the scatter (one thread).
        if patches * 4 >= self.boundary_patches.len() {
            return self.gather_over_neighbours(&pieces);
        }
        // The patches in order of first appearance, each once, as `sum_by_patch` lists them.
        let mut flux: Vec<(u32, Vec3)> = (pieces.iter())
            .filter_map(|&(k, _)| {
                let e = std::mem::take(&mut self.scratch[k as usize]);
                (e != Vec3::ZERO).then_some((k, e))
            })
            .collect();
        // In patch order, so that neighbourhoods next in turn lie next in memory (a splat's
        // texel order jumps over the walls: every neighbour a cache miss).
        flux.sort_unstable_by_key(|&(k, _)| k);
        let near = &self.neighbours;
        // `scratch` is zero and `reached` false everywhere on entry, and again on return.
        let (sum, reached) = (&mut self.scratch, &mut self.reached);
        let mut targets = Vec::with_capacity(flux.len() * 4);
        for &(k, f) in &flux {
            let share = f * near.inv_area[k as usize];
            for &i in near.of(k as usize) {
                if !std::mem::replace(&mut reached[i as usize], true) {
                    targets.push(i);
                }
                sum[i as usize] += share;
            }
        }
        targets
            .into_iter()
            .filter_map(|i| {
                reached[i as usize] = false;
                let e = std::mem::take(&mut sum[i as usize]);
                (e != Vec3::ZERO).then_some((i, e))
            })
            .collect()
    }

    /// [`Self::spread_over_neighbours`] as a gather: `near` is symmetric (patches sharing a
    /// vertex), so patch `i` sums the weighted flux of `near(i)`, the flux of each patch being
    /// in `scratch` (set to zero again at the `pieces`' patches).
    fn gather_over_neighbours(&mut self, pieces: &[(u32, Vec3)]) -> Vec<(u32, Vec3)> {
        let near = &self.neighbours;
        let flux = &self.scratch;
        let spread: Vec<(u32, Vec3)> = (self.boundary_patches.par_iter())
            .filter_map(|&i| {
                let e: Vec3 = near
                    .of(i as usize)
                    .iter()
                    .map(|&k| flux[k as usize] * near.inv_area[k as usize])
                    .sum();
                (e != Vec3::ZERO).then_some((i, e))
            })
            .collect();
        pieces
            .iter()
            .for_each(|&(k, _)| self.scratch[k as usize] = Vec3::ZERO);
        spread
    }
}
