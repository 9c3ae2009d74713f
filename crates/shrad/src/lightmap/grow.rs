//! Growing charts over curved meshes. The planar charts ([`super::chart`]) of a tessellated
//! sphere or a Suzanne are one input triangle each: hundreds of tiny charts, each with its
//! padding (most of the atlas is padding) and a seam at every edge. Here planar charts are
//! merged into larger near-flat ones, the usual greedy chart growing of lightmap unwrappers
//! (as in xatlas's `ChartGrower`, or Lévy et al. 2002, "Least squares conformal maps",
//! section 5, whose seeds grow over a mesh's adjacency), kept as simple as its job:
//!
//! - **Seeds** largest first (a wall stays the seed of its own chart); a chart grows breadth
//!   first over planar charts that share an *edge* (two corners' shading vertices) with it,
//!   of the same object, while every patch of it stays within [`MAX_ANGLE_DEG`] of the
//!   chart's **mean normal** (area-weighted, moving as the chart grows);
//! - **Projection** along that mean normal (orthogonal: a patch stays an affine image of
//!   itself, as the texel lookup wants; a texel shrinks by at most `cos 30 deg` = 0.866
//!   along one axis). Measured against the mean rather than the seed, a seed beside charts
//!   already made grows away from them into a whole cap instead of a sliver around itself:
//!   on the room's spheres 40 charts instead of 67 (tests/lightmap_curved.rs, where the bar
//!   is derived; the strict lower bound under this rule is 25);
//! - **Fold-over**: a candidate whose patches turn over in the projection (signed area not
//!   positive) is refused; within 30 degrees of the axis this cannot happen, it is a guard;
//! - **Overlap**: a candidate whose projected patches overlap the chart's (a surface that
//!   turns back over itself while its normals stay within the angle) is refused: a spatial
//!   hash of the chart's triangles projected onto the seed's plane, tested with the
//!   separating-axis test of [`super::uv_chart::triangles_overlap`]. The finished chart is
//!   checked again along its mean normal; should it overlap there, the chart is grown
//!   again about the seed's normal alone and projected onto the seed's plane, which the
//!   hash has checked. A refused candidate seeds or joins another chart.
//!
//! Neighbours are visited in index order, so a bake's charts are the same every time.
//!
//! Why written rather than bound: xatlas (C++) has Rust bindings on crates.io (`xatlas-rs`,
//! `xatlas`) but they build a C++ library through `cc` and are little kept (see
//! docs/results.md, section 12); shrad's charts are already planar faces, so what curved
//! meshes need is the growing step only, which is this file. Charts are packed by the same
//! shelf packer, with the same padding and dilation, as every other chart.

use std::collections::HashMap;

use glam::{Vec2, Vec3};

use super::chart::{Chart, Plane};
use super::uv_chart::triangles_overlap;
use crate::World;

/// Largest angle between a grown chart's axis (its mean normal) and any of its patches
/// (degrees).
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
    fn new(cell: f32) -> Hash {
        Hash {
            cell,
            cells: HashMap::new(),
        }
    }
    /// Whether planar chart `chart` projected onto `plane` keeps every triangle turned up
    /// and clear of the triangles in the hash.
    fn fits(&self, world: &World, chart: &Chart, plane: &Plane, eps: f32, size: f32) -> bool {
        chart.patches.iter().all(|&i| {
            let q = plane.patch(world, i);
            patch_triangles(world, i, &q).iter().all(|t| {
                let turned = (t[1] - t[0]).perp_dot(t[2] - t[0]) <= eps * size;
                !turned && !self.overlaps(t, eps)
            })
        })
    }
    /// Planar chart `chart` projected onto `plane`, added.
    fn add(&mut self, world: &World, chart: &Chart, plane: &Plane) {
        for &i in &chart.patches {
            let q = plane.patch(world, i);
            patch_triangles(world, i, &q)
                .into_iter()
                .for_each(|t| self.insert(t));
        }
    }
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
    // In index order, not the hash's: a bake is the same every time.
    out.iter_mut().for_each(|n| n.sort_unstable());
    out
}

/// What a grown chart is measured against while it grows.
#[derive(Clone, Copy, PartialEq)]
enum Axis {
    /// Every patch within the angle of the chart's mean normal, the axis it is projected
    /// along (the mean moves as the chart grows).
    Mean,
    /// Every patch within the angle of the seed's normal, projected onto the seed's plane.
    Seed,
}

/// What every chart of one [`grow`] shares.
struct Grower<'a> {
    world: &'a World,
    planar: &'a [Chart],
    around: Vec<Vec<usize>>,
    /// Each planar chart's normal and area.
    normal: Vec<Vec3>,
    area: Vec<f32>,
    cos_max: f32,
}

impl Grower<'_> {
    /// The planar charts of the chart grown from `seed` over those not `taken`, and the
    /// plane it is projected onto; `None` when its projection along its mean normal would
    /// overlap itself (the caller then grows it about the seed's normal, which cannot).
    fn chart(&self, taken: &[bool], seed: usize, axis: Axis) -> Option<(Vec<usize>, Plane)> {
        let p = &self.world.patches;
        let first = self.planar[seed].patches[0];
        let c = p.world_corners(first);
        let n_seed = self.normal[seed];
        let seed_plane = Plane::new(c[0], n_seed, c[1] - c[0]);
        let size = p.area[first].sqrt().max(1e-6);
        let eps = 1e-5 * size;
        let mut hash = Hash::new(2.0 * size);
        let mut members = vec![seed];
        let mut inside = std::collections::HashSet::from([seed]);
        hash.add(self.world, &self.planar[seed], &seed_plane);
        // The mean normal (area-weighted sum) and the least cosine of a member to it.
        let (mut sum, mut least, mut next_least) = (n_seed * self.area[seed], 1.0f32, 1.0f32);
        // Breadth first: charts grow round rather than in snakes.
        let mut queue: std::collections::VecDeque<usize> =
            self.around[seed].iter().copied().collect();
        while let Some(k) = queue.pop_front() {
            if taken[k] || inside.contains(&k) || self.planar[k].object != self.planar[seed].object
            {
                continue;
            }
            let n = self.normal[k];
            let within = match axis {
                Axis::Seed => n.dot(n_seed) >= self.cos_max,
                Axis::Mean => {
                    let old = sum.normalize();
                    let new = (sum + n * self.area[k]).normalize();
                    // A member's cosine falls by at most the axis's move: test them all only
                    // when that bound does not settle it.
                    let bound = (least - (new - old).length()).min(n.dot(new));
                    let exact = || {
                        members
                            .iter()
                            .map(|&j| self.normal[j].dot(new))
                            .fold(n.dot(new), f32::min)
                    };
                    let m = if bound >= self.cos_max {
                        bound
                    } else {
                        exact()
                    };
                    // Kept only if the candidate is: it is the bound for the new axis.
                    next_least = m;
                    m >= self.cos_max
                }
            };
            if !within || !hash.fits(self.world, &self.planar[k], &seed_plane, eps, size) {
                continue;
            }
            if axis == Axis::Mean {
                sum += n * self.area[k];
                least = next_least;
            }
            inside.insert(k);
            members.push(k);
            hash.add(self.world, &self.planar[k], &seed_plane);
            queue.extend(
                self.around[k]
                    .iter()
                    .filter(|&&j| !taken[j] && !inside.contains(&j)),
            );
        }
        if axis == Axis::Seed {
            return Some((members, seed_plane));
        }
        let plane = Plane::new(c[0], sum.normalize_or(n_seed), c[1] - c[0]);
        let mut hash = Hash::new(2.0 * size);
        for &k in &members {
            if !hash.fits(self.world, &self.planar[k], &plane, eps, size) {
                return None;
            }
            hash.add(self.world, &self.planar[k], &plane);
        }
        Some((members, plane))
    }
}

/// Planar charts merged into grown charts (see the module docs); with `max_angle_deg` 0
/// they are returned as they are.
pub fn grow(world: &World, planar: Vec<Chart>, max_angle_deg: f32) -> Vec<Chart> {
    if max_angle_deg <= 0.0 {
        return planar;
    }
    let g = Grower {
        world,
        planar: &planar,
        around: neighbours(world, &planar),
        normal: planar
            .iter()
            .map(|c| world.patches.normal[c.patches[0]])
            .collect(),
        area: planar.iter().map(Chart::area).collect(),
        cos_max: max_angle_deg.to_radians().cos(),
    };
    let mut order: Vec<usize> = (0..planar.len()).collect();
    order.sort_by(|&a, &b| g.area[b].total_cmp(&g.area[a]).then(a.cmp(&b)));
    let mut taken = vec![false; planar.len()];
    let mut out = Vec::new();
    for seed in order {
        if taken[seed] {
            continue;
        }
        let (members, plane) = g
            .chart(&taken, seed, Axis::Mean)
            .or_else(|| g.chart(&taken, seed, Axis::Seed))
            .expect("a chart about its seed's normal is always made");
        let (mut patches, mut coords) = (Vec::new(), Vec::new());
        for &k in &members {
            taken[k] = true;
            for &i in &planar[k].patches {
                patches.push(i);
                coords.push(plane.patch(world, i));
            }
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
