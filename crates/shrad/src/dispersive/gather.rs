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
        // The entries' shadow rays all end at the centre: one cone of directions a chunk.
        let cones = ChunkCones::new(facing.len(), |n| {
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
        let lit: Vec<(usize, Vec3)> = (0..len.div_ceil(BLOCK))
            .into_par_iter()
            .flat_map_iter(|b| {
                let (lo, hi) = (b * BLOCK, ((b + 1) * BLOCK).min(len));
                let mut value = [Vec3::ZERO; BLOCK];
                let [x, y, z] = [0, 1, 2].map(|a| &dir[a][lo..hi]);
                intensity.eval_many(x, y, z, &mut value[..hi - lo]);
                (lo..hi).filter_map(move |n| {
                    if ray[n] == RAY_BLOCKED {
                        return None;
                    }
                    let e = value[n - lo].max(Vec3::ZERO) * cos[n];
                    (e.max_element() > 0.0).then_some((n, e))
                })
            })
            .collect();
        let unknown: Vec<usize> = lit
            .iter()
            .map(|&(n, _)| n)
            .filter(|&n| g.ray[n] == RAY_UNKNOWN)
            .collect();
        if !unknown.is_empty() {
            let from: Vec<Vec3> = unknown
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
            for (&n, b) in unknown.iter().zip(blocked) {
                g.ray[n] = if b { RAY_BLOCKED } else { RAY_CLEAR };
            }
        }
        let clear: Vec<(u32, Vec3, f32, f32)> = lit
            .into_iter()
            .filter(|&(n, _)| g.ray[n] == RAY_CLEAR)
            .map(|(n, e)| {
                let (j, r2) = (g.patch[n], g.r2[n]);
                let a = p.area[j as usize];
                (
                    j,
                    e / (r2 + soften),
                    a * e.element_sum() / r2,
                    a * e.element_sum() / (r2 + soften),
                )
            })
            .collect();
        let (plain, softened) = clear
            .iter()
            .fold((0f64, 0f64), |(x, y), e| (x + e.2 as f64, y + e.3 as f64));
        let scale = if softened > 0.0 {
            (plain / softened) as f32
        } else {
            1.0
        };
        clear
            .into_iter()
            .map(|(j, e, _, _)| (j, e * scale))
            .collect()
    }
}
