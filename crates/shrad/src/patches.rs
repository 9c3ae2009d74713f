//! Patches (spec section 3): every object's triangles subdivided until no edge is longer
//! than the patch size `h`; planar parallelograms (wall quads, box faces: two triangles that
//! share their longest edge) are divided into a grid of near-square cells, as the paper does
//! ("墙面及地面划分为小正方形", paper 3). A patch is one cell (a parallelogram, two triangles)
//! or one triangle, with one centre, normal and area.
//!
//! Storage is structure-of-arrays, object by object: object `o` owns the contiguous patch
//! range `object_ranges[o]`.
//!
//! **World units under any rest transform** (spec section 3). An object's rest transform
//! `world_from_object` may scale, shear or mirror (a Blender object with unapplied scale, an
//! exporter that instances a unit cube). It is split by a polar decomposition into a rigid
//! part and a *shape*: `world_from_object = world_from_local * local_from_object`, where
//! `local_from_object` (symmetric, possibly with a negative determinant) holds every scale,
//! shear and mirror, and `world_from_local` is a rotation and a translation. Patches are cut
//! and measured in the *local* frame — the object's mesh with its shape applied — so `h`,
//! areas, centres and normals are world quantities, and the probe box stays aligned with the
//! object. Mirroring follows glTF: the mesh's triangles are counter-clockwise from the front
//! in the object frame and world normals are the inverse transpose of object normals; a
//! mirroring shape reverses the local winding so that local cross products point to the
//! front again. When an object later moves rigidly its areas are kept; a transform that
//! scales (an animation's scale keys) re-measures every area from the local one.

use std::ops::Range;

use glam::{Affine3A, Mat3, Vec2, Vec3};
use shrad_scene::{Mesh, Object, Role, Scene};

/// Marks "no patch".
pub const NO_PATCH: u32 = u32::MAX;

/// The surface attributes at a patch corner, interpolated from the source triangle's
/// vertices: what a textured or vertex-coloured material is sampled with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CornerAttr {
    /// Texture coordinates: `[0]` the set the base-colour texture reads, `[1]` the set the
    /// emissive texture reads.
    pub uv: [Vec2; 2],
    /// Vertex colour (1 without `COLOR_0`).
    pub color: Vec3,
}

impl Default for CornerAttr {
    fn default() -> Self {
        CornerAttr {
            uv: [Vec2::ZERO; 2],
            color: Vec3::ONE,
        }
    }
}

impl CornerAttr {
    /// `sum w_k a_k`.
    pub fn combine<const N: usize>(terms: [(f32, CornerAttr); N]) -> CornerAttr {
        let mut r = CornerAttr {
            uv: [Vec2::ZERO; 2],
            color: Vec3::ZERO,
        };
        for (w, a) in terms {
            r.uv[0] += w * a.uv[0];
            r.uv[1] += w * a.uv[1];
            r.color += w * a.color;
        }
        r
    }
    /// The attributes at `(s, t)` of a parallelogram with these corners (bilinear; affine
    /// when the corners are, as [`pair_parallelograms`] makes sure).
    pub fn bilinear(c: &[CornerAttr; 4], s: f32, t: f32) -> CornerAttr {
        CornerAttr::combine([
            ((1.0 - s) * (1.0 - t), c[0]),
            (s * (1.0 - t), c[1]),
            (s * t, c[2]),
            ((1.0 - s) * t, c[3]),
        ])
    }
    /// The attributes at barycentric `(u, v)` of a triangle `c0, c1, c2`.
    pub fn barycentric(c: &[CornerAttr; 4], u: f32, v: f32) -> CornerAttr {
        CornerAttr::combine([(1.0 - u - v, c[0]), (u, c[1]), (v, c[2])])
    }
    fn close(&self, o: &CornerAttr) -> bool {
        let uv =
            |a: Vec2, b: Vec2| (a - b).abs().max_element() <= 1e-5 * (1.0 + a.abs().max_element());
        uv(self.uv[0], o.uv[0])
            && uv(self.uv[1], o.uv[1])
            && (self.color - o.color).abs().max_element() <= 1e-4
    }
}

/// Does object `o` need per-corner attributes (a texture or vertex colours)?
fn needs_attributes(o: &Object) -> bool {
    o.material.is_textured() || !o.mesh.colors.is_empty()
}

/// The attributes of vertex `i` of a local-frame shape (see [`shaped_objects`]).
fn vertex_attr(mesh: &Mesh, i: u32) -> CornerAttr {
    let i = i as usize;
    let uv = |k: usize| {
        mesh.uvs
            .get(k)
            .and_then(|s| s.get(i))
            .copied()
            .unwrap_or(Vec2::ZERO)
    };
    CornerAttr {
        uv: [uv(0), uv(1)],
        color: mesh.colors.get(i).copied().unwrap_or(Vec3::ONE),
    }
}

/// What [`Patches::build`] will make, known before it is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchPlan {
    /// The patch size `h` (world units).
    pub patch_size: f32,
    /// The number of patches (saturating at `usize::MAX`).
    pub count: usize,
}

/// How to choose the patch size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PatchSizing {
    /// Edge length `h` in scene units.
    Size(f32),
    /// About this many patches in the whole scene (the size is found by bisection).
    Count(usize),
}

/// One object's patch mesh in its local frame, for visibility and drawing.
#[derive(Clone, Debug, Default)]
pub struct ObjectMesh {
    /// Corner positions (local frame); not welded.
    pub positions: Vec<Vec3>,
    /// Triangles (counter-clockwise from the front).
    pub triangles: Vec<[u32; 3]>,
    /// Patch id (global) of every triangle.
    pub triangle_patch: Vec<u32>,
}

/// All patches of a scene, structure of arrays.
#[derive(Clone, Debug, Default)]
pub struct Patches {
    /// Owning object of each patch.
    pub object: Vec<u32>,
    /// Corners in the local frame: a parallelogram `c0, c1, c2, c3` or a triangle with
    /// `c3 == c2` (see `is_quad`).
    pub corners: Vec<[Vec3; 4]>,
    /// Is the patch a parallelogram (else a triangle)?
    pub is_quad: Vec<bool>,
    /// Centre in the local frame.
    pub centre_local: Vec<Vec3>,
    /// Unit normal in the local frame.
    pub normal_local: Vec<Vec3>,
    /// Area in the local frame (world units: the rest shape is applied).
    pub area_local: Vec<f32>,
    /// World area at the current transforms (equal to `area_local` under rigid motion).
    pub area: Vec<f32>,
    /// World-space centre (current transforms).
    pub centre: Vec<Vec3>,
    /// World-space unit normal (current transforms).
    pub normal: Vec<Vec3>,
    /// For a double-sided surface: the patch of the other side (same geometry, flipped
    /// normal), else [`NO_PATCH`]. A ray that meets the back of a patch with a twin sees the
    /// twin's front.
    pub twin: Vec<u32>,
    /// Index into `shading_vertices` of each corner (for smooth shading).
    pub corner_vertex: Vec<[u32; 4]>,
    /// Number of shading vertices (corners welded by position and normal, per object).
    pub shading_vertex_count: usize,
    /// Patch range of each object.
    pub object_ranges: Vec<Range<u32>>,
    /// Role of each object.
    pub object_role: Vec<Role>,
    /// Current transform of each object's local frame (rigid unless an animation scales).
    pub world_from_local: Vec<Affine3A>,
    /// The rest shape of each object: its scale, shear and mirroring (see the module docs).
    pub local_from_object: Vec<Mat3>,
    /// Each object's input mesh in its local frame (shape applied, winding made
    /// counter-clockwise from the front there): what the lights' exact irradiance and the
    /// probe boxes are computed from.
    pub shapes: Vec<Mesh>,
    /// Patch mesh of each object, for visibility.
    pub meshes: Vec<ObjectMesh>,
    /// Per-corner surface attributes of the patches of objects that need them (textured or
    /// vertex-coloured); see [`Patches::corner_attrs`].
    pub corner_attr: Vec<[CornerAttr; 4]>,
    /// Where object `o`'s patches start in `corner_attr` (`u32::MAX`: it has none).
    pub attr_offset: Vec<u32>,
    /// The patch size used (the scene's default; objects may override).
    pub patch_size: f32,
}

impl Patches {
    /// Number of patches.
    pub fn len(&self) -> usize {
        self.area_local.len()
    }
    /// No patches at all?
    pub fn is_empty(&self) -> bool {
        self.area_local.is_empty()
    }
    /// Role of patch `p`.
    pub fn role(&self, p: usize) -> Role {
        self.object_role[self.object[p] as usize]
    }
    /// The corner attributes of patch `p` (in corner order; a triangle repeats its last),
    /// or `None` for an untextured object without vertex colours.
    pub fn corner_attrs(&self, p: usize) -> Option<&[CornerAttr; 4]> {
        let o = self.object[p] as usize;
        let off = *self.attr_offset.get(o)?;
        if off == u32::MAX {
            return None;
        }
        self.corner_attr
            .get(off as usize + p - self.object_ranges[o].start as usize)
    }
    /// Patches of object `o` as a `usize` range.
    pub fn range(&self, o: usize) -> Range<usize> {
        let r = &self.object_ranges[o];
        r.start as usize..r.end as usize
    }

    /// The patch size and the number of patches that [`Patches::build`] would make, found
    /// without making them (so that an absurd size is refused before anything is allocated).
    pub fn plan(scene: &Scene, sizing: PatchSizing) -> PatchPlan {
        let shaped = shaped_objects(scene);
        let faces: Vec<Vec<Face>> = shaped
            .iter()
            .map(|(_, _, m)| pair_parallelograms(m))
            .collect();
        let h = match sizing {
            PatchSizing::Size(h) => h,
            PatchSizing::Count(n) => size_for_count(scene, &shaped, &faces, n),
        };
        PatchPlan {
            patch_size: h,
            count: count_patches(scene, &shaped, &faces, h),
        }
    }

    /// Subdivide every object of `scene`. See [`Patches::plan`] for the count beforehand.
    pub fn build(scene: &Scene, sizing: PatchSizing) -> Patches {
        let shaped = shaped_objects(scene);
        let h = match sizing {
            PatchSizing::Size(h) => h,
            PatchSizing::Count(n) => {
                let faces: Vec<Vec<Face>> = shaped
                    .iter()
                    .map(|(_, _, m)| pair_parallelograms(m))
                    .collect();
                size_for_count(scene, &shaped, &faces, n)
            }
        };
        let mut patches = Patches {
            patch_size: h,
            ..Default::default()
        };
        let mut welder = Welder::default();
        for (oi, (object, (world_from_local, local_from_object, shape))) in
            scene.objects.iter().zip(shaped).enumerate()
        {
            let start = patches.len() as u32;
            let mesh = ObjectMesh::default();
            patches.meshes.push(mesh);
            let oh = object.patch_size.unwrap_or(h);
            welder.next_object(&shape);
            let with_attrs = needs_attributes(object);
            patches.attr_offset.push(if with_attrs {
                patches.corner_attr.len() as u32
            } else {
                u32::MAX
            });
            for cell in subdivide(&shape, oh) {
                if with_attrs {
                    patches.corner_attr.push(cell.attrs);
                }
                patches.push_cell(oi as u32, cell, &mut welder, false);
                if object.material.double_sided {
                    let me = patches.len() as u32 - 1;
                    fn flip<T: Copy>(c: [T; 4], quad: bool) -> [T; 4] {
                        if quad {
                            [c[0], c[3], c[2], c[1]]
                        } else {
                            [c[0], c[2], c[1], c[1]]
                        }
                    }
                    let flipped = Cell {
                        corners: flip(cell.corners, cell.is_quad),
                        attrs: flip(cell.attrs, cell.is_quad),
                        is_quad: cell.is_quad,
                    };
                    if with_attrs {
                        patches.corner_attr.push(flipped.attrs);
                    }
                    patches.push_cell(oi as u32, flipped, &mut welder, true);
                    let twin = patches.len() as u32 - 1;
                    patches.twin[me as usize] = twin;
                    patches.twin[twin as usize] = me;
                }
            }
            patches.object_ranges.push(start..patches.len() as u32);
            patches.object_role.push(object.role());
            patches.world_from_local.push(world_from_local);
            patches.local_from_object.push(local_from_object);
            patches.shapes.push(shape);
        }
        patches.shading_vertex_count = welder.count;
        patches.centre = patches.centre_local.clone();
        patches.normal = patches.normal_local.clone();
        patches.area = patches.area_local.clone();
        for o in 0..scene.objects.len() {
            patches.update_world(o);
        }
        patches
    }

    fn push_cell(&mut self, object: u32, cell: Cell, welder: &mut Welder, geometry_shared: bool) {
        let id = self.len() as u32;
        let c = cell.corners;
        let (centre, cross) = if cell.is_quad {
            (
                0.25 * (c[0] + c[1] + c[2] + c[3]),
                (c[1] - c[0]).cross(c[3] - c[0]),
            )
        } else {
            (
                (c[0] + c[1] + c[2]) / 3.0,
                0.5 * (c[1] - c[0]).cross(c[2] - c[0]),
            )
        };
        let normal = cross.normalize_or_zero();
        self.object.push(object);
        self.corners.push(c);
        self.is_quad.push(cell.is_quad);
        self.centre_local.push(centre);
        self.normal_local.push(normal);
        self.area_local.push(cross.length());
        self.twin.push(NO_PATCH);
        self.corner_vertex.push(c.map(|p| welder.vertex(p, normal)));
        if geometry_shared {
            // The twin has no triangles of its own: rays that meet the back of the front
            // patch are redirected to it.
            return;
        }
        let mesh = &mut self.meshes[object as usize];
        let base = mesh.positions.len() as u32;
        if cell.is_quad {
            mesh.positions.extend_from_slice(&c);
            mesh.triangles.push([base, base + 1, base + 2]);
            mesh.triangles.push([base, base + 2, base + 3]);
            mesh.triangle_patch.extend([id, id]);
        } else {
            mesh.positions.extend_from_slice(&c[..3]);
            mesh.triangles.push([base, base + 1, base + 2]);
            mesh.triangle_patch.push(id);
        }
    }

    /// The transform of object `o`'s local frame that puts the object at
    /// `world_from_object` (its rest transform, or that moved by an animation).
    pub fn local_transform_for(&self, o: usize, world_from_object: Affine3A) -> Affine3A {
        world_from_object * Affine3A::from_mat3(self.local_from_object[o].inverse())
    }

    /// Set object `o`'s local-frame transform (see [`Patches::local_transform_for`]) and
    /// recompute its patches' world centres, normals and, if it does not keep lengths,
    /// areas.
    pub fn set_transform(&mut self, o: usize, world_from_local: Affine3A) {
        self.world_from_local[o] = world_from_local;
        self.update_world(o);
    }

    fn update_world(&mut self, o: usize) {
        let m = self.world_from_local[o];
        let normal_matrix = m.matrix3.inverse().transpose();
        let rigid = is_rigid(Mat3::from(m.matrix3));
        let det = m.matrix3.determinant().abs();
        for p in self.range(o) {
            self.centre[p] = m.transform_point3(self.centre_local[p]);
            let n = normal_matrix * glam::Vec3A::from(self.normal_local[p]);
            self.normal[p] = n.normalize_or_zero().into();
            // A planar element of area A and normal n maps to area |det L| |L^-T n| A.
            self.area[p] = if rigid {
                self.area_local[p]
            } else {
                self.area_local[p] * det * n.length()
            };
        }
    }

    /// World-space corners of patch `p` (4; a triangle repeats its last corner).
    pub fn world_corners(&self, p: usize) -> [Vec3; 4] {
        let m = self.world_from_local[self.object[p] as usize];
        self.corners[p].map(|c| m.transform_point3(c))
    }

    /// A point of patch `p` (world) from two numbers in [0,1)^2, uniform in area.
    pub fn sample_point(&self, p: usize, u: f32, v: f32) -> Vec3 {
        let c = self.world_corners(p);
        if self.is_quad[p] {
            c[0] + u * (c[1] - c[0]) + v * (c[3] - c[0])
        } else {
            let su = u.sqrt();
            c[0] * (1.0 - su) + c[1] * (su * (1.0 - v)) + c[2] * (su * v)
        }
    }

    /// Total count of patches by role `(boundary, interior, light)`.
    pub fn count_by_role(&self) -> (usize, usize, usize) {
        let mut n = (0, 0, 0);
        for (o, r) in self.object_ranges.iter().enumerate() {
            let k = (r.end - r.start) as usize;
            match self.object_role[o] {
                Role::Boundary => n.0 += k,
                Role::Interior => n.1 += k,
                Role::Light => n.2 += k,
            }
        }
        n
    }
}

/// Split a rest transform into a rigid part and a shape (polar decomposition, Higham's
/// iteration `R <- (R + R^-T) / 2` in f64): `world_from_object = world_from_local *
/// local_from_object`, with `world_from_local` a proper rotation and a translation and
/// `local_from_object = R^T L` (symmetric; negative determinant for a mirror).
pub fn split_rest_transform(world_from_object: Affine3A) -> (Affine3A, Mat3) {
    let l = Mat3::from(world_from_object.matrix3).as_dmat3();
    let det = l.determinant();
    if !det.is_finite() || det.abs() < 1e-300 {
        return (world_from_object, Mat3::IDENTITY);
    }
    // -L has the opposite determinant in 3D, so its orthogonal factor is a proper rotation.
    let mut r = if det < 0.0 { -l } else { l };
    for _ in 0..100 {
        let next = 0.5 * (r + r.inverse().transpose());
        let change: f64 = (next - r)
            .to_cols_array()
            .iter()
            .map(|x| x.abs())
            .fold(0.0, f64::max);
        r = next;
        if change < 1e-15 {
            break;
        }
    }
    let shape = r.transpose() * l;
    let rigid = Affine3A::from_mat3_translation(r.as_mat3(), world_from_object.translation.into());
    (rigid, shape.as_mat3())
}

/// Does `m` keep lengths (a rotation, possibly mirrored), within float precision?
fn is_rigid(m: Mat3) -> bool {
    let e = m.transpose() * m - Mat3::IDENTITY;
    e.to_cols_array().iter().all(|x| x.abs() < 1e-5)
}

/// `object`'s mesh with `local_from_object` applied; a mirroring shape reverses the winding
/// so that the local cross products point to the front (glTF: front = object-frame CCW
/// side). Its attributes are only those the patches carry: `uvs[0]` the set the base-colour
/// texture reads, `uvs[1]` the emissive one's, and the vertex colours.
fn shape_mesh(object: &Object, local_from_object: Mat3) -> Mesh {
    let mesh = &object.mesh;
    let mirror = local_from_object.determinant() < 0.0;
    let material = &object.material;
    let set = |t: &Option<shrad_scene::Texture>| {
        t.as_ref()
            .and_then(|t| mesh.uvs.get(t.tex_coord as usize))
            .cloned()
            .unwrap_or_else(|| vec![Vec2::ZERO; mesh.positions.len()])
    };
    let uvs = if material.is_textured() {
        vec![
            set(&material.base_color_texture),
            set(&material.emissive_texture),
        ]
    } else {
        Vec::new()
    };
    Mesh {
        uvs,
        colors: mesh.colors.clone(),
        positions: mesh
            .positions
            .iter()
            .map(|&p| local_from_object * p)
            .collect(),
        triangles: mesh
            .triangles
            .iter()
            .map(|&[a, b, c]| if mirror { [a, c, b] } else { [a, b, c] })
            .collect(),
    }
}

/// One patch before it is stored: a parallelogram or a triangle (local frame).
#[derive(Clone, Copy, Debug)]
struct Cell {
    corners: [Vec3; 4],
    attrs: [CornerAttr; 4],
    is_quad: bool,
}

/// Welds patch corners into shading vertices per object: corners at the same (quantised)
/// position share a vertex when their normals are within the crease angle of the vertex's
/// first normal, so a tessellated sphere shades smooth across its facets while a box's
/// edges stay crisp.
#[derive(Default)]
struct Welder {
    /// Quantised position -> the vertices there, with the normal that opened each.
    map: std::collections::HashMap<[i64; 3], Vec<(Vec3, u32)>>,
    count: usize,
    /// 1 / the quantum of [`quantum`]: positions that round together are one vertex.
    inv_quantum: f32,
}

/// Cosine of the crease angle (40 degrees): a 24-segment sphere's facets (15 degrees apart)
/// weld, a box's edges (90 degrees) and a 6-sided prism's (60 degrees) do not.
const CREASE_COS: f32 = 0.766;

impl Welder {
    fn next_object(&mut self, shape: &Mesh) {
        self.map.clear();
        self.inv_quantum = 1.0 / quantum(shape);
    }
    fn vertex(&mut self, p: Vec3, n: Vec3) -> u32 {
        let qp = (p * self.inv_quantum).round().as_i64vec3().to_array();
        let here = self.map.entry(qp).or_default();
        if let Some(&(_, id)) = here.iter().find(|(m, _)| m.dot(n) >= CREASE_COS) {
            return id;
        }
        let id = self.count as u32;
        here.push((n, id));
        self.count += 1;
        id
    }
}

/// The length below which two positions of `mesh` are the same point: 1e-5 of its size,
/// so welding and pairing behave alike whatever the scene's unit.
fn quantum(mesh: &Mesh) -> f32 {
    let size = mesh
        .bounds()
        .map_or(1.0, |(lo, hi)| (hi - lo).max_element());
    (1e-5 * size).max(f32::MIN_POSITIVE)
}

/// The cells of one (local-frame) mesh at patch size `h`.
fn subdivide(mesh: &Mesh, h: f32) -> Vec<Cell> {
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

fn cells_along(length: f32, h: f32) -> usize {
    if h > 0.0 && h.is_finite() {
        ((length / h) * (1.0 - 1e-5)).ceil().clamp(1.0, 1e6) as usize
    } else {
        1
    }
}

enum Face {
    /// Parallelogram corners, counter-clockwise, and their attributes.
    Quad([Vec3; 4], [CornerAttr; 4]),
    Triangle([u32; 3]),
}

/// Pair triangles that share their longest edge and together form a planar parallelogram
/// (the usual export of a quad) over which the attributes (texture coordinates, colours)
/// are affine and continuous; the rest stay triangles. Deterministic: triangle order.
fn pair_parallelograms(mesh: &Mesh) -> Vec<Face> {
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
    let mut by_edge: HashMap<([i64; 3], [i64; 3]), Vec<usize>> = HashMap::new();
    for (ti, t) in mesh.triangles.iter().enumerate() {
        let e = longest_edge(t);
        let (ka, kb) = (tri_keys[ti][e], tri_keys[ti][(e + 1) % 3]);
        let k = if ka <= kb { (ka, kb) } else { (kb, ka) };
        by_edge.entry(k).or_default().push(ti);
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
        for &other in by_edge.get(&k).into_iter().flatten() {
            if used[other] {
                continue;
            }
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
fn parallelogram(
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

/// Patch size that gives about `n` patches, by bisection on the count (cheap: no geometry).
fn size_for_count(scene: &Scene, shaped: &[ShapedObject], faces: &[Vec<Face>], n: usize) -> f32 {
    let count = |h: f32| count_patches(scene, shaped, faces, h);
    let total_area: f32 = shaped.iter().map(|(_, _, m)| m.area()).sum();
    let mut lo = (total_area / (n.max(1) as f32) / 50.0).sqrt();
    let mut hi = (total_area / (n.max(1) as f32) * 50.0).sqrt().max(lo * 2.0);
    for _ in 0..40 {
        let mid = (lo * hi).sqrt();
        if count(mid) > n {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    // The coarser of the two brackets never overshoots the target by much.
    if count(lo).abs_diff(n) < count(hi).abs_diff(n) {
        lo
    } else {
        hi
    }
}

/// Every object's rest transform split, and its mesh in the local frame.
type ShapedObject = (Affine3A, Mat3, Mesh);

fn shaped_objects(scene: &Scene) -> Vec<ShapedObject> {
    scene
        .objects
        .iter()
        .map(|o| {
            let (world_from_local, local_from_object) = split_rest_transform(o.world_from_object);
            (
                world_from_local,
                local_from_object,
                shape_mesh(o, local_from_object),
            )
        })
        .collect()
}

/// Patches of the whole scene at size `h` (double-sided objects count twice), saturating.
fn count_patches(scene: &Scene, shaped: &[ShapedObject], faces: &[Vec<Face>], h: f32) -> usize {
    scene
        .objects
        .iter()
        .zip(shaped.iter().zip(faces))
        .map(|(o, ((_, _, mesh), faces))| {
            let sides = if o.material.double_sided { 2 } else { 1 };
            let oh = o.patch_size.unwrap_or(h);
            count_faces(mesh, faces, oh).saturating_mul(sides)
        })
        .fold(0usize, usize::saturating_add)
}

/// How many cells `faces` (of `mesh`) give at patch size `h`, saturating (no overflow for
/// an absurd `h`): what [`subdivide`] would make, without making it.
fn count_faces(mesh: &Mesh, faces: &[Face], h: f32) -> usize {
    let p = |i: u32| mesh.positions[i as usize];
    faces
        .iter()
        .map(|f| match f {
            Face::Quad(c, _) => cells_along((c[1] - c[0]).length(), h)
                .saturating_mul(cells_along((c[3] - c[0]).length(), h)),
            Face::Triangle(t) => {
                let [a, b, c] = t.map(p);
                let n = cells_along(
                    (b - a).length().max((c - b).length()).max((a - c).length()),
                    h,
                );
                n.saturating_mul(n)
            }
        })
        .fold(0usize, usize::saturating_add)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cornell_walls_become_squares_and_area_is_kept() {
        let scene = shrad_scene::cornell_box();
        let patches = Patches::build(&scene, PatchSizing::Size(20.0));
        for (o, object) in scene.objects.iter().enumerate() {
            let area: f32 = patches.range(o).map(|p| patches.area[p]).sum();
            let want = object.mesh.transformed(object.world_from_object).area();
            assert!(
                (area - want).abs() < 1e-3 * want,
                "{}: {area} vs {want}",
                object.name
            );
            assert!(
                patches.range(o).all(|p| patches.is_quad[p]),
                "{} has triangles",
                object.name
            );
        }
        // Walls of ~556 at h = 20 give 28 cells per side.
        let floor = patches.range(0);
        assert_eq!(floor.len(), 28 * 28);
        let max_edge = patches
            .corners
            .iter()
            .map(|c| (c[1] - c[0]).length().max((c[3] - c[0]).length()))
            .fold(0.0, f32::max);
        assert!(max_edge <= 20.0 + 1e-3, "max edge {max_edge}");
    }

    #[test]
    fn corners_weld_across_facets_but_not_across_creases() {
        // A tessellated sphere (facets 15 degrees apart): one shading vertex per position.
        let mut scene = shrad_scene::room(&Default::default());
        scene.objects.retain(|o| o.name.starts_with("sphere"));
        scene.objects.truncate(1);
        let sphere = Patches::build(&scene, PatchSizing::Size(0.05));
        let positions: std::collections::HashSet<[i64; 3]> = sphere
            .corners
            .iter()
            .flatten()
            .map(|p| {
                (*p / quantum(&sphere.shapes[0]))
                    .round()
                    .as_i64vec3()
                    .to_array()
            })
            .collect();
        assert_eq!(sphere.shading_vertex_count, positions.len());
        // A box: the 8 corners of the short box each belong to 3 faces at right angles,
        // which must not share a vertex.
        let scene = shrad_scene::cornell_box();
        let o = scene
            .objects
            .iter()
            .position(|o| o.name.contains("short"))
            .expect("the short box");
        let patches = Patches::build(&scene, PatchSizing::Size(20.0));
        for i in patches.range(o) {
            for j in patches.range(o) {
                let shared = patches.corner_vertex[i]
                    .iter()
                    .any(|v| patches.corner_vertex[j].contains(v));
                if shared {
                    assert!(
                        patches.normal[i].dot(patches.normal[j]) > 0.9,
                        "patches {i} and {j} share a vertex across a crease"
                    );
                }
            }
        }
    }

    #[test]
    fn patch_count_target_is_met() {
        let scene = shrad_scene::cornell_box();
        let patches = Patches::build(&scene, PatchSizing::Count(20_000));
        let n = patches.len() as f32;
        assert!((n - 20_000.0).abs() < 0.1 * 20_000.0, "{n}");
    }

    #[test]
    fn triangles_subdivide_with_area_kept() {
        let mut scene = shrad_scene::room(&Default::default());
        scene.objects.retain(|o| o.name.starts_with("sphere"));
        let patches = Patches::build(&scene, PatchSizing::Size(0.05));
        let o = &scene.objects[0];
        let area: f32 = patches.range(0).map(|p| patches.area[p]).sum();
        assert!((area - o.mesh.area()).abs() < 1e-3 * area);
        // Normals of a closed sphere point outward.
        let centre: Vec3 = o.world_from_object.translation.into();
        assert!(patches
            .range(0)
            .all(|p| patches.normal[p].dot(patches.centre[p] - centre) > 0.0));
    }

    #[test]
    fn world_normals_follow_rotation() {
        let scene = shrad_scene::cornell_box();
        let patches = Patches::build(&scene, PatchSizing::Size(50.0));
        let short = scene
            .objects
            .iter()
            .position(|o| o.name == "short_block")
            .unwrap();
        // The block's top face points up in the world.
        assert!(patches.range(short).any(|p| patches.normal[p].y > 0.999));
        assert!(patches
            .range(short)
            .all(|p| (patches.normal[p].length() - 1.0).abs() < 1e-4));
    }
}
