//! Form factors, shared transport code of the reference solver (the whole matrix) and the
//! dispersive solver (its wall exchange among boundary patches, re-traced row by row where
//! objects move; the energy meter's rays from the lights). `F_ij` is estimated by
//! stratified cosine-weighted rays from stratified points on patch `i` (area-to-area, not
//! centre-to-area) and stored as [`SparseRows`]: a row holds only the patches its rays met,
//! so memory grows with patches x rays, not patches^2 (100k patches x 128 rays stay well
//! under 1 GiB). Probe capture, the other shared piece, is [`crate::probes`].

use glam::Vec3;
use rayon::prelude::*;

use crate::progress::Progress;
use crate::sampling::{hammersley, hash, square_to_cosine_hemisphere, unit};
use crate::sparse::SparseRows;
use crate::{Error, World};

/// Sparse form-factor matrix: row `i` holds `(patch seen, F_ij)`, columns ascending.
pub type FormFactors = SparseRows<(u32, f32)>;

/// Estimate the form factors of the patches in `rows` (all others get empty rows) with
/// `rays` rays each. Patches with zero reflectance need no row; pass only those you need.
/// [`Error::Interrupted`] when `progress` asks to stop (checked between chunks of rays).
pub fn form_factors(
    world: &World,
    rows: &[u32],
    rays: u32,
    progress: &dyn Progress,
) -> Result<FormFactors, Error> {
    form_factors_with(world, rows, rays, &[], progress)
}

/// [`form_factors`] with the objects in `exclude` transparent.
pub fn form_factors_with(
    world: &World,
    rows: &[u32],
    rays: u32,
    exclude: &[u32],
    progress: &dyn Progress,
) -> Result<FormFactors, Error> {
    let n = world.patches.len();
    let mut per_patch: Vec<Vec<(u32, f32)>> = vec![Vec::new(); n];
    let rows_out = form_factor_rows(world, rows, rays, exclude, |_| true, progress)?;
    for (&i, row) in rows.iter().zip(rows_out) {
        per_patch[i as usize] = row;
    }
    Ok(SparseRows::from_rows(per_patch))
}

/// The `rays` form-factor rays of patch `i` (world space): stratified points on the patch
/// and stratified cosine-weighted directions, paired by a random permutation (a fixed
/// pairing correlates them and biases F). Deterministic: the same rays every call.
pub fn patch_rays(world: &World, i: usize, origins: &mut [Vec3], dirs: &mut [Vec3]) {
    let rays = origins.len();
    let all: Vec<usize> = (0..rays).collect();
    some_patch_rays(world, i, rays, &all, origins, dirs);
}

/// Rays `which` of patch `i`'s `rays` [`patch_rays`] (the same rays, bit for bit), into
/// `origins[k]`, `dirs[k]` for `which[k]`: re-tracing a few of a patch's rays costs those.
pub fn some_patch_rays(
    world: &World,
    i: usize,
    rays: usize,
    which: &[usize],
    origins: &mut [Vec3],
    dirs: &mut [Vec3],
) {
    let p = &world.patches;
    let nrm = p.normal[i];
    let seed = hash(i as u32);
    let s1 = (unit(seed), unit(hash(seed ^ 1)));
    let s2 = (unit(hash(seed ^ 2)), unit(hash(seed ^ 3)));
    let perm = crate::sampling::shuffled(rays, seed);
    let corners = p.world_corners(i);
    for (k, &j) in which.iter().enumerate() {
        let (u, v) = hammersley(perm[j], rays as u32, s1);
        origins[k] = point_in(p.is_quad[i], &corners, u, v) + nrm * world.eps;
        let (a, b) = hammersley(j as u32, rays as u32, s2);
        dirs[k] = square_to_cosine_hemisphere(a, b, nrm);
    }
}

/// [`crate::patches::Patches::sample_point`] of a patch whose world corners are known.
fn point_in(quad: bool, c: &[Vec3; 4], u: f32, v: f32) -> Vec3 {
    if quad {
        c[0] + u * (c[1] - c[0]) + v * (c[3] - c[0])
    } else {
        let su = u.sqrt();
        c[0] * (1.0 - su) + c[1] * (su * (1.0 - v)) + c[2] * (su * v)
    }
}

/// Sparse form-factor rows `(patch seen, F)` of `rows`, keeping the columns `keep` accepts.
/// [`Error::Interrupted`] when `progress` asks to stop: it is asked before each chunk of
/// about a million rays, where the progress advances.
pub fn form_factor_rows(
    world: &World,
    rows: &[u32],
    rays: u32,
    exclude: &[u32],
    keep: impl Fn(usize) -> bool + Sync,
    progress: &dyn Progress,
) -> Result<Vec<Vec<(u32, f32)>>, Error> {
    let rays = rays.max(1) as usize;
    let chunk = ((1 << 20) / rays).max(1);
    let mut out = Vec::with_capacity(rows.len());
    progress.begin("form factors", rows.len() as u64);
    for ids in rows.chunks(chunk) {
        crate::progress::check(progress).inspect_err(|_| progress.end())?;
        let mut origins = vec![Vec3::ZERO; ids.len() * rays];
        let mut dirs = vec![Vec3::ZERO; ids.len() * rays];
        origins
            .par_chunks_mut(rays)
            .zip(dirs.par_chunks_mut(rays))
            .zip(ids.par_iter())
            .for_each(|((o, d), &i)| patch_rays(world, i as usize, o, d));
        let mut hits = vec![shrad_vis::Hit::MISS; origins.len()];
        world.vis.closest(&origins, &dirs, 0.0, exclude, &mut hits);
        out.par_extend(hits.par_chunks(rays).map(|h| {
            row_from_hits(
                h.iter()
                    .filter_map(|h| world.seen_patch(h))
                    .filter(|&j| keep(j))
                    .map(|j| j as u32),
                rays,
            )
        }));
        progress.advance(ids.len() as u64);
    }
    progress.end();
    Ok(out)
}

/// The form-factor row of a patch whose `rays` rays saw the patches `seen` (those kept, in
/// any order): `(patch, F)`, columns ascending, each ray worth `1 / rays`.
pub fn row_from_hits(seen: impl Iterator<Item = u32>, rays: usize) -> Vec<(u32, f32)> {
    let w = 1.0 / rays as f32;
    let mut seen: Vec<u32> = seen.collect();
    seen.sort_unstable();
    let mut row: Vec<(u32, f32)> = Vec::new();
    for j in seen {
        match row.last_mut() {
            Some((c, f)) if *c == j => *f += w,
            _ => row.push((j, w)),
        }
    }
    row
}
