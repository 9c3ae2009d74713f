//! One mesh instance: each triangle primitive of a node's mesh becomes an object (positions,
//! morphed by the weights at rest, then placed by the node's skin if it has one, see `skin`;
//! indices, texture coordinates, vertex colours, the shrad extras of the node and mesh). A
//! primitive whose material is seen nowhere (alpha, see `material::cut_away`) is left out
//! with a warning; a MASK primitive with a base colour texture is cut by its alpha (see
//! `cutout`).

use glam::{Affine3A, Mat4, Vec3};
use gltf::mesh::Mode;
use serde_json::Value;

use super::{walk::Walk, PartNames};
use crate::{Material, Mesh, Object, Role, SceneError, MAX_COORDINATE};

/// The named parent whose name and extras an unnamed mesh node takes, if it has one.
/// gltfpack (meshoptimizer) moves each mesh of a named node to an unnamed child, so that the
/// names and `extras` a file gave its objects (roles: light, boundary, interior) are on the
/// parent; a viewer's outliner shows the parent's name.
fn named_parent<'a, 'd>(inst: &Instance<'a, 'd>) -> Option<&'a gltf::Node<'d>> {
    inst.node
        .filter(|n| n.name().is_none())
        .and(inst.parent)
        .filter(|p| p.name().is_some())
}

/// Why `prim` is skipped, if `unpack` marked it so (its data is not in the file).
fn no_data_mark(prim: &gltf::Primitive) -> Option<String> {
    let raw = prim.extras().as_ref()?;
    let v: Value = serde_json::from_str(raw.get()).ok()?;
    super::unpack::no_data::skipped(&v).map(str::to_string)
}

/// One primitive's mesh and material, and what its objects take from its node and mesh
/// ([`Walk::push_objects`]).
struct Drawn {
    mesh: Mesh,
    material: crate::Material,
    name: String,
    world_from_object: Affine3A,
    role: Option<Role>,
    patch_size: Option<f32>,
    names: PartNames,
}

/// Where a mesh is drawn: by a node, or (a file without scenes, a library of meshes) once at
/// the origin.
pub(super) struct Instance<'a, 'd> {
    /// The node that instances the mesh; None for a mesh of a library placed at the origin.
    pub node: Option<&'a gltf::Node<'d>>,
    /// That node's parent, if any.
    pub parent: Option<&'a gltf::Node<'d>>,
    /// The world transform of what is drawn: the node's, times the instance's own when
    /// `instance` is given.
    pub world: Mat4,
    /// Which instance of an instanced node (`instancing`) this is, with its own transform
    /// in the node's frame.
    pub instance: Option<(usize, Mat4)>,
    /// The node's skin, if it has one: its mesh is then placed by the skin (see `skin`).
    pub skin: Option<usize>,
    /// How messages name the instance: `nodes[3] 'lamp'`, or `placed at the origin`.
    pub label: String,
}

impl Walk<'_> {
    /// The objects of `mesh` drawn by `inst`: one per triangle primitive with area.
    pub(super) fn mesh(&mut self, inst: &Instance, mesh: &gltf::Mesh) -> Result<(), SceneError> {
        let path = self.path;
        let bad = |m: String| SceneError::invalid(path, m);
        let (mut node_role, mut node_patch) = match inst.node {
            Some(node) => super::extras::extras_of(node.extras(), &inst.label).map_err(bad)?,
            None => (None, None),
        };
        let (mesh_role, mesh_patch) =
            super::extras::extras_of(mesh.extras(), &format!("meshes[{}]", mesh.index()))
                .map_err(bad)?;
        let named = named_parent(inst);
        if let Some(parent) = named {
            // gltfpack moves a named node's mesh to an unnamed child: the object is the
            // parent's, by name and by the roles its extras give.
            let label = format!("nodes[{}]", parent.index());
            let (role, patch) = super::extras::extras_of(parent.extras(), &label).map_err(bad)?;
            node_role = node_role.or(role);
            node_patch = node_patch.or(patch);
        }
        let node_name = inst
            .node
            .and_then(gltf::Node::name)
            .or(named.and_then(gltf::Node::name));
        let base_name = object_base_name(inst, mesh, node_name);
        // A mirroring transform (negative determinant) is kept as it is: the mesh stays
        // counter-clockwise from the front in its own frame, and the world normal is the
        // inverse transpose of the local one (glTF 2.0, "Transformations").
        let world_from_object = Affine3A::from_mat4(inst.world);
        // The morph target weights at rest (glTF 2.0, "Morph Targets"): the node's, else the
        // mesh's, else all 0. An animation of them is not played (`anim` warns).
        let weights = inst
            .node
            .and_then(gltf::Node::weights)
            .or(mesh.weights())
            .unwrap_or(&[]);
        let skinning = self.skin_of(inst).map_err(bad)?;
        let n_prims = mesh.primitives().len();
        for prim in mesh.primitives() {
            let at = Place {
                who: format!("meshes[{}].primitives[{}]", mesh.index(), prim.index()),
                inst: format!(" ({})", inst.label),
            };
            if let Some(why) = super::material::cut_away(&prim.material()) {
                let mesh_name = mesh
                    .name()
                    .map(|n| format!(" of mesh '{n}'"))
                    .unwrap_or_default();
                self.scene.warnings.push(format!(
                    "{}{mesh_name}{}: skipped (it neither reflects nor blocks light): {why}",
                    at.who, at.inst
                ));
                continue;
            }
            let skinned = self.skinned(skinning.as_ref(), &prim, &at);
            let Some(mut shape) = self
                .primitive_shape(&prim, weights, skinned, &at)
                .map_err(bad)?
            else {
                continue;
            };
            let reader = prim.reader(|b| self.buffers.get(b.index()).map(|d| d.0.as_slice()));
            let mut material = self.material(&prim.material());
            self.attributes(&reader, &mut shape, &mut material, &at.both())
                .map_err(bad)?;
            // After the material and attributes, so that a primitive without area has been
            // read (and checked) as far as any other.
            if !self.drop_zero_area(&mut shape, &at.both())
                || !self.cut_mask(&prim, &reader, &mut shape, &material, &at)
            {
                continue;
            }
            let name = if n_prims > 1 {
                format!("{base_name}.{}", prim.index())
            } else {
                base_name.clone()
            };
            let drawn = Drawn {
                mesh: shape,
                material,
                name,
                world_from_object,
                role: node_role.or(mesh_role),
                patch_size: node_patch.or(mesh_patch),
                names: PartNames {
                    node: node_name.map(str::to_string),
                    mesh: mesh.name().map(str::to_string),
                },
            };
            self.push_objects(inst, &prim, skinned, drawn, &at)
                .map_err(bad)?;
        }
        Ok(())
    }

    /// The objects of primitive `prim`'s mesh `shape` as `inst` draws it: one, or one per
    /// joint of a skin the animation moves (`skin::rigid_parts`), each named, placed and
    /// animated.
    fn push_objects(
        &mut self,
        inst: &Instance,
        prim: &gltf::Primitive,
        skinned: Option<&super::skin::Skinning>,
        drawn: Drawn,
        at: &Place,
    ) -> Result<(), String> {
        let Drawn { mesh, material, .. } = drawn;
        let parts = match skinned.filter(|s| s.animated) {
            Some(skin) => self.rigid_parts(prim, skin, &mesh, at)?,
            None => vec![(None, mesh)],
        };
        let several = parts.len() > 1;
        for (joint, part) in parts {
            let name = match (several, joint) {
                (false, _) => drawn.name.clone(),
                (true, Some(j)) => format!("{}.{}", drawn.name, self.node_name(j)),
                (true, None) => format!("{}.unskinned", drawn.name),
            };
            let mut object = Object::new(name, part, material.clone());
            object.material_tracks = (prim.material().index())
                .and_then(|m| self.material_tracks.get(m))
                .and_then(|k| k.with_rest_of(&prim.material()));
            match (joint, skinned, inst.node) {
                // A part of a skin follows its joint (`skin::rigid_parts`).
                (Some(j), _, _) => {
                    object.world_from_object = Affine3A::from_mat4(self.skins.rest_of(j));
                    self.animate(&mut object, j, Affine3A::IDENTITY);
                }
                // Otherwise a skinned mesh is in world space already, and its node's
                // animation does not move it (glTF 2.0, "Skins").
                (None, Some(_), _) => {}
                (None, None, node) => {
                    object.world_from_object = drawn.world_from_object;
                    if let Some(node) = node {
                        let inner = inst
                            .instance
                            .map_or(Affine3A::IDENTITY, |(_, m)| Affine3A::from_mat4(m));
                        self.animate(&mut object, node.index(), inner);
                    }
                }
            }
            object.role = drawn.role;
            object.patch_size = drawn.patch_size;
            self.scene.objects.push(object);
            self.names.push(drawn.names.clone());
        }
        Ok(())
    }

    /// The positions (morphed by `weights`, see [`Walk::morph`], then placed by `skin` if
    /// given, see `skin`) and triangles of a primitive (`at` names it in messages); None
    /// (with a warning) when it has nothing to light: not triangles, empty or without
    /// POSITION.
    fn primitive_shape(
        &mut self,
        prim: &gltf::Primitive,
        weights: &[f32],
        skin: Option<&super::skin::Skinning>,
        at: &Place,
    ) -> Result<Option<Mesh>, String> {
        let (who, inst) = (&at.who, &at.inst);
        if let Some(why) = no_data_mark(prim) {
            self.scene.warnings.push(format!(
                "{who}{inst}: skipped, its data is not in the file: {why}"
            ));
            self.skipped.no_data += 1;
            return Ok(None);
        }
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.scene.warnings.push(format!(
                "{who}{inst}: {mode:?} primitive skipped (only triangles are used)"
            ));
            self.skipped.not_triangles += 1;
            return Ok(None);
        }
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            // Taken out before the gltf crate sees them (counted in `skipped`), and warned
            // about by `validate`.
            return Ok(None);
        };
        if pos_acc.count() == 0 || prim.indices().is_some_and(|a| a.count() == 0) {
            self.scene
                .warnings
                .push(format!("{who}{inst}: empty primitive skipped"));
            return Ok(None);
        }
        let buffers = self.buffers;
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));
        let mut positions = read_positions(&reader, pos_acc.count(), at)?;
        self.morph(prim, weights, &mut positions, at)?;
        let mirrored = match skin {
            Some(skin) => self.skin_positions(prim, skin, &mut positions, at)?,
            None => Vec::new(),
        };
        let indices = read_indices(&reader, prim, positions.len(), at)?;
        self.warn_primitive_restart(prim, &indices, at);
        if mode == Mode::Triangles && indices.len() % 3 != 0 {
            self.scene.warnings.push(format!(
                "{who}{inst}: {} index(es) beyond the last whole triangle ignored",
                indices.len() % 3
            ));
        }
        let mut triangles = to_triangles(mode, &indices);
        super::skin::keep_fronts(&mut triangles, &mirrored);
        if triangles.is_empty() {
            self.scene.warnings.push(format!(
                "{who}{inst}: {} index(es) make no whole triangle: primitive skipped",
                indices.len()
            ));
            return Ok(None);
        }
        Ok(Some(Mesh::new(positions, triangles)))
    }

    /// glTF 2.0 ("Meshes") forbids the largest value of the indices' component type (a GPU
    /// takes it as a primitive restart); shrad reads it as a plain index, so this warns.
    fn warn_primitive_restart(&mut self, prim: &gltf::Primitive, indices: &[u32], at: &Place) {
        use gltf::accessor::DataType;
        let (name, restart) = match prim.indices().map(|a| a.data_type()) {
            Some(DataType::U8) => ("UNSIGNED_BYTE", u32::from(u8::MAX)),
            Some(DataType::U16) => ("UNSIGNED_SHORT", u32::from(u16::MAX)),
            Some(DataType::U32) => ("UNSIGNED_INT", u32::MAX),
            _ => return,
        };
        if let Some(k) = indices.iter().position(|&i| i == restart) {
            self.scene.warnings.push(format!(
                "{}.indices{}: index {restart} (element {k}) is the primitive restart value of {name} indices, which must not occur (glTF 2.0, Meshes)",
                at.who, at.inst
            ));
        }
    }

    /// Drop a primitive's zero-area triangles with a warning. The specification does not
    /// forbid degenerate triangles (the glTF-Validator reports them as information only,
    /// ACCESSOR_INDEX_TRIANGLE_DEGENERATE), and exporters write them (strips joined by
    /// repeated indices, welded or collapsed vertices; an accessor without bufferView is
    /// all zeros): they draw nothing, so a glTF reader drops them rather than refusing the
    /// file. Radiosity cannot light them (a patch needs an area), hence they go. A primitive
    /// left without triangles is skipped, with the same warning: returns false then.
    fn drop_zero_area(&mut self, shape: &mut Mesh, who: &str) -> bool {
        // A triangle beyond the coordinates a solve holds may read as of no area in 32-bit
        // floats (corners 1e15 away, one unit apart): it stays, for the scene's check to
        // refuse by its reach, not to be dropped as degenerate.
        let beyond = |t: &[u32; 3]| {
            (t.iter()).any(|&i| shape.positions[i as usize].abs().max_element() > MAX_COORDINATE)
        };
        let degenerate: Vec<usize> = (shape.zero_area_triangles().into_iter())
            .filter(|&k| !beyond(&shape.triangles[k]))
            .collect();
        if degenerate.is_empty() {
            return true;
        }
        let all = degenerate.len() == shape.triangles.len();
        self.scene.warnings.push(format!(
            "{who}: {} of {} triangle(s) have zero area and were dropped{}",
            degenerate.len(),
            shape.triangles.len(),
            if all {
                " (the primitive is skipped)"
            } else {
                ""
            }
        ));
        self.skipped.zero_area_triangles += degenerate.len();
        if all {
            self.skipped.zero_area_primitives += 1;
        }
        shape.remove_triangles(&degenerate);
        !all
    }

    /// The texture coordinates the material's textures read and `COLOR_0` (normalized
    /// integers or floats, RGB or RGBA; alpha dropped, floats clamped to [0, 1]). A texture
    /// whose `TEXCOORD_n` the primitive lacks is averaged to one colour, with a warning.
    fn attributes<'a, 's, F>(
        &mut self,
        reader: &gltf::mesh::Reader<'a, 's, F>,
        mesh: &mut Mesh,
        material: &mut Material,
        who: &str,
    ) -> Result<(), String>
    where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        let n = mesh.positions.len();
        let mut sets = 0;
        for (what, slot) in [
            ("base colour", &mut material.base_color_texture),
            ("emissive", &mut material.emissive_texture),
        ] {
            let Some(t) = slot else { continue };
            let k = t.tex_coord;
            let uvs: Option<Vec<glam::Vec2>> = reader
                .read_tex_coords(k)
                .map(|r| r.into_f32().map(glam::Vec2::from).collect());
            match uvs {
                Some(uvs) if uvs.len() == n && uvs.iter().all(|p| p.is_finite()) => {
                    let k = k as usize;
                    if mesh.uvs.len() <= k {
                        mesh.uvs.resize(k + 1, vec![glam::Vec2::ZERO; n]);
                    }
                    mesh.uvs[k] = uvs;
                    sets = sets.max(k + 1);
                }
                got => {
                    let why = match got {
                        None => "is missing or cannot be read",
                        Some(u) if u.len() != n => "has too few elements",
                        Some(_) => "has a non-finite value",
                    };
                    let mean = t.image.mean();
                    self.scene.warnings.push(format!(
                        "{who}: {what} texture averaged to one colour (TEXCOORD_{k} {why})"
                    ));
                    if what == "base colour" {
                        material.reflectance *= mean;
                    } else {
                        material.emitted_radiance *= mean;
                    }
                    *slot = None;
                }
            }
        }
        mesh.uvs.truncate(sets);
        self.lightmap_uvs(reader, mesh, who);
        if let Some(colors) = reader.read_colors(0) {
            let colors: Vec<Vec3> = colors.into_rgb_f32().map(Vec3::from).collect();
            if colors.len() != n {
                return Err(format!(
                    "{who}.attributes.COLOR_0: has fewer elements than POSITION"
                ));
            }
            if let Some(k) = colors.iter().position(|c| !c.is_finite()) {
                return Err(format!(
                    "{who}.attributes.COLOR_0: colour {k} is not finite"
                ));
            }
            if colors
                .iter()
                .any(|c| c.min_element() < 0.0 || c.max_element() > 1.0)
            {
                self.scene.warnings.push(format!(
                    "{who}.attributes.COLOR_0: colours outside [0, 1] clamped"
                ));
            }
            mesh.colors = colors
                .into_iter()
                .map(|c| c.clamp(Vec3::ZERO, Vec3::ONE))
                .collect();
            if mesh.colors.iter().all(|&c| c == Vec3::ONE) {
                mesh.colors.clear();
            }
        }
        Ok(())
    }
}

impl Walk<'_> {
    /// `TEXCOORD_1`, kept as the lightmap's layout (a Blender lightmap UV layer is exported
    /// as it) whether or not a texture reads it: floats, or (`KHR_mesh_quantization`, already
    /// dequantized by `unpack`) normalized integers. One that cannot be used is dropped with
    /// a warning naming the primitive; a lightmap bake then makes its own charts.
    fn lightmap_uvs<'a, 's, F>(
        &mut self,
        reader: &gltf::mesh::Reader<'a, 's, F>,
        mesh: &mut Mesh,
        who: &str,
    ) where
        F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
    {
        let Some(set) = reader.read_tex_coords(1) else {
            return;
        };
        let uvs: Vec<glam::Vec2> = set.into_f32().map(glam::Vec2::from).collect();
        let n = mesh.positions.len();
        let why = if uvs.len() != n {
            format!("has {} elements for {n} positions", uvs.len())
        } else if let Some(k) = uvs.iter().position(|p| !p.is_finite()) {
            format!("element {k} is not finite")
        } else {
            mesh.lightmap_uvs = uvs;
            return;
        };
        self.scene.warnings.push(format!(
            "{who}.attributes.TEXCOORD_1: {why}: not used as a lightmap layout"
        ));
    }
}

/// How messages name a primitive: its JSON path `who` (`meshes[0].primitives[1]`) and the
/// instance `inst` (` (nodes[2] 'lamp')`); a property's path goes between the two.
pub(super) struct Place {
    pub(super) who: String,
    pub(super) inst: String,
}

impl Place {
    pub(super) fn both(&self) -> String {
        format!("{}{}", self.who, self.inst)
    }
}

/// A primitive's `count` positions, all finite.
fn read_positions<'a, 's, F>(
    reader: &gltf::mesh::Reader<'a, 's, F>,
    count: usize,
    at: &Place,
) -> Result<Vec<Vec3>, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let (who, inst) = (&at.who, &at.inst);
    let positions: Vec<Vec3> = reader
        .read_positions()
        .ok_or_else(|| format!("{who}.attributes.POSITION{inst}: cannot be read"))?
        .map(Vec3::from)
        .collect();
    if positions.len() != count {
        return Err(format!(
            "{who}.attributes.POSITION{inst}: has {} of {count} elements",
            positions.len()
        ));
    }
    if let Some(k) = positions.iter().position(|p| !p.is_finite()) {
        return Err(format!(
            "{who}.attributes.POSITION{inst}: vertex {k} is not finite ({})",
            positions[k]
        ));
    }
    Ok(positions)
}

/// A primitive's indices (0, 1, 2, ... without an indices accessor), each below `n`, the
/// number of vertices.
fn read_indices<'a, 's, F>(
    reader: &gltf::mesh::Reader<'a, 's, F>,
    prim: &gltf::Primitive,
    n: usize,
    at: &Place,
) -> Result<Vec<u32>, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let (who, inst) = (&at.who, &at.inst);
    let Some(acc) = prim.indices() else {
        return Ok((0..n as u32).collect());
    };
    let indices: Vec<u32> = reader
        .read_indices()
        .ok_or_else(|| format!("{who}.indices{inst}: cannot be read"))?
        .into_u32()
        .collect();
    if indices.len() != acc.count() {
        return Err(format!(
            "{who}.indices{inst}: has fewer elements than its count"
        ));
    }
    if let Some(k) = indices.iter().position(|&i| i as usize >= n) {
        return Err(format!(
            "{who}.indices{inst}: index {} (element {k}) is out of range: POSITION has {n} vertices",
            indices[k]
        ));
    }
    Ok(indices)
}

/// Triangles of a triangle list, strip or fan (front faces counter-clockwise).
fn to_triangles(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| {
                if i % 2 == 0 {
                    [idx[i], idx[i + 1], idx[i + 2]]
                } else {
                    [idx[i + 1], idx[i], idx[i + 2]]
                }
            })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1))
            .map(|i| [idx[0], idx[i], idx[i + 1]])
            .collect(),
        _ => Vec::new(),
    }
}

/// The name of the objects `inst` makes of `mesh`: the node's name (or its named parent's,
/// `node_name`), else the mesh's, else `node<i>` / `mesh<i>`; an instance's with its number
/// (`Tree#3`).
fn object_base_name(inst: &Instance, mesh: &gltf::Mesh, node_name: Option<&str>) -> String {
    let base = node_name
        .or(mesh.name())
        .map(str::to_string)
        .unwrap_or_else(|| match inst.node {
            Some(node) => format!("node{}", node.index()),
            None => format!("mesh{}", mesh.index()),
        });
    match inst.instance {
        Some((k, _)) => format!("{base}#{k}"),
        None => base,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans_keep_counter_clockwise_order() {
        assert_eq!(
            to_triangles(Mode::TriangleStrip, &[0, 1, 2, 3, 4]),
            vec![[0, 1, 2], [2, 1, 3], [2, 3, 4]]
        );
        assert_eq!(
            to_triangles(Mode::TriangleFan, &[0, 1, 2, 3]),
            vec![[0, 1, 2], [0, 2, 3]]
        );
        assert_eq!(
            to_triangles(Mode::Triangles, &[0, 1, 2, 3]),
            vec![[0, 1, 2]]
        );
        assert!(to_triangles(Mode::TriangleStrip, &[0, 1]).is_empty());
    }
}
