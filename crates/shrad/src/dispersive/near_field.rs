//! The near field of an interior object's patches (beyond the paper; issue 22 item 1): the
//! light a patch receives from surfaces close to it, gathered from those surfaces' radiosity
//! instead of read from the probes.
//!
//! The 8 probes of paper 2.3.3 see the scene from the corners of the object's box. Where the
//! surroundings' light changes within a box size of the object, they see it in the wrong
//! place: a probe moved inward (`ProbeRepair::MoveInward`) above a floor sees the dark floor
//! under its own object, where the box's low side faces see the lit floor beside it (sides
//! 5-45 % too dark); corner probes beside a sphere see the lit floor, where the sphere's
//! underside sees its own shadow (+50 %). Per patch, `near_rays` rays (the transfer vectors'
//! directions, `setup::transfer_direction`) look for anything within `near_reach` of the
//! object's box diagonal; in those directions the probes' radiance is taken out of the
//! patch's lobe and the radiosity of the patch a ray meets is put in, one form factor of
//! `1 / near_rays` per ray (cosine-distributed rays):
//!
//! `E = L . (T - N) + sum_near (B_q - M_q) / near_rays`, `N = pi / near_rays sum_near Y(w_j)`.
//!
//! Of `B_q` the light the object itself sent `q` is taken in from its own near-field rows
//! read backwards, not from its Step 3 emitters (`Dispersive::near_echo`).
//!
//! A face resting on another surface meets it at once: its near field is the (dark) surface
//! under it, which is what contact openness approximated with black; the near field then
//! stands in for it. Like contact openness it is geometry: measured again when the object or
//! something within its reach moves (`stale.rs`); while the object moves with coarse
//! updates, a slice of its patches at each update (`Dispersive::near_field_follows`).
//!
//! In a scene open to the outside (some boundary rays meet nothing:
//! [`super::near_rays::is_open`]) a ray that meets nothing within the reach is traced on: if
//! it meets nothing at all it leaves the scene and sees exactly nothing (under a sky too,
//! whose light Step 1 gives every patch), and a patch with such a ray
//! takes its whole view from its rays, their hits beyond the reach included
//! (`near_rays::beyond_the_reach`). Taking only the leaving rays out was not enough: the probes'
//! band-limited radiance blurs the lit floor beside an opening into the opening's
//! directions and darkens the floor's own, and the two errors cancel in a patch's lobe only
//! while both are read from the probes (the Cornell short block's front, facing the open
//! side, went from +27 % to -22 % with the leaving rays alone, to +1.6 % with its whole view;
//! `interior_errors`, docs/results.md §14). The ends of those rays are kept: a mover that
//! crosses one makes its patch stale, as one within the reach does.

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::{Aabb, Role};
use shrad_sh::{eval_basis, num_coeffs};
use shrad_vis::Hit;

use super::caches::{SEES_BACK, SEES_NOTHING};
use super::near_rays::{near_hits, near_objects_beyond_the_reach};
use super::setup::transfer_direction;
use super::{Dispersive, DispersiveOptions};
use crate::sparse::SparseRows;
use crate::World;

/// The near-field rays a coarse update of a moving object measures again
/// ([`Dispersive::near_field_follows`]): a fifth of the 77k room's moving frame's other rays.
/// `scenes/moving_box.toml` lifted: the same error as 8192 (interior 1.3-1.4 % at the end),
/// 1.8-1.9 % with 2048.
const NEAR_RAYS_WHILE_MOVING: usize = 4096;

/// One patch's near field while it is measured: its lobe, its row and its far rays' ends.
type PatchNear = (Vec<f32>, Vec<(u32, f32)>, Vec<Vec3>);

/// One object's near field (empty when `near_rays` is 0).
#[derive(Default)]
pub(super) struct NearField {
    /// Per patch, `nc` floats: `pi / near_rays` times the SH basis summed over the rays that
    /// meet something within reach, in the probes' frame (the object's with transfer
    /// vectors, else the world's).
    pub(super) lobe: Vec<f32>,
    /// Per patch: (the patch met within reach, as its index in `seen`; its form factor).
    pub(super) view: SparseRows<(u32, f32)>,
    /// The patches the view meets, ascending, once each.
    seen: Vec<u32>,
    /// `seen` as bits over every patch of the scene.
    seen_bits: Vec<u64>,
    /// Per patch: where its rays taken beyond the reach end (the whole view of a patch that
    /// sees the void, and the rays that leave the scene), for the stale test
    /// ([`NearField::far_stale`]).
    far: SparseRows<Vec3>,
}

impl NearField {
    /// Each patch's row with the patches it sees as scene indices (as measured).
    #[cfg(test)]
    pub(super) fn measured_rows(&self) -> Vec<Vec<(u32, f32)>> {
        (self.view.rows())
            .map(|row| {
                row.iter()
                    .map(|&(q, f)| (self.seen[q as usize], f))
                    .collect()
            })
            .collect()
    }

    /// Replace the lobes and rows of patches `offsets` (ascending) by `fresh`'s (one each,
    /// in that order, as measured: scene indices), and renumber the view. The patches still
    /// seen are those the kept rows see (marked in one pass over them) and the fresh rows'
    /// (sorted, a few): rebuilding the whole view as rows of scene indices and sorting every
    /// entry again ([`NearField::index_seen`]) was half of a moving object's near field at
    /// each coarse update (the 77k room's largest object: 4.5k rows, ~0.3 ms a frame for a
    /// slice of 64 patches measured again).
    fn replace(&mut self, offsets: &[u32], fresh: &NearField, nc: usize, scene_patches: usize) {
        debug_assert!(offsets.is_sorted() && offsets.len() == fresh.view.len());
        let is_fresh = |k: usize| offsets.binary_search(&(k as u32)).ok();
        let mut used = vec![false; self.seen.len()];
        for (k, row) in self.view.rows().enumerate() {
            if is_fresh(k).is_none() {
                row.iter().for_each(|&(h, _)| used[h as usize] = true);
            }
        }
        let mut added: Vec<u32> = fresh.view.rows().flatten().map(|e| e.0).collect();
        let kept = self.seen.iter().zip(&used).filter(|(_, &u)| u);
        added.extend(kept.map(|(&q, _)| q));
        added.sort_unstable();
        added.dedup();
        let seen = added;
        let index = |q: u32| seen.partition_point(|&s| s < q) as u32;
        let renumber: Vec<u32> = (self.seen.iter().zip(&used))
            .map(|(&q, &u)| if u { index(q) } else { u32::MAX })
            .collect();
        let (mut view, mut far) = (SparseRows::default(), SparseRows::default());
        for k in 0..self.view.len() {
            match is_fresh(k) {
                Some(n) => {
                    view.push_row(fresh.view.row(n).iter().map(|&(q, f)| (index(q), f)));
                    far.push_row(fresh.far.row(n).iter().copied());
                    let lobe = &fresh.lobe[n * nc..(n + 1) * nc];
                    self.lobe[k * nc..(k + 1) * nc].copy_from_slice(lobe);
                }
                None => {
                    let row = self.view.row(k).iter();
                    view.push_row(row.map(|&(h, f)| (renumber[h as usize], f)));
                    far.push_row(self.far.row(k).iter().copied());
                }
            }
        }
        (self.view, self.far) = (view, far);
        self.set_seen(seen, scene_patches);
    }

    /// The patches (offsets in the object's range `range`) one of whose rays beyond the
    /// reach `meets` (a segment from the patch's centre to the ray's end) a mover's box.
    pub(super) fn far_stale(
        &self,
        world: &World,
        range: std::ops::Range<usize>,
        meets: impl Fn(Vec3, Vec3) -> bool + Sync,
    ) -> Vec<u32> {
        let p = &world.patches;
        (0..self.far.len().min(range.len()))
            .into_par_iter()
            .filter(|&k| {
                let c = p.centre[range.start + k];
                self.far.row(k).iter().any(|&end| meets(c, end - c))
            })
            .map(|k| k as u32)
            .collect()
    }

    /// Renumber the view's patches (scene indices as measured) to indices into `seen`, and
    /// mark them in `seen_bits`: an update's echo ([`Dispersive::near_echo`]) is then a bit
    /// test per piece the object sent and a value per patch seen, instead of a vector over
    /// every patch of the scene (0.2 ms of the 77k room's moving frame, 0.4 at 129k, alone
    /// on one thread).
    fn index_seen(&mut self, patches: usize) {
        let mut seen: Vec<u32> = self.view.rows().flatten().map(|e| e.0).collect();
        seen.sort_unstable();
        seen.dedup();
        let index = |q: u32| seen.partition_point(|&s| s < q) as u32;
        let rows = self
            .view
            .rows()
            .map(|row| row.iter().map(|&(q, f)| (index(q), f)).collect::<Vec<_>>());
        self.view = SparseRows::from_rows(rows);
        self.set_seen(seen, patches);
    }

    /// The patches the view meets (`seen`, ascending), and their bits over the scene's
    /// `patches`.
    fn set_seen(&mut self, seen: Vec<u32>, patches: usize) {
        self.seen_bits = vec![0; patches.div_ceil(64)];
        for &q in &seen {
            self.seen_bits[q as usize / 64] |= 1 << (q % 64);
        }
        self.seen = seen;
    }

    /// The index in `seen` of patch `q`, if the view meets it.
    fn seen_index(&self, q: u32) -> Option<usize> {
        let word = self.seen_bits.get(q as usize / 64)?;
        (word >> (q % 64) & 1 == 1).then(|| self.seen.partition_point(|&s| s < q))
    }
}

/// How far the near field (or, without it, contact openness) of object `o` with probe box
/// `probe_box` looks, in world units: a fraction of the box's diagonal.
pub(super) fn near_reach(
    options: &DispersiveOptions,
    world: &World,
    o: usize,
    probe_box: &Aabb,
) -> f32 {
    let m = world.patches.world_from_local[o];
    let fraction = if options.near_rays > 0 {
        options.near_reach.max(CONTACT_REACH)
    } else {
        CONTACT_REACH
    };
    fraction * m.transform_vector3(probe_box.size()).length()
}

/// Contact openness's reach, as a fraction of the box diagonal.
pub(super) const CONTACT_REACH: f32 = 0.02;

/// Patches whose near-field rays are traced at once (64 rays each, traced from two origins:
/// about 30 MB of rays and hits).
const NEAR_CHUNK: usize = 4096;

/// Patches whose near field is measured at once under a frame's deadline: as many as the
/// time left takes at the last measured cost a patch, within these (512 patches of the 77k
/// room's sphere take 6-8 ms on two cores, too much of a 10 ms budget).
const NEAR_CHUNK_WITHIN: std::ops::RangeInclusive<usize> = 64..=512;

impl Dispersive {
    /// The near field of object `k` (see the module docs), measured on from `progress`
    /// (what is measured, and the first patch not yet measured) a chunk of patches at a
    /// time, until it is whole (true) or `deadline` has passed with patches left (false:
    /// `progress` says where to go on). At least one chunk is measured, so the measure
    /// always ends.
    ///
    /// Under a budget a chunk is what fits the time left ([`NEAR_CHUNK_WITHIN`]): the frame
    /// after the 77k room's 4,512-patch sphere came to rest spent 58 ms on its near field in
    /// one go.
    pub(super) fn near_field_within(
        &self,
        world: &World,
        k: usize,
        progress: &mut (NearField, usize),
        deadline: Option<std::time::Instant>,
    ) -> bool {
        let rays = self.options.near_rays as usize;
        if rays == 0 {
            *progress = Default::default();
            return true;
        }
        let p = &world.patches;
        let ob = &self.objects[k];
        let o = ob.object;
        let m = p.world_from_local[o];
        let reach = near_reach(&self.options, world, o, &ob.probe_box);
        let contact = CONTACT_REACH * m.transform_vector3(ob.probe_box.size()).length();
        let range = p.range(o);
        // A chunk of patches at a time: the 1M-patch room's 43k-patch object casts 2.8M
        // rays, whose arrays took its peak memory over 1.5 GiB in one batch.
        let chunk = |now: std::time::Instant| match deadline {
            None => NEAR_CHUNK,
            Some(d) => {
                let left_ms = d.saturating_duration_since(now).as_secs_f64() * 1e3;
                let fits = left_ms / self.near_ms_per_patch.max(1e-6);
                (fits as usize).clamp(*NEAR_CHUNK_WITHIN.start(), *NEAR_CHUNK_WITHIN.end())
            }
        };
        let (near, next) = progress;
        let from = *next;
        let mut lo = from;
        while lo < range.len() {
            let now = std::time::Instant::now();
            if lo > from && deadline.is_some_and(|d| now >= d) {
                *next = lo;
                return false;
            }
            let patches = lo..(lo + chunk(now)).min(range.len());
            lo = patches.end;
            self.near_field_of(world, k, patches, (reach, contact), near);
        }
        *next = range.len();
        near.index_seen(p.len());
        true
    }

    /// Object `k`'s near field measured again at its stale patches alone
    /// (`ObjectProbes::near_stale`), a run of consecutive patches at a time: the rest was
    /// measured where everything within its reach still is. With `at_most`, that many of
    /// them, in turn from where the last such slice ended (`near_cursor`); the others stay
    /// stale.
    pub(super) fn near_field_again(&mut self, world: &World, k: usize, at_most: Option<usize>) {
        let stale = self.objects[k].take_stale_slice(at_most);
        let ob = &self.objects[k];
        let o = ob.object;
        let m = world.patches.world_from_local[o];
        let reach = near_reach(&self.options, world, o, &ob.probe_box);
        let contact = CONTACT_REACH * m.transform_vector3(ob.probe_box.size()).length();
        let mut fresh = NearField::default();
        let mut at = 0;
        while at < stale.len() {
            let mut end = at + 1;
            while end < stale.len() && stale[end] == stale[end - 1] + 1 {
                end += 1;
            }
            let run = stale[at] as usize..stale[end - 1] as usize + 1;
            self.near_field_of(world, k, run, (reach, contact), &mut fresh);
            at = end;
        }
        let nc = num_coeffs(self.options.bands);
        let patches = world.patches.len();
        self.objects[k].near.replace(&stale, &fresh, nc, patches);
    }

    /// While object `k` moves under coarse updates (`coarse_while_moving`), the near field
    /// measured where it last rested stands in for one measured where it is (measuring it
    /// whole at every update would cost the 77k room's largest object 289k rays a frame).
    /// Measured where it rested, a box lifted off the floor went on reading the floor under
    /// it at distance 0, and a box slid across it the floor where it stood, lit once it
    /// left (`scenes/moving_box.toml`: interior error 20 % lifted, 9-10 % slid, while it
    /// moved). So at each of its updates a slice of its patches is measured again, in turn
    /// ([`NEAR_RAYS_WHILE_MOVING`] rays), and the stand-in follows it: 1.3 % and 2.3 %
    /// (docs/results.md §14).
    /// Part of the update, so that its cost is the update's (the scheduler's and a budget's
    /// prediction), not a preparation's that could defer it.
    pub(super) fn near_field_follows(&mut self, world: &World, k: usize) {
        let rays = self.options.near_rays as usize;
        let ob = &mut self.objects[k];
        let coarse_mover = ob.moving && self.options.coarse_while_moving;
        if !coarse_mover || rays == 0 || ob.near.lobe.is_empty() {
            return;
        }
        let n = world.patches.range(ob.object).len();
        let slice = (NEAR_RAYS_WHILE_MOVING / rays).clamp(1, n);
        let start = ob.near_cursor % n;
        ob.near_cursor = (start + slice) % n;
        (ob.near_stale).extend((start..start + slice).map(|i| (i % n) as u32));
        ob.near_stale.sort_unstable();
        ob.near_stale.dedup();
        self.near_field_again(world, k, None);
    }

    /// The interior objects whose boxes come within object `k`'s near reach of its box, where
    /// they are now (`see_through_near`; none without a near field): its probes see through
    /// them, and its near field's rays take them at any distance
    /// ([`near_objects_beyond_the_reach`]), so that they come from the near field alone, not
    /// also, shifted by parallax, from the probes at its box's corners (a ball beside a
    /// block: the block's face towards it was 8 % too dark, docs/results.md §14).
    pub(super) fn near_objects(&self, world: &World, k: usize) -> Vec<u32> {
        if !self.options.see_through_near || self.options.near_rays == 0 {
            return Vec::new();
        }
        let ob = &self.objects[k];
        let reach = near_reach(&self.options, world, ob.object, &ob.probe_box);
        let within = self.object_boxes[ob.object].padded(Vec3::splat(reach));
        (self.objects.iter())
            .map(|other| other.object)
            .filter(|&q| q != ob.object && self.object_boxes[q].meets_box(&within))
            .map(|q| q as u32)
            .collect()
    }

    /// [`Dispersive::near_field_within`] of object `k`'s `patches` (offsets in its range),
    /// appended to `near`.
    fn near_field_of(
        &self,
        world: &World,
        k: usize,
        patches: std::ops::Range<usize>,
        (reach, contact): (f32, f32),
        near: &mut NearField,
    ) {
        let rays = self.options.near_rays as usize;
        let p = &world.patches;
        let ob = &self.objects[k];
        let o = ob.object;
        let start = p.range(o).start + patches.start;
        let absolute = start..start + patches.len();
        let (dirs, local) = self.near_directions(world, o, absolute.clone());
        let hits = near_hits(
            world,
            o,
            absolute,
            &dirs,
            (reach, contact),
            &ob.shape_box,
            self.open,
        );
        let mut hits = hits;
        let near_objects = self.near_objects(world, k);
        near_objects_beyond_the_reach(world, o, &dirs, reach, &near_objects, &mut hits);
        let blocked = self.self_blocked(world, k, patches.clone(), &dirs);
        let with_transfer = !ob.transfer.is_empty();
        let bands = self.options.bands;
        let nc = num_coeffs(bands);
        let per_patch: Vec<PatchNear> = (0..patches.len())
            .into_par_iter()
            .map(|k| {
                let mut lobe = vec![0f32; nc];
                let mut row: Vec<(u32, f32)> = Vec::new();
                let mut far: Vec<Vec3> = Vec::new();
                let mut basis = [0f32; 64];
                for j in k * rays..(k + 1) * rays {
                    let h = &hits.hit[j];
                    // A ray beyond the reach, kept for the stale test (`beyond_the_reach`).
                    if let Some(end) = hits.end[j].filter(|_| !blocked[j]) {
                        far.push(end);
                    }
                    // One that leaves the scene sees nothing: the probes' radiance is taken
                    // out of the lobe there, and nothing put in.
                    let escapes = hits.escapes[j] && !blocked[j];
                    let within = h.t <= reach + 2.0 * world.eps || hits.whole[j];
                    if !escapes && (!h.is_hit() || !within || blocked[j]) {
                        continue;
                    }
                    let d = if with_transfer { local[j] } else { dirs[j] };
                    eval_basis(bands, d, &mut basis[..nc]);
                    for (a, b) in lobe.iter_mut().zip(&basis[..nc]) {
                        *a += std::f32::consts::PI / rays as f32 * b;
                    }
                    // A surface in contact (within contact openness's reach, under the
                    // object: `near_hits`) sends nothing, as contact openness has it: a face
                    // resting on a floor sees the floor patch it stands on, lit where it
                    // reaches beyond the face. A back face (the outside of the enclosure, the
                    // inside of a closed object) neither.
                    if escapes {
                        continue;
                    }
                    let q = self.seen_code(world, h, o as u32);
                    if q == SEES_NOTHING || q == SEES_BACK || hits.contact[j] {
                        continue;
                    }
                    match row.iter_mut().find(|e| e.0 == q) {
                        Some(e) => e.1 += 1.0 / rays as f32,
                        None => row.push((q, 1.0 / rays as f32)),
                    }
                }
                (lobe, row, far)
            })
            .collect();
        for (lobe, row, far) in per_patch {
            near.lobe.extend(lobe);
            near.view.push_row(row);
            near.far.push_row(far);
        }
    }

    /// The near-field ray directions of object `o`'s `patches` (absolute indices), in the
    /// world and in the object's frame: the transfer vectors' directions.
    fn near_directions(
        &self,
        world: &World,
        o: usize,
        patches: std::ops::Range<usize>,
    ) -> (Vec<Vec3>, Vec<Vec3>) {
        let rays = self.options.near_rays as usize;
        let p = &world.patches;
        let m = p.world_from_local[o];
        let count = patches.len() * rays;
        let (mut dirs, mut local) = (vec![Vec3::ZERO; count], vec![Vec3::ZERO; count]);
        dirs.par_chunks_mut(rays)
            .zip(local.par_chunks_mut(rays))
            .zip(patches)
            .for_each(|((dir, loc), i)| {
                for j in 0..rays {
                    loc[j] = transfer_direction(p, i, j, rays);
                    dir[j] = m.transform_vector3(loc[j]).normalize_or_zero();
                }
            });
        (dirs, local)
    }

    /// Per ray of [`Dispersive::near_field_within`], whether the object itself blocks it (the
    /// transfer vector has taken that direction out already, and the self form factors put
    /// the object's own light in): traced only from patches that see their own object.
    fn self_blocked(
        &self,
        world: &World,
        k: usize,
        patches: std::ops::Range<usize>,
        dirs: &[Vec3],
    ) -> Vec<bool> {
        let ob = &self.objects[k];
        let mut blocked = vec![false; dirs.len()];
        if ob.transfer.is_empty() {
            return blocked;
        }
        let p = &world.patches;
        let range = p.range(ob.object);
        let rays = self.options.near_rays as usize;
        let concave: Vec<usize> = patches
            .clone()
            .filter(|&k| !ob.self_view(k).is_empty())
            .map(|k| k - patches.start)
            .collect();
        if concave.is_empty() {
            return blocked;
        }
        let others: Vec<u32> = (0..p.object_role.len() as u32)
            .filter(|&x| x as usize != ob.object)
            .collect();
        let (mut origins, mut d) = (Vec::new(), Vec::new());
        for &k in &concave {
            let i = range.start + patches.start + k;
            for j in 0..rays {
                origins.push(p.centre[i] + p.normal[i] * world.eps);
                d.push(dirs[k * rays + j]);
            }
        }
        let mut hits = vec![Hit::MISS; origins.len()];
        world.vis.closest(&origins, &d, 0.0, &others, &mut hits);
        for (&k, h) in concave.iter().zip(hits.chunks(rays)) {
            for (j, h) in h.iter().enumerate() {
                blocked[k * rays + j] = h.is_hit();
            }
        }
        blocked
    }

    /// The radiosity object `k` itself put on the boundary patches its near field meets
    /// (its Step 3 light, reflected), less what its own patches send them through the near
    /// field's rows: taken out of what the near field gathers. Close to the floor, Step 3's
    /// emitter and the near field otherwise make a loop in which a sphere's underside lights
    /// the floor under it and is lit back (measured: undersides 4-5x too bright among 128
    /// objects); the rows read backwards carry that light where it goes, with form factors
    /// whose loop gain is below 1 (`ρ_p ρ_q Σ F_pq F_qp`).
    ///
    /// One value per patch the near field sees (`NearField::seen`), summed over the
    /// contribution's entries, which `resend.rs` may list more than once per patch: a hash
    /// set of the near field's hits and a map per update took 10 ms an update in the 1M room,
    /// a dense vector over every patch 0.2-0.4 ms in the 77k-129k rooms.
    pub(super) fn near_echo(&self, world: &World, k: usize) -> Vec<Vec3> {
        let ob = &self.objects[k];
        if ob.near.lobe.is_empty() {
            return Vec::new();
        }
        let mut echo = vec![Vec3::ZERO; ob.near.seen.len()];
        for &(q, e) in &ob.to_boundary {
            if let Some(h) = ob.near.seen_index(q) {
                echo[h] += world.reflectance[q as usize] * e;
            }
        }
        // What the object's own patches within reach send each boundary patch they see, by
        // their near-field rows read backwards (reciprocity: `A_q F_qp = A_p F_pq`), goes
        // back in: the light that goes from a sphere's underside to the floor under it and
        // back, which Step 3's emitters put in the wrong place at that range (undersides
        // 22 % too dark without it, docs/results.md §14).
        let p = &world.patches;
        let mut back = vec![Vec3::ZERO; ob.near.seen.len()];
        for (kp, i) in p.range(ob.object).enumerate() {
            let sent = (self.radiosity[i] - world.exitance[i]) * p.area[i];
            for &(h, f) in ob.near.view.row(kp) {
                back[h as usize] += sent * f;
            }
        }
        for ((e, b), &q) in echo.iter_mut().zip(back).zip(&ob.near.seen) {
            let q = q as usize;
            // Another object's light is its own probes' and near field's, not this echo.
            if p.role(q) != Role::Interior {
                *e -= world.reflectance[q] * b / p.area[q].max(f32::MIN_POSITIVE);
            }
        }
        echo
    }

    /// The light each patch object `k`'s near field sees sends it (one value per patch
    /// seen, by its index in `seen`): the radiosity the probes would carry
    /// (`texel_radiance`, times pi), less the object's own echo (`near_echo`), at least 0.
    /// Found once per patch seen, not once per near-field entry that sees it (a floor patch
    /// under a ball is seen by many of its patches).
    pub(super) fn near_seen_light(&self, world: &World, k: usize) -> Vec<Vec3> {
        let echo = self.near_echo(world, k);
        let seen = &self.objects[k].near.seen;
        (seen.par_iter().zip(echo))
            .map(|(&q, echo)| {
                let b = self.texel_radiance(world, q as usize) * std::f32::consts::PI;
                (b - echo).max(Vec3::ZERO)
            })
            .collect()
    }

    /// The light object `k`'s patch `k_patch` (offset in its range) gathers from its near
    /// field, from what each patch seen sends (`near_seen_light`).
    pub(super) fn near_light(&self, k: usize, k_patch: usize, seen_light: &[Vec3]) -> Vec3 {
        let near = &self.objects[k].near;
        (near.view.row(k_patch).iter())
            .map(|&(h, f)| seen_light[h as usize] * f)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dispersive::tests::cornell;

    #[test]
    fn a_near_field_measured_over_several_deadlines_equals_one_measured_whole() {
        let world = cornell(12_000);
        let d = Dispersive::new(&world, DispersiveOptions::improved()).unwrap();
        let patches = |k: usize| world.patches.range(d.objects[k].object).len();
        let k = (0..d.objects.len()).max_by_key(|&k| patches(k)).unwrap();
        let mut whole = Default::default();
        assert!(d.near_field_within(&world, k, &mut whole, None));
        let whole = whole.0;
        // A deadline already passed: one chunk a frame, each going on where the last stopped.
        let passed = Some(std::time::Instant::now());
        let (mut pieces, mut frames) = (Default::default(), 1);
        while !d.near_field_within(&world, k, &mut pieces, passed) {
            frames += 1;
        }
        let pieces = pieces.0;
        assert!(frames > 1, "{} patches: one chunk", patches(k));
        assert_eq!(frames, patches(k).div_ceil(*NEAR_CHUNK_WITHIN.start()));
        assert!(!whole.lobe.is_empty() && whole.view.entries() > 0);
        assert_eq!(pieces.lobe, whole.lobe);
        assert_eq!(pieces.view, whole.view);
        assert_eq!(pieces.seen, whole.seen);
    }

    #[test]
    fn replacing_some_rows_renumbers_the_view_as_indexing_it_whole_does() {
        let rows = [
            vec![(70, 0.25), (3, 0.5)],
            vec![(129, 0.125), (70, 0.0625)],
            vec![],
            vec![(5, 0.5)],
        ];
        let far = [vec![Vec3::X], vec![], vec![Vec3::Y], vec![]];
        let mut near = NearField {
            lobe: (0..8).map(|i| i as f32).collect(),
            view: SparseRows::from_rows(rows.clone()),
            far: SparseRows::from_rows(far.clone()),
            ..Default::default()
        };
        near.index_seen(200);
        // Rows 1 and 3 measured again: 129 and 5 are seen no more, 64 is, 3 again.
        let fresh_rows = [vec![(64, 0.5), (3, 0.25)], vec![]];
        let fresh_far = [vec![Vec3::Z], vec![Vec3::ONE]];
        let fresh = NearField {
            lobe: vec![10.0, 11.0, 12.0, 13.0],
            view: SparseRows::from_rows(fresh_rows.clone()),
            far: SparseRows::from_rows(fresh_far.clone()),
            ..Default::default()
        };
        near.replace(&[1, 3], &fresh, 2, 200);
        let [r0, _, r2, _] = rows;
        let [f0, f1] = fresh_rows;
        let [e0, _, e2, _] = far;
        let [g0, g1] = fresh_far;
        let mut whole = NearField {
            lobe: vec![0.0, 1.0, 10.0, 11.0, 4.0, 5.0, 12.0, 13.0],
            view: SparseRows::from_rows([r0, f0, r2, f1]),
            far: SparseRows::from_rows([e0, g0, e2, g1]),
            ..Default::default()
        };
        whole.index_seen(200);
        assert_eq!(near.seen, [3, 64, 70]);
        assert_eq!(near.seen, whole.seen);
        assert_eq!(near.view, whole.view);
        assert_eq!(near.far, whole.far);
        assert_eq!(near.lobe, whole.lobe);
        assert_eq!(near.seen_bits, whole.seen_bits);
        assert_eq!(near.seen_index(129), None);
        assert_eq!(near.seen_index(64), Some(1));
    }

    #[test]
    fn the_view_numbers_each_patch_it_sees_once_and_finds_it_by_its_bit() {
        // Three rows that meet patches 70, 3 and 70 again, 129 (a second bit word and a
        // third), and nothing.
        let mut near = NearField {
            view: SparseRows::from_rows([
                vec![(70, 0.25), (3, 0.5)],
                vec![(129, 0.125), (70, 0.0625)],
                vec![],
            ]),
            ..Default::default()
        };
        near.index_seen(200);
        assert_eq!(near.seen, [3, 70, 129]);
        // Each entry, read back through `seen`, is the patch it was measured with.
        let read: Vec<Vec<(u32, f32)>> = (near.view.rows())
            .map(|row| {
                row.iter()
                    .map(|&(h, f)| (near.seen[h as usize], f))
                    .collect()
            })
            .collect();
        assert_eq!(
            read,
            [
                vec![(70, 0.25), (3, 0.5)],
                vec![(129, 0.125), (70, 0.0625)],
                vec![]
            ]
        );
        assert_eq!(near.seen_index(3), Some(0));
        assert_eq!(near.seen_index(70), Some(1));
        assert_eq!(near.seen_index(129), Some(2));
        // Patches it does not see, in a word with a seen one, and beyond the scene.
        assert_eq!(near.seen_index(71), None);
        assert_eq!(near.seen_index(4), None);
        assert_eq!(near.seen_index(1_000), None);
    }
}
