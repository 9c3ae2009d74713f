//! The scheduler: which interior objects a frame updates (paper 2.3.3 Step 1, "场景物体选择":
//! the paper numbers the interior objects and takes one per frame in turn; spec 4.3).
//!
//! Four policies ([`Schedule`]): the paper's round robin, `per_frame` objects at a time; a
//! priority order, staleness × a weight that grows when the object or a neighbour moved or a
//! light changed, with a hard staleness bound (an object that waited `max_staleness` frames
//! goes first whatever the weights); as many objects by priority as fit a time budget (at
//! least one, so the scene always progresses); every object every frame. It reads only what
//! it keeps per object ([`Freshness`]), so its order is tested without a world.

use super::{Batch, Schedule};

/// What the scheduler knows of one interior object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Freshness {
    /// Frame of the last update (None: never).
    last_update: Option<u64>,
    /// Something near it changed since its last update (1: nothing; 2: a neighbour moved or
    /// a light changed; 4: it moved).
    disturbed: f32,
    /// Measured ms of its last update.
    cost_ms: f64,
    /// Measured ms of its last update that sent its whole light to the boundary: what its
    /// next update costs once nothing moves (while something moves, a still object's update
    /// may send only the paths the mover crossed, `resend.rs`, for a fraction of that).
    full_cost_ms: f64,
    /// Asleep since its light stopped changing (see `DispersiveOptions::sleep_tolerance`):
    /// the boundary's drift when it fell asleep. A sleeping object is never scheduled and is
    /// never stale: its light is current.
    asleep_at: Option<f64>,
}

/// The scheduler's state: the policy, each object's [`Freshness`] and the round robin's
/// next object.
pub(super) struct Scheduler {
    schedule: Schedule,
    objects: Vec<Freshness>,
    round_robin_next: usize,
    /// Something moves this frame: the objects' costs are their last ones, not their last
    /// full ones.
    something_moves: bool,
}

impl Scheduler {
    /// A scheduler over `n` interior objects, none of them ever updated.
    pub(super) fn new(schedule: Schedule, n: usize) -> Scheduler {
        Scheduler {
            schedule,
            objects: vec![
                Freshness {
                    last_update: None,
                    disturbed: 1.0,
                    cost_ms: 0.0,
                    full_cost_ms: 0.0,
                    asleep_at: None,
                };
                n
            ],
            round_robin_next: 0,
            something_moves: false,
        }
    }

    /// Switch the schedule; every object keeps its staleness and disturbance.
    pub(super) fn set_schedule(&mut self, schedule: Schedule) {
        self.schedule = schedule;
    }

    /// The schedule in use.
    pub(super) fn schedule_in_use(&self) -> Schedule {
        self.schedule
    }

    /// Raise object `k`'s disturbance to at least `level`; it wakes.
    pub(super) fn disturb(&mut self, k: usize, level: f32) {
        let o = &mut self.objects[k];
        o.disturbed = o.disturbed.max(level);
        o.asleep_at = None;
    }

    /// Object `k` was updated in `frame` at a cost of `cost_ms`.
    pub(super) fn updated(&mut self, k: usize, frame: u64, cost_ms: f64) {
        self.objects[k] = Freshness {
            last_update: Some(frame),
            disturbed: 1.0,
            cost_ms,
            asleep_at: None,
            ..self.objects[k]
        };
    }

    /// Add `ms` to the measured cost of object `k`'s last update (its Step 3, measured after
    /// its Step 2); `whole`: that Step 3 sent the object's whole light.
    pub(super) fn add_cost(&mut self, k: usize, ms: f64, whole: bool) {
        let o = &mut self.objects[k];
        o.cost_ms += ms;
        if whole {
            o.full_cost_ms = o.cost_ms;
        }
    }

    /// Whether something moves this frame (then an object is expected to cost what its last
    /// update did, else what its last whole one did, if more).
    pub(super) fn note_something_moves(&mut self, moves: bool) {
        self.something_moves = moves;
    }

    /// Whether something moves this frame ([`Scheduler::note_something_moves`]).
    pub(super) fn something_moves(&self) -> bool {
        self.something_moves
    }

    /// What object `k`'s last update cost (ms).
    pub(super) fn last_cost(&self, k: usize) -> f64 {
        self.objects[k].cost_ms
    }

    /// What updating object `k` is expected to cost (ms).
    pub(super) fn expected_cost(&self, k: usize) -> f64 {
        let o = &self.objects[k];
        match self.something_moves {
            true => o.cost_ms,
            false => o.cost_ms.max(o.full_cost_ms),
        }
    }

    /// Object `k` sleeps, the boundary having drifted by `drift` so far (its update changed
    /// nothing that matters; see [`Scheduler::wake_drifted`]).
    pub(super) fn sleep(&mut self, k: usize, drift: f64) {
        self.objects[k].asleep_at = Some(drift);
    }

    /// Wake the objects asleep since the boundary drifted by more than `tolerance`: what
    /// their probes see has changed by more than the tolerance since.
    pub(super) fn wake_drifted(&mut self, drift: f64, tolerance: f64) {
        for o in &mut self.objects {
            if o.asleep_at.is_some_and(|at| drift - at > tolerance) {
                o.asleep_at = None;
            }
        }
    }

    /// Whether object `k` sleeps.
    pub(super) fn is_asleep(&self, k: usize) -> bool {
        self.objects[k].asleep_at.is_some()
    }

    /// Objects asleep.
    pub(super) fn asleep(&self) -> usize {
        self.objects
            .iter()
            .filter(|o| o.asleep_at.is_some())
            .count()
    }

    /// Frames since the stalest awake object was updated, at `frame` (`frame + 1` for one
    /// never updated; 0 without objects, or when all sleep).
    pub(super) fn stalest(&self, frame: u64) -> u64 {
        self.objects
            .iter()
            .filter(|o| o.asleep_at.is_none())
            .map(|o| o.last_update.map_or(frame + 1, |f| frame - f))
            .max()
            .unwrap_or(0)
    }

    /// Frames in which the scheduler updates every object once on a static scene.
    pub(super) fn frames_per_pass(&self) -> usize {
        let n = self.objects.len().max(1);
        match self.schedule {
            Schedule::Full => 1,
            Schedule::RoundRobin { per_frame } | Schedule::Priority { per_frame, .. } => {
                n.div_ceil(per_frame.max(1))
            }
            Schedule::Budget { .. } => n,
        }
    }

    /// The objects `frame` updates (spec 4.3), never a sleeping one. A budget schedule
    /// spends `objects_ms` at most (what the frame's budget leaves after Steps 1 and 4), by
    /// the objects' last measured costs, in priority order; when the first does not fit it
    /// takes none, unless `must` says it goes anyway.
    pub(super) fn schedule(&mut self, frame: u64, objects_ms: Option<f64>, must: Must) -> Batch {
        let n = self.objects.len();
        let awake = n - self.asleep();
        if awake == 0 {
            return Batch(Vec::new());
        }
        match self.schedule {
            Schedule::Full => Batch((0..n).filter(|&k| !self.is_asleep(k)).collect()),
            Schedule::RoundRobin { per_frame } => {
                let k = per_frame.clamp(1, awake);
                let mut picked = Vec::with_capacity(k);
                let mut next = self.round_robin_next;
                while picked.len() < k {
                    if !self.is_asleep(next % n) {
                        picked.push(next % n);
                    }
                    next += 1;
                }
                self.round_robin_next = next % n;
                Batch(picked)
            }
            Schedule::Priority {
                per_frame,
                max_staleness,
            } => {
                let k = per_frame.clamp(1, n);
                Batch(
                    self.by_priority(frame, max_staleness)
                        .into_iter()
                        .take(k)
                        .collect(),
                )
            }
            Schedule::Budget { ms, max_staleness } => {
                let order = self.by_priority(frame, max_staleness);
                let budget = objects_ms.unwrap_or(ms as f64);
                let mut spent = 0.0;
                let mut picked = Vec::new();
                for o in order {
                    let cost = self.expected_cost(o).max(0.01);
                    let goes = picked.is_empty()
                        && match must {
                            Must::First => true,
                            Must::OverStale => self.over_stale(o, frame, max_staleness),
                            Must::Nothing => false,
                        };
                    if !goes && spent + cost > budget {
                        break;
                    }
                    spent += cost;
                    picked.push(o);
                }
                Batch(picked)
            }
        }
    }

    /// The expected cost of updating `batch` (ms; 0 for objects never updated).
    pub(super) fn cost_of(&self, batch: &[usize]) -> f64 {
        batch.iter().map(|&o| self.expected_cost(o)).sum()
    }

    /// Whether object `o` may wait past `frame` and still be within the staleness bound of
    /// the schedule in use (one without a bound, or an object never updated, may not).
    pub(super) fn may_wait(&self, o: usize, frame: u64) -> bool {
        match self.schedule {
            Schedule::Priority { max_staleness, .. } | Schedule::Budget { max_staleness, .. } => {
                !self.over_stale(o, frame + 1, max_staleness)
            }
            _ => false,
        }
    }

    /// Whether object `o` was last updated `max_staleness` frames or more before `frame`
    /// (or never).
    fn over_stale(&self, o: usize, frame: u64, max_staleness: usize) -> bool {
        self.objects[o]
            .last_update
            .is_none_or(|f| frame - f >= max_staleness as u64)
    }

    /// Objects in decreasing priority: over-stale objects first, then staleness x weight;
    /// ties in index order.
    fn by_priority(&self, frame: u64, max_staleness: usize) -> Vec<usize> {
        let staleness = |o: &Freshness| o.last_update.map_or(u64::MAX / 4, |f| frame - f) as f64;
        let mut order: Vec<(usize, f64)> = self
            .objects
            .iter()
            .enumerate()
            .filter(|(_, o)| o.asleep_at.is_none())
            .map(|(i, o)| {
                let s = staleness(o);
                let forced = if s >= max_staleness as f64 { 1e12 } else { 0.0 };
                (i, forced + (s + 1.0) * o.disturbed as f64)
            })
            .collect();
        order.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        order.into_iter().map(|(i, _)| i).collect()
    }
}

/// Under a budget, what a frame updates even when it does not fit what is left (so that no
/// object starves); without a budget every schedule takes what it takes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Must {
    /// The first in line, when it is over the staleness bound.
    OverStale,
    /// The first in line, whatever it costs (the last frame updated none).
    First,
    /// Nothing: this frame's must-do is Step 1's; the over-stale wait one frame more.
    Nothing,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Run `frames` frames, each updating what it picked at `cost(k)` ms; the batches.
    fn run(s: &mut Scheduler, frames: u64, cost: impl Fn(usize) -> f64) -> Vec<Vec<usize>> {
        (0..frames)
            .map(|frame| {
                let batch = s.schedule(frame, None, Must::OverStale);
                for &k in &batch.0 {
                    s.updated(k, frame, cost(k));
                }
                batch.0
            })
            .collect()
    }

    #[test]
    fn round_robin_takes_objects_in_turn() {
        let mut s = Scheduler::new(Schedule::RoundRobin { per_frame: 2 }, 5);
        assert_eq!(
            run(&mut s, 4, |_| 1.0),
            [vec![0, 1], vec![2, 3], vec![4, 0], vec![1, 2]]
        );
        assert_eq!(s.frames_per_pass(), 3);
        // More per frame than objects: each object once.
        let mut s = Scheduler::new(Schedule::RoundRobin { per_frame: 9 }, 3);
        assert_eq!(s.schedule(0, None, Must::OverStale).0, [0, 1, 2]);
    }

    /// A sleeping object is never picked and never stale; it wakes when disturbed or when
    /// the boundary drifted past the tolerance since it fell asleep.
    #[test]
    fn sleepers_are_skipped_until_woken() {
        for schedule in [
            Schedule::RoundRobin { per_frame: 1 },
            Schedule::Priority {
                per_frame: 1,
                max_staleness: 2,
            },
            Schedule::Full,
        ] {
            let mut s = Scheduler::new(schedule, 3);
            run(&mut s, 3, |_| 1.0);
            s.sleep(1, 0.5);
            // Frames 3..15, after the first run's 0..3 (frames never go back).
            let mut picked = Vec::new();
            for frame in 3..15 {
                let batch = s.schedule(frame, None, Must::OverStale);
                for &k in &batch.0 {
                    s.updated(k, frame, 1.0);
                }
                picked.extend(batch.0);
            }
            assert!(!picked.contains(&1), "{schedule:?}: a sleeper was picked");
            assert!(picked.contains(&0) && picked.contains(&2), "{schedule:?}");
            // Objects 0 and 2 were updated in turn: the stalest waited 2 frames at frame 15;
            // the sleeper, last updated at frame 1 or 2, does not count.
            assert!(
                s.stalest(15) <= 2,
                "{schedule:?}: a sleeper counted as stale: {}",
                s.stalest(15)
            );
            s.wake_drifted(0.5 + 1e-4, 1e-3);
            assert!(s.is_asleep(1), "{schedule:?}: woke below the tolerance");
            s.wake_drifted(0.5 + 2e-3, 1e-3);
            assert!(!s.is_asleep(1), "{schedule:?}: the drift did not wake it");
            s.sleep(0, 0.0);
            s.sleep(1, 0.0);
            s.sleep(2, 0.0);
            assert!(s.schedule(20, None, Must::OverStale).0.is_empty() && s.stalest(20) == 0);
            s.disturb(2, 2.0);
            assert_eq!(
                s.schedule(21, None, Must::OverStale).0,
                [2],
                "{schedule:?}: disturbing wakes"
            );
        }
    }

    #[test]
    fn full_updates_every_object_and_none_is_empty() {
        let mut s = Scheduler::new(Schedule::Full, 4);
        assert_eq!(s.schedule(0, None, Must::OverStale).0, [0, 1, 2, 3]);
        assert_eq!(s.frames_per_pass(), 1);
        let mut none = Scheduler::new(Schedule::Full, 0);
        assert!(none.schedule(0, None, Must::OverStale).0.is_empty());
        assert_eq!(none.stalest(7), 0);
    }

    /// On a static scene the priority order is a round robin: the stalest object first,
    /// ties by index.
    #[test]
    fn priority_on_a_static_scene_visits_every_object_in_turn() {
        let mut s = Scheduler::new(
            Schedule::Priority {
                per_frame: 1,
                max_staleness: 100,
            },
            3,
        );
        let order: Vec<usize> = run(&mut s, 6, |_| 1.0).concat();
        assert_eq!(order, [0, 1, 2, 0, 1, 2]);
        assert_eq!(s.stalest(6), 3);
    }

    /// A disturbed object jumps the queue, but no object waits beyond the staleness bound.
    #[test]
    fn priority_prefers_disturbed_objects_within_the_staleness_bound() {
        let max_staleness = 4;
        let mut s = Scheduler::new(
            Schedule::Priority {
                per_frame: 1,
                max_staleness,
            },
            3,
        );
        run(&mut s, 3, |_| 1.0);
        let mut last = [0u64, 1, 2];
        for frame in 3..40 {
            // Object 0 moves every frame: weight 4 against the others' 1.
            s.disturb(0, 4.0);
            let batch = s.schedule(frame, None, Must::OverStale);
            assert_eq!(batch.0.len(), 1);
            let k = batch.0[0];
            s.updated(k, frame, 1.0);
            last[k] = frame;
            for (o, &f) in last.iter().enumerate() {
                assert!(
                    frame - f <= max_staleness as u64,
                    "frame {frame}: object {o} last updated in frame {f}"
                );
            }
        }
        // The mover gets most of the frames, the others still theirs.
        let mut s2 = Scheduler::new(
            Schedule::Priority {
                per_frame: 1,
                max_staleness,
            },
            3,
        );
        run(&mut s2, 3, |_| 1.0);
        let mut count = [0; 3];
        for frame in 3..43 {
            s2.disturb(0, 4.0);
            let k = s2.schedule(frame, None, Must::OverStale).0[0];
            s2.updated(k, frame, 1.0);
            count[k] += 1;
        }
        assert!(count[0] > count[1] && count[0] > count[2], "{count:?}");
        assert!(count[1] > 0 && count[2] > 0, "{count:?}");
    }

    /// Once nothing moves, an object is expected to cost its last update that sent its
    /// whole light (a still object's update while another moves may only amend it, for a
    /// fraction of the cost): the budget then takes fewer.
    #[test]
    fn a_still_object_is_expected_to_cost_its_last_full_update() {
        let mut s = Scheduler::new(
            Schedule::Budget {
                ms: 8.0,
                max_staleness: 1000,
            },
            2,
        );
        for k in 0..2 {
            s.updated(k, 0, 2.0);
            s.add_cost(k, 4.0, true);
            // Then an update that only amended its light, while something moved.
            s.updated(k, 1, 0.5);
            s.add_cost(k, 0.5, false);
        }
        s.note_something_moves(true);
        assert_eq!(s.expected_cost(0), 1.0);
        assert_eq!(s.schedule(2, Some(8.0), Must::OverStale).0, [0, 1]);
        s.note_something_moves(false);
        assert_eq!(s.expected_cost(0), 6.0);
        assert_eq!(s.schedule(2, Some(8.0), Must::OverStale).0, [0]);
    }

    /// A budget takes objects by priority while their last costs fit, and at least one.
    #[test]
    fn budget_takes_what_fits_and_one_when_owed_or_over_stale() {
        let cost = |k: usize| [3.0, 4.0, 5.0, 100.0][k];
        let budget = |max_staleness| {
            Scheduler::new(
                Schedule::Budget {
                    ms: 8.0,
                    max_staleness,
                },
                4,
            )
        };
        let mut s = budget(1000);
        // Costs unknown (0, counted as 0.01 ms): the first frame takes everything.
        assert_eq!(run(&mut s, 1, cost), [vec![0, 1, 2, 3]]);
        // Now all equally stale: by index while the sum fits 8 ms (3 + 4; + 5 would not).
        assert_eq!(s.schedule(1, None, Must::OverStale).0, [0, 1]);
        // An object dearer than the whole budget first in line: the frame takes none (its
        // work is carried over) ...
        let mut s = budget(1000);
        run(&mut s, 1, cost);
        s.disturb(3, 4.0);
        assert!(s.schedule(1, None, Must::OverStale).0.is_empty());
        // ... and the next, owed, takes it alone.
        assert_eq!(s.schedule(1, None, Must::First).0, [3]);
        // Over the staleness bound it goes whatever the budget; the others follow as they fit.
        let mut s = budget(4);
        run(&mut s, 1, cost);
        s.disturb(3, 4.0);
        assert_eq!(s.schedule(4, Some(7.5), Must::OverStale).0, [3]);
        assert_eq!(s.frames_per_pass(), 4);
    }

    /// A budget far below every object's cost: frames alternate between none and one owed
    /// object, and no object waits longer than the staleness bound.
    #[test]
    fn a_budget_below_every_cost_starves_no_object() {
        let mut s = Scheduler::new(
            Schedule::Budget {
                ms: 0.001,
                max_staleness: 6,
            },
            5,
        );
        let mut owed = false;
        let mut last = [0u64; 5];
        for frame in 0..200u64 {
            let batch = s.schedule(
                frame,
                Some(0.001),
                if owed { Must::First } else { Must::OverStale },
            );
            assert!(batch.0.len() <= 5);
            for &k in &batch.0 {
                s.updated(k, frame, 10.0 + k as f64);
                last[k] = frame;
            }
            owed = batch.0.is_empty();
            if frame > 20 {
                assert!(batch.0.len() <= 1, "frame {frame} took {:?}", batch.0);
                for (k, &f) in last.iter().enumerate() {
                    assert!(
                        frame - f <= 10,
                        "object {k} not updated since frame {f} (now {frame})"
                    );
                }
            }
        }
    }
}
