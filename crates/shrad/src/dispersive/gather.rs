//! Step 3's gather (paper 2.3.4, beyond it): an emitter's SH intensity evaluated towards
//! each boundary patch it lights, with one shadow ray each, cached between updates
//! (`caches::GatherEntries`). The splat is the paper's way; the gather is exact in direction
//! and cheaper on small boundaries (`ToBoundary::Auto`).

use glam::Vec3;
use rayon::prelude::*;
use shrad_sh::ShRgb;

use super::caches::{ChunkCones, GatherEntries, RAY_BLOCKED, RAY_CLEAR, RAY_UNKNOWN};
use super::Dispersive;
use crate::World;

impl Dispersive {
    /// The boundary patches that face a point emitter at `centre` and that it `takes` (by
    /// their centres: `setup::Reach`), with `cos`, `r^2` and the direction towards them; no
    /// shadow ray cast yet.
    pub(super) fn gather_entries(
        &self,
        world: &World,
        centre: Vec3,
        takes: impl Fn(Vec3) -> bool + Sync,
    ) -> GatherEntries {
        let p = &world.patches;
        let facing: Vec<(u32, f32, f32, Vec3)> = self
            .boundary_patches
            .par_iter()
            .filter(|&&j| takes(p.centre[j as usize]))
            .filter_map(|&j| {
                let d = centre - p.centre[j as usize];
                let r2 = d.length_squared().max(1e-12);
                let towards_object = d / r2.sqrt();
                let cos = p.normal[j as usize].dot(towards_object);
                (cos > 0.0).then_some((j, cos, r2, -towards_object))
            })
            .collect();
        // The entries' shadow rays all end at the centre: one cone of directions a tile.
        let cones = ChunkCones::by_direction(facing.len(), |n| {
            let j = facing[n].0 as usize;
            p.centre[j] + p.normal[j] * world.eps - centre
        });
        GatherEntries {
            centre,
            cones,
            patch: facing.iter().map(|f| f.0).collect(),
            cos: facing.iter().map(|f| f.1).collect(),
            r2: facing.iter().map(|f| f.2).collect(),
            dir: [0, 1, 2].map(|a| facing.iter().map(|f| f.3[a]).collect()),
            ray: vec![RAY_UNKNOWN; facing.len()],
            forgotten: Vec::new(),
            sent_scale: 1.0,
        }
    }

    /// Point-emitter gather: `E_j = I(w_j) cos_j / r^2`, one shadow ray per boundary patch
    /// the emitter sends light to (cast once, then cached until something moves across it).
    ///
    /// `soften` (an area / pi) regularises `1 / r^2` near an extended emitter, as for a disc:
    /// `cos / (r^2 + soften)` (on a disc's axis this is exact).
    pub(super) fn gather(
        &self,
        world: &World,
        o: usize,
        g: &mut GatherEntries,
        intensity: &ShRgb,
        soften: f32,
    ) -> Vec<(u32, Vec3)> {
        let p = &world.patches;
        // Unoccluded irradiance with the softened and the plain 1 / r^2; the softened one is
        // rescaled to the plain one's total flux, so softening moves light but neither adds
        // nor loses any. Patches behind the emitter's lobe get no ray.
        // `I(w_j)`, block by block (`ShRgb::eval_many`: the floats `ShRgb::eval` gives, one
        // basis function at a time over the block, which vectorises; a direction takes 12
        // bytes where its basis would take 64).
        const BLOCK: usize = 256;
        let len = g.patch.len();
        let (dir, ray, cos) = (&g.dir, &g.ray, &g.cos);
        // `E` without `1 / r^2` per entry (0 where blocked or unlit), in place: no list of
        // pieces is made before the last pass (the lists and their copies were a fifth of a
        // still object's gather in the 40k objects rooms).
        let mut value = vec![Vec3::ZERO; len];
        value
            .par_chunks_mut(BLOCK)
            .enumerate()
            .for_each(|(b, value)| {
                let (lo, hi) = (b * BLOCK, b * BLOCK + value.len());
                let [x, y, z] = [0, 1, 2].map(|a| &dir[a][lo..hi]);
                intensity.eval_many(x, y, z, value);
                for (v, n) in value.iter_mut().zip(lo..hi) {
                    let e = v.max(Vec3::ZERO) * cos[n];
                    let lit = ray[n] != RAY_BLOCKED && e.max_element() > 0.0;
                    *v = if lit { e } else { Vec3::ZERO };
                }
            });
        let lit = |n: usize| value[n] != Vec3::ZERO;
        let unknown: Vec<usize> = (0..len)
            .filter(|&n| g.ray[n] == RAY_UNKNOWN && lit(n))
            .collect();
        trace_entries(world, o, g, &unknown);
        let (mut plain, mut softened) = (0f64, 0f64);
        let mut out: Vec<(u32, Vec3)> = Vec::new();
        for n in (0..len).filter(|&n| g.ray[n] == RAY_CLEAR && lit(n)) {
            let (j, r2, e) = (g.patch[n], g.r2[n], value[n]);
            let a = p.area[j as usize];
            plain += (a * e.element_sum() / r2) as f64;
            softened += (a * e.element_sum() / (r2 + soften)) as f64;
            out.push((j, e / (r2 + soften)));
        }
        let scale = if softened > 0.0 {
            (plain / softened) as f32
        } else {
            1.0
        };
        out.iter_mut().for_each(|(_, e)| *e *= scale);
        // What the boundary holds from now on (`resend.rs`).
        g.forgotten.clear();
        g.sent_scale = scale;
        out
    }
}

/// Cast the shadow rays of entries `which` of `g` (object `o` transparent), and keep them.
pub(super) fn trace_entries(world: &World, o: usize, g: &mut GatherEntries, which: &[usize]) {
    if which.is_empty() {
        return;
    }
    let p = &world.patches;
    let from: Vec<Vec3> = which
        .iter()
        .map(|&n| {
            let j = g.patch[n] as usize;
            p.centre[j] + p.normal[j] * world.eps
        })
        .collect();
    let to = vec![g.centre; from.len()];
    let mut blocked = vec![false; from.len()];
    world
        .vis
        .occluded(&from, &to, world.eps, &[o as u32], &mut blocked);
    for (&n, b) in which.iter().zip(blocked) {
        g.ray[n] = if b { RAY_BLOCKED } else { RAY_CLEAR };
    }
}

/// The entries of `g` forgotten since its contribution was sent, traced again: (patch,
/// irradiance) pieces that take off the light of each one no longer clear and put on that of
/// each one clear now, as it was sent (`sent`, with the scale it was sent with).
pub(super) fn crossed_entries(
    world: &World,
    o: usize,
    g: &mut GatherEntries,
    sent: &ShRgb,
    soften: f32,
) -> Vec<(u32, Vec3)> {
    let mut forgotten = std::mem::take(&mut g.forgotten);
    // An entry forgotten twice keeps what it was when sent: its first record.
    forgotten.sort_by_key(|&(n, _)| n);
    forgotten.dedup_by_key(|&mut (n, _)| n);
    let unknown: Vec<usize> = (forgotten.iter())
        .map(|&(n, _)| n as usize)
        .filter(|&n| g.ray[n] == RAY_UNKNOWN)
        .collect();
    trace_entries(world, o, g, &unknown);
    let mut pieces = Vec::new();
    for (n, was) in forgotten {
        let n = n as usize;
        let now = g.ray[n];
        if (now == RAY_CLEAR) == (was == RAY_CLEAR) {
            continue;
        }
        let dir = Vec3::new(g.dir[0][n], g.dir[1][n], g.dir[2][n]);
        let e = sent.eval(dir).max(Vec3::ZERO) * g.cos[n];
        if e.max_element() <= 0.0 {
            continue;
        }
        let e = e / (g.r2[n] + soften) * g.sent_scale;
        pieces.push((g.patch[n], if now == RAY_CLEAR { e } else { -e }));
    }
    pieces
}
