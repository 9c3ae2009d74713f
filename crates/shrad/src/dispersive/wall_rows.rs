//! The wall exchange's form-factor rows (Step 4, beyond the paper) with what their rays hit,
//! so that a mover costs only the rays it may have changed, and the rows stay exactly what a
//! fresh trace would give.
//!
//! Why it is exact: a ray's closest hit changes only if (1) it hit an object that moved
//! (that object left), or (2) a moved object's new place meets the segment from the ray's
//! origin to its hit (something new in front). A mover's old place cannot matter otherwise:
//! had it been on the segment, the ray would have hit it. So a frame marks the rays of
//! class (1), from the object they hit, and of class (2), from their segment against the
//! movers' new boxes; marked rays are re-traced (a bounded number per frame), and a row is
//! rebuilt from its rays' hits.
//!
//! The marking is amortised too: a frame checks only a share of the rows (from a cursor that
//! goes round), each against the objects that moved since that row was last checked, at
//! their places *now*. That is as exact as checking every row every frame: where a mover
//! was in between cannot matter, by the same argument (a place it left is not in front of
//! any hit unless the ray hit it, which class (1) catches). A drag then costs a share of the
//! rows' tests per frame instead of all of them; the rows are exact again once every row
//! has been checked and every marked ray re-traced after the motion stops.
//!
//! What a ray keeps (10 bytes; the ray itself is [`patch_rays`], regenerated when traced):
//! the triangle it hit (its patch, and the side in the top bit) and where its segment ends,
//! clipped to a box `W` around the scene and quantised to 16 bits an axis. The segment test
//! then uses the segment from the patch's centre to that end point, against the box padded
//! by the patch's radius and the quantisation step (a superset: conservative). Per row, the
//! box of all its segments rejects a mover at once, and a mask of the objects its rays hit
//! rejects class (1). A segment that leaves `W` (a miss, or a hit beyond it) is clipped; it
//! is tested whole, from regenerated rays, only when a mover's box leaves `W`.
//!
//! Memory: 10 bytes a ray plus 40 a row and the rows themselves: 10 MB at Cornell 20k
//! (15.3k boundary rows x 64 rays), about 50 MB at the 77k room.

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Aabb;

use super::setup::receives_as_boundary;
use super::{Changes, Dispersive};
use crate::form_factors::{patch_rays, row_from_hits, some_patch_rays};
use crate::sparse::SparseRows;
use crate::World;

/// At most `1 / WALL_RETRACE_SHARE` of the wall exchange's rays (boundary patches x
/// `wall_rays`) are re-traced per frame where movers passed (whole rows at a time, so up to
/// one row's rays more); the rest wait for the next frames. A 128th (7.7k rays at Cornell
/// 20k, about 3 ms on 2 cores; a 32nd took 10-20 ms, which made a drag's frame half wall
/// rows) keeps a frame with a mover near a static frame's cost; a ray marked while the budget
/// is spent stays dirty, so the rows are exact again some frames after the motion stops.
pub const WALL_RETRACE_SHARE: usize = 128;

/// At most `1 / WALL_CHECK_SHARE` of the wall rows are checked against the movers per frame
/// (`wall_rows.rs`: as exact as checking all of them, only later). Checking all of them took
/// 16 ms a frame of a Cornell 20k drag on 2 cores (every row's rays span the box, so its
/// bounds reject no mover); an eighth takes about 2 ms.
pub const WALL_CHECK_SHARE: usize = 8;

/// And never more than this many rows checked, nor [`WALL_RETRACE_MAX`] rays re-traced, in
/// one frame: the shares above grow with the boundary (a 77k room has 64k rows: an eighth is
/// 8k rows, 512k segment tests, and a 128th of its rays 32k), so a frame with a mover would
/// grow with the boundary too. Beyond these the rows only take more frames to be exact
/// again; the Cornell box (15k rows) is within both.
pub const WALL_CHECK_MAX: usize = 2048;
/// See [`WALL_CHECK_MAX`].
pub const WALL_RETRACE_MAX: usize = 8192;

/// A scene with more wall-exchange rays than this (boundary patches x `wall_rays`: 7M at the
/// 129k room, 54M at a 1M-patch room) builds its rows lazily: the solver is ready at once,
/// and [`WALL_BUILD_PER_FRAME`] rays of rows not yet traced are traced each frame (the first
/// frames use the rows that are ready; `DispersiveStats::wall_rows_pending` says how many
/// are not). Below it the rows are traced when the solver is made, as before.
pub const WALL_EAGER_RAYS: usize = 1 << 23;
/// See [`WALL_EAGER_RAYS`].
pub const WALL_BUILD_PER_FRAME: usize = 1 << 18;

impl Dispersive {
    /// Check an eighth of the wall rows against the objects that moved since each was last
    /// checked ([`WALL_CHECK_SHARE`]), marking the rays a move may have changed (those that
    /// hit a mover, those with a mover's box now in front of their hit, every ray of a moved
    /// boundary object's rows: `wall_rows.rs`), and re-trace dirty rays, at most a 128th of
    /// the boundary's rays per frame ([`WALL_RETRACE_SHARE`]), from cursors that go round:
    /// the dispersive idea applied to the walls, the cost of a frame stays bounded and what
    /// is left waits for the next frames.
    pub(super) fn refresh_wall_rows(
        &mut self,
        world: &World,
        changes: &Changes,
        deadline: Option<Instant>,
    ) {
        let Some(rows) = &mut self.wall_rows else {
            return;
        };
        let n = self.boundary_patches.len();
        let past = || deadline.is_some_and(|d| Instant::now() >= d);
        let tt = Instant::now();
        rows.note_moves(&changes.moved); // `object_boxes`: every object's box now
                                         // Half as much while something moves (what is left catches up once it rests).
        let moving = 1 + usize::from(!changes.moved.is_empty());
        let mut left = n.div_ceil(WALL_CHECK_SHARE).min(WALL_CHECK_MAX / moving);
        // Under a deadline a few rows at a time (the first even past it: always progress).
        let step = if deadline.is_some() { 256 } else { left };
        while left > 0 {
            let done = rows.check(
                world,
                &self.boundary_patches,
                &self.object_boxes,
                step.min(left),
            );
            left = left.saturating_sub(done);
            if done == 0 || past() {
                break;
            }
        }
        super::tr("  mark", tt);
        let tt = Instant::now();
        let mut left = if rows.pending_rows() > 0 {
            rows.build_per_frame
        } else {
            (n * self.options.wall_rays.max(1) as usize)
                .div_ceil(WALL_RETRACE_SHARE)
                .min(WALL_RETRACE_MAX / moving)
        }
        .max(1);
        let step = if deadline.is_some() { 1024 } else { left };
        while left > 0 {
            let done = rows.retrace(world, &self.boundary_patches, step.min(left));
            left = left.saturating_sub(done);
            if done == 0 || past() {
                break;
            }
        }
        super::tr("  retrace", tt);
    }
}

/// A row rebuilt from its rays: entries, box, mask of objects hit.
type RebuiltRow = (Vec<(u32, f32)>, Aabb, u64);

/// A ray that hit nothing.
const MISS: u32 = u32::MAX;
/// The side bit of a stored hit: set when the ray met the triangle's front face.
const FRONT: u32 = 1 << 31;

/// Rows among boundary patches with their rays' hits (see the module's docs).
pub(super) struct WallRows {
    rays: usize,
    /// `u64` words of dirty bits per row.
    words: usize,
    rows: SparseRows<(u32, f32)>,
    /// `[k * rays + j]`: the patch whose triangle ray `j` of row `k` hit, with [`FRONT`];
    /// [`MISS`] for none.
    hit: Vec<u32>,
    /// `[k * rays + j]`: where its segment ends (clipped to `space`), quantised.
    end: Vec<[u16; 3]>,
    /// The box the end points are quantised in (the scene's bounds at build, with room
    /// around).
    space: Aabb,
    /// Per row: the box holding its segments (as clipped), grown by the patch's radius.
    bounds: Vec<Aabb>,
    /// Per row: bit `o % 64` set when a ray hit object `o`.
    objects_hit: Vec<u64>,
    /// Per row: whether a segment leaves `space` (a miss or a hit outside; or the patch is
    /// outside).
    leaves: Vec<bool>,
    /// `[k * words ..]`: bit `j` set while ray `j` of row `k` waits to be re-traced.
    dirty: Vec<u64>,
    /// The row the next re-trace starts from (so every dirty ray gets its turn).
    cursor: usize,
    /// Frames seen by [`WallRows::mark`].
    frame: u64,
    /// Per object: the last frame it moved in (0: never).
    moved_at: Vec<u64>,
    /// Per row: the frame it was last checked against the movers.
    checked_at: Vec<u64>,
    /// The row the next check starts from.
    mark_cursor: usize,
    /// Every row has been checked against every move up to this frame.
    checked_all: u64,
    /// Per row: traced at least once (rows built lazily start empty: [`WALL_EAGER_RAYS`]).
    built: Vec<bool>,
    /// Rows not built yet.
    pending: usize,
    /// Rays traced per frame while rows are pending ([`WALL_BUILD_PER_FRAME`]).
    pub(super) build_per_frame: usize,
}

impl WallRows {
    /// The rows of `rays` rays from each patch of `boundary`; every object occludes, only
    /// boundary-to-boundary entries are kept (light via interior objects is Step 3's). Traced
    /// now when `eager` (and always up to [`WALL_EAGER_RAYS`]), else empty and all dirty:
    /// [`WallRows::retrace`] builds them over the next frames.
    pub(super) fn new(
        world: &World,
        boundary: &[u32],
        rays: u32,
        eager: bool,
        progress: &dyn crate::Progress,
    ) -> WallRows {
        let rays = rays.max(1) as usize;
        let words = rays.div_ceil(64);
        let n = boundary.len();
        let bounds = world
            .scene
            .bounds()
            .unwrap_or(Aabb::new(Vec3::ZERO, Vec3::ONE));
        let (lo, hi) = (bounds.min, bounds.max);
        let size = bounds.size().max(Vec3::splat(1e-3));
        let mut out = WallRows {
            rays,
            words,
            rows: SparseRows::from_rows(vec![Vec::<(u32, f32)>::new(); n]),
            hit: vec![MISS; n * rays],
            end: vec![[0; 3]; n * rays],
            space: Aabb::new(lo - 0.25 * size, hi + 0.25 * size),
            bounds: vec![Aabb::EMPTY; n],
            objects_hit: vec![0; n],
            leaves: vec![false; n],
            dirty: vec![0; n * words],
            cursor: 0,
            frame: 0,
            moved_at: vec![0; world.scene.objects.len()],
            checked_at: vec![0; n],
            mark_cursor: 0,
            checked_all: 0,
            built: vec![false; n],
            pending: n,
            build_per_frame: WALL_BUILD_PER_FRAME,
        };
        // Everything is dirty: trace it all now, a chunk of rays at a time, or later.
        for k in 0..n {
            out.set_all_dirty(k);
        }
        if eager || n * rays <= WALL_EAGER_RAYS {
            let chunk = ((1 << 20) / rays).max(1) * rays;
            progress.begin("wall-exchange rows", n as u64);
            loop {
                let traced = out.retrace(world, boundary, chunk);
                if traced == 0 {
                    break;
                }
                progress.advance((traced / rays) as u64);
            }
            progress.end();
        }
        out.cursor = 0;
        out
    }

    /// The rows of [`WallRows::new`], none traced yet, whatever their size (for tests of the
    /// lazy build on small scenes).
    #[cfg(test)]
    pub(super) fn new_unbuilt(world: &World, boundary: &[u32], rays: u32) -> WallRows {
        let mut rows = WallRows::new(world, &boundary[..0], rays, false, &crate::NoProgress);
        let n = boundary.len();
        let r = rows.rays;
        rows.rows = SparseRows::from_rows(vec![Vec::<(u32, f32)>::new(); n]);
        rows.hit = vec![MISS; n * r];
        rows.end = vec![[0; 3]; n * r];
        rows.bounds = vec![Aabb::EMPTY; n];
        rows.objects_hit = vec![0; n];
        rows.leaves = vec![false; n];
        rows.dirty = vec![0; n * rows.words];
        rows.checked_at = vec![0; n];
        rows.built = vec![false; n];
        rows.pending = n;
        for k in 0..n {
            rows.set_all_dirty(k);
        }
        rows
    }

    /// Rows not traced yet (built lazily: [`WALL_EAGER_RAYS`]).
    pub(super) fn pending_rows(&self) -> usize {
        self.pending
    }

    /// Row `k` (aligned with the boundary patches): `(patch seen, F)`.
    pub(super) fn row(&self, k: usize) -> &[(u32, f32)] {
        self.rows.row(k)
    }

    /// The rows.
    #[cfg(test)]
    pub(super) fn rows(&self) -> &SparseRows<(u32, f32)> {
        &self.rows
    }

    /// Bytes held (the rows, the rays' hits and ends, the rows' boxes and masks).
    #[cfg(test)]
    pub(super) fn bytes(&self) -> usize {
        self.rows.bytes()
            + self.hit.len() * 4
            + self.end.len() * 6
            + self.bounds.len() * (std::mem::size_of::<Aabb>() + 8 + 1)
            + self.dirty.len() * 8
    }

    /// Rays waiting to be re-traced.
    #[cfg(test)]
    pub(super) fn dirty_rays(&self) -> usize {
        self.dirty.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Rows not yet checked against a move (see [`WallRows::mark`]).
    #[cfg(test)]
    pub(super) fn unchecked_rows(&self) -> usize {
        let last = self.moved_at.iter().copied().max().unwrap_or(0);
        self.checked_at.iter().filter(|&&c| c < last).count()
    }

    /// No ray waits to be re-traced and every row has been checked against every move: the
    /// rows are what a fresh trace gives.
    pub(super) fn settled(&self) -> bool {
        let last = self.moved_at.iter().copied().max().unwrap_or(0);
        last <= self.checked_all && self.dirty.iter().all(|&w| w == 0)
    }

    fn set_all_dirty(&mut self, k: usize) {
        let w = &mut self.dirty[k * self.words..(k + 1) * self.words];
        w.fill(u64::MAX);
        if self.rays % 64 != 0 {
            w[self.words - 1] = u64::MAX >> (self.words * 64 - self.rays);
        }
    }

    /// Quantisation step of the end points, per axis.
    fn step(&self) -> Vec3 {
        self.space.size() / 65535.0
    }

    fn decode(&self, e: [u16; 3]) -> Vec3 {
        self.space.min + Vec3::new(e[0] as f32, e[1] as f32, e[2] as f32) * self.step()
    }

    fn encode(&self, p: Vec3) -> [u16; 3] {
        let q = ((p - self.space.min) / self.step()).round();
        let q = q.clamp(Vec3::ZERO, Vec3::splat(65535.0));
        [q.x as u16, q.y as u16, q.z as u16]
    }

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
        let n = boundary.len();
        if n == 0 || last <= self.checked_all {
            return 0;
        }
        // The rows to check this frame.
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
            // The scan went round: these are all the rows left to check.
            self.checked_all = last;
        }
        if rows.is_empty() {
            return 0;
        }
        self.mark_cursor = next;
        let p = &world.patches;
        let (rays, words) = (self.rays, self.words);
        // Slack for the float noise of hits on a mover's surface (a ray that grazes a padded
        // box is only re-traced for nothing).
        let padded: Vec<Aabb> = boxes
            .iter()
            .map(|b| b.padded(Vec3::splat(4.0 * world.eps + 1e-5 * b.diagonal())))
            .collect();
        let q = self.step();
        // Per row: (row, rays newly dirty, whether all of them).
        let marks: Vec<(usize, Vec<u64>, bool)> = rows
            .par_iter()
            .filter_map(|&k| {
                // The objects that moved since this row was last checked.
                let since = self.checked_at[k];
                let moved: Vec<usize> = (0..self.moved_at.len())
                    .filter(|&o| self.moved_at[o] > since)
                    .collect();
                let moved_mask = moved.iter().fold(0u64, |m, &o| m | 1 << (o % 64));
                let new: Vec<Aabb> = moved
                    .iter()
                    .map(|&o| padded[o])
                    .filter(|b| !b.is_empty())
                    .collect();
                let inside = new
                    .iter()
                    .all(|b| self.space.contains(b.min) && self.space.contains(b.max));
                let i = boundary[k] as usize;
                let bits = &self.dirty[k * words..(k + 1) * words];
                if moved.contains(&(p.object[i] as usize)) {
                    let mut all = vec![u64::MAX; words];
                    if rays % 64 != 0 {
                        all[words - 1] = u64::MAX >> (words * 64 - rays);
                    }
                    return (all != bits).then_some((k, all, true));
                }
                let mut out = vec![0u64; words];
                let clean =
                    |out: &[u64], j: usize| (out[j / 64] | bits[j / 64]) & (1 << (j % 64)) == 0;
                let hits = &self.hit[k * rays..(k + 1) * rays];
                // (1) Rays that hit a mover.
                if self.objects_hit[k] & moved_mask != 0 {
                    for (j, &h) in hits.iter().enumerate() {
                        if h != MISS
                            && clean(&out, j)
                            && moved.contains(&(p.object[(h & !FRONT) as usize] as usize))
                        {
                            out[j / 64] |= 1 << (j % 64);
                        }
                    }
                }
                // (2) Rays with a mover's new place in front of their hit.
                let (c, r) = patch_sphere(world, i);
                let pad = Vec3::splat(r) + q;
                let near: Vec<Aabb> = new
                    .iter()
                    .map(|b| b.padded(pad))
                    .filter(|b| b.meets_box(&self.bounds[k]))
                    .collect();
                if !inside && self.leaves[k] {
                    // A mover outside the quantised space: the whole rays, regenerated.
                    let mut o = vec![Vec3::ZERO; rays];
                    let mut d = vec![Vec3::ZERO; rays];
                    patch_rays(world, i, &mut o, &mut d);
                    for j in 0..rays {
                        if clean(&out, j) && new.iter().any(|b| b.meets_ray(o[j], d[j])) {
                            out[j / 64] |= 1 << (j % 64);
                        }
                    }
                } else if !near.is_empty() {
                    let ends = &self.end[k * rays..(k + 1) * rays];
                    for j in 0..rays {
                        if clean(&out, j) {
                            let e = self.decode(ends[j]);
                            if near.iter().any(|b| b.meets_segment(c, e)) {
                                out[j / 64] |= 1 << (j % 64);
                            }
                        }
                    }
                }
                out.iter().any(|&w| w != 0).then_some((k, out, false))
            })
            .collect();
        for (k, bits, _) in marks {
            let w = &mut self.dirty[k * words..(k + 1) * words];
            w.iter_mut().zip(&bits).for_each(|(w, b)| *w |= b);
        }
        for &k in &rows {
            self.checked_at[k] = self.frame;
        }
        rows.len()
    }

    /// Row `k`'s entries from its rays' hits.
    fn row_entries(&self, world: &World, k: usize) -> Vec<(u32, f32)> {
        let rays = self.rays;
        row_from_hits(
            self.hit[k * rays..(k + 1) * rays]
                .iter()
                .filter_map(|&h| seen(world, h))
                .filter(|&s| receives_as_boundary(world, s))
                .map(|s| s as u32),
            rays,
        )
    }

    /// Rays `js` of each row `k` in `rows`, regenerated, in that order.
    fn regenerate(
        &self,
        world: &World,
        boundary: &[u32],
        rows: &[(usize, Vec<usize>)],
    ) -> (Vec<Vec3>, Vec<Vec3>) {
        let total: usize = rows.iter().map(|(_, js)| js.len()).sum();
        let mut o = vec![Vec3::ZERO; total];
        let mut d = vec![Vec3::ZERO; total];
        let (mut os, mut ds) = (&mut o[..], &mut d[..]);
        let mut jobs = Vec::with_capacity(rows.len());
        for (k, js) in rows {
            let (oc, rest_o) = os.split_at_mut(js.len());
            let (dc, rest_d) = ds.split_at_mut(js.len());
            (os, ds) = (rest_o, rest_d);
            jobs.push((*k, js, oc, dc));
        }
        jobs.into_par_iter().for_each(|(k, js, oc, dc)| {
            some_patch_rays(world, boundary[k] as usize, self.rays, js, oc, dc)
        });
        (o, d)
    }

    /// Rebuild rows `ks` from their rays' hits, with their boxes and masks.
    fn rebuild(&mut self, world: &World, boundary: &[u32], ks: &[usize]) {
        let rays = self.rays;
        let p = &world.patches;
        let rebuilt: Vec<RebuiltRow> = ks
            .par_iter()
            .map(|&k| {
                let i = boundary[k] as usize;
                let hits = &self.hit[k * rays..(k + 1) * rays];
                let row = self.row_entries(world, k);
                let (c, r) = patch_sphere(world, i);
                let b = self.end[k * rays..(k + 1) * rays]
                    .iter()
                    .fold(Aabb::new(c, c).padded(Vec3::splat(r)), |b, &e| {
                        b.grow(self.decode(e))
                    });
                let mask = hits.iter().filter(|&&h| h != MISS).fold(0u64, |m, &h| {
                    m | 1 << (p.object[(h & !FRONT) as usize] % 64)
                });
                (row, b, mask)
            })
            .collect();
        for (&k, (row, b, mask)) in ks.iter().zip(rebuilt) {
            self.rows.set_row(k, &row);
            self.bounds[k] = b;
            self.objects_hit[k] = mask;
        }
    }

    /// Re-trace dirty rays, whole rows at a time from the cursor round, until about
    /// `budget` rays (at least one row's, at most `budget + rays`); rebuild those rows from
    /// their rays' hits. Returns the rays traced.
    pub(super) fn retrace(&mut self, world: &World, boundary: &[u32], budget: usize) -> usize {
        let (rays, words) = (self.rays, self.words);
        let n = boundary.len();
        // Nothing to do on most frames of a static scene: one pass over the bits.
        if n == 0 || self.dirty.iter().all(|&w| w == 0) {
            return 0;
        }
        // Pick the rows.
        let mut picked: Vec<usize> = Vec::new();
        let mut count = 0;
        let start = self.cursor % n;
        let mut next = start;
        for step in 0..n {
            let k = (start + step) % n;
            next = (k + 1) % n;
            let c: usize = self.dirty[k * words..(k + 1) * words]
                .iter()
                .map(|w| w.count_ones() as usize)
                .sum();
            if c == 0 {
                continue;
            }
            picked.push(k);
            count += c;
            if count >= budget {
                break;
            }
        }
        if picked.is_empty() {
            return 0;
        }
        self.cursor = next;
        // The dirty rays, regenerated.
        let rows: Vec<(usize, Vec<usize>)> = picked
            .iter()
            .map(|&k| {
                let bits = &self.dirty[k * words..(k + 1) * words];
                let js = (0..rays)
                    .filter(|j| bits[j / 64] & (1 << (j % 64)) != 0)
                    .collect();
                (k, js)
            })
            .collect();
        let (o, d) = self.regenerate(world, boundary, &rows);
        let which: Vec<(usize, usize)> = rows
            .iter()
            .enumerate()
            .flat_map(|(c, (_, js))| js.iter().map(move |&j| (c, j)))
            .collect();
        let mut hits = vec![shrad_vis::Hit::MISS; o.len()];
        world.vis.closest(&o, &d, 0.0, &[], &mut hits);
        let ends: Vec<([u16; 3], bool)> = (0..which.len())
            .into_par_iter()
            .map(|r| {
                let (o, d, h) = (o[r], d[r], &hits[r]);
                let exit = exit_distance(&self.space, o, d);
                let t = if h.is_hit() { h.t } else { f32::INFINITY };
                (self.encode(o + d * t.min(exit)), t > exit)
            })
            .collect();
        for ((&(c, j), h), &(e, _)) in which.iter().zip(&hits).zip(&ends) {
            let k = picked[c];
            self.hit[k * rays + j] = if h.is_hit() {
                h.id | if h.front { FRONT } else { 0 }
            } else {
                MISS
            };
            self.end[k * rays + j] = e;
        }
        let mut leaving = vec![false; picked.len()];
        for (&(c, _), &(_, l)) in which.iter().zip(&ends) {
            leaving[c] |= l;
        }
        // Rebuild the rows, their boxes and masks.
        self.rebuild(world, boundary, &picked);
        for (c, &k) in picked.iter().enumerate() {
            let (centre, _) = patch_sphere(world, boundary[k] as usize);
            // A segment once outside stays outside until the row is traced again whole.
            let all_traced = rows[c].1.len() == rays;
            self.leaves[k] =
                leaving[c] || !self.space.contains(centre) || (!all_traced && self.leaves[k]);
            self.dirty[k * words..(k + 1) * words].fill(0);
            if !self.built[k] {
                self.built[k] = true;
                self.pending -= 1;
            }
        }
        which.len()
    }
}

/// The patch a stored hit sees (its twin when the back was hit), as [`World::seen_patch`].
fn seen(world: &World, h: u32) -> Option<usize> {
    (h != MISS).then_some(())?;
    world.seen_patch(&shrad_vis::Hit {
        id: h & !FRONT,
        object: 0,
        t: 0.0,
        front: h & FRONT != 0,
    })
}

/// A sphere holding patch `i` and its rays' origins (which are `eps` above it).
fn patch_sphere(world: &World, i: usize) -> (Vec3, f32) {
    let c = world.patches.centre[i];
    let r = world
        .patches
        .world_corners(i)
        .iter()
        .map(|&v| (v - c).length())
        .fold(0.0, f32::max);
    (c, r * (1.0 + 1e-5) + 2.0 * world.eps)
}

/// Distance along `o + t d` to where it leaves `b` (0 when `o` is outside).
fn exit_distance(b: &Aabb, o: Vec3, d: Vec3) -> f32 {
    if !b.contains(o) {
        return 0.0;
    }
    let inv = d.recip();
    let t0 = (b.min - o) * inv;
    let t1 = (b.max - o) * inv;
    t0.max(t1).min_element().max(0.0)
}
