//! Which of its object's 8 probes each patch can see (beyond the paper; the
//! `probe_visibility` option). The trilinear interpolation of paper 2.3.3 Step 4 reads a
//! patch's light from the probes at its box's corners whatever lies between: a crate sunk
//! into the floor has its buried patches lit from probes above the floor (Blender's
//! instanced crates: interior error 32.6 %, of which most is the patches below the floor),
//! and a box reaching through a shelf reads the light above it. Here a probe hidden from a
//! patch by *another* object (the object is transparent to its own probes,
//! `see_through_self`) is left out of that patch's interpolation, which renormalises over
//! the probes it sees; a patch that sees none gets no probe light (only its near field and
//! its own light), as a buried patch should.
//!
//! Like the near field it is geometry: measured with a shadow ray per patch and probe once
//! the object rests (a moving object's coarse updates use every probe, as before), and
//! again only where it can have changed: the segments a mover's box met, and every segment
//! to a probe that was repaired to another place.

use glam::Vec3;
use shrad_scene::Aabb;

use crate::World;

/// One object's patch-to-probe visibility (empty until measured).
#[derive(Clone, Debug, Default)]
pub(super) struct ProbeVisibility {
    /// Per patch (its offset in the object's range): bit `c` set when probe `c` is hidden
    /// from it.
    hidden: Vec<u8>,
    /// Per probe, where it stood (world) when its segments were measured; `None`: never
    /// measured, or forgotten.
    measured_at: [Option<Vec3>; 8],
    /// Segments a mover's box met since they were measured: (patch offset, probe).
    stale: Vec<(u32, u8)>,
}

impl ProbeVisibility {
    /// The probes hidden from patch `k` (bit `c`: probe `c`); none where nothing is measured.
    pub(super) fn hidden(&self, k: usize) -> u8 {
        self.hidden.get(k).copied().unwrap_or(0)
    }

    /// Where each probe stood when its segments were last measured (`None`: not measured).
    #[cfg(test)]
    pub(super) fn measured_at(&self) -> [Option<Vec3>; 8] {
        self.measured_at
    }

    /// Forget everything: the object moved (its probes with it).
    pub(super) fn forget(&mut self) {
        *self = ProbeVisibility::default();
    }

    /// Mark stale the segments that one of the boxes swept since the last check may have
    /// changed (`meets(from, to)`: whether the segment meets one of them). `probe_box`: the
    /// object's probe box in the world, which holds every segment (a patch and its probes
    /// lie in it, and it is convex).
    pub(super) fn forget_where(
        &mut self,
        world: &World,
        (object, probe_box): (usize, &Aabb),
        swept: &[Aabb],
        meets: impl Fn(Vec3, Vec3) -> bool,
    ) {
        if self.hidden.is_empty() || !swept.iter().any(|b| b.meets_box(probe_box)) {
            return;
        }
        let p = &world.patches;
        for (k, i) in p.range(object).enumerate() {
            let from = p.centre[i] + p.normal[i] * world.eps;
            for (c, at) in self.measured_at.iter().enumerate() {
                if at.is_some_and(|to| meets(from, to)) {
                    self.stale.push((k as u32, c as u8));
                }
            }
        }
    }

    /// Measure what is not current: the stale segments, then every segment to a probe that
    /// was never measured or now stands elsewhere (`probes`: where they stand now, world),
    /// a probe at a time while `more()` says there is time (asked before each probe), so
    /// that an update prepared under a budget measures it in pieces (`prepare.rs`).
    /// `object`: whose patches, and which is transparent to the rays. Every probe is measured,
    /// an invalid one too (its bits are not read): what is measured is geometry alone, which
    /// a preparation can measure before the light. Returns whether all is current.
    pub(super) fn refresh(
        &mut self,
        world: &World,
        object: usize,
        probes: &[Vec3; 8],
        mut more: impl FnMut() -> bool,
    ) -> bool {
        let range = world.patches.range(object);
        if self.hidden.len() != range.len() {
            self.forget();
            self.hidden = vec![0; range.len()];
        }
        let moved: [bool; 8] = std::array::from_fn(|c| self.measured_at[c] != Some(probes[c]));
        // A moved probe's segments are all measured below.
        let mut stale: Vec<(u32, u8)> = std::mem::take(&mut self.stale);
        stale.retain(|&(_, c)| !moved[c as usize]);
        stale.sort_unstable();
        stale.dedup();
        self.trace(world, object, probes, &stale);
        for c in 0..8 {
            if !moved[c] {
                continue;
            }
            if !more() {
                return false;
            }
            let column: Vec<(u32, u8)> = (0..range.len() as u32).map(|k| (k, c as u8)).collect();
            self.trace(world, object, probes, &column);
            self.measured_at[c] = Some(probes[c]);
        }
        true
    }

    /// Whether everything is measured for the probes where they stand (`probes`, world).
    #[cfg(test)]
    pub(super) fn is_current(&self, probes: &[Vec3; 8]) -> bool {
        self.stale.is_empty() && (0..8).all(|c| self.measured_at[c] == Some(probes[c]))
    }

    /// Trace `segments` (patch offset, probe) and set their bits.
    fn trace(&mut self, world: &World, object: usize, probes: &[Vec3; 8], segments: &[(u32, u8)]) {
        if segments.is_empty() {
            return;
        }
        let (p, start) = (&world.patches, world.patches.range(object).start);
        let from: Vec<Vec3> = (segments.iter())
            .map(|&(k, _)| p.centre[start + k as usize] + p.normal[start + k as usize] * world.eps)
            .collect();
        let to: Vec<Vec3> = segments.iter().map(|&(_, c)| probes[c as usize]).collect();
        let mut blocked = vec![false; segments.len()];
        (world.vis).occluded(&from, &to, world.eps, &[object as u32], &mut blocked);
        for (&(k, c), b) in segments.iter().zip(blocked) {
            let bits = &mut self.hidden[k as usize];
            *bits = match b {
                true => *bits | 1 << c,
                false => *bits & !(1 << c),
            };
        }
    }
}
