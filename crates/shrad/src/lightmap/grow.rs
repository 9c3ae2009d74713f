//! Growing charts over curved meshes. The planar charts ([`super::chart`]) of a tessellated
//! sphere or a Suzanne are one input triangle each: hundreds of tiny charts, each with its
//! padding (most of the atlas is padding) and a seam at every edge. Here planar charts are
//! merged into larger near-flat ones, the usual greedy chart growing of lightmap unwrappers
//! (as in xatlas's `ChartGrower`, or Lévy et al. 2002, "Least squares conformal maps",
//! section 5, whose seeds grow over a mesh's adjacency), kept as simple as its job:
//!
//! - **Seeds** largest first (a wall stays the seed of its own chart); a chart grows over
//!   planar charts that share an *edge* (two corners' shading vertices) with it, of the same
//!   object, whose normal is within [`MAX_ANGLE_DEG`] of the seed's.
//! - **Projection** onto the seed's plane (orthogonal: a patch stays an affine image of
//!   itself, as the texel lookup wants; a texel stretches by at most `1 / cos 30 deg` =
//!   1.155 along one axis).
//! - **Fold-over**: a candidate whose patches turn over in the projection (signed area not
//!   positive) is refused; within 30 degrees this cannot happen, the check is a guard.
//! - **Overlap**: a candidate whose projected patches overlap the chart's (a surface that
//!   turns back over itself while its normals stay within the angle) is refused: a spatial
//!   hash of the chart's projected triangles, tested with the separating-axis test of
//!   [`super::uv_chart::triangles_overlap`]. A refused candidate seeds or joins another chart.
//!
//! Why written rather than bound: xatlas (C++) has Rust bindings on crates.io (`xatlas-rs`,
//! `xatlas`) but they build a C++ library through `cc` and are little kept (see
//! docs/results.md, section 12); shrad's charts are already planar faces, so what curved
//! meshes need is the growing step only, which is this file. Charts are packed by the same
//! shelf packer, with the same padding and dilation, as every other chart.

use std::collections::HashMap;

use glam::Vec2;

use super::chart::{Chart, Plane};
use super::uv_chart::triangles_overlap;
use crate::World;

/// Largest angle between a grown chart's seed normal and any of its patches (degrees).
pub const MAX_ANGLE_DEG: f32 = 30.0;

/// The triangles of a patch's chart coordinates (one for a triangle, two for a quad).
fn patch_triangles(world: &World, i: usize, q: &[Vec2; 4]) -> Vec<[Vec2; 3]> {
    if world.patches.is_quad[i] {
        vec![[q[0], q[1], q[2]], [q[0], q[2], q[3]]]
    } else {
        vec![[q[0], q[1], q[2]]]
    }
}

/// A grown chart's projected triangles in a uniform hash of cells `cell` wide.
struct Hash {
    cell: f32,
    cells: HashMap<(i32, i32), Vec<[Vec2; 3]>>,
}

impl Hash {
    fn keys(&self, t: &[Vec2; 3]) -> impl Iterator<Item = (i32, i32)> {
        let lo = (t[0].min(t[1]).min(t[2]) / self.cell).floor().as_ivec2();
        let hi = (t[0].max(t[1]).max(t[2]) / self.cell).floor().as_ivec2();
        (lo.y..=hi.y).flat_map(move |y| (lo.x..=hi.x).map(move |x| (x, y)))
    }
    fn overlaps(&self, t: &[Vec2; 3], eps: f32) -> bool {
        self.keys(t).any(|k| {
            self.cells
                .get(&k)
                .is_some_and(|ts| ts.iter().any(|u| triangles_overlap(*t, *u, eps)))
        })
    }
    fn insert(&mut self, t: [Vec2; 3]) {
        let keys: Vec<_> = self.keys(&t).collect();
        for k in keys {
            self.cells.entry(k).or_default().push(t);
        }
    }
}

/// For each planar chart, the charts sharing an edge with it.
fn neighbours(world: &World, planar: &[Chart]) -> Vec<Vec<usize>> {
    let p = &world.patches;
    let mut by_edge: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
    for (c, chart) in planar.iter().enumerate() {
        for &i in &chart.patches {
            let n = if p.is_quad[i] { 4 } else { 3 };
            let v = p.corner_vertex[i];
            for k in 0..n {
                let (a, b) = (v[k], v[(k + 1) % n]);
                by_edge.entry((a.min(b), a.max(b))).or_default().push(c);
            }
        }
    }
    let mut out = vec![Vec::new(); planar.len()];
    for charts in by_edge.values() {
        for &a in charts {
            for &b in charts {
                if a != b && !out[a].contains(&b) {
                    out[a].push(b);
                }
            }
        }
    }
    out
}

/// Planar charts merged into grown charts (see the module docs); with `max_angle_deg` 0
/// they are returned as they are.
pub fn grow(world: &World, planar: Vec<Chart>, max_angle_deg: f32) -> Vec<Chart> {
    if max_angle_deg <= 0.0 {
        return planar;
    }
    let p = &world.patches;
    let cos_max = max_angle_deg.to_radians().cos();
    let around = neighbours(world, &planar);
    let mut order: Vec<usize> = (0..planar.len()).collect();
    let area: Vec<f32> = planar.iter().map(Chart::area).collect();
    order.sort_by(|&a, &b| area[b].total_cmp(&area[a]).then(a.cmp(&b)));
    let mut taken = vec![false; planar.len()];
    let mut out = Vec::new();
    for seed in order {
        if taken[seed] {
            continue;
        }
        taken[seed] = true;
        let first = planar[seed].patches[0];
        let n = p.normal[first];
        let c = p.world_corners(first);
        let plane = Plane::new(c[0], n, c[1] - c[0]);
        let size = p.area[first].sqrt().max(1e-6);
        let mut hash = Hash {
            cell: 2.0 * size,
            cells: HashMap::new(),
        };
        let eps = 1e-5 * size;
        let (mut patches, mut coords) = (Vec::new(), Vec::new());
        let add = |k: usize, hash: &mut Hash, patches: &mut Vec<usize>, coords: &mut Vec<_>| {
            for &i in &planar[k].patches {
                let q = plane.patch(world, i);
                patch_triangles(world, i, &q)
                    .into_iter()
                    .for_each(|t| hash.insert(t));
                patches.push(i);
                coords.push(q);
            }
        };
        add(seed, &mut hash, &mut patches, &mut coords);
        // Breadth first: charts grow round rather than in snakes.
        let mut queue: std::collections::VecDeque<usize> = around[seed].iter().copied().collect();
        while let Some(k) = queue.pop_front() {
            if taken[k]
                || planar[k].object != planar[seed].object
                || p.normal[planar[k].patches[0]].dot(n) < cos_max
            {
                continue;
            }
            let fits = planar[k].patches.iter().all(|&i| {
                let q = plane.patch(world, i);
                patch_triangles(world, i, &q).iter().all(|t| {
                    let turned = (t[1] - t[0]).perp_dot(t[2] - t[0]) <= eps * size;
                    !turned && !hash.overlaps(t, eps)
                })
            });
            if !fits {
                continue;
            }
            taken[k] = true;
            add(k, &mut hash, &mut patches, &mut coords);
            queue.extend(around[k].iter().filter(|&&j| !taken[j]));
        }
        out.push(Chart::new(planar[seed].object, patches, coords));
    }
    out
}

/// The number of seams: patch edges (shared shading vertices) whose two sides lie in
/// different charts of `chart_of_patch`.
pub fn seams(world: &World, chart_of_patch: &[u32]) -> usize {
    let p = &world.patches;
    let mut by_edge: HashMap<(u32, u32), Vec<u32>> = HashMap::new();
    for i in 0..p.len() {
        let n = if p.is_quad[i] { 4 } else { 3 };
        let v = p.corner_vertex[i];
        for k in 0..n {
            let (a, b) = (v[k], v[(k + 1) % n]);
            by_edge
                .entry((a.min(b), a.max(b)))
                .or_default()
                .push(chart_of_patch[i]);
        }
    }
    by_edge
        .values()
        .filter(|c| c.len() >= 2 && c.iter().any(|&x| x != c[0]))
        .count()
}
