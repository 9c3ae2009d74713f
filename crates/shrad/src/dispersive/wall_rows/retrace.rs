//! Re-tracing the wall rows' dirty rays and rebuilding the rows from their hits (also how
//! the rows are built in the first place: every ray starts dirty).

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::Aabb;
use shrad_vis::Hit;

use super::{patch_sphere, WallRows, FRONT, MISS};
use crate::dispersive::setup::receives_as_boundary;
use crate::form_factors::{row_from_hits, some_patch_rays};
use crate::World;

/// A row rebuilt from its rays: entries, box, mask of objects hit.
type RebuiltRow = (Vec<(u32, f32)>, Aabb, u64);

/// What [`WallRows::store_hits`] found, per row re-traced.
struct Stored {
    /// The objects the row's new hits meet (bit `object % 64`).
    objects_hit: Vec<u64>,
    /// Whether some of the row's rays kept their stored hits (its `leaves` is kept too).
    kept: Vec<bool>,
    /// Each entry a ray left and met, in the rows' order.
    moved: Vec<EntryMoved>,
}

/// A ray of a row (`.0`, its index among the rows re-traced) that left entry `.1` for
/// entry `.2` (`None`: no entry, a ray that missed or met no boundary patch).
type EntryMoved = (usize, Option<usize>, Option<usize>);

/// Move one ray's `share` of `row` (sorted by patch) from entry `left` to entry `met`;
/// false (the row partly changed) when `row` holds no share for `left`.
fn amend_row(
    row: &mut Vec<(u32, f32)>,
    left: Option<usize>,
    met: Option<usize>,
    share: f32,
) -> bool {
    if let Some(left) = left {
        let Ok(at) = row.binary_search_by_key(&(left as u32), |e| e.0) else {
            return false;
        };
        row[at].1 -= share;
        if row[at].1 <= 0.0 {
            row.remove(at);
        }
    }
    if let Some(met) = met {
        match row.binary_search_by_key(&(met as u32), |e| e.0) {
            Ok(at) => row[at].1 += share,
            Err(at) => row.insert(at, (met as u32, share)),
        }
    }
    true
}

/// The mask of the objects `hits` met (bit `object % 64`).
pub(super) fn mask_of_objects_hit(world: &World, hits: &[u32]) -> u64 {
    let p = &world.patches;
    (hits.iter().filter(|&&h| h != MISS)).fold(0u64, |m, &h| {
        m | 1 << (p.object[(h & !FRONT) as usize] % 64)
    })
}

impl WallRows {
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
                (row, b, mask_of_objects_hit(world, hits))
            })
            .collect();
        self.rebuilt.extend_from_slice(ks);
        for (&k, (row, b, mask)) in ks.iter().zip(rebuilt) {
            self.rows.set_row(k, &row);
            self.bounds[k] = b;
            self.objects_hit[k] = mask;
        }
    }

    /// Rows `picked[c]` for `c` in `amended` (ascending), whose entries `moved` changed
    /// (`(c, left, met)` in the same order): each entry's share moved by one ray, so the same
    /// floats as a row rebuilt from its hits where a ray's share `1 / rays` is a power of two
    /// (every share a multiple of it, exactly; 1.6 us a row rebuilt, 159 rows in some of the
    /// 77k room's moving frames); rebuilt otherwise, or where a row does not hold an entry
    /// it should. The mask of objects hit is made exact again; the box was grown already.
    fn amend_rows(
        &mut self,
        world: &World,
        boundary: &[u32],
        (picked, amended): (&[usize], &[usize]),
        moved: &[EntryMoved],
    ) {
        let rays = self.rays;
        if !rays.is_power_of_two() {
            let ks: Vec<usize> = amended.iter().map(|&c| picked[c]).collect();
            return self.rebuild(world, boundary, &ks);
        }
        let share = 1.0 / rays as f32;
        let mut again = Vec::new();
        let mut next = 0;
        for &c in amended {
            let k = picked[c];
            let mut row = self.rows.row(k).to_vec();
            let start = next + moved[next..].partition_point(|m| m.0 < c);
            next = start + moved[start..].partition_point(|m| m.0 == c);
            let held = moved[start..next]
                .iter()
                .all(|&(_, left, met)| amend_row(&mut row, left, met, share));
            if !held {
                again.push(k);
                continue;
            }
            self.rows.set_row(k, &row);
            let hits = &self.hit[k * rays..(k + 1) * rays];
            self.objects_hit[k] = mask_of_objects_hit(world, hits);
            self.rebuilt.push(k);
        }
        self.rebuild(world, boundary, &again);
    }

    /// Rows with dirty rays from the cursor round, until about `budget` rays (at least one
    /// row's); the cursor moves past them. A pass over the rows' dirty bits, a word (64
    /// rows) at a time.
    fn pick_dirty_rows(&mut self, n: usize, budget: usize) -> Vec<usize> {
        let words = self.words;
        let mut picked: Vec<usize> = Vec::new();
        let mut count = 0;
        let start = self.cursor % n;
        // From `start` to the end, then from 0 to `start`: `(from, to)` ranges of rows.
        for (from, to) in [(start, n), (0, start)] {
            let mut k = from;
            while k < to {
                let word = self.dirty_rows[k / 64] >> (k % 64);
                if word == 0 {
                    k = (k / 64 + 1) * 64;
                    continue;
                }
                k += word.trailing_zeros() as usize;
                if k >= to {
                    break;
                }
                picked.push(k);
                count += self.dirty[k * words..(k + 1) * words]
                    .iter()
                    .map(|w| w.count_ones() as usize)
                    .sum::<usize>();
                if count >= budget {
                    self.cursor = (k + 1) % n;
                    return picked;
                }
                k += 1;
            }
        }
        if let Some(&last) = picked.last() {
            self.cursor = (last + 1) % n;
        }
        picked
    }

    /// Store the hits and ends of the re-traced rays `which` (`(c, j)`: ray `j` of row
    /// `picked[c]`; a hit `None` stands as it was): per row re-traced, the objects its new
    /// hits meet, whether some of its rays kept their stored hits, and each entry a ray
    /// left and met (`moved`, in the rows' order).
    /// Most re-traced rays hit what they hit before (a mover's box is a loose bound of what
    /// it blocks): only a row whose entries changed is amended, and a row whose ends moved
    /// only has its box grown (a box is a superset; rebuilding 900 rows of one changed ray
    /// each took 2-3 ms of the 77k room's frame after a drag). A ray that hits another patch
    /// of a mover (an interior object, which no row holds) changes no entry: its row only
    /// has the object's bit added to its mask.
    fn store_hits(
        &mut self,
        world: &World,
        (picked, which): (&[usize], &[(usize, usize)]),
        hits: &[Option<Hit>],
        ends: &[([u16; 3], bool)],
    ) -> Stored {
        let rays = self.rays;
        let mut stored = Stored {
            objects_hit: vec![0u64; picked.len()],
            kept: vec![false; picked.len()],
            moved: Vec::new(),
        };
        let entry = |h: u32| seen(world, h).filter(|&s| receives_as_boundary(world, s));
        for ((&(c, j), h), &(e, _)) in which.iter().zip(hits).zip(ends) {
            let Some(h) = h else {
                stored.kept[c] = true;
                continue;
            };
            let k = picked[c];
            let hit = if h.is_hit() {
                stored.objects_hit[c] |= 1 << (world.patches.object[h.id as usize] % 64);
                h.id | if h.front { FRONT } else { 0 }
            } else {
                MISS
            };
            let old = self.hit[k * rays + j];
            if old != hit && entry(old) != entry(hit) {
                stored.moved.push((c, entry(old), entry(hit)));
            }
            self.hit[k * rays + j] = hit;
            if self.end[k * rays + j] != e {
                self.end[k * rays + j] = e;
                self.bounds[k] = self.bounds[k].grow(self.decode(e));
            }
        }
        stored
    }

    /// Re-trace dirty rays, whole rows at a time from the cursor round, until about
    /// `budget` rays (at least one row's, at most `budget + rays`); rebuild those rows from
    /// their rays' hits. Returns the rays traced.
    pub(super) fn retrace(&mut self, world: &World, boundary: &[u32], budget: usize) -> usize {
        let (rays, words) = (self.rays, self.words);
        let n = boundary.len();
        // Nothing to do on most frames of a static scene: one pass over the bits.
        if n == 0 || self.dirty_row_count == 0 {
            return 0;
        }
        let picked = self.pick_dirty_rows(n, budget);
        if picked.is_empty() {
            return 0;
        }
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
        // `None`: the stored hit stands (`movers_first.rs`).
        let hits = self.trace_movers_first(world, (boundary, &picked), &which, (&o, &d));
        let ends: Vec<([u16; 3], bool)> = (0..which.len())
            .into_par_iter()
            .map(|r| {
                let Some(h) = &hits[r] else {
                    return ([0; 3], false);
                };
                let (o, d) = (o[r], d[r]);
                let exit = exit_distance(&self.space, o, d);
                let t = if h.is_hit() { h.t } else { f32::INFINITY };
                (self.encode(o + d * t.min(exit)), t > exit)
            })
            .collect();
        let Stored {
            objects_hit,
            kept,
            moved,
        } = self.store_hits(world, (&picked, &which), &hits, &ends);
        let mut leaving = vec![false; picked.len()];
        for (&(c, _), &(_, l)) in which.iter().zip(&ends) {
            leaving[c] |= l;
        }
        // Rebuild the rows traced for the first time, with their boxes and masks, and amend
        // those whose hits changed (or rebuild them: `amend_rows`).
        let mut hits_changed = vec![false; picked.len()];
        for &(c, _, _) in &moved {
            hits_changed[c] = true;
        }
        let (fresh, amended): (Vec<usize>, Vec<usize>) = (0..picked.len())
            .filter(|&c| hits_changed[c] || !self.built[picked[c]])
            .partition(|&c| !self.built[picked[c]]);
        let fresh: Vec<usize> = fresh.into_iter().map(|c| picked[c]).collect();
        self.rebuild(world, boundary, &fresh);
        self.amend_rows(world, boundary, (&picked, &amended), &moved);
        for (c, &k) in picked.iter().enumerate() {
            // A superset of the objects its rays hit (a rebuilt row's mask is exact).
            self.objects_hit[k] |= objects_hit[c];
            let (centre, _) = patch_sphere(world, boundary[k] as usize);
            // A segment once outside stays outside until the row is traced again whole.
            let all_traced = rows[c].1.len() == rays && !kept[c];
            self.leaves[k] =
                leaving[c] || !self.space.contains(centre) || (!all_traced && self.leaves[k]);
            self.clean_row(k);
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

/// Distance along `o + t d` to where it leaves `b` (0 when `o` is outside).
pub(super) fn exit_distance(b: &Aabb, o: Vec3, d: Vec3) -> f32 {
    if !b.contains(o) {
        return 0.0;
    }
    let inv = d.recip();
    let t0 = (b.min - o) * inv;
    let t1 = (b.max - o) * inv;
    t0.max(t1).min_element().max(0.0)
}
