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
//!
//! One idea per file: `attrs.rs` (per-corner texture coordinates and colours), `shape.rs`
//! (the rest transform split into a rigid part and a shape), `split.rs` (quads paired into
//! parallelograms and cut into cells, triangles into sub-triangles), `weld.rs` (corners
//! welded into shading vertices), `plan.rs` (the patch count and size found without making
//! the patches), and here the storage and its accessors.

mod attrs;
mod plan;
mod shape;
mod sizing;
mod split;
#[cfg(test)]
mod tests;
mod weld;

use std::ops::Range;

use glam::{Affine3A, Mat3, Vec3};
use shrad_scene::{Aabb, Mesh, Role, Scene};

pub use attrs::CornerAttr;
pub use shape::split_rest_transform;

use attrs::needs_attributes;
use plan::{count_patches, size_for_count};
use shape::{is_rigid, shaped_objects};
use split::{pair_parallelograms, subdivide, Cell, Face};
use weld::Welder;

/// Marks "no patch".
pub const NO_PATCH: u32 = u32::MAX;

/// What [`Patches::build`] will make, known before it is made.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PatchPlan {
    /// The patch size `h` (world units).
    pub patch_size: f32,
    /// The number of patches (saturating at `usize::MAX`).
    pub count: usize,
    /// Of the objects with a patch size of their own, the one with the most patches: a too
    /// small size there is reported with its name (`limits::check_patches`).
    pub heaviest_own: Option<OwnSized>,
}

/// An object's own patch size and the patches it makes ([`PatchPlan::heaviest_own`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OwnSized {
    /// Its index in the scene.
    pub object: usize,
    /// Its own patch size.
    pub patch_size: f32,
    /// The patches it makes (saturating).
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
    /// Each object's world box and sphere where it is now ([`Patches::world_box`],
    /// [`Patches::world_sphere`]), kept by [`Patches::set_transform`]: a pass over the
    /// shape's vertices when it moves, not at each of the several asks of a moving frame.
    world_bounds: Vec<(Aabb, Option<(Vec3, f32)>)>,
    /// Each object's shape's box in its local frame (`None` without vertices), found once
    /// ([`Patches::shape_bounds`]): every move and every check of a pose reads it.
    shape_bounds: Vec<Option<Aabb>>,
    /// The rest shape of each object: its scale, shear and mirroring (see the module docs).
    pub local_from_object: Vec<Mat3>,
    /// Each object's input mesh in its local frame (shape applied, winding made
    /// counter-clockwise from the front there): what the lights' exact irradiance and the
    /// probe boxes are computed from.
    pub shapes: Vec<Mesh>,
    /// Patch mesh of each object, for visibility: [`crate::World::new`] hands them to the
    /// visibility backend, which keeps its own copy, and leaves this empty.
    pub meshes: Vec<ObjectMesh>,
    /// Per-corner surface attributes of the patches of objects that need them (textured or
    /// vertex-coloured); see [`Patches::corner_attrs`].
    pub corner_attr: Vec<[CornerAttr; 4]>,
    /// Where object `o`'s patches start in `corner_attr` (`u32::MAX`: it has none).
    pub attr_offset: Vec<u32>,
    /// The lightmap texture coordinates (the mesh's `lightmap_uvs`) at the corners of the
    /// patches of objects that have them; see [`Patches::lightmap_uvs`].
    pub lightmap_uv: Vec<[glam::Vec2; 4]>,
    /// Where object `o`'s patches start in `lightmap_uv` (`u32::MAX`: it has none).
    pub lightmap_offset: Vec<u32>,
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
    /// The lightmap texture coordinates of patch `p`'s corners (corner order; a triangle
    /// repeats its last), or `None` when its object's mesh has none.
    pub fn lightmap_uvs(&self, p: usize) -> Option<&[glam::Vec2; 4]> {
        let o = self.object[p] as usize;
        let off = *self.lightmap_offset.get(o)?;
        if off == u32::MAX {
            return None;
        }
        self.lightmap_uv
            .get(off as usize + p - self.object_ranges[o].start as usize)
    }
    /// Patches of object `o` as a `usize` range.
    pub fn range(&self, o: usize) -> Range<usize> {
        let r = &self.object_ranges[o];
        r.start as usize..r.end as usize
    }

    /// Where the patches of `objects` sit in `sorted` (patch indices, ascending), ascending:
    /// a binary search per object (an object's patches are a range), not a pass over
    /// `sorted` (a cache's receivers: the 1M-patch room's million).
    pub fn positions_in(
        &self,
        sorted: &[u32],
        objects: impl IntoIterator<Item = usize>,
    ) -> Vec<usize> {
        debug_assert!(sorted.is_sorted());
        let mut out: Vec<usize> = Vec::new();
        for o in objects {
            let r = self.range(o);
            let lo = sorted.partition_point(|&i| (i as usize) < r.start);
            let hi = sorted.partition_point(|&i| (i as usize) < r.end);
            out.extend(lo..hi);
        }
        out.sort_unstable();
        out.dedup();
        out
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
            heaviest_own: plan::heaviest_own(scene, &shaped, &faces),
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
            let with_lightmap = !shape.lightmap_uvs.is_empty();
            patches.lightmap_offset.push(if with_lightmap {
                patches.lightmap_uv.len() as u32
            } else {
                u32::MAX
            });
            for cell in subdivide(&shape, oh) {
                if with_attrs {
                    patches.corner_attr.push(cell.attrs);
                }
                if with_lightmap {
                    patches.lightmap_uv.push(cell.attrs.map(|a| a.lightmap));
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
                    if with_lightmap {
                        patches.lightmap_uv.push(flipped.attrs.map(|a| a.lightmap));
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
            patches.shape_bounds.push(shape.bounds());
            patches.shapes.push(shape);
        }
        patches.shading_vertex_count = welder.count;
        patches.centre = patches.centre_local.clone();
        patches.normal = patches.normal_local.clone();
        patches.area = patches.area_local.clone();
        patches.world_bounds = vec![(Aabb::EMPTY, None); scene.objects.len()];
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
        self.world_bounds[o] = (self.shape_box(o), self.shape_sphere(o));
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

    /// Object `o`'s world box where it is now: its shape's box transformed (empty, at the
    /// origin, for a shape without vertices).
    pub fn world_box(&self, o: usize) -> Aabb {
        self.world_bounds[o].0
    }

    /// A sphere (world centre, radius) holding object `o`'s surface where it is now: about
    /// its shape's box centre, through its farthest vertex (every patch lies in the hull of
    /// the vertices). A ball's is 1/sqrt(3) of its world box's own sphere, and a ray it may
    /// block must meet it (`direct/mover_spheres.rs`). `None` for a shape without vertices.
    pub fn world_sphere(&self, o: usize) -> Option<(Vec3, f32)> {
        self.world_bounds[o].1
    }

    /// [`Patches::world_box`] found again from the shape.
    fn shape_box(&self, o: usize) -> Aabb {
        match self.shape_bounds(o) {
            Some(local) => local.transformed(self.world_from_local[o]),
            None => Aabb::new(Vec3::ZERO, Vec3::ZERO),
        }
    }

    /// Object `o`'s shape's box in its local frame (`None` for a shape without vertices).
    pub fn shape_bounds(&self, o: usize) -> Option<Aabb> {
        self.shape_bounds[o]
    }

    /// [`Patches::world_sphere`] found again from the shape.
    fn shape_sphere(&self, o: usize) -> Option<(Vec3, f32)> {
        let m = self.world_from_local[o];
        let shape = &self.shapes[o];
        let centre = m.transform_point3(self.shape_bounds(o)?.centre());
        let radius = (shape.positions.iter())
            .map(|&v| (m.transform_point3(v) - centre).length())
            .fold(0.0, f32::max);
        Some((centre, radius))
    }

    /// World-space corners of patch `p` (4; a triangle repeats its last corner).
    pub fn world_corners(&self, p: usize) -> [Vec3; 4] {
        let m = self.world_from_local[self.object[p] as usize];
        self.corners[p].map(|c| m.transform_point3(c))
    }

    /// The largest distance from patch `p`'s centre to its corners (world): a sphere at
    /// the centre with this radius holds the patch.
    pub fn radius(&self, p: usize) -> f32 {
        let c = self.centre[p];
        (self.world_corners(p).iter())
            .map(|&v| (v - c).length())
            .fold(0.0, f32::max)
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
