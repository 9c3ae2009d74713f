//! The indexed triangle mesh of an object, in its own (rest) frame.

use glam::{Affine3A, Vec2, Vec3};

/// Units of rounding a triangle's area may be off by and still be zero
/// ([`Mesh::zero_area_triangles`]).
const ROUNDING: f32 = 4.0 * f32::EPSILON;

/// An indexed triangle mesh in the object's own (rest) frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Counter-clockwise (seen from the front) vertex index triples.
    pub triangles: Vec<[u32; 3]>,
    /// Texture-coordinate sets (glTF `TEXCOORD_n` is `uvs[n]`), each one per vertex;
    /// `(0, 0)` is the image's top-left corner, `v` grows downwards (glTF's convention).
    pub uvs: Vec<Vec<Vec2>>,
    /// Vertex colours (glTF `COLOR_0`, linear RGB in [0, 1], alpha dropped): empty, or one
    /// per vertex. They multiply the material's reflectance.
    pub colors: Vec<Vec3>,
    /// The lightmap's texture coordinates (glTF `TEXCOORD_1`, kept whether or not a texture
    /// reads it: a lightmap UV layer made in Blender is `TEXCOORD_1`): empty, or one per
    /// vertex, finite. `shrad bake --lightmap` lays the object out by them when they are
    /// usable (crates/shrad/src/lightmap/uv_chart.rs).
    pub lightmap_uvs: Vec<Vec2>,
}

impl Mesh {
    /// Axis-aligned bounding box; `None` for an empty mesh.
    pub fn bounds(&self) -> Option<crate::Aabb> {
        crate::Aabb::from_points(self.positions.iter().copied())
    }
    /// Area of triangle `t`.
    pub fn triangle_area(&self, t: usize) -> f32 {
        let [a, b, c] = self.triangles[t].map(|i| self.positions[i as usize]);
        0.5 * (b - a).cross(c - a).length()
    }
    /// The triangles whose area is zero as far as `f32` can tell, or not a number, in
    /// increasing order: at most what rounding can make of its area
    /// (`Mesh::area_and_rounding`). Each triangle is judged by its own size and place, not
    /// the mesh's: a 1 m quad beside a 200 km ground in one mesh was dropped when the floor
    /// was 1e-10 of the mesh's diagonal squared, as was a box with one stray vertex far
    /// away. A triangle under the floor has no direction but its rounding's (its normal is
    /// noise). One with a corner that is not a number is zero too.
    pub fn zero_area_triangles(&self) -> Vec<usize> {
        (0..self.triangles.len())
            .filter(|&t| {
                // Beyond f32's range (corners past about 1e19) is not zero: it is kept for
                // the check of the scene's reach to refuse, naming the object.
                let (area, floor) = self.area_and_rounding(t);
                area.is_nan() || (floor.is_finite() && area <= floor)
            })
            .collect()
    }

    /// [`Mesh::triangle_area`] of triangle `t`, and the most rounding can make it off by:
    /// each edge's components by up to `f32::EPSILON` of the largest coordinate of its two
    /// ends, the cross product by `f32::EPSILON` of the edges' product; with margin, 4
    /// units of rounding ([`ROUNDING`]).
    fn area_and_rounding(&self, t: usize) -> (f32, f32) {
        let [a, b, c] = self.triangles[t].map(|i| self.positions[i as usize]);
        let (e1, e2) = (b - a, c - a);
        let (ab, ac) = (e1.length(), e2.length());
        let reach = |p: Vec3, q: Vec3| p.abs().max(q.abs()).max_element();
        let area = 0.5 * e1.cross(e2).length();
        (
            area,
            ROUNDING * (reach(a, b) * ac + ab * reach(a, c) + ab * ac),
        )
    }
    /// The triangles with the same three corners, facing the same way, as an earlier one
    /// (bit for bit; in increasing order). Such a copy is the same surface twice: it
    /// cannot be seen, yet lit as a patch of its own it would be counted again in every
    /// sum, and every ray that meets it meets all its copies.
    pub fn repeated_triangles(&self) -> Vec<usize> {
        let mut seen = std::collections::HashSet::with_capacity(self.triangles.len());
        (0..self.triangles.len())
            .filter(|&t| {
                let corners = self.triangles[t].map(|i| self.positions[i as usize]);
                !seen.insert(same_way_key(corners))
            })
            .collect()
    }
    /// Remove the triangles `sorted` lists (increasing indices, as
    /// [`Mesh::zero_area_triangles`] gives them); vertices stay.
    pub fn remove_triangles(&mut self, sorted: &[usize]) {
        let mut k = 0;
        self.triangles.retain(|_| {
            let keep = sorted.binary_search(&k).is_err();
            k += 1;
            keep
        });
    }
    /// Total surface area.
    pub fn area(&self) -> f32 {
        (0..self.triangles.len())
            .map(|t| self.triangle_area(t))
            .sum()
    }
    /// A mesh of positions and triangles only.
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        Mesh {
            positions,
            triangles,
            ..Default::default()
        }
    }
    /// Append another mesh (texture coordinates a side lacks are 0, colours 1; lightmap
    /// coordinates are kept only when both sides have them).
    pub fn append(&mut self, other: &Mesh) {
        let base = self.positions.len() as u32;
        let (n, m) = (self.positions.len(), other.positions.len());
        let sets = self.uvs.len().max(other.uvs.len());
        self.uvs.resize(sets, vec![Vec2::ZERO; n]);
        for (k, set) in self.uvs.iter_mut().enumerate() {
            match other.uvs.get(k) {
                Some(o) => set.extend_from_slice(o),
                None => set.resize(n + m, Vec2::ZERO),
            }
        }
        if !self.colors.is_empty() || !other.colors.is_empty() {
            self.colors.resize(n, Vec3::ONE);
            if other.colors.is_empty() {
                self.colors.resize(n + m, Vec3::ONE);
            } else {
                self.colors.extend_from_slice(&other.colors);
            }
        }
        // A lightmap layout only when both sides have one: zeros would fold the other
        // side's triangles onto one point.
        if self.lightmap_uvs.len() == n && other.lightmap_uvs.len() == m {
            self.lightmap_uvs.extend_from_slice(&other.lightmap_uvs);
        } else {
            self.lightmap_uvs.clear();
        }
        self.positions.extend_from_slice(&other.positions);
        self.triangles
            .extend(other.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    /// The triangles `which` lists and only the vertices they use (renumbered in the order
    /// the triangles first use them), with their attributes.
    pub fn subset(&self, which: &[usize]) -> Mesh {
        let mut new_index = vec![u32::MAX; self.positions.len()];
        let mut used: Vec<usize> = Vec::new();
        let triangles = which
            .iter()
            .map(|&t| {
                self.triangles[t].map(|i| {
                    let slot = &mut new_index[i as usize];
                    if *slot == u32::MAX {
                        *slot = used.len() as u32;
                        used.push(i as usize);
                    }
                    *slot
                })
            })
            .collect();
        let pick = |v: &[Vec2]| used.iter().map(|&i| v[i]).collect::<Vec<_>>();
        let lightmap_ok = self.lightmap_uvs.len() == self.positions.len();
        let colors_ok = self.colors.len() == self.positions.len();
        Mesh {
            positions: used.iter().map(|&i| self.positions[i]).collect(),
            triangles,
            uvs: self.uvs.iter().map(|set| pick(set)).collect(),
            colors: match colors_ok {
                true => used.iter().map(|&i| self.colors[i]).collect(),
                false => Vec::new(),
            },
            lightmap_uvs: match lightmap_ok {
                true => pick(&self.lightmap_uvs),
                false => Vec::new(),
            },
        }
    }
    /// The same mesh with every vertex transformed.
    pub fn transformed(&self, m: Affine3A) -> Mesh {
        Mesh {
            positions: self
                .positions
                .iter()
                .map(|&p| m.transform_point3(p))
                .collect(),
            triangles: self.triangles.clone(),
            uvs: self.uvs.clone(),
            colors: self.colors.clone(),
            lightmap_uvs: self.lightmap_uvs.clone(),
        }
    }
}

/// The corners' bits from the smallest corner on, in the triangle's own order: equal for
/// the same triangle whatever corner it starts at, different for its mirror.
fn same_way_key(corners: [Vec3; 3]) -> [u32; 9] {
    let bits = corners.map(|p| p.to_array().map(f32::to_bits));
    let first = (0..3).min_by_key(|&k| bits[k]).unwrap_or(0);
    let mut key = [0u32; 9];
    for k in 0..3 {
        key[3 * k..3 * k + 3].copy_from_slice(&bits[(first + k) % 3]);
    }
    key
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn repeated_triangles_are_the_same_corners_facing_the_same_way() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X, Vec3::Z];
        // 1 is 0 started at another corner, 2 is 0 mirrored, 3 shares the corners through
        // other vertices (3 is at X as 1 is), 4 is another triangle, 5 repeats 2.
        let t = vec![
            [0, 1, 2],
            [1, 2, 0],
            [0, 2, 1],
            [2, 0, 3],
            [0, 1, 4],
            [2, 1, 0],
        ];
        let m = Mesh::new(p, t);
        assert_eq!(m.repeated_triangles(), vec![1, 3, 5]);
    }

    #[test]
    fn zero_area_is_judged_by_each_triangle_own_size_and_place() {
        // A 200 km ground and a 1 m quad in one mesh: both kept (the quad was dropped when
        // the floor was the mesh's diagonal squared x 1e-10).
        let (w, p) = (1e5, [Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.0)]);
        let mut positions = vec![
            Vec3::new(-w, 0.0, -w),
            Vec3::new(w, 0.0, -w),
            Vec3::new(w, 0.0, w),
            Vec3::new(-w, 0.0, w),
        ];
        positions.extend([p[0], p[1], p[1] + Vec3::Z, p[0] + Vec3::Z]);
        let mut m = Mesh::new(positions, vec![[0, 2, 1], [0, 3, 2], [4, 6, 5], [4, 7, 6]]);
        assert!(m.zero_area_triangles().is_empty());
        // Corners on one line (up to rounding), near and far from the origin; a sliver whose
        // height is below what rounding leaves at its place; a NaN corner: all zero.
        let far = Vec3::splat(1e5);
        let line = |o: Vec3| {
            [
                o,
                o + Vec3::new(1.0, 2.0, 3.0),
                o + Vec3::new(3.0, 6.0, 9.0),
            ]
        };
        let sliver = [far, far + Vec3::X, far + Vec3::X * 0.5 + Vec3::Y * 1e-3];
        let mut add = |corners: [Vec3; 3]| {
            let n = m.positions.len() as u32;
            m.positions.extend(corners);
            m.triangles.push([n, n + 1, n + 2]);
        };
        add(line(Vec3::new(0.1, 0.2, 0.3)));
        add(line(far));
        add(sliver);
        add([Vec3::ZERO, Vec3::X, Vec3::NAN]);
        // A small but well-formed triangle far out is not zero, nor one that reaches far.
        add([far, far + Vec3::X * 0.5, far + Vec3::Y * 0.5]);
        add([Vec3::ZERO, Vec3::X * 1e13, Vec3::Y]);
        add([Vec3::ZERO, Vec3::X * 1e37, Vec3::Y]);
        assert_eq!(m.zero_area_triangles(), vec![4, 5, 6, 7]);
    }

    #[test]
    fn a_subset_keeps_its_triangles_vertices_and_their_attributes_only() {
        let mut m = Mesh::new(
            (0..5).map(|k| Vec3::splat(k as f32)).collect(),
            vec![[0, 1, 2], [2, 3, 4], [4, 3, 1]],
        );
        m.uvs = vec![(0..5).map(|k| Vec2::new(k as f32, 0.0)).collect()];
        m.colors = (0..5).map(|k| Vec3::new(0.0, k as f32, 0.0)).collect();
        let s = m.subset(&[2, 1]);
        // Vertices in the order the kept triangles first use them: 4, 3, 1, 2.
        assert_eq!(s.triangles, vec![[0, 1, 2], [3, 1, 0]]);
        let was = [4.0, 3.0, 1.0, 2.0];
        assert_eq!(s.positions, was.map(Vec3::splat).to_vec());
        assert_eq!(s.uvs[0], was.map(|k| Vec2::new(k, 0.0)).to_vec());
        assert_eq!(s.colors, was.map(|k| Vec3::new(0.0, k, 0.0)).to_vec());
        assert!(s.lightmap_uvs.is_empty());
    }
}
