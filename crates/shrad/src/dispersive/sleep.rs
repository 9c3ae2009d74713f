//! Sleep and wake (beyond the paper, which updates some object every frame forever): once
//! the light stops changing, a frame should stop costing. Users of probe systems ask for an
//! update rate that follows how much the light still changes (RTXGI's probe variability).
//!
//! - An **object** sleeps when its update changed its patches' radiosity by less than
//!   `sleep_tolerance` (relative, area weighted): the scheduler skips it and it is never
//!   stale. It wakes when it is disturbed (it moved, a mover came near it, a light changed:
//!   `note_changes`) or when the boundary, which its probes see, has drifted by more than
//!   the tolerance since it fell asleep (the drift is the sum of every frame's relative
//!   change of the boundary's radiosity).
//! - The **walls** (Step 4's exchange) sleep after a whole sweep of frames in which nothing
//!   changed, no object was updated and each sweep changed the boundary by less than the
//!   tolerance.
//! - Before that, the walls **doze** while the objects settle: while the light Step 4's rows
//!   read changed by less than the tolerance since their last whole window, a frame gathers
//!   only a small window of them and the rows a re-trace rebuilt ([`Dispersive::walls_doze`]).
//! - When every object and the walls sleep, nothing moved or changed, and the wall rows
//!   hold no ray waiting to be re-traced, a frame does nothing: no tracing, no sweep, the
//!   published state is the last one.
//!
//! The error stays within the tolerance of never sleeping (`tests.rs` checks it on the
//! Cornell box with an object moving then stopping; `tests_settle.rs` that the room's walls
//! dozed and fell asleep with every row gathered as it is).

use std::time::Instant;

use super::{ms, Changes, Dispersive, DispersiveStats, FrameStats, WALL_ROWS_PER_FRAME};
use crate::frame::SolverStats;

impl Dispersive {
    fn sleep_tolerance(&self) -> f64 {
        self.options.sleep_tolerance as f64
    }

    /// Whether this frame can sleep whole (see the module's docs). Wakes the objects whose
    /// surroundings drifted first.
    pub(super) fn everything_sleeps(&mut self, changes: &Changes) -> bool {
        let tolerance = self.sleep_tolerance();
        if tolerance <= 0.0 {
            return false;
        }
        self.scheduler.wake_drifted(self.drift, tolerance);
        changes.moved.is_empty()
            && !changes.light_changed()
            && self.direct_valid
            && self.direct_sync.moved.is_empty()
            && !self.direct_cache.catching_up()
            && !self.punctual.catching_up()
            && self.scheduler.asleep() == self.objects.len()
            && self.quiet_frames >= self.frames_per_wall_sweep()
            && self.wall_rows.as_ref().is_none_or(|rows| rows.settled())
    }

    /// Whether Step 4 may gather only a small window of wall rows this frame
    /// ([`super::WALL_ROWS_DOZING`], with the rows rebuilt since the last frame): the
    /// scene settles (nothing moved, no light changed) and the light the rows read has
    /// changed by less than the tolerance since their last whole window, that window's own
    /// change included. A whole window now would change the boundary by less than the
    /// tolerance, which is what the walls sleep at; the small one keeps them converging.
    /// While the objects settle one at a time after a mover stops, most of their updates
    /// change the boundary by less than that (the 77k room), and a whole window there cost
    /// 4 ms a frame.
    pub(super) fn walls_doze(&self, changes: &Changes) -> bool {
        let tolerance = self.sleep_tolerance();
        tolerance > 0.0
            && changes.moved.is_empty()
            && !changes.light_changed()
            && self.wall_unswept < tolerance
    }

    /// Frames of Step 4 windows that make one sweep over every wall row.
    fn frames_per_wall_sweep(&self) -> usize {
        match &self.wall_rows {
            Some(_) => self
                .boundary_patches
                .len()
                .div_ceil(WALL_ROWS_PER_FRAME)
                .max(1),
            None => 1,
        }
    }

    /// A frame in which everything sleeps: the state stays as it is.
    pub(super) fn sleeping_frame(&mut self, frame_start: Instant) -> FrameStats {
        let mut stats = FrameStats::new(
            self.frame,
            SolverStats::Dispersive(DispersiveStats {
                objects_asleep: self.objects.len(),
                asleep: true,
                ..Default::default()
            }),
        );
        stats.energy = self.last_energy;
        stats.frame_ms = ms(frame_start);
        self.frame += 1;
        stats
    }

    /// After a frame that ran: put to sleep the objects `updated` whose light stopped
    /// changing, add the boundary's `change` to the drift, and count quiet frames for the
    /// walls.
    pub(super) fn note_settling(
        &mut self,
        changes: &Changes,
        updated: &[usize],
        change: f64,
        stats: &FrameStats,
    ) {
        self.last_energy = stats.energy;
        let tolerance = self.sleep_tolerance();
        if tolerance <= 0.0 {
            return;
        }
        self.drift += change;
        let nothing_changed = changes.moved.is_empty() && !changes.light_changed();
        for &k in updated {
            if nothing_changed && self.object_change[k] < tolerance {
                self.scheduler.sleep(k, self.drift);
            }
        }
        let quiet = nothing_changed && updated.is_empty() && stats.diverged.is_none();
        self.quiet_frames = if quiet && change < tolerance {
            self.quiet_frames + 1
        } else {
            0
        };
    }
}
