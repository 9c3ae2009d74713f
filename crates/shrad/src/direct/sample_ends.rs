//! Where each cached shadow ray ends: finding the rays a mover's box meets is then a slab
//! test per ray, not a regenerated sample ([`super::cache::DirectCache`]).

use glam::Vec3;
use shrad_scene::Aabb;

use crate::segments::{Offsets, LANES};
use crate::World;

/// `[(k * emitters + e) * samples + j]`: the end of shadow ray `j` of receiver `k` towards
/// emitter `e` (a point on the emitter). Up to [`SampleEnds::MAX_EXACT`] rays the ends are
/// kept as they are (12 bytes a ray; 59 MB at the 77k room): a ray found is re-traced from
/// its stored end, with no sample regenerated. Above, up to [`SampleEnds::MAX_RAYS`], they
/// are quantised to 16 bits an axis in `space` (6 bytes a ray), tested against the boxes
/// padded by the quantisation step (a superset), and each ray found is regenerated to be
/// re-traced. Left empty above that, where every sample is regenerated.
#[derive(Clone, Debug, Default)]
pub(super) enum SampleEnds {
    /// None kept: every sample is regenerated.
    #[default]
    None,
    /// Each end as it was put.
    Exact(Vec<Vec3>),
    /// Each end quantised in `space`.
    Quantised { space: Aabb, end: Vec<[u16; 3]> },
}

impl SampleEnds {
    /// At most this many rays' ends are kept as they are (96 MB: the 77k and 129k rooms'
    /// 4.9M and 7.7M rays; the 1M room's 16M would be 96 MB more where its peak memory is
    /// at issue 24's bound, so it keeps them quantised).
    pub(super) const MAX_EXACT: usize = 1 << 23;
    /// At most this many rays' ends are kept (quantised: 192 MB; the 1M room's 16M rays take
    /// 96 MB).
    pub(super) const MAX_RAYS: usize = 1 << 25;

    pub(super) fn new(world: &World, rays: usize) -> SampleEnds {
        if rays <= Self::MAX_EXACT {
            return SampleEnds::Exact(vec![Vec3::ZERO; rays]);
        }
        match world.scene.bounds().filter(|_| rays <= Self::MAX_RAYS) {
            Some(b) => SampleEnds::Quantised {
                space: b.padded(Vec3::splat(1e-3) + 0.01 * b.size()),
                end: vec![[0; 3]; rays],
            },
            None => SampleEnds::None,
        }
    }

    /// Rays whose ends are kept (exact or quantised).
    pub(super) fn len(&self) -> usize {
        match self {
            SampleEnds::None => 0,
            SampleEnds::Exact(exact) => exact.len(),
            SampleEnds::Quantised { end, .. } => end.len(),
        }
    }

    /// Bytes held.
    pub(super) fn bytes(&self) -> usize {
        match self {
            SampleEnds::None => 0,
            SampleEnds::Exact(exact) => exact.len() * 12,
            SampleEnds::Quantised { end, .. } => end.len() * 6,
        }
    }

    /// The end of ray `at` as it was put, where ends are kept exact.
    pub(super) fn exact(&self, at: usize) -> Option<Vec3> {
        match self {
            SampleEnds::Exact(exact) => exact.get(at).copied(),
            _ => None,
        }
    }

    /// Quantisation step, per axis.
    pub(super) fn step(space: &Aabb) -> Vec3 {
        space.size().max(Vec3::splat(1e-6)) / 65535.0
    }

    pub(super) fn put(&mut self, at: usize, p: Vec3) {
        match self {
            SampleEnds::None => {}
            SampleEnds::Exact(exact) => exact[at] = p,
            SampleEnds::Quantised { space, end } => {
                if !space.contains(p) {
                    // An end outside (an emitter beyond the scene's bounds): keep none.
                    *self = SampleEnds::None;
                    return;
                }
                let q = ((p - space.min) / Self::step(space)).round();
                let q = q.clamp(Vec3::ZERO, Vec3::splat(65535.0));
                end[at] = [q.x as u16, q.y as u16, q.z as u16];
            }
        }
    }

    /// Which of the up to 64 stored ends `first .. first + n` have their segment from
    /// `from` meet one of the boxes of each set in `sets` (already [`SampleEnds::pad`]ded;
    /// exactly where the ends are exact, else a superset):
    /// bit `j` of result `s` for end `first + j`, for set `s`. `None` where no ends are kept.
    /// The ends are decoded once into arrays and tested by a slab test per box over all of
    /// them at once (vectorised: a per-ray call was a third of finding a mover's shadow
    /// rays).
    pub(super) fn meeting(
        &self,
        first: usize,
        n: usize,
        from: Vec3,
        sets: [&[Aabb]; 2],
    ) -> Option<[u64; 2]> {
        debug_assert!(n <= 64);
        let mut d: Offsets = [[0f32; LANES]; 3];
        match self {
            SampleEnds::None => return None,
            SampleEnds::Exact(exact) => {
                for (j, e) in exact[first..first + n].iter().enumerate() {
                    let e = *e - from;
                    for a in 0..3 {
                        d[a][j] = e[a];
                    }
                }
            }
            SampleEnds::Quantised { space, end } => {
                let (lo, step) = (space.min - from, Self::step(space));
                for (j, e) in end[first..first + n].iter().enumerate() {
                    for a in 0..3 {
                        d[a][j] = lo[a] + e[a] as f32 * step[a];
                    }
                }
            }
        }
        let meeting = |boxes: &[Aabb]| match boxes.is_empty() {
            true => 0,
            false => crate::segments::meeting(from, &d, n, boxes),
        };
        Some([meeting(sets[0]), meeting(sets[1])])
    }

    /// `boxes` padded by the quantisation step: a segment to a stored end misses them only
    /// if the segment to the exact end misses the boxes unpadded (as they are where the
    /// ends are exact).
    pub(super) fn pad(&self, boxes: &[Aabb]) -> Vec<Aabb> {
        let q = match self {
            SampleEnds::Quantised { space, .. } => Self::step(space),
            _ => Vec3::ZERO,
        };
        boxes.iter().map(|b| b.padded(q)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `meeting` finds every stored ray whose exact segment meets a box (it is given the
    /// boxes [`SampleEnds::pad`]ded, as the cache does: by the quantisation step where the
    /// ends are quantised), and rejects most of those that pass far from it (where the ends
    /// are exact, every one); a segment along an axis (a zero component) is handled.
    #[test]
    fn meeting_finds_every_segment_that_meets_a_box() {
        let space = Aabb::new(Vec3::splat(-2.0), Vec3::splat(2.0));
        for exact in [false, true] {
            let mut rnd = crate::sampling::test_rng(7);
            let (mut found, mut rejected, mut extra) = (0, 0, 0);
            for case in 0..400 {
                let n = 1 + case % 64;
                let mut v = || Vec3::new(rnd(), rnd(), rnd()) * 3.6 - 1.8;
                let from = v();
                let mut ends = match exact {
                    true => SampleEnds::Exact(vec![Vec3::ZERO; n]),
                    false => SampleEnds::Quantised {
                        space,
                        end: vec![[0; 3]; n],
                    },
                };
                let ends_put: Vec<Vec3> = (0..n)
                    .map(|j| match j % 7 {
                        // Straight up from `from`: two components of the segment are 0.
                        0 => Vec3::new(from.x, 1.9, from.z),
                        _ => v(),
                    })
                    .collect();
                for (j, &e) in ends_put.iter().enumerate() {
                    ends.put(j, e);
                    assert_eq!(ends.exact(j), exact.then_some(e));
                }
                let (c, h) = (v() * 0.5, Vec3::new(rnd(), rnd(), rnd()) * 0.6 + 0.05);
                let boxes = [Aabb::new(c - h, c + h)];
                let [mask, none] = ends.meeting(0, n, from, [&ends.pad(&boxes), &[]]).unwrap();
                assert_eq!(none, 0, "no box met");
                assert_eq!(mask >> n.min(63) >> (n / 64), 0, "bits past n");
                for (j, &e) in ends_put.iter().enumerate() {
                    let bit = mask >> j & 1 != 0;
                    if boxes[0].meets_segment(from, e) {
                        assert!(bit, "case {case}: ray {j} meets the box and was not found");
                        found += 1;
                    } else if !bit {
                        rejected += 1;
                    } else {
                        extra += 1;
                    }
                }
            }
            assert!(
                found > 500 && rejected > 5000,
                "{found} found, {rejected} rejected"
            );
            assert!(!exact || extra == 0, "{extra} found that miss the box");
        }
    }
}
