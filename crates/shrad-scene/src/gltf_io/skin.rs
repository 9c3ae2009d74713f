//! Skinned meshes at rest (glTF 2.0, "Skins"). A mesh drawn by a node with a `skin` is
//! placed by the skin, not by the node: each vertex `v` (morphed first, "Morph Targets") goes
//! to `sum_i w_i * (globalTransform(joint_i) * inverseBindMatrix_i) * v` over its JOINTS_n /
//! WEIGHTS_n influences, n = 0, 1, ..., in world space; the skinned node's own transform
//! (and its animation) is not applied, and `skeleton` is only a hint, not read. "At rest" is
//! each joint's own TRS or matrix accumulated from its root, without animation. shrad
//! cannot deform a mesh per frame: when the animation that plays moves the joints, the mesh
//! is cut into rigid parts, one per joint, each moved by its joint's animated transform
//! ([`Walk::rigid_parts`]), with a warning saying so. A rig whose vertices each follow one
//! joint (a robot, a desk lamp) moves exactly; a smooth one's parts may open at the joints.
//!
//! The object's `world_from_object` is then the identity: its mesh is in world space.
//! shrad keeps no normals (it computes face normals from the positions); a vertex whose
//! blended matrix mirrors (negative determinant) turns its triangles' winding as that
//! matrix's inverse transpose turns a normal, so a triangle most of whose vertices mirror is
//! reversed, and its front stays the front. Which way the mesh's own triangles face is told
//! by the skinned node's transform (glTF 2.0, "Transformations": its determinant defines the
//! winding), although it places nothing: under a mirroring node, a vertex mirrors where its
//! blended matrix does not (Blender writes a mesh under a mirrored armature so).
//!
//! Refused, naming the file, the primitive and the node: a joint index beyond the skin's
//! joints with a non-zero weight (one with a zero weight contributes nothing; `validate`
//! warns of it), inverse bind matrices fewer than the joints (more are allowed: glTF 2.0
//! asks at least one for each joint) or not MAT4 FLOAT, and a blended matrix that is not
//! finite. A skin whose joints name nodes that do not exist is refused by `validate` before.
//! A singular blended matrix (a joint scaled to zero at rest: how a rig hides a part, as a
//! node scaled to zero is hidden) flattens its vertices where it puts them, with a warning;
//! the triangles it leaves without area are dropped as every degenerate glTF triangle is.
//!
//! A vertex whose weights are all zero breaks glTF 2.0 (they sum to 1), but a valid file
//! may have them: an accessor without bufferView is all zeros, and the glTF-Validator does
//! not look into data that is not there (its own skin test files are so). Its blended matrix
//! would be zero, every such vertex at the origin (what a GPU skinning shader draws); it is
//! instead left unskinned, placed by the skinned node's own transform, where the file would
//! draw it without its skin, with a warning naming the primitive, the node and how many.

use std::collections::BTreeMap;

use glam::{Affine3A, Mat3, Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions, Iter};
use serde_json::Value;

use super::mesh::{Instance, Place};
use super::validate::Floats;
use super::walk::Walk;
use crate::Mesh;

/// The skins of a file, read from the raw JSON (the gltf crate never sees them), and the
/// rest transform of every node.
#[derive(Default)]
pub(super) struct FileSkins {
    skins: Vec<RawSkin>,
    /// Each node's `skin`, if it has one.
    node_skin: Vec<Option<usize>>,
    /// Each node's world transform at rest (its own and its ancestors' TRS or matrix);
    /// filled by [`FileSkins::place`] when the file has a skin.
    rest: Vec<Mat4>,
    /// Each node's depth in its tree (a root's is 0); filled with `rest`.
    depth: Vec<usize>,
}

/// One skin of the raw JSON (checked by `validate`: every index in range).
struct RawSkin {
    joints: Vec<usize>,
    inverse_bind_matrices: Option<usize>,
}

/// One JOINTS_n / WEIGHTS_n set of a primitive: each vertex's four joint indices and
/// weights.
type Influences = (Vec<[u16; 4]>, Vec<[f32; 4]>);

/// One skinned instance: its skin, the skinning matrix of each joint,
/// `globalTransform(joint_i) * inverseBindMatrix_i`, and the node's own world transform
/// (which places only the vertices without weight).
pub(super) struct Skinning {
    pub(super) skin: usize,
    pub(super) joints: Vec<Mat4>,
    pub(super) node: Mat4,
    /// Whether the animation that plays moves one of its joints (the mesh then moves as
    /// rigid parts, [`Walk::rigid_parts`]).
    pub(super) animated: bool,
}

fn indices(v: &Value) -> Vec<usize> {
    v.as_array()
        .into_iter()
        .flatten()
        .filter_map(|x| Some(x.as_u64()? as usize))
        .collect()
}

impl FileSkins {
    /// Take `skins` and every node's `skin` out of `root`, which the gltf crate then reads.
    pub(super) fn take(root: &mut Value) -> Self {
        let mut out = FileSkins::default();
        let Some(root) = root.as_object_mut() else {
            return out;
        };
        if let Some(Value::Array(skins)) = root.remove("skins") {
            out.skins = skins
                .iter()
                .map(|s| RawSkin {
                    joints: indices(&s["joints"]),
                    inverse_bind_matrices: s["inverseBindMatrices"].as_u64().map(|a| a as usize),
                })
                .collect();
        }
        if let Some(Value::Array(nodes)) = root.get_mut("nodes") {
            out.node_skin = nodes
                .iter_mut()
                .map(|n| {
                    let s = n.as_object_mut()?.remove("skin")?.as_u64()? as usize;
                    Some(s)
                })
                .collect();
        }
        out
    }

    /// The skin of node `node`, if it has one.
    pub(super) fn of_node(&self, node: usize) -> Option<usize> {
        self.node_skin.get(node).copied().flatten()
    }

    /// Every node's world transform at rest, from `doc` (whose node hierarchy `validate`
    /// found to be a set of trees), when the file has a skin to place.
    pub(super) fn place(&mut self, doc: &gltf::Document) {
        if self.skins.is_empty() {
            return;
        }
        let children: Vec<Vec<usize>> = doc
            .nodes()
            .map(|n| n.children().map(|c| c.index()).collect())
            .collect();
        let mut is_child = vec![false; children.len()];
        children.iter().flatten().for_each(|&c| is_child[c] = true);
        let local: Vec<Mat4> = doc
            .nodes()
            .map(|n| Mat4::from_cols_array_2d(&n.transform().matrix()))
            .collect();
        // A node not reached from a root (in a set of trees, every node is) stays not
        // finite: refused if a skin uses it.
        let mut rest = vec![Mat4::NAN; children.len()];
        let mut depth = vec![usize::MAX; children.len()];
        let mut seen = vec![false; children.len()];
        let mut stack: Vec<(usize, Mat4, usize)> = (0..children.len())
            .filter(|&k| !is_child[k])
            .map(|k| (k, Mat4::IDENTITY, 0))
            .collect();
        while let Some((k, above, d)) = stack.pop() {
            if std::mem::replace(&mut seen[k], true) {
                continue;
            }
            (rest[k], depth[k]) = (above * local[k], d);
            stack.extend(children[k].iter().map(|&c| (c, rest[k], d + 1)));
        }
        (self.rest, self.depth) = (rest, depth);
    }

    /// Node `n`'s world transform at rest (NaN for a node no skin needed).
    pub(super) fn rest_of(&self, n: usize) -> Mat4 {
        self.rest.get(n).copied().unwrap_or(Mat4::NAN)
    }

    /// The joints of skin `s`.
    pub(super) fn joints(&self, s: usize) -> &[usize] {
        self.skins.get(s).map_or(&[], |s| &s.joints)
    }
}

impl Walk<'_> {
    /// The skinning of instance `inst` if its node has a skin, with a warning when the
    /// animation that plays moves one of its joints (the mesh stays at its rest pose).
    pub(super) fn skin_of(&mut self, inst: &Instance) -> Result<Option<Skinning>, String> {
        let Some(s) = inst.skin else {
            return Ok(None);
        };
        let mut skinning = self.skinning(s, inst.world)?;
        let moving: Vec<String> = match &self.graph {
            Some(g) => (self.skins.joints(s).iter())
                .filter(|&&j| g.moves(j))
                .map(|j| format!("nodes[{j}]"))
                .collect(),
            None => Vec::new(),
        };
        if !moving.is_empty() {
            skinning.animated = true;
            self.scene.warnings.push(format!(
                "{}: skinned mesh moved as rigid parts, one per joint (each triangle follows the joint that weighs most on it); the blend between joints is not deformed, so parts may open where they meet (the joints {} of skins[{s}] are animated; shrad cannot deform a mesh per frame)",
                inst.label,
                moving.join(", ")
            ));
        }
        Ok(Some(skinning))
    }

    /// `skinning` for primitive `prim` (at `at`) if it has JOINTS_0 and WEIGHTS_0 to skin
    /// with; one without (glTF 2.0 requires them; `validate` warns) is drawn unskinned, by
    /// its node's transform, with a warning.
    pub(super) fn skinned<'s>(
        &mut self,
        skinning: Option<&'s Skinning>,
        prim: &gltf::Primitive,
        at: &Place,
    ) -> Option<&'s Skinning> {
        use gltf::Semantic::{Joints, Weights};
        let skinning = skinning?;
        if prim.get(&Joints(0)).is_some() && prim.get(&Weights(0)).is_some() {
            return Some(skinning);
        }
        self.scene.warnings.push(format!(
            "{}{}: its node has skins[{}], but it has no JOINTS_0 and WEIGHTS_0: drawn unskinned, by the node's transform",
            at.who, at.inst, skinning.skin
        ));
        None
    }

    /// Skin `s` at rest: each joint's rest world transform times its inverse bind matrix
    /// (the identity when the skin has none), for a node whose world transform is `node`.
    fn skinning(&self, s: usize, node: Mat4) -> Result<Skinning, String> {
        let at = format!("skins[{s}]");
        let skin = &self.skins.skins[s];
        let n = skin.joints.len();
        let inverse_bind = match skin.inverse_bind_matrices {
            None => vec![Mat4::IDENTITY; n],
            Some(a) => self.inverse_bind_matrices(a, n, &at)?,
        };
        let mut joints = Vec::with_capacity(n);
        for (k, (&j, ibm)) in skin.joints.iter().zip(inverse_bind).enumerate() {
            let global = self.skins.rest.get(j).copied().unwrap_or(Mat4::NAN);
            if !global.is_finite() {
                return Err(format!(
                    "{at}.joints[{k}]: the rest transform of its node {j} is not finite"
                ));
            }
            joints.push(global * ibm);
        }
        Ok(Skinning {
            skin: s,
            joints,
            node,
            animated: false,
        })
    }

    /// The first `n` matrices of accessor `a`, the inverse bind matrices of the skin at `at`.
    fn inverse_bind_matrices(&self, a: usize, n: usize, at: &str) -> Result<Vec<Mat4>, String> {
        let here = format!("{at}.inverseBindMatrices");
        let acc = self
            .doc
            .accessors()
            .nth(a)
            .ok_or_else(|| format!("{here}: accessor {a} does not exist"))?;
        if acc.dimensions() != Dimensions::Mat4
            || acc.data_type() != DataType::F32
            || acc.normalized()
        {
            return Err(format!(
                "{here}: accessor {a} is {:?} {:?}, but inverse bind matrices are MAT4 FLOAT (glTF 2.0, Skins)",
                acc.dimensions(),
                acc.data_type()
            ));
        }
        if acc.count() < n {
            return Err(format!(
                "{here}: accessor {a} has {} matrices for {n} joints (one for each joint, glTF 2.0, Skins)",
                acc.count()
            ));
        }
        let buffers = self.buffers;
        let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());
        let unread = || {
            let b = acc.view().map(|v| v.buffer().index());
            match b.filter(|&b| buffers.get(b).is_none_or(|d| d.0.is_empty())) {
                Some(b) => format!(
                    "{here}: accessor {a} cannot be read: its data is not in the file (buffer {b} has none)"
                ),
                None => format!("{here}: accessor {a} cannot be read"),
            }
        };
        let matrices: Vec<Mat4> = Iter::<[[f32; 4]; 4]>::new(acc.clone(), get)
            .ok_or_else(unread)?
            .take(n)
            .map(|m| Mat4::from_cols_array_2d(&m))
            .collect();
        if matrices.len() != n {
            return Err(format!(
                "{here}: accessor {a} has {} readable matrices for {n} joints",
                matrices.len()
            ));
        }
        if let Some(k) = matrices.iter().position(|m| !m.is_finite()) {
            return Err(format!("{here}: matrix {k} of accessor {a} is not finite"));
        }
        Ok(matrices)
    }

    /// Move `positions`, the vertices of `prim` (`at` names it in messages), to where
    /// `skin` puts them. Returns, for each vertex, whether its blended matrix mirrors where
    /// the skinned node's transform does not, or the other way round.
    pub(super) fn skin_positions(
        &mut self,
        prim: &gltf::Primitive,
        skin: &Skinning,
        positions: &mut [Vec3],
        at: &Place,
    ) -> Result<Vec<bool>, String> {
        let (who, inst) = (&at.who, &at.inst);
        let sets = self.influences(prim, positions.len(), at)?;
        // The skinned node's own transform, although it places nothing, tells which way its
        // mesh's triangles face (glTF 2.0, "Transformations": its determinant defines the
        // winding; three.js reads a skinned mesh's so), as Blender's exporter writes a mesh
        // under a mirrored armature: a triangle turns only where its vertices' blended
        // matrices mirror otherwise than that node.
        let node_mirrors = Mat3::from_mat4(skin.node).determinant() < 0.0;
        let mut mirrored = Vec::with_capacity(positions.len());
        let mut unweighted = (0, None);
        let mut flattened = (0, None);
        for (k, p) in positions.iter_mut().enumerate() {
            let m = match blend(&sets, k, &skin.joints) {
                Ok(Some(m)) => m,
                Ok(None) => {
                    unweighted.0 += 1;
                    unweighted.1.get_or_insert(k);
                    skin.node
                }
                Err((s, j, w)) => {
                    return Err(format!(
                        "{who}.attributes.JOINTS_{s}{inst}: vertex {k} names joint {j} (weight {w}), but skins[{}] has {} joints",
                        skin.skin,
                        skin.joints.len()
                    ))
                }
            };
            let m3 = Mat3::from_mat4(m);
            if !m.is_finite() {
                return Err(format!(
                    "{who}{inst}: the blended skinning matrix of vertex {k} is not finite: the vertex cannot be placed"
                ));
            }
            if crate::model::is_singular(&m3) {
                flattened.0 += 1;
                flattened.1.get_or_insert(k);
            }
            *p = m.transform_point3(*p);
            mirrored.push((m3.determinant() < 0.0) != node_mirrors);
        }
        if let (n, Some(k)) = unweighted {
            let sets = (0..sets.len()).map(|s| format!("WEIGHTS_{s}"));
            self.scene.warnings.push(format!(
                "{who}.attributes.{}{inst}: {n} of {} vertices have every weight zero (first: vertex {k}); a skinned vertex's weights sum to 1 (glTF 2.0, Skins): they are left unskinned, placed by the node's own transform",
                sets.collect::<Vec<_>>().join(" + "),
                positions.len()
            ));
        }
        if let (n, Some(k)) = flattened {
            self.scene.warnings.push(format!(
                "{who}{inst}: the blended skinning matrix of {n} of {} vertices is singular (first: vertex {k}; a joint scaled to zero at rest, as a rig hides a part): they are placed flattened, and triangles left without area are dropped",
                positions.len()
            ));
        }
        Ok(mirrored)
    }

    /// Every JOINTS_n / WEIGHTS_n set of `prim` (n = 0, 1, ... while both are there), one
    /// element for each of its `count` vertices.
    fn influences(
        &self,
        prim: &gltf::Primitive,
        count: usize,
        at: &Place,
    ) -> Result<Vec<Influences>, String> {
        use gltf::Semantic::{Joints, Weights};
        let (who, inst) = (&at.who, &at.inst);
        let buffers = self.buffers;
        let get = |b: gltf::Buffer| buffers.get(b.index()).map(|d| d.0.as_slice());
        let mut sets = Vec::new();
        for n in 0.. {
            let (Some(ja), Some(wa)) = (prim.get(&Joints(n)), prim.get(&Weights(n))) else {
                break;
            };
            let (jn, wn) = (format!("JOINTS_{n}"), format!("WEIGHTS_{n}"));
            for (acc, name) in [(&ja, &jn), (&wa, &wn)] {
                if acc.count() != count {
                    return Err(format!(
                        "{who}.attributes.{name}{inst}: accessor {} has {} elements for {count} vertices",
                        acc.index(),
                        acc.count()
                    ));
                }
            }
            let joints: Option<Vec<[u16; 4]>> =
                match (ja.dimensions(), ja.data_type(), ja.normalized()) {
                    (Dimensions::Vec4, DataType::U8, false) => {
                        Iter::<[u8; 4]>::new(ja.clone(), get)
                            .map(|it| it.map(|j| j.map(u16::from)).collect())
                    }
                    (Dimensions::Vec4, DataType::U16, false) => {
                        Iter::<[u16; 4]>::new(ja.clone(), get).map(Iterator::collect)
                    }
                    _ => None,
                };
            let joints = joints.filter(|j| j.len() == count).ok_or_else(|| {
                format!(
                    "{who}.attributes.{jn}{inst}: accessor {} cannot be read as joint indices (VEC4 UNSIGNED_BYTE or UNSIGNED_SHORT)",
                    ja.index()
                )
            })?;
            let weights: Option<Vec<[f32; 4]>> = (wa.dimensions() == Dimensions::Vec4)
                .then(|| Floats::<4>::new(&wa, get, false))
                .flatten()
                .map(|it| it.map(|w| w.map(|x| x as f32)).collect());
            let weights = weights.filter(|w| w.len() == count).ok_or_else(|| {
                format!(
                    "{who}.attributes.{wn}{inst}: accessor {} cannot be read as weights (VEC4 FLOAT, or normalized UNSIGNED_BYTE or UNSIGNED_SHORT)",
                    wa.index()
                )
            })?;
            if let Some(k) = weights
                .iter()
                .position(|w| !w.iter().all(|x| x.is_finite()))
            {
                return Err(format!(
                    "{who}.attributes.{wn}{inst}: weight {k} is not finite"
                ));
            }
            sets.push((joints, weights));
        }
        Ok(sets)
    }
}

impl Walk<'_> {
    /// A skinned primitive whose joints the animation moves, cut into rigid parts: each
    /// triangle goes with one joint ([`joint_of_triangle`]), and a part is one joint's
    /// triangles in that joint's frame at rest, with the joint's node, to
    /// be moved by its animated transform. A vertex weighted wholly to its part's joint then
    /// lands where skinning puts it at every time (`J(t) J_rest^-1 * (J_rest IBM v) = J(t) IBM
    /// v`); one blended between joints follows its part's joint only. Triangles without
    /// weight, or whose joint's rest transform is singular (a joint scaled to zero at rest),
    /// stay in world space, unmoved (node None). `shape`: the primitive at rest, in world
    /// space. Parts in the order of their joints.
    pub(super) fn rigid_parts(
        &mut self,
        prim: &gltf::Primitive,
        skin: &Skinning,
        shape: &Mesh,
        at: &Place,
    ) -> Result<Vec<(Option<usize>, Mesh)>, String> {
        let sets = self.influences(prim, shape.positions.len(), at)?;
        let joints = self.skins.joints(skin.skin);
        let rest = &self.skins.rest;
        let movable = |n: &usize| {
            let m = rest.get(*n).copied().unwrap_or(Mat4::NAN);
            m.is_finite() && !crate::model::is_singular(&Mat3::from_mat4(m))
        };
        let depth = |j: usize| {
            let node = joints.get(j).copied();
            node.and_then(|n| self.skins.depth.get(n).copied())
                .unwrap_or(usize::MAX)
        };
        let mut by_node: BTreeMap<Option<usize>, Vec<usize>> = BTreeMap::new();
        for (t, triangle) in shape.triangles.iter().enumerate() {
            let node = joint_of_triangle(&sets, triangle, depth)
                .and_then(|j| joints.get(j).copied())
                .filter(movable);
            by_node.entry(node).or_default().push(t);
        }
        let parts = by_node.into_iter().map(|(node, triangles)| {
            let part = shape.subset(&triangles);
            let Some(n) = node else {
                return (None, part);
            };
            let rest = Affine3A::from_mat4(rest[n]);
            let mut part = part.transformed(rest.inverse());
            // A mirroring joint frame: the part stays counter-clockwise from the front in its
            // own frame (see `mesh`), its world normal the inverse transpose of the local one.
            if rest.matrix3.determinant() < 0.0 {
                part.triangles.iter_mut().for_each(|t| t.swap(1, 2));
            }
            (Some(n), part)
        });
        Ok(parts.collect())
    }
}

/// The joint (its index in the skin) a triangle's rigid part follows: the one whose weights
/// on its three vertices in `sets` sum highest (the lowest index of a tie), when each vertex
/// has some weight on it; else (a triangle spanning a joint whose vertices each belong to
/// one bone, as Blender's rigid weights make them) the joint nearest the root (by `depth`)
/// among its vertices' heaviest, so that every triangle of such a band goes with the same
/// joint and the parts open along one ring instead of in alternate spikes. None when every
/// weight is zero.
fn joint_of_triangle(
    sets: &[Influences],
    triangle: &[u32; 3],
    depth: impl Fn(usize) -> usize,
) -> Option<usize> {
    // Weights summed per joint (a joint may appear in several sets), ascending by joint.
    let summed = |pairs: &mut dyn Iterator<Item = (usize, f32)>| {
        let mut sums: Vec<(usize, f32)> = Vec::new();
        for (j, w) in pairs {
            match sums.iter_mut().find(|(k, _)| *k == j) {
                Some((_, sum)) => *sum += w,
                None => sums.push((j, w)),
            }
        }
        sums.retain(|&(_, w)| w > 0.0);
        sums.sort_by_key(|&(j, _)| j);
        sums
    };
    let weights =
        |v: u32| {
            let v = v as usize;
            summed(&mut sets.iter().flat_map(|(js, ws)| {
                (js[v].iter().zip(&ws[v])).map(|(&j, &w)| (usize::from(j), w))
            }))
        };
    let each = triangle.map(weights);
    let heaviest = |sums: &[(usize, f32)]| {
        (sums.iter().copied())
            .fold(None, |best: Option<(usize, f32)>, (j, w)| match best {
                Some((_, b)) if b >= w => best,
                _ => Some((j, w)),
            })
            .map(|(j, _)| j)
    };
    let total = summed(&mut each.iter().flatten().copied());
    let j = heaviest(&total)?;
    let weighs_on_each = each.iter().all(|s| s.iter().any(|&(k, _)| k == j));
    match weighs_on_each {
        true => Some(j),
        false => (each.iter().filter_map(|s| heaviest(s))).min_by_key(|&k| (depth(k), k)),
    }
}

/// The blended matrix of vertex `k`, `sum_i w_i * joints[j_i]` over its influences in
/// `sets`; None when every weight is zero; Err((set, joint, weight)) for a joint index
/// beyond `joints` with a non-zero weight.
fn blend(
    sets: &[Influences],
    k: usize,
    joints: &[Mat4],
) -> Result<Option<Mat4>, (usize, usize, f32)> {
    let mut m = Mat4::ZERO;
    let mut any = false;
    for (s, (js, ws)) in sets.iter().enumerate() {
        for (&j, &w) in js[k].iter().zip(&ws[k]) {
            if w == 0.0 {
                continue;
            }
            let joint = joints.get(usize::from(j)).ok_or((s, usize::from(j), w))?;
            m += *joint * w;
            any = true;
        }
    }
    Ok(any.then_some(m))
}

/// Reverse each triangle most of whose vertices' blended matrices mirror (see the module's
/// documentation).
pub(super) fn keep_fronts(triangles: &mut [[u32; 3]], mirrored: &[bool]) {
    for t in triangles.iter_mut() {
        let flips = t
            .iter()
            .filter(|&&i| mirrored.get(i as usize) == Some(&true))
            .count();
        if flips >= 2 {
            t.swap(1, 2);
        }
    }
}
