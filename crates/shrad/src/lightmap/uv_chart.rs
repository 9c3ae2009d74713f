//! The object's own lightmap layout: its mesh's `lightmap_uvs` (glTF `TEXCOORD_1`, often a
//! lightmap UV layer made in Blender). When usable, the object's patches form one chart
//! whose coordinates are the UVs of the patch corners, offset to the used rectangle's corner
//! and scaled to metres (`sqrt(surface area / UV area)`, so that the object gets the texel
//! density a generated chart would): in the atlas this is a per-object scale and offset, as
//! Unity's `lightmapScaleOffset`. The written `TEXCOORD_1` is then the atlas's coordinates,
//! the user's layout scaled and moved into its rectangle.
//!
//! What is checked, on the user's triangles (the patches interpolate them, so they are the
//! same layout), and why:
//! - **finite**: a NaN places no texel (the glTF reader already drops such a set, warning);
//! - **no triangle without UV area** (at most 1e-10 of the used rectangle's): it has
//!   surface but no texel of its own, and would show whatever texel lies nearby;
//! - **no two triangles overlapping in UV space** (interiors, beyond 1e-6 of the rectangle,
//!   so that neighbours sharing an edge or a corner pass): two surface points would share a
//!   texel and one would show the other's light, the classic lightmap fault (what a
//!   UV-packing tool's "overlap" check reports).
//!
//! Not checked, deliberately: UVs outside [0, 1] (the used rectangle is rescaled anyway),
//! mirrored triangles (a texel does not care about winding), stretch (the user's choice:
//! texel density follows it) and the spacing between islands (bilinear filtering may blend
//! islands less than a texel apart; give the layout a margin, as Blender's Lightmap Pack
//! does). A set that fails is not used: the object gets generated charts, with a warning
//! naming it.
//!
//! A double-sided object's back patches (the twins, same UVs as their fronts) cannot share
//! the front's texels, whose light differs: they get generated charts.

use glam::Vec2;

use super::chart::{polygon_area, Chart};
use crate::patches::NO_PATCH;
use crate::World;

/// The charts made from objects' own lightmap UVs, which patches they hold, and a warning
/// for each object whose UVs could not be used.
pub(super) fn uv_charts(world: &World) -> (Vec<Chart>, Vec<bool>, Vec<String>) {
    let p = &world.patches;
    let mut charted = vec![false; p.len()];
    let (mut charts, mut warnings) = (Vec::new(), Vec::new());
    for o in 0..p.object_ranges.len() {
        let range = p.range(o);
        if range.is_empty() || p.lightmap_uvs(range.start).is_none() {
            continue;
        }
        let shape = &p.shapes[o];
        if let Some(why) = problem(&shape.lightmap_uvs, &shape.triangles) {
            warnings.push(format!(
                "object '{}': its TEXCOORD_1 is not used as the lightmap layout ({why}): charts generated instead",
                world.scene.objects[o].name
            ));
            continue;
        }
        // The fronts only: a back twin was pushed after its front.
        let front: Vec<usize> = range
            .filter(|&i| p.twin[i] == NO_PATCH || (p.twin[i] as usize) > i)
            .collect();
        let uvs: Vec<[Vec2; 4]> = front
            .iter()
            .map(|&i| *p.lightmap_uvs(i).expect("the object has lightmap UVs"))
            .collect();
        let uv_area: f32 = uvs.iter().map(polygon_area).sum();
        let area: f32 = front.iter().map(|&i| p.area[i]).sum();
        let scale = (area / uv_area).sqrt();
        if !(scale.is_finite() && scale > 0.0) {
            continue;
        }
        let lo = uvs.iter().flatten().fold(Vec2::INFINITY, |a, &b| a.min(b));
        let coords = uvs.iter().map(|c| c.map(|q| (q - lo) * scale)).collect();
        for &i in &front {
            charted[i] = true;
        }
        charts.push(Chart::new(o, front, coords));
    }
    (charts, charted, warnings)
}

/// Why `uvs` over `triangles` cannot be a lightmap layout, if it cannot.
pub fn problem(uvs: &[Vec2], triangles: &[[u32; 3]]) -> Option<String> {
    if let Some(k) = uvs.iter().position(|q| !q.is_finite()) {
        return Some(format!("coordinate {k} is not finite"));
    }
    let (lo, hi) = uvs
        .iter()
        .fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(a, b), &q| {
            (a.min(q), b.max(q))
        });
    let extent = (hi - lo).max_element();
    if extent.is_nan() || extent <= 0.0 {
        return Some("all its coordinates are one point".into());
    }
    let tri = |t: &[u32; 3]| t.map(|i| uvs[i as usize]);
    let flat = triangles
        .iter()
        .filter(|t| {
            let [a, b, c] = tri(t);
            0.5 * (b - a).perp_dot(c - a).abs() <= 1e-10 * extent * extent
        })
        .count();
    if flat > 0 {
        return Some(format!(
            "{flat} of {} triangles have no area in it",
            triangles.len()
        ));
    }
    let (a, b, count) = overlaps(uvs, triangles, lo, extent)?;
    Some(format!(
        "{count} pair(s) of triangles overlap in it, the first triangles {a} and {b}"
    ))
}

/// The first overlapping pair of triangles (interiors) and the number of overlapping
/// pairs, if any: a uniform grid over the used square, each triangle in the cells its
/// bounding box covers, the pairs sharing a cell tested once each.
fn overlaps(
    uvs: &[Vec2],
    triangles: &[[u32; 3]],
    lo: Vec2,
    extent: f32,
) -> Option<(usize, usize, usize)> {
    let n = triangles.len();
    let side = ((n as f32).sqrt().ceil() as usize).clamp(1, 1024);
    let cell = |q: Vec2| {
        let c = ((q - lo) / extent * side as f32).floor();
        (
            c.x.clamp(0.0, (side - 1) as f32) as usize,
            c.y.clamp(0.0, (side - 1) as f32) as usize,
        )
    };
    let tri = |t: usize| triangles[t].map(|i| uvs[i as usize]);
    let mut grid: Vec<Vec<u32>> = vec![Vec::new(); side * side];
    for t in 0..n {
        let q = tri(t);
        let (x0, y0) = cell(q[0].min(q[1]).min(q[2]));
        let (x1, y1) = cell(q[0].max(q[1]).max(q[2]));
        for y in y0..=y1 {
            for x in x0..=x1 {
                grid[y * side + x].push(t as u32);
            }
        }
    }
    let eps = 1e-6 * extent;
    let mut seen = std::collections::HashSet::new();
    let mut first = None;
    for members in &grid {
        for (k, &a) in members.iter().enumerate() {
            for &b in &members[..k] {
                let (a, b) = (a.min(b) as usize, a.max(b) as usize);
                if triangles_overlap(tri(a), tri(b), eps) && seen.insert((a, b)) {
                    first.get_or_insert((a, b));
                }
            }
        }
    }
    first.map(|(a, b)| (a, b, seen.len()))
}

/// Whether two triangles' interiors overlap by more than `eps` (the separating-axis test
/// on the six edge normals: two convex polygons that do not overlap have a separating line
/// parallel to an edge of one of them).
pub fn triangles_overlap(a: [Vec2; 3], b: [Vec2; 3], eps: f32) -> bool {
    for t in [a, b] {
        for k in 0..3 {
            let e = t[(k + 1) % 3] - t[k];
            let axis = Vec2::new(-e.y, e.x).normalize_or_zero();
            if axis == Vec2::ZERO {
                continue;
            }
            let span = |q: [Vec2; 3]| {
                let d = q.map(|v| v.dot(axis));
                (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]))
            };
            let ((a0, a1), (b0, b1)) = (span(a), span(b));
            if a1 <= b0 + eps || b1 <= a0 + eps {
                return false;
            }
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32, y: f32) -> Vec2 {
        Vec2::new(x, y)
    }

    /// Neighbours sharing an edge or a corner do not overlap; a triangle inside another,
    /// a crossing pair and a copy do.
    #[test]
    fn overlap_is_of_interiors() {
        let a = [v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0)];
        let e = 1e-6;
        assert!(!triangles_overlap(
            a,
            [v(1.0, 0.0), v(1.0, 1.0), v(0.0, 1.0)],
            e
        ));
        assert!(!triangles_overlap(
            a,
            [v(1.0, 0.0), v(2.0, 0.0), v(2.0, 1.0)],
            e
        ));
        assert!(!triangles_overlap(
            a,
            [v(0.0, 0.0), v(-1.0, 0.0), v(-1.0, -1.0)],
            e
        ));
        assert!(triangles_overlap(
            a,
            [v(0.1, 0.1), v(0.3, 0.1), v(0.1, 0.3)],
            e
        ));
        assert!(triangles_overlap(
            a,
            [v(0.4, -0.5), v(0.6, -0.5), v(0.5, 2.0)],
            e
        ));
        assert!(triangles_overlap(a, a, e));
    }

    /// A quad's two triangles pass; folded over, collapsed or NaN they fail, each saying
    /// why.
    #[test]
    fn problems_are_named() {
        let tris = [[0, 1, 2], [0, 2, 3]];
        let square = [v(0.0, 0.0), v(2.0, 0.0), v(2.0, 2.0), v(0.0, 2.0)];
        assert_eq!(problem(&square, &tris), None);
        let folded = [v(0.0, 0.0), v(2.0, 0.0), v(2.0, 2.0), v(1.5, 0.2)];
        let why = problem(&folded, &tris).unwrap();
        assert!(why.contains("1 pair(s) of triangles overlap"), "{why}");
        let collapsed = [v(0.0, 0.0), v(1.0, 0.0), v(2.0, 0.0), v(0.0, 1.0)];
        let why = problem(&collapsed, &tris).unwrap();
        assert!(why.contains("1 of 2 triangles have no area"), "{why}");
        let why = problem(&[v(0.5, 0.5); 4], &tris).unwrap();
        assert!(why.contains("one point"), "{why}");
        let mut nan = square;
        nan[2].x = f32::NAN;
        assert!(problem(&nan, &tris).unwrap().contains("coordinate 2"));
    }
}
