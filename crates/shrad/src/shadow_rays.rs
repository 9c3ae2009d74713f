//! Shadow rays kept as which of them are blocked, so that a cache of direct light re-traces
//! only the rays a mover may have changed: the sky's ([`crate::sky::SkyCache`], a set of
//! rays a receiver), the punctual lights' ([`crate::lights::PunctualCache`], a set a
//! receiver and light) and the emitting objects' ([`crate::direct::DirectCache`], a set a
//! receiver and emitter, which finds and traces its rays itself). The rays themselves are
//! regenerated from their sample index when needed; what changes between caches is how a
//! sample makes its ray and weight.

use std::ops::AddAssign;

use glam::Vec3;
use rayon::prelude::*;

use crate::direct::mover_spheres::{padded_with_spheres, segment_meets_sphere, Bounds, Moves};
use crate::World;

/// Sets traced in one batch by [`ShadowRays::trace`] (bounds the rays held at once).
const SETS_PER_BATCH: usize = 4096;

/// A ray as [`cast`] makes it: the set's place in the batch, its sample, its segment (from,
/// to) and its weight.
type Cast<W> = (usize, u32, Vec3, Vec3, W);

/// The rays `ray(s, j)` of `sets` (`samples` a set), cast, with whether each is blocked.
fn cast<W: Copy + Send + Sync>(
    world: &World,
    sets: &[usize],
    samples: u32,
    ray: &(impl Fn(usize, u32) -> Option<(Vec3, Vec3, W)> + Sync),
) -> (Vec<Cast<W>>, Vec<bool>) {
    let rays: Vec<Cast<W>> = sets
        .par_iter()
        .enumerate()
        .flat_map_iter(|(c, &s)| {
            (0..samples).filter_map(move |j| ray(s, j).map(|(f, t, w)| (c, j, f, t, w)))
        })
        .collect();
    let from: Vec<Vec3> = rays.iter().map(|r| r.2).collect();
    let to: Vec<Vec3> = rays.iter().map(|r| r.3).collect();
    let mut blocked = vec![false; rays.len()];
    world.vis.occluded(&from, &to, world.eps, &[], &mut blocked);
    (rays, blocked)
}

/// Cast the rays of `sets` ([`cast`]) [`SETS_PER_BATCH`] sets at a time, handing each batch
/// (its sets, rays and outcomes) to `each`; per set, its sums ([`sum_by_set`]).
fn cast_in_batches<W: Copy + Default + AddAssign + Send + Sync>(
    world: &World,
    sets: &[usize],
    samples: u32,
    ray: impl Fn(usize, u32) -> Option<(Vec3, Vec3, W)> + Sync,
    mut each: impl FnMut(&[usize], &[Cast<W>], &[bool]),
) -> Vec<(W, W)> {
    let mut sums = Vec::with_capacity(sets.len());
    for batch in sets.chunks(SETS_PER_BATCH) {
        let (rays, blocked) = cast(world, batch, samples, &ray);
        each(batch, &rays, &blocked);
        sums.extend(sum_by_set(batch.len(), &rays, &blocked));
    }
    sums
}

/// Per set (`n` of them), the sum of its rays' weights and of its free rays' (in sample
/// order), from [`cast`]'s rays.
fn sum_by_set<W: Copy + Default + AddAssign>(
    n: usize,
    rays: &[Cast<W>],
    blocked: &[bool],
) -> Vec<(W, W)> {
    let mut sums = vec![(W::default(), W::default()); n];
    for (&(c, .., w), &b) in rays.iter().zip(blocked) {
        sums[c].0 += w;
        if !b {
            sums[c].1 += w;
        }
    }
    sums
}

/// A move's boxes padded for the shadow-ray tests of [`ShadowRays::near_movers`]
/// ([`padded_with_spheres`]), each with a sphere about its mover
/// (`direct/mover_spheres.rs`), where the movers were and where they are; `None` when there
/// are none: no ray can have changed.
pub fn padded_move(moves: Moves, eps: f32) -> Option<(Bounds, Bounds)> {
    let old = padded_with_spheres(moves.old, moves.was, eps);
    let new = padded_with_spheres(moves.new, moves.is, eps);
    (!old.0.is_empty() || !new.0.is_empty()).then_some((old, new))
}

/// Sets of `samples` shadow rays each: bit `j` of set `s` is set when ray `j` is blocked.
#[derive(Clone, Debug, Default)]
pub struct ShadowRays {
    samples: u32,
    /// `u64` words of bits per set.
    words: usize,
    /// `[s * words ..]`: set `s`'s bits.
    blocked: Vec<u64>,
}

/// One shadow ray of a set to trace again: `sample` of `set`, from `from` to `to`.
pub struct ShadowRay {
    pub set: u32,
    pub sample: u32,
    pub from: Vec3,
    pub to: Vec3,
}

impl ShadowRays {
    /// `sets` sets of `samples` rays (at least one), none blocked.
    pub fn new(sets: usize, samples: u32) -> ShadowRays {
        let samples = samples.max(1);
        let words = (samples as usize).div_ceil(64);
        ShadowRays {
            samples,
            words,
            blocked: vec![0; sets * words],
        }
    }

    /// Rays per set.
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// The word and bit of ray `j` of set `s` in `blocked`.
    #[inline]
    fn at(&self, s: usize, j: u32) -> (usize, u64) {
        (s * self.words + j as usize / 64, 1 << (j % 64))
    }

    /// Is ray `j` of set `s` blocked?
    #[inline]
    pub fn is_blocked(&self, s: usize, j: u32) -> bool {
        let (w, bit) = self.at(s, j);
        self.blocked[w] & bit != 0
    }

    /// Word `w` of set `s` (rays `64 w .. 64 w + 63`, bit `j` for ray `64 w + j`): set
    /// where it is blocked; bits past the set's last ray are clear.
    pub fn blocked_word(&self, s: usize, w: usize) -> u64 {
        self.blocked[s * self.words + w]
    }

    /// Mark every ray of set `s` free.
    pub fn clear(&mut self, s: usize) {
        self.blocked[s * self.words..(s + 1) * self.words].fill(0);
    }

    /// Keep set `s` as `blocked` says (ray `j` blocked when `blocked[j]`), traced by the
    /// caller; rays past its end are free.
    pub fn put(&mut self, s: usize, blocked: &[bool]) {
        self.clear(s);
        for (j, &b) in (0u32..).zip(blocked) {
            if b {
                let (w, bit) = self.at(s, j);
                self.blocked[w] |= bit;
            }
        }
    }

    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.blocked.len() * 8
    }

    /// Trace the rays of `sets` from scratch: `ray(s, j)` gives ray `j` of set `s` (from, to)
    /// and its weight, or `None` for a sample that casts no ray (it stays free and weighs
    /// nothing). Returns, per set of `sets` in order, the sum of its rays' weights and the
    /// sum over its free rays (both in sample order).
    pub fn trace<W>(
        &mut self,
        world: &World,
        sets: &[usize],
        ray: impl Fn(usize, u32) -> Option<(Vec3, Vec3, W)> + Sync,
    ) -> Vec<(W, W)>
    where
        W: Copy + Default + AddAssign + Send + Sync,
    {
        cast_in_batches(world, sets, self.samples, ray, |batch, rays, blocked| {
            for &s in batch {
                self.clear(s);
            }
            for (&(c, j, ..), &b) in rays.iter().zip(blocked) {
                if b {
                    let (w, bit) = self.at(batch[c], j);
                    self.blocked[w] |= bit;
                }
            }
        })
    }

    /// [`ShadowRays::trace`] with `samples` rays a set (fewer than the sets keep, say:
    /// `ray(s, j)` is then sample `j` of `samples`), keeping nothing: a moving receiver's
    /// light while it moves, whose rays are traced whole once it rests.
    pub fn trace_sums<W>(
        world: &World,
        sets: &[usize],
        samples: u32,
        ray: impl Fn(usize, u32) -> Option<(Vec3, Vec3, W)> + Sync,
    ) -> Vec<(W, W)>
    where
        W: Copy + Default + AddAssign + Send + Sync,
    {
        cast_in_batches(world, sets, samples.max(1), ray, |_, _, _| {})
    }

    /// The rays of `sets` a move may have changed: a blocked one whose segment meets an `old`
    /// box (its blocker may have left) and a sphere about a mover there, a free one whose
    /// segment meets a `new` box and sphere (as [`padded_move`] has them). `rays_of(s)` gives
    /// set `s`'s rays: ray `j` as `(from, to)`, or `None` for a sample that casts no ray or
    /// that cannot meet a box (a caller's cheaper test first: [`crate::footprint_cones`]).
    pub fn near_movers<R: Fn(u32) -> Option<(Vec3, Vec3)>>(
        &self,
        sets: &[usize],
        old: &Bounds,
        new: &Bounds,
        rays_of: impl Fn(usize) -> R + Sync,
    ) -> Vec<ShadowRay> {
        sets.par_iter()
            .flat_map_iter(|&s| {
                let ray = rays_of(s);
                (0..self.samples).filter_map(move |j| {
                    let (from, to) = ray(j)?;
                    let (boxes, spheres) = if self.is_blocked(s, j) { old } else { new };
                    let meets = (boxes.iter()).any(|b| b.meets_segment(from, to))
                        && (spheres.iter()).any(|&s| segment_meets_sphere(from, to, s));
                    meets.then_some(ShadowRay {
                        set: s as u32,
                        sample: j,
                        from,
                        to,
                    })
                })
            })
            .collect()
    }

    /// Trace `rays` again and keep what they say now; returns the sets whose bits changed,
    /// ascending.
    pub fn retrace(&mut self, world: &World, rays: &[ShadowRay]) -> Vec<usize> {
        let from: Vec<Vec3> = rays.iter().map(|r| r.from).collect();
        let to: Vec<Vec3> = rays.iter().map(|r| r.to).collect();
        let mut blocked = vec![false; rays.len()];
        world.vis.occluded(&from, &to, world.eps, &[], &mut blocked);
        let outcomes = rays.iter().zip(blocked);
        self.keep(outcomes.map(|(r, b)| (r.set as usize, r.sample, b)))
    }

    /// Keep the `outcomes` (set, ray, whether it is blocked now) of rays traced again by the
    /// caller (against the movers first, say); returns the sets whose bits changed,
    /// ascending.
    pub fn keep(&mut self, outcomes: impl IntoIterator<Item = (usize, u32, bool)>) -> Vec<usize> {
        let mut changed: Vec<usize> = Vec::new();
        for (s, j, b) in outcomes {
            let (w, bit) = self.at(s, j);
            let w = &mut self.blocked[w];
            if b != (*w & bit != 0) {
                *w ^= bit;
                changed.push(s);
            }
        }
        changed.sort_unstable();
        changed.dedup();
        changed
    }
}
