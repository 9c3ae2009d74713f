//! Cutting a local-frame mesh into patches at size `h`: triangle pairs that form a planar
//! parallelogram become a grid of near-square cells (the paper's wall squares), other
//! triangles are subdivided until no edge is longer than `h`.

use glam::Vec3;
use shrad_scene::Mesh;

use super::attrs::{vertex_attr, CornerAttr};
use super::weld::quantum;

/// One patch before it is stored: a parallelogram or a triangle (local frame).
#[derive(Clone, Copy, Debug)]
pub(super) struct Cell {
    pub(super) corners: [Vec3; 4],
    pub(super) attrs: [CornerAttr; 4],
    pub(super) is_quad: bool,
}

/// The cells of one (local-frame) mesh at patch size `h`.
pub(super) fn subdivide(mesh: &Mesh, h: f32) -> Vec<Cell> {
    let pos = |i: u32| mesh.positions[i as usize];
    let mut cells = Vec::new();
    for face in pair_parallelograms(mesh) {
        match face {
            Face::Quad(c, ca) => {
                let (e1, e2) = (c[1] - c[0], c[3] - c[0]);
                let nu = cells_along(e1.length(), h);
                let nv = cells_along(e2.length(), h);
                for j in 0..nv {
                    for i in 0..nu {
                        let at = |a: usize, b: usize| {
                            c[0] + e1 * (a as f32 / nu as f32) + e2 * (b as f32 / nv as f32)
                        };
                        let attr = |a: usize, b: usize| {
                            CornerAttr::bilinear(&ca, a as f32 / nu as f32, b as f32 / nv as f32)
                        };
                        cells.push(Cell {
                            corners: [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)],
                            attrs: [
                                attr(i, j),
                                attr(i + 1, j),
                                attr(i + 1, j + 1),
                                attr(i, j + 1),
                            ],
                            is_quad: true,
                        });
                    }
                }
            }
            Face::Triangle(t) => {
                let [a, b, c] = t.map(pos);
                let longest = (b - a).length().max((c - b).length()).max((a - c).length());
                let n = cells_along(longest, h);
                let at = |i: usize, j: usize| {
                    a + (b - a) * (i as f32 / n as f32) + (c - a) * (j as f32 / n as f32)
                };
                let ta = t.map(|i| vertex_attr(mesh, i));
                let ta = [ta[0], ta[1], ta[2], ta[2]];
                let attr = |i: usize, j: usize| {
                    CornerAttr::barycentric(&ta, i as f32 / n as f32, j as f32 / n as f32)
                };
                for j in 0..n {
                    for i in 0..n - j {
                        cells.push(Cell {
                            corners: [at(i, j), at(i + 1, j), at(i, j + 1), at(i, j + 1)],
                            attrs: [attr(i, j), attr(i + 1, j), attr(i, j + 1), attr(i, j + 1)],
                            is_quad: false,
                        });
                        if i + j + 1 < n {
                            cells.push(Cell {
                                corners: [
                                    at(i + 1, j),
                                    at(i + 1, j + 1),
                                    at(i, j + 1),
                                    at(i, j + 1),
                                ],
                                attrs: [
                                    attr(i + 1, j),
                                    attr(i + 1, j + 1),
                                    attr(i, j + 1),
                                    attr(i, j + 1),
                                ],
                                is_quad: false,
                            });
                        }
                    }
                }
            }
        }
    }
    cells
}

pub(super) fn cells_along(length: f32, h: f32) -> usize {
    if h > 0.0 && h.is_finite() {
        ((length / h) * (1.0 - 1e-5)).ceil().clamp(1.0, 1e6) as usize
    } else {
        1
    }
}

pub(super) enum Face {
    /// Parallelogram corners, counter-clockwise, and their attributes.
    Quad([Vec3; 4], [CornerAttr; 4]),
    Triangle([u32; 3]),
}

/// An edge by its two ends' quantised positions, the smaller first.
type EdgeKey = ([i64; 3], [i64; 3]);

/// The most triangles sharing a longest edge that one triangle tries to pair with
/// ([`pair_parallelograms`]).
const PAIR_CANDIDATES: usize = 8;

/// Pair triangles that share their longest edge and together form a planar parallelogram
/// (the usual export of a quad) over which the attributes (texture coordinates, colours)
/// are affine and continuous; the rest stay triangles. Deterministic: triangle order.
pub(super) fn pair_parallelograms(mesh: &Mesh) -> Vec<Face> {
    use std::collections::HashMap;
    let p = |i: u32| mesh.positions[i as usize];
    // Key vertices by position so unwelded exports pair too.
    let inv_quantum = 1.0 / quantum(mesh);
    let key = |v: Vec3| (v * inv_quantum).round().as_i64vec3().to_array();
    let tri_keys: Vec<[[i64; 3]; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| key(p(i))))
        .collect();
    let longest_edge = |t: &[u32; 3]| -> usize {
        let [a, b, c] = t.map(p);
        let l = [
            (b - a).length_squared(),
            (c - b).length_squared(),
            (a - c).length_squared(),
        ];
        (0..3).max_by(|&x, &y| l[x].total_cmp(&l[y])).unwrap_or(0)
    };
    // Per longest edge: its triangles in order, and how many at the front are used.
    let mut by_edge: HashMap<EdgeKey, (usize, Vec<usize>)> = HashMap::new();
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let e = longest_edge(t);
        let (ka, kb) = (tri_keys[ti][e], tri_keys[ti][(e + 1) % 3]);
        let k = if ka <= kb { (ka, kb) } else { (kb, ka) };
        by_edge.entry(k).or_default().1.push(ti);
    }
    let mut used = vec![false; mesh.triangles.len()];
    let mut faces = Vec::with_capacity(mesh.triangles.len());
    for (ti, t) in mesh.triangles.iter().enumerate() {
        if used[ti] {
            continue;
        }
        used[ti] = true;
        let e = longest_edge(t);
        let (ka, kb) = (tri_keys[ti][e], tri_keys[ti][(e + 1) % 3]);
        let k = if ka <= kb { (ka, kb) } else { (kb, ka) };
        let mut paired = None;
        // Past the used front of the edge's list, at most `PAIR_CANDIDATES` tries: an edge
        // shared by thousands of triangles (the same one repeated) made this quadratic
        // (20k copies 3.4 s, 200k never ended), and a parallelogram's partner is one of few.
        let (mut tries, mut n) = ([0usize; PAIR_CANDIDATES], 0);
        if let Some((front, list)) = by_edge.get_mut(&k) {
            while list.get(*front).is_some_and(|&o| used[o]) {
                *front += 1;
            }
            for &o in list[*front..].iter().filter(|&&o| !used[o]) {
                if n == PAIR_CANDIDATES {
                    break;
                }
                (tries[n], n) = (o, n + 1);
            }
        }
        for &other in &tries[..n] {
            if let Some(q) = parallelogram(
                t,
                &mesh.triangles[other],
                e,
                longest_edge(&mesh.triangles[other]),
                &p,
                &|i| vertex_attr(mesh, i),
            ) {
                paired = Some((other, q));
                break;
            }
        }
        match paired {
            Some((other, (q, a))) => {
                used[other] = true;
                faces.push(Face::Quad(q, a));
            }
            None => faces.push(Face::Triangle(*t)),
        }
    }
    faces
}

/// If triangles `t` (longest edge `e`) and `u` (longest edge `f`) share that edge in opposite
/// directions and form a planar parallelogram, its corners counter-clockwise.
pub(super) fn parallelogram(
    t: &[u32; 3],
    u: &[u32; 3],
    e: usize,
    f: usize,
    p: &impl Fn(u32) -> Vec3,
    attr: &impl Fn(u32) -> CornerAttr,
) -> Option<([Vec3; 4], [CornerAttr; 4])> {
    let (a, b, c) = (p(t[e]), p(t[(e + 1) % 3]), p(t[(e + 2) % 3]));
    let (ua, ub, d) = (p(u[f]), p(u[(f + 1) % 3]), p(u[(f + 2) % 3]));
    let scale = (b - a).length();
    let tol = 1e-4 * scale;
    // Shared edge in opposite directions: u's edge is (b, a).
    if (ua - b).length() > tol || (ub - a).length() > tol {
        return None;
    }
    // Parallelogram: the far corners are symmetric about the diagonal's midpoint.
    if (c + d - a - b).length() > tol {
        return None;
    }
    // Same plane and orientation.
    let n1 = (b - a).cross(c - a);
    let n2 = (a - b).cross(d - b);
    if n1.normalize_or_zero().dot(n2.normalize_or_zero()) < 0.9999 {
        return None;
    }
    // The attributes: the same on both sides of the shared edge, and affine over the whole.
    let (aa, ab, ac) = (attr(t[e]), attr(t[(e + 1) % 3]), attr(t[(e + 2) % 3]));
    let (ua, ub, ad) = (attr(u[f]), attr(u[(f + 1) % 3]), attr(u[(f + 2) % 3]));
    let sum = |x: CornerAttr, y: CornerAttr| CornerAttr::combine([(1.0, x), (1.0, y)]);
    if !(ua.close(&ab) && ub.close(&aa) && sum(ac, ad).close(&sum(aa, ab))) {
        return None;
    }
    // Corners counter-clockwise: a, d, b, c (t = a,b,c is ccw; d lies across edge ab).
    Some(([a, d, b, c], [aa, ad, ab, ac]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square as two triangles, `copies` times over (the same vertices each time).
    fn squares(copies: usize) -> Mesh {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let triangles = (0..copies).flat_map(|_| [[0, 1, 2], [0, 2, 3]]).collect();
        Mesh {
            positions,
            triangles,
            ..Mesh::default()
        }
    }

    /// Triangles sharing one edge by the thousand (a square repeated) still pair, each
    /// with its own partner: every square a quad, as one square alone is.
    #[test]
    fn a_repeated_square_pairs_into_as_many_quads() {
        for copies in [1, 3, 5000] {
            let faces = pair_parallelograms(&squares(copies));
            let quads = faces.iter().filter(|f| matches!(f, Face::Quad(..))).count();
            assert_eq!((faces.len(), quads), (copies, copies));
        }
    }
}
