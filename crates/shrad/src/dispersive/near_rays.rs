//! The near field's rays (`near_field.rs`): where each patch's rays meet something within
//! the reach, from its centre or a point spread over it, and, in a scene open to the outside,
//! where they meet something beyond it or leave the scene.

use glam::Vec3;
use rayon::prelude::*;
use shrad_scene::{Aabb, Role};
use shrad_vis::Hit;

use crate::World;

/// Stratified points over patch `i`, one per near-field ray, paired with the ray directions
/// by a permutation of the patch's own (a fixed pairing correlates them), as the reference's
/// form-factor rays are (`form_factors::some_patch_rays`).
fn spread_over_patch(p: &crate::Patches, i: usize, out: &mut [Vec3]) {
    use crate::sampling::{hammersley, hash, shuffled, unit};
    let rays = out.len();
    let seed = hash(i as u32 ^ 0x6e65_6172);
    let shift = (unit(seed), unit(hash(seed)));
    let perm = shuffled(rays, seed);
    for (o, &j) in out.iter_mut().zip(&perm) {
        let (u, v) = hammersley(j, rays as u32, shift);
        *o = p.sample_point(i, u, v);
    }
}

/// The near-field rays' hits, with whether each is in contact (met at once under the object).
pub(super) struct NearHits {
    pub(super) hit: Vec<Hit>,
    pub(super) contact: Vec<bool>,
    /// Met nothing within the reach, nor beyond: the ray leaves the scene (only looked for
    /// in a scene open to the outside, [`is_open`]).
    pub(super) escapes: Vec<bool>,
    /// Its hit counts although beyond the reach: a ray of a patch that sees the void, or one
    /// that met a near object first (`see_through_near`).
    pub(super) whole: Vec<bool>,
    /// Where each ray starts (the patch's centre or a point spread over it, as taken).
    pub(super) origin: Vec<Vec3>,
    /// Where a ray that met nothing within the reach ends (its hit beyond, or far outside
    /// the scene), in a scene open to the outside or with near objects seen through.
    pub(super) end: Vec<Option<Vec3>>,
}

/// How far a ray that leaves the scene is followed: beyond everything in it.
fn escape_length(world: &World) -> f32 {
    4.0 * world
        .scene
        .bounds()
        .map_or(1.0, |b| b.diagonal())
        .max(world.eps)
}

/// In a scene open to the outside, the rays of `out` that met nothing within the reach traced
/// on to whatever they meet (`exclude`d objects transparent): those that meet nothing leave
/// the scene. A patch one of whose rays leaves the scene takes its whole view from its rays
/// (their hits beyond the reach count, `whole`); every such ray's end is kept (`end`), so
/// that a mover crossing it (which may block it, or open another patch's view of the void)
/// makes the patch stale.
fn beyond_the_reach(
    world: &World,
    dirs: &[Vec3],
    rays: usize,
    exclude: &[u32],
    out: &mut NearHits,
) {
    let rays = rays.max(1);
    let open: Vec<usize> = (0..dirs.len()).filter(|&j| !out.hit[j].is_hit()).collect();
    let from: Vec<Vec3> = open.iter().map(|&j| out.origin[j]).collect();
    let towards: Vec<Vec3> = open.iter().map(|&j| dirs[j]).collect();
    let mut beyond = vec![Hit::MISS; open.len()];
    world
        .vis
        .closest(&from, &towards, 0.0, exclude, &mut beyond);
    let escape = escape_length(world);
    let mut seeing = vec![false; dirs.len().div_ceil(rays)];
    for (&j, h) in open.iter().zip(&beyond) {
        out.escapes[j] = !h.is_hit();
        seeing[j / rays] |= !h.is_hit();
        let t = if h.is_hit() { h.t } else { escape };
        out.end[j] = Some(out.origin[j] + dirs[j] * t);
    }
    for (&j, h) in open.iter().zip(beyond) {
        if seeing[j / rays] && h.is_hit() {
            out.hit[j] = h;
            out.whole[j] = true;
        }
    }
}

/// The rays of `out` (object `o`'s, directions `dirs`) that met nothing within the reach
/// traced on to what they meet first (`o` transparent): where that is one of the `near`
/// objects (`Dispersive::near_objects`, which its probes see through), the hit counts as if
/// within the reach (`whole`). Every such ray's end is kept (its hit, or far outside the
/// scene), so that a mover crossing it makes its patch stale, as a void's rays are
/// (`NearField::far_stale`).
pub(super) fn near_objects_beyond_the_reach(
    world: &World,
    o: usize,
    dirs: &[Vec3],
    reach: f32,
    near: &[u32],
    out: &mut NearHits,
) {
    if near.is_empty() {
        return;
    }
    let within = |h: &Hit| h.is_hit() && h.t <= reach + 2.0 * world.eps;
    let open: Vec<usize> = (0..dirs.len())
        .filter(|&j| !within(&out.hit[j]) && !out.whole[j] && !out.escapes[j])
        .collect();
    let from: Vec<Vec3> = open.iter().map(|&j| out.origin[j]).collect();
    let towards: Vec<Vec3> = open.iter().map(|&j| dirs[j]).collect();
    let mut first = vec![Hit::MISS; open.len()];
    (world.vis).closest(&from, &towards, 0.0, &[o as u32], &mut first);
    let escape = escape_length(world);
    for (&j, h) in open.iter().zip(first) {
        let t = if h.is_hit() { h.t } else { escape };
        out.end[j] = Some(out.origin[j] + dirs[j] * t);
        let object = world.seen_patch(&h).map(|q| world.patches.object[q]);
        if object.is_some_and(|q| near.contains(&q)) {
            out.hit[j] = h;
            out.whole[j] = true;
        }
    }
}

/// Whether `world` is open to the outside: some of 4,096 rays from its boundary patches
/// (cosine-distributed over their fronts, the samples hashes of their indices) meet nothing.
/// A near-field ray that leaves such a scene sees exactly nothing, where the probes'
/// band-limited radiance in its direction carries the light beside the opening (the Cornell
/// box's short block, whose front faces the open side, was 27 % too bright). Under a sky
/// too: its light reaches every patch through Step 1 (`lights/cache.rs`, with its shadow
/// rays), and a probe texel that sees it reads nothing (`Dispersive::shade_probe_texel`), so
/// what a ray that leaves sees is nothing there as well (taken from the probes, the
/// courtyard's interior faces were 1-5 % too dark and the Cornell box's front under a sky
/// 2.8 % too bright; `tests_near.rs`). The test is geometry alone: a sky that comes or goes
/// changes no near field.
pub(super) fn is_open(world: &World) -> bool {
    use crate::sampling::{hash2, square_to_cosine_hemisphere, unit};
    let p = &world.patches;
    let boundary: Vec<usize> = (0..p.len())
        .filter(|&i| p.role(i) == Role::Boundary)
        .collect();
    if boundary.is_empty() {
        return false;
    }
    let n = 4096u32;
    let (mut from, mut dirs) = (Vec::new(), Vec::new());
    for k in 0..n {
        let i = boundary[hash2(k, 0x766f_6964) as usize % boundary.len()];
        let (u, v) = (unit(hash2(k, 1)), unit(hash2(k, 2)));
        from.push(p.centre[i] + p.normal[i] * world.eps);
        dirs.push(square_to_cosine_hemisphere(u, v, p.normal[i]));
    }
    let mut hits = vec![Hit::MISS; from.len()];
    world.vis.closest(&from, &dirs, 0.0, &[], &mut hits);
    hits.iter().any(|h| !h.is_hit())
}

/// The hits of the near-field rays `dirs` of `patches` (object `o`'s, `near_rays` each).
///
/// Each ray is traced twice: from the patch centre and from a point spread over the patch
/// (`spread_over_patch`). Where either meets a surface in contact, the spread ray's hit is
/// taken, else the centre's. A patch partly covered by another object (a small box riding
/// on a larger one covers part of the patches under it) then sees its cover from the
/// covered part and the rest from the open part, as its mean over the area does (the
/// reference's form-factor rays start over the patch): from its centre alone it was all
/// dark or all open (the animated room's patches under the rider: 0 against the reference's
/// 0.34, or 0.71 against 0.50). Elsewhere the centre's view stands: spread over the patch,
/// every ray's view moved to the floor right beside a box's lowest side patches, which are
/// darker in the dispersive solution than in the reference there (the 128-object room's
/// interior error 2.95 -> 3.58 %).
pub(super) fn near_hits(
    world: &World,
    o: usize,
    patches: std::ops::Range<usize>,
    dirs: &[Vec3],
    (reach, contact): (f32, f32),
    shape: &Aabb,
    open: bool,
) -> NearHits {
    let p = &world.patches;
    let rays = dirs.len() / patches.len().max(1);
    let mut spread = vec![Vec3::ZERO; dirs.len()];
    let mut centre = vec![Vec3::ZERO; dirs.len()];
    spread
        .par_chunks_mut(rays)
        .zip(centre.par_chunks_mut(rays))
        .zip(patches.clone())
        .for_each(|((s, c), i)| {
            spread_over_patch(p, i, s);
            // Just inside the surface, the object transparent: a face resting on a floor
            // meets the floor (contact openness's start).
            let inward = p.normal[i] * world.eps;
            s.iter_mut().for_each(|x| *x -= inward);
            c.fill(p.centre[i] - inward);
        });
    let mut from_spread = vec![Hit::MISS; dirs.len()];
    let mut from_centre = vec![Hit::MISS; dirs.len()];
    let exclude = [o as u32];
    // Only hits within the reach count, so the rays stop there; and a spread ray's hit is
    // kept only where it or its centre ray meets a contact, so it stops at contact's reach
    // and goes on to the reach only where the centre ray met one and it did not. The same
    // hits as whole rays give, so the same light to the last digit. The near field of the
    // 77k room's 4,512-patch sphere, measured in the frame after it stops moving, took 149
    // ms with whole rays, 47-58 with both stopped at the reach, and 41-46 so
    // (`moving_frame 77000 8 16`, `SHRAD_TRACE`'s `openness`).
    let to_reach = (0.0, reach + 3.0 * world.eps);
    let to_contact = (0.0, contact + 3.0 * world.eps);
    world
        .vis
        .closest_within(&spread, dirs, to_contact, &exclude, &mut from_spread);
    world
        .vis
        .closest_within(&centre, dirs, to_reach, &exclude, &mut from_centre);
    // Contact is a surface met at once *under the object*: the floor a box stands on, the
    // box a rider stands on; not the floor met at once beside a side face's lowest points.
    // The object's box, padded by float noise (a hit on the surface it rests on lies on that
    // box's face).
    let shape = shape.padded(Vec3::splat(1e-5 * shape.diagonal()));
    let local_from_world = p.world_from_local[o].inverse();
    let in_contact = |from: Vec3, d: Vec3, h: &Hit| {
        h.is_hit()
            && h.t <= contact + 2.0 * world.eps
            && shape.contains(local_from_world.transform_point3(from + d * h.t))
    };
    let at_spread: Vec<bool> = (0..dirs.len())
        .map(|j| in_contact(spread[j], dirs[j], &from_spread[j]))
        .collect();
    let at_centre: Vec<bool> = (0..dirs.len())
        .map(|j| in_contact(centre[j], dirs[j], &from_centre[j]))
        .collect();
    let further: Vec<usize> = (0..dirs.len())
        .filter(|&j| at_centre[j] && !at_spread[j])
        .collect();
    if !further.is_empty() {
        let from: Vec<Vec3> = further.iter().map(|&j| spread[j]).collect();
        let towards: Vec<Vec3> = further.iter().map(|&j| dirs[j]).collect();
        let mut hits = vec![Hit::MISS; further.len()];
        world
            .vis
            .closest_within(&from, &towards, to_reach, &exclude, &mut hits);
        for (&j, h) in further.iter().zip(hits) {
            from_spread[j] = h;
        }
    }
    let mut out = NearHits {
        hit: Vec::with_capacity(dirs.len()),
        contact: Vec::with_capacity(dirs.len()),
        escapes: vec![false; dirs.len()],
        whole: vec![false; dirs.len()],
        origin: Vec::with_capacity(dirs.len()),
        end: vec![None; dirs.len()],
    };
    for j in 0..dirs.len() {
        let take_spread = at_spread[j] || at_centre[j];
        out.hit.push(if take_spread {
            from_spread[j]
        } else {
            from_centre[j]
        });
        out.origin
            .push(if take_spread { spread[j] } else { centre[j] });
        out.contact.push(at_spread[j]);
    }
    if open {
        beyond_the_reach(world, dirs, rays, &exclude, &mut out);
    }
    out
}
