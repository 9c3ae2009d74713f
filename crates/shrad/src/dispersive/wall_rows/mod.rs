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
//! A marked ray is re-traced against the objects that moved first (`movers_first.rs`): its
//! stored hit stands unless it was on one of them or one of them is now in front of it.
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
use shrad_scene::Aabb;

use super::Changes;
use crate::sparse::SparseRows;
use crate::World;

mod check;
mod movers_first;
mod retrace;

/// At most `1 / WALL_RETRACE_SHARE` of the wall exchange's rays (boundary patches x
/// `wall_rays`) are re-traced per frame where movers passed (whole rows at a time, so up to
/// one row's rays more); the rest wait for the next frames. A 128th (7.7k rays at Cornell
/// 20k, about 3 ms on 2 cores; a 32nd took 10-20 ms, which made a drag's frame half wall
/// rows) keeps a frame with a mover near a static frame's cost; a ray marked while the budget
/// is spent stays dirty, so the rows are exact again some frames after the motion stops.
pub const WALL_RETRACE_SHARE: usize = 128;

/// At most `1 / WALL_CHECK_SHARE` of the wall rows are checked against the movers per frame
/// (the module's docs: as exact as checking all of them, only later). Checking all of them took
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

/// At most this many wall-exchange rays in all (about 900 MB of rows and ray records at 64
/// rays a patch; the 1M-patch room's 850k boundary patches x 64 took 1.94 GB of peak memory
/// with its rows built, against the 1.5 GiB asked). A boundary larger than this allows gets
/// fewer rays a patch ([`wall_rays_for`]).
pub const WALL_MAX_RAYS: usize = 1 << 25;

/// Rays a patch for a boundary of `patches` patches, with `asked` rays a patch asked: halved
/// (never below 16) until all of them fit in [`WALL_MAX_RAYS`]. Such a boundary's patches are
/// small, so its rays per unit of area stay above those of a smaller scene at `asked`: the
/// 1M room at 32 casts 6x the 77k room's at 64 per square metre of wall.
pub fn wall_rays_for(patches: usize, asked: u32) -> u32 {
    let mut rays = asked.max(1);
    while rays > 16 && patches * rays as usize > WALL_MAX_RAYS {
        rays /= 2;
    }
    rays
}

impl WallRows {
    /// Check an eighth of these rows (among the `boundary` patches) against the objects
    /// that moved since each was last checked ([`WALL_CHECK_SHARE`]; every object's box now
    /// in `object_boxes`), marking the rays a move may have changed (those that hit a mover,
    /// those with a mover's box now in front of their hit, every ray of a moved boundary
    /// object's rows: the module's docs), and re-trace dirty rays, at most a 128th of the
    /// boundary's rays per frame ([`WALL_RETRACE_SHARE`]), from cursors that go round: the
    /// dispersive idea applied to the walls, the cost of a frame stays bounded and what is
    /// left waits for the next frames. It reads nothing else of the solver, so that the frame
    /// runs it beside Step 1.
    pub(super) fn refresh(
        &mut self,
        world: &World,
        (boundary, object_boxes): (&[u32], &[Aabb]),
        changes: &Changes,
        deadline: Option<Instant>,
    ) {
        let rows = self;
        let n = boundary.len();
        let past = || deadline.is_some_and(|d| Instant::now() >= d);
        let tt = Instant::now();
        rows.note_moves(&changes.moved);
        // A quarter as much while something moves (what is left catches up once it rests).
        // Not less: a sixteenth took 1.6 ms of one thread off the 77k room's moving frame,
        // but the Cornell box's error while its box slides (`scenes/moving_box.toml`) went
        // from 3.1-3.7 % to 4.2-4.8 % (an eighth: 3.3-3.7 %); its walls' light through the
        // rows the box crosses lagged behind.
        let moving = 1 + 3 * usize::from(!changes.moved.is_empty());
        let mut left = n.div_ceil(WALL_CHECK_SHARE).min(WALL_CHECK_MAX / moving);
        // Under a deadline a few rows at a time (the first even past it: always progress,
        // a quarter as much when the frame is already late).
        let late = if past() { 4 } else { 1 };
        let step = if deadline.is_some() { 256 / late } else { left };
        while left > 0 {
            // `object_boxes`: every object's box now.
            let done = rows.check(world, boundary, object_boxes, step.min(left));
            left = left.saturating_sub(done);
            if done == 0 || past() {
                break;
            }
        }
        super::tr("  mark", tt);
        let tt = Instant::now();
        // Rows still to build (a large scene's lazy start) take their share too: an eighth
        // while something moves, so that a drag costs what moved (in the 1M-patch room a
        // quarter, 65k rays, kept its moving frames over 60 ms while the rows built).
        let mut left = if rows.pending_rows() > 0 {
            rows.build_per_frame / (1 + 7 * usize::from(!changes.moved.is_empty()))
        } else {
            (n * rows.rays)
                .div_ceil(WALL_RETRACE_SHARE)
                .min(WALL_RETRACE_MAX / moving)
        }
        .max(1);
        let step = if deadline.is_some() {
            1024 / late
        } else {
            left
        };
        while left > 0 {
            let done = rows.retrace(world, boundary, step.min(left));
            left = left.saturating_sub(done);
            if done == 0 || past() {
                break;
            }
        }
        super::tr("  retrace", tt);
    }
}

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
    /// Bit `k` set while row `k` has a dirty ray, so that finding them is a pass over a
    /// bit a row (a 77k room's 64k rows: 1k words), not over every row's rays.
    dirty_rows: Vec<u64>,
    /// Rows with a dirty ray (the bits set in `dirty_rows`).
    dirty_row_count: usize,
    /// The row the next re-trace starts from (so every dirty ray gets its turn).
    cursor: usize,
    /// Per dirty row: the frame since which its dirty rays' stored hits were right (its
    /// check before they were marked), or `movers_first::UNKNOWN`: only the objects that
    /// moved after it can have changed them (`movers_first.rs`).
    valid_at: Vec<u64>,
    /// Frames seen by [`WallRows::note_moves`].
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
    /// Rows rebuilt since Step 4 last took them ([`WallRows::take_rebuilt`]).
    rebuilt: Vec<usize>,
}

impl WallRows {
    /// The rows of `rays` rays from each patch of `boundary`; every object occludes, only
    /// boundary-to-boundary entries are kept (light via interior objects is Step 3's). Traced
    /// now when `eager` (and always up to [`WALL_EAGER_RAYS`]), else empty and all dirty:
    /// [`WallRows::retrace`] builds them over the next frames. [`crate::Error::Interrupted`]
    /// when `progress` asks to stop (before each chunk of about a million rays).
    pub(super) fn new(
        world: &World,
        boundary: &[u32],
        rays: u32,
        eager: bool,
        progress: &dyn crate::Progress,
    ) -> Result<WallRows, crate::Error> {
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
            dirty_rows: vec![0; n.div_ceil(64)],
            dirty_row_count: 0,
            cursor: 0,
            valid_at: vec![movers_first::UNKNOWN; n],
            frame: 0,
            moved_at: vec![0; world.scene.objects.len()],
            checked_at: vec![0; n],
            mark_cursor: 0,
            checked_all: 0,
            built: vec![false; n],
            pending: n,
            build_per_frame: WALL_BUILD_PER_FRAME,
            rebuilt: Vec::new(),
        };
        // Everything is dirty: trace it all now, a chunk of rays at a time, or later.
        for k in 0..n {
            out.set_all_dirty(k);
        }
        if eager || n * rays <= WALL_EAGER_RAYS {
            let chunk = ((1 << 20) / rays).max(1) * rays;
            progress.begin("wall-exchange rows", n as u64);
            loop {
                crate::progress::check(progress).inspect_err(|_| progress.end())?;
                let traced = out.retrace(world, boundary, chunk);
                if traced == 0 {
                    break;
                }
                progress.advance((traced / rays) as u64);
            }
            progress.end();
        }
        out.cursor = 0;
        Ok(out)
    }

    /// The rows of [`WallRows::new`], none traced yet, whatever their size (for tests of the
    /// lazy build on small scenes).
    #[cfg(test)]
    pub(super) fn new_unbuilt(world: &World, boundary: &[u32], rays: u32) -> WallRows {
        let mut rows = WallRows::new(world, &boundary[..0], rays, false, &crate::NoProgress)
            .expect("NoProgress never stops");
        let n = boundary.len();
        let r = rows.rays;
        rows.rows = SparseRows::from_rows(vec![Vec::<(u32, f32)>::new(); n]);
        rows.hit = vec![MISS; n * r];
        rows.end = vec![[0; 3]; n * r];
        rows.bounds = vec![Aabb::EMPTY; n];
        rows.objects_hit = vec![0; n];
        rows.leaves = vec![false; n];
        rows.dirty = vec![0; n * rows.words];
        rows.dirty_rows = vec![0; n.div_ceil(64)];
        rows.dirty_row_count = 0;
        rows.checked_at = vec![0; n];
        rows.valid_at = vec![movers_first::UNKNOWN; n];
        rows.built = vec![false; n];
        rows.pending = n;
        for k in 0..n {
            rows.set_all_dirty(k);
        }
        rows
    }

    /// The rows rebuilt since the last call, each once, ascending (Step 4 gathers them
    /// beside its window: a row the mover made exact again should not wait for the window
    /// to come round).
    pub(super) fn take_rebuilt(&mut self) -> Vec<usize> {
        let mut ks = std::mem::take(&mut self.rebuilt);
        ks.sort_unstable();
        ks.dedup();
        ks
    }

    /// Rows not traced yet (built lazily: [`WALL_EAGER_RAYS`]).
    pub(super) fn pending_rows(&self) -> usize {
        self.pending
    }

    /// Rays a row (as built: [`wall_rays_for`]).
    pub(super) fn rays(&self) -> usize {
        self.rays
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

    /// Whether rows `k` of `self` and `other` differ only in rays that report different
    /// surfaces at the same distance (their stored ends equal): a box's bottom face on the floor,
    /// seen from inside the box, where which one a trace reports depends on the order it
    /// visits them in (with Embree, on the other rays of its packet). Rows whose rays all hit
    /// the same do not differ in ties (their entries should be the same).
    #[cfg(test)]
    pub(super) fn differ_only_in_ties(&self, other: &WallRows, k: usize) -> bool {
        let r = k * self.rays..(k + 1) * self.rays;
        let (hits, ends) = (
            self.hit[r.clone()].iter().zip(&other.hit[r.clone()]),
            self.end[r.clone()].iter().zip(&other.end[r]),
        );
        let mut some_tie = false;
        let only_ties = hits.zip(ends).all(|((a, b), (ea, eb))| {
            some_tie |= a != b;
            a == b || ea == eb
        });
        some_tie && only_ties
    }

    /// Rows whose mask of objects hit misses an object one of their rays hits (a row is
    /// checked against a mover only if its mask holds the mover: see [`WallRows::check`]).
    #[cfg(test)]
    pub(super) fn rows_missing_an_object_hit(&self, world: &World) -> usize {
        (0..self.bounds.len())
            .filter(|&k| {
                let hits = &self.hit[k * self.rays..(k + 1) * self.rays];
                let mask = retrace::mask_of_objects_hit(world, hits);
                mask & !self.objects_hit[k] != 0
            })
            .count()
    }

    /// Rays waiting to be re-traced.
    #[cfg(test)]
    pub(super) fn dirty_rays(&self) -> usize {
        self.dirty.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Rows not yet checked against a move (see [`WallRows::check`]).
    #[cfg(test)]
    pub(super) fn unchecked_rows(&self) -> usize {
        let last = self.moved_at.iter().copied().max().unwrap_or(0);
        self.checked_at.iter().filter(|&&c| c < last).count()
    }

    /// No ray waits to be re-traced and every row has been checked against every move: the
    /// rows are what a fresh trace gives.
    pub(super) fn settled(&self) -> bool {
        let last = self.moved_at.iter().copied().max().unwrap_or(0);
        last <= self.checked_all && self.dirty_row_count == 0
    }

    /// Forget what row `k`'s rays hit and mark them to be re-traced: the re-trace then finds
    /// their hits changed and rebuilds the row, as after a mover's passage.
    #[cfg(test)]
    pub(super) fn forget_hits(&mut self, k: usize) {
        self.hit[k * self.rays..(k + 1) * self.rays].fill(MISS);
        self.set_all_dirty(k);
    }

    fn set_all_dirty(&mut self, k: usize) {
        let w = &mut self.dirty[k * self.words..(k + 1) * self.words];
        w.fill(u64::MAX);
        if self.rays % 64 != 0 {
            w[self.words - 1] = u64::MAX >> (self.words * 64 - self.rays);
        }
        self.note_dirty_row(k, movers_first::UNKNOWN);
    }

    /// Row `k` has a dirty ray now, whose stored hit was right at frame `since`
    /// (`movers_first::UNKNOWN`: not known). A row already dirty keeps the earlier frame
    /// (frames only grow), unless the new one is unknown.
    fn note_dirty_row(&mut self, k: usize, since: u64) {
        let (w, bit) = (k / 64, 1u64 << (k % 64));
        if self.dirty_rows[w] & bit == 0 {
            self.dirty_rows[w] |= bit;
            self.dirty_row_count += 1;
            self.valid_at[k] = since;
        } else if since == movers_first::UNKNOWN {
            self.valid_at[k] = since;
        }
    }

    /// Row `k`'s rays are all clean now.
    fn clean_row(&mut self, k: usize) {
        self.dirty[k * self.words..(k + 1) * self.words].fill(0);
        let (w, bit) = (k / 64, 1u64 << (k % 64));
        if self.dirty_rows[w] & bit != 0 {
            self.dirty_rows[w] &= !bit;
            self.dirty_row_count -= 1;
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
}

/// A sphere holding patch `i` and its rays' origins (which are `eps` above it).
fn patch_sphere(world: &World, i: usize) -> (Vec3, f32) {
    let r = world.patches.radius(i);
    (world.patches.centre[i], r * (1.0 + 1e-5) + 2.0 * world.eps)
}

#[cfg(test)]
mod tests {
    use super::{wall_rays_for, WALL_MAX_RAYS};

    #[test]
    fn rays_a_patch_halve_only_on_boundaries_too_large_for_them() {
        // The 77k and 129k rooms keep what is asked; the 1M room's 850k patches get 32.
        assert_eq!(wall_rays_for(70_000, 64), 64);
        assert_eq!(wall_rays_for(WALL_MAX_RAYS / 64, 64), 64);
        assert_eq!(wall_rays_for(WALL_MAX_RAYS / 64 + 1, 64), 32);
        assert_eq!(wall_rays_for(850_000, 64), 32);
        // Never below 16, and never above what is asked.
        assert_eq!(wall_rays_for(100_000_000, 64), 16);
        assert_eq!(wall_rays_for(10, 8), 8);
        assert_eq!(wall_rays_for(10, 0), 1);
    }
}
