//! Skinned meshes at rest in glTF import (glTF 2.0, "Skins").
//!
//! A mesh drawn by a node with a `skin` is placed by the skin: each vertex goes to
//! `sum_i w_i * (globalTransform(joint_i) * inverseBindMatrix_i) * v`, the joints' rest
//! transforms (their own TRS, no animation), and the skinned node's own transform is not
//! applied. The object's mesh is then in world space (`world_from_object` the identity).
//! Morph targets apply before skinning. When an animation moves a joint the mesh moves as
//! rigid parts, one per joint, each following its joint, with a warning saying so. What cannot be skinned is refused, naming the
//! file: a joint beyond the skin with a weight, too few inverse bind matrices, a joint that
//! does not exist. A vertex whose weights are all zero stays with its node, and a singular
//! blended matrix flattens its vertices, each with a warning.
//!
//! The fixture ([`strip`]) is a strip of two quads in the XY plane, x in {0, 1, 2} and y in
//! {0, 1}. Joint 0 (node "root") binds at the origin, joint 1 (node "tip", its child) at
//! (1, 0, 0); inverse bind matrices are the inverses of those. At rest "root" is moved by
//! (0, 0, 5) and "tip" turned 90 degrees about +y (Ry(90) (x, y, z) = (z, y, -x)), which
//! bends the strip down at x = 1; in closed form:
//! - x = 0 (weight 1 on joint 0): (0, y, 0) -> (0, y, 5);
//! - x = 2 (weight 1 on joint 1): T(0,0,5) T(1,0,0) Ry(90) T(-1,0,0) (2, y, 0) = (1, y, 4);
//! - x = 1 (half each): the mean of (1, y, 5) and T(1,0,5) Ry(90) (0, y, 0) = (1, y, 5).
//!
//! Unskinned (the reader before skins were read) the strip stayed flat at z = 0.

use std::path::Path;

use glam::{Mat4, Quat, Vec3};
use serde_json::{json, Value};
use shrad_scene::{load, LoadOptions, Object, Scene};

use crate::common::err_of;
use crate::common::gltf_bin::Bin;

impl Bin {
    fn floats(&mut self, data: &[f32], count: usize, ty: &str, extra: Value) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(&bytes, count, ty, 5126, extra)
    }

    fn joints(&mut self, data: &[[u8; 4]]) -> usize {
        let flat: Vec<u8> = data.iter().flatten().copied().collect();
        self.accessor(&flat, data.len(), "VEC4", 5121, json!({}))
    }

    fn weights(&mut self, data: &[[f32; 4]]) -> usize {
        let flat: Vec<f32> = data.iter().flatten().copied().collect();
        self.floats(&flat, data.len(), "VEC4", json!({}))
    }

    fn matrices(&mut self, data: &[Mat4]) -> usize {
        let flat: Vec<f32> = data.iter().flat_map(|m| m.to_cols_array()).collect();
        self.floats(&flat, data.len(), "MAT4", json!({}))
    }
}

/// The strip's vertices: (x, y, 0) for x in {0, 1, 2}, y in {0, 1}, vertex 2x + y.
const STRIP: [[f32; 3]; 6] = [
    [0.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [1.0, 0.0, 0.0],
    [1.0, 1.0, 0.0],
    [2.0, 0.0, 0.0],
    [2.0, 1.0, 0.0],
];

/// The strip's vertices skinned at rest, in closed form (see the module's documentation).
fn skinned_strip() -> [Vec3; 6] {
    let at = |x: f32, y: f32| match x as u32 {
        0 => Vec3::new(0.0, y, 5.0),
        1 => Vec3::new(1.0, y, 5.0),
        _ => Vec3::new(1.0, y, 4.0),
    };
    STRIP.map(|[x, y, _]| at(x, y))
}

/// What a test may change in [`strip`].
struct Strip {
    joints: [[u8; 4]; 6],
    weights: [[f32; 4]; 6],
    /// The inverse bind matrices (None: no accessor, identities).
    inverse_bind: Option<Vec<Mat4>>,
    /// The skinned node ("Strip", nodes[0]) besides its mesh and skin.
    node: Value,
    /// The "tip" joint's rest transform.
    tip: Value,
    /// A morph target of the mesh (its displacements, weight 1), if any.
    target: Option<[[f32; 3]; 6]>,
}

impl Default for Strip {
    fn default() -> Self {
        let (a, b) = ([0, 0, 0, 0], [1, 0, 0, 0]);
        let (one, half) = ([1.0, 0.0, 0.0, 0.0], [0.5, 0.5, 0.0, 0.0]);
        Strip {
            joints: [a, a, [0, 1, 0, 0], [0, 1, 0, 0], b, b],
            weights: [one, one, half, half, one, one],
            inverse_bind: Some(vec![
                Mat4::IDENTITY,
                Mat4::from_translation(Vec3::new(-1.0, 0.0, 0.0)),
            ]),
            node: json!({}),
            tip: json!({"translation": [1.0, 0.0, 0.0],
                        "rotation": Quat::from_rotation_y(std::f32::consts::FRAC_PI_2).to_array()}),
            target: None,
        }
    }
}

/// The strip glTF: nodes[0] "Strip" draws the mesh with skins[0] (joints "root", nodes[1],
/// and its child "tip", nodes[2]); both nodes are roots of the scene.
fn strip(s: Strip) -> Value {
    let mut b = Bin::default();
    let pos = b.vec3(&STRIP);
    let joints = b.joints(&s.joints);
    let weights = b.weights(&s.weights);
    let idx = b.indices(&[0, 2, 1, 1, 2, 3, 2, 4, 3, 3, 4, 5]);
    let mut prim = json!({
        "attributes": {"POSITION": pos, "JOINTS_0": joints, "WEIGHTS_0": weights},
        "indices": idx
    });
    let mut mesh = json!({"name": "StripMesh", "primitives": [prim.clone()]});
    if let Some(t) = s.target {
        let t = b.vec3(&t);
        prim["targets"] = json!([{"POSITION": t}]);
        mesh = json!({"name": "StripMesh", "primitives": [prim], "weights": [1.0]});
    }
    let mut skin = json!({"joints": [1, 2]});
    if let Some(m) = &s.inverse_bind {
        skin["inverseBindMatrices"] = json!(b.matrices(m));
    }
    let mut node = json!({"name": "Strip", "mesh": 0, "skin": 0});
    if let (Some(n), Some(extra)) = (node.as_object_mut(), s.node.as_object()) {
        n.extend(extra.clone());
    }
    let mut tip = json!({"name": "tip"});
    if let (Some(n), Some(extra)) = (tip.as_object_mut(), s.tip.as_object()) {
        n.extend(extra.clone());
    }
    b.finish(json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [node, {"name": "root", "translation": [0.0, 0.0, 5.0], "children": [2]}, tip],
        "meshes": [mesh],
        "skins": [skin],
    }))
}

fn load_json(name: &str, root: &Value) -> Scene {
    crate::common::load_gltf_json("gltf-skin", name, root)
}

/// The error loading `root` gives; it names the file.
fn refused(name: &str, root: &Value) -> String {
    let file = format!("{name}.gltf");
    let p = crate::common::gltf_json_file("gltf-skin", name, root);
    let e = err_of(load(&p, &LoadOptions::default()));
    assert!(
        e.contains(&file),
        "{name}: the error does not name the file: {e}"
    );
    e
}

fn object<'a>(s: &'a Scene, name: &str) -> &'a Object {
    s.objects
        .iter()
        .find(|o| o.name == name)
        .unwrap_or_else(|| {
            let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
            panic!("no object '{name}' among {names:?}")
        })
}

/// The object's vertices in world space.
fn world_positions(o: &Object) -> Vec<Vec3> {
    (o.mesh.positions.iter())
        .map(|&p| o.world_from_object.transform_point3(p))
        .collect()
}

/// The unit normal of each of `o`'s triangles from its vertices at `p` (their winding).
fn face_normals(o: &Object, p: &[Vec3]) -> Vec<Vec3> {
    (o.mesh.triangles.iter())
        .map(|t| {
            let [a, b, c] = t.map(|i| p[i as usize]);
            (b - a).cross(c - a).normalize()
        })
        .collect()
}

fn assert_close(got: &[Vec3], want: &[Vec3], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (*g - *w).abs().max_element() < 1e-5,
            "{what}: vertex {k} at {g}, expected {w} (all: {got:?})"
        );
    }
}

/// Two joints, the second turned 90 degrees at rest: every vertex where the closed form
/// puts it, the mesh in world space under an identity transform, the object named after
/// its node; a static file says nothing of animation.
#[test]
fn skinned_vertices_are_where_the_joints_rest_transforms_put_them() {
    let s = load_json("closed_form", &strip(Strip::default()));
    assert_eq!(s.objects.len(), 1, "{:?}", s.warnings);
    let o = object(&s, "Strip");
    assert_eq!(o.world_from_object, glam::Affine3A::IDENTITY);
    assert!(o.node_animation.is_none());
    assert_close(&world_positions(o), &skinned_strip(), "skinned strip");
    assert_eq!(o.mesh.triangles.len(), 4);
    assert!(
        !s.warnings.iter().any(|w| w.contains("skin")),
        "{:?}",
        s.warnings
    );
}

/// glTF 2.0, "Skins": "only the joint transforms are applied to the skinned mesh; the
/// transform of the skinned mesh node MUST be ignored". A translated, rotated and scaled
/// node, and one scaled to zero (which hides an unskinned mesh), place the mesh exactly as
/// an untransformed one, as does a parent of the skinned node.
#[test]
fn the_skinned_nodes_own_transform_is_ignored() {
    let moved = json!({"translation": [100.0, -3.0, 7.0],
                       "rotation": Quat::from_rotation_x(1.0).to_array(),
                       "scale": [3.0, 2.0, 0.5]});
    let zero = json!({"scale": [0.0, 0.0, 0.0]});
    for (name, node) in [("moved", moved), ("zero_scale", zero)] {
        let s = load_json(
            name,
            &strip(Strip {
                node,
                ..Strip::default()
            }),
        );
        let o = object(&s, "Strip");
        assert_eq!(o.world_from_object, glam::Affine3A::IDENTITY, "{name}");
        assert_close(&world_positions(o), &skinned_strip(), name);
    }
    // Under a parent that moves it: still where the joints put it.
    let mut file = strip(Strip::default());
    file["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "holder", "translation": [0.0, 40.0, 0.0], "children": [0]}));
    file["scenes"][0]["nodes"] = json!([3, 1]);
    let s = load_json("parented", &file);
    assert_close(
        &world_positions(object(&s, "Strip")),
        &skinned_strip(),
        "parented",
    );
}

/// No inverseBindMatrices: each is the identity, so a vertex goes by its joint's global
/// transform alone: (x, y, 0) -> (x, y, 5) on "root"; on "tip", T(0,0,5) T(1,0,0) Ry(90)
/// (x, y, 0) = (1, y, 5 - x).
#[test]
fn missing_inverse_bind_matrices_are_identities() {
    let s = load_json(
        "no_ibm",
        &strip(Strip {
            inverse_bind: None,
            ..Strip::default()
        }),
    );
    let want: Vec<Vec3> = STRIP
        .iter()
        .map(|&[x, y, _]| match x as u32 {
            0 => Vec3::new(x, y, 5.0),
            1 => (Vec3::new(x, y, 5.0) + Vec3::new(1.0, y, 5.0 - x)) / 2.0,
            _ => Vec3::new(1.0, y, 5.0 - x),
        })
        .collect();
    assert_close(&world_positions(object(&s, "Strip")), &want, "no IBM");
}

/// Morph targets apply before skinning (glTF 2.0, "Skins": "morph targets are applied before
/// skinning"): vertex 5, (2, 1, 0), moved by (1, 0, 0) to (3, 1, 0), then skinned by "tip":
/// Ry(90) (2, 1, 0) + (1, 0, 5) = (1, 1, 3). (Skinned first, then moved: (2, 1, 4).)
#[test]
fn morph_targets_apply_before_skinning() {
    let mut target = [[0.0; 3]; 6];
    target[5] = [1.0, 0.0, 0.0];
    let s = load_json(
        "morph",
        &strip(Strip {
            target: Some(target),
            ..Strip::default()
        }),
    );
    let mut want = skinned_strip();
    want[5] = Vec3::new(1.0, 1.0, 3.0);
    assert_close(&world_positions(object(&s, "Strip")), &want, "morphed");
}

/// A skeleton that mirrors at rest ("root" scaled by -1 along x) mirrors the mesh, and turns
/// its triangles' fronts as its inverse transpose turns a normal. Every blended matrix is
/// `T(0,0,5) S X`, S = diag(-1, 1, 1) and `T(0,0,5) X` that of the unmirrored strip, so
/// each vertex is the unmirrored one with x negated, and a normal n of the unmirrored
/// strip goes to `S^-T n = S n`: each face normal shrad computes from the positions is the
/// unmirrored one with x negated (without reversing the winding, it would be its opposite).
#[test]
fn a_mirroring_skeleton_keeps_the_fronts_where_normals_go() {
    let plain = load_json("unmirrored", &strip(Strip::default()));
    let mut file = strip(Strip::default());
    file["nodes"][1]["scale"] = json!([-1.0, 1.0, 1.0]);
    let mirrored = load_json("mirror", &file);
    let (p0, p1) = (
        world_positions(object(&plain, "Strip")),
        world_positions(object(&mirrored, "Strip")),
    );
    let s = |v: Vec3| Vec3::new(-v.x, v.y, v.z);
    assert_close(
        &p1,
        &p0.iter().map(|&v| s(v)).collect::<Vec<_>>(),
        "mirrored",
    );
    let n0 = face_normals(object(&plain, "Strip"), &p0);
    let n1 = face_normals(object(&mirrored, "Strip"), &p1);
    assert_eq!(n0.len(), 4);
    assert_close(
        &n1,
        &n0.iter().map(|&n| s(n)).collect::<Vec<_>>(),
        "normals",
    );
}

/// `file` with an animation turning "tip" (nodes[2]) through `keys` (time, rotation),
/// LINEAR.
fn with_tip_keys(mut file: Value, keys: &[(f32, Quat)]) -> Value {
    let times: Vec<f32> = keys.iter().map(|k| k.0).collect();
    let rotations: Vec<f32> = keys.iter().flat_map(|k| k.1.to_array()).collect();
    let bytes: Vec<u8> = (times.iter().chain(&rotations))
        .flat_map(|x| x.to_le_bytes())
        .collect();
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::encode(&bytes)
    );
    let n = keys.len();
    let buffers = file["buffers"].as_array_mut().unwrap();
    buffers.push(json!({"byteLength": bytes.len(), "uri": uri}));
    let b = buffers.len() - 1;
    let views = file["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": b, "byteOffset": 0, "byteLength": 4 * n}));
    views.push(json!({"buffer": b, "byteOffset": 4 * n, "byteLength": 16 * n}));
    let (v0, v1) = (views.len() - 2, views.len() - 1);
    let accessors = file["accessors"].as_array_mut().unwrap();
    accessors.push(json!({"bufferView": v0, "componentType": 5126, "count": n,
                          "type": "SCALAR", "min": [times[0]], "max": [times[n - 1]]}));
    accessors.push(json!({"bufferView": v1, "componentType": 5126, "count": n, "type": "VEC4"}));
    let (a0, a1) = (accessors.len() - 2, accessors.len() - 1);
    file["animations"] = json!([{
        "channels": [{"sampler": 0, "target": {"node": 2, "path": "rotation"}}],
        "samplers": [{"input": a0, "output": a1}]
    }]);
    file
}

/// The object's vertices in world space at time `t` of its node's animation.
fn world_positions_at(o: &Object, t: f32) -> Vec<Vec3> {
    let m = o
        .node_animation
        .as_ref()
        .map_or(o.world_from_object, |a| a.world_from_object_at(t));
    (o.mesh.positions.iter())
        .map(|&p| m.transform_point3(p))
        .collect()
}

/// An animation of a joint moves the mesh as rigid parts, one per joint, with a warning
/// that says so. "tip" turns from no rotation (t = 0) to its rest turn, Ry(90), at t = 1,
/// so at time t it is turned by Ry(90 t). Each triangle goes with the joint that weighs most
/// on it: the quad x in [0, 1] with "root" (weights 1, 1, 1/2, 1/2), the quad x in [1, 2]
/// with "tip". A vertex of weight 1 on "tip" goes, in closed form, to
/// `T(0,0,5) T(1,0,0) Ry(a) T(-1,0,0) (2, y, 0) = (1 + cos a, y, 5 - sin a)`; the x = 1
/// vertices sit on tip's pivot, (1, y, 5) whatever its turn; "root" does not move. At
/// t = 1 the parts are where skinning at rest puts the strip.
#[test]
fn joint_animation_moves_the_mesh_as_rigid_parts_and_says_so() {
    let ry = |deg: f32| Quat::from_rotation_y(deg.to_radians());
    let file = with_tip_keys(strip(Strip::default()), &[(0.0, ry(0.0)), (1.0, ry(90.0))]);
    let s = load_json("animated", &file);
    assert_eq!(s.objects.len(), 2, "{:?}", s.warnings);
    let (root, tip) = (object(&s, "Strip.root"), object(&s, "Strip.tip"));
    assert!(root.node_animation.is_none());
    assert!(tip.node_animation.is_some());
    let rest = skinned_strip();
    let root_at_rest: Vec<Vec3> = [0, 2, 1, 3].map(|k| rest[k]).to_vec();
    assert_close(&world_positions_at(root, 0.5), &root_at_rest, "root part");
    for t in [0.0f32, 0.25, 0.5, 1.0] {
        let a = (90.0 * t).to_radians();
        // The tip part's vertices in the order its triangles first use them: 2, 4, 3, 5.
        let want = [
            Vec3::new(1.0, 0.0, 5.0),
            Vec3::new(1.0 + a.cos(), 0.0, 5.0 - a.sin()),
            Vec3::new(1.0, 1.0, 5.0),
            Vec3::new(1.0 + a.cos(), 1.0, 5.0 - a.sin()),
        ];
        assert_close(
            &world_positions_at(tip, t),
            &want,
            &format!("tip part at t = {t}"),
        );
    }
    let tip_at_rest: Vec<Vec3> = [2, 4, 3, 5].map(|k| rest[k]).to_vec();
    assert_close(
        &world_positions_at(tip, 1.0),
        &tip_at_rest,
        "tip part at rest",
    );
    let w = "nodes[0] 'Strip': skinned mesh moved as rigid parts, one per joint (each triangle follows the joint that weighs most on it)";
    assert!(
        s.warnings.iter().any(|x| x.contains(w)),
        "no warning says '{w}': {:#?}",
        s.warnings
    );
}

/// The skinned node's own transform places nothing, but its determinant tells which way its
/// mesh's triangles face (glTF 2.0, "Transformations"): under a node mirrored by -1 along x
/// the strip's vertices are where the joints put them, as without, and every face normal
/// shrad computes is the unmirrored one reversed (Blender's exporter writes a mesh under a
/// mirrored armature so; before, every one of its faces faced inwards).
#[test]
fn a_mirrored_skinned_node_turns_its_fronts() {
    let plain = load_json("unmirrored_node", &strip(Strip::default()));
    let mirrored = load_json(
        "mirrored_node",
        &strip(Strip {
            node: json!({"scale": [-1.0, 1.0, 1.0]}),
            ..Strip::default()
        }),
    );
    let (a, b) = (object(&plain, "Strip"), object(&mirrored, "Strip"));
    let (pa, pb) = (world_positions(a), world_positions(b));
    assert_close(&pb, &pa, "positions");
    let reversed: Vec<Vec3> = face_normals(a, &pa).iter().map(|&n| -n).collect();
    assert_close(&face_normals(b, &pb), &reversed, "normals");
}

/// A joint scaled to zero along y at rest (how a rig flattens a part) whose animation moves
/// it: its triangles cannot be put in its frame (the rest transform has no inverse), so they
/// stay where skinning at rest puts them, unmoved, as a part named "unskinned"; nothing is
/// not finite at any time.
#[test]
fn a_flattened_animated_joint_leaves_its_part_unmoved() {
    let mut tip = Strip::default().tip;
    tip["scale"] = json!([1.0, 0.0, 1.0]);
    let ry = |deg: f32| Quat::from_rotation_y(deg.to_radians());
    let file = with_tip_keys(
        strip(Strip {
            tip,
            ..Strip::default()
        }),
        &[(0.0, ry(0.0)), (1.0, ry(90.0))],
    );
    let s = load_json("flattened_animated", &file);
    let still = object(&s, "Strip.unskinned");
    assert!(still.node_animation.is_none());
    assert_eq!(still.world_from_object, glam::Affine3A::IDENTITY);
    assert!(!still.mesh.triangles.is_empty());
    for o in &s.objects {
        for t in [0.0, 0.5, 1.0] {
            let p = world_positions_at(o, t);
            assert!(p.iter().all(|v| v.is_finite()), "{} at {t}: {p:?}", o.name);
        }
    }
}

/// A part whose joint mirrors at rest ("tip" scaled by -1 along z, animated from its rest
/// pose) keeps its fronts: its world normals, as shrad computes them (the inverse transpose
/// of its transform times the local face normals), are those of the same strip skinned at
/// rest without animation (computed from its world-space triangles).
#[test]
fn a_mirroring_joint_part_keeps_its_fronts() {
    let mut file = strip(Strip::default());
    file["nodes"][2]["scale"] = json!([1.0, 1.0, -1.0]);
    let still = load_json("mirror_joint_still", &file);
    let turn = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
    let moving = load_json(
        "mirror_joint_moving",
        &with_tip_keys(file, &[(0.0, turn), (1.0, Quat::IDENTITY)]),
    );
    let face = |p: &[Vec3], t: &[u32; 3]| {
        let [a, b, c] = t.map(|i| p[i as usize]);
        (b - a).cross(c - a).normalize()
    };
    let whole = object(&still, "Strip");
    let p = world_positions(whole);
    // The still strip's tip quad (triangles 2 and 3) in world space.
    let want: Vec<Vec3> = whole.mesh.triangles[2..]
        .iter()
        .map(|t| face(&p, t))
        .collect();
    let tip = object(&moving, "Strip.tip");
    let m = tip.world_from_object;
    assert!(m.matrix3.determinant() < 0.0, "the joint does not mirror");
    let local = &tip.mesh.positions;
    let got: Vec<Vec3> = (tip.mesh.triangles.iter())
        .map(|t| (m.matrix3.inverse().transpose() * face(local, t)).normalize())
        .collect();
    assert_close(&got, &want, "the tip part's world normals");
}

/// Joint 2 of a skin of two joints, with a weight: refused, naming the primitive, the
/// vertex and the skin. (With a zero weight it contributes nothing: the file loads, with
/// the validator's warning.)
#[test]
fn a_joint_beyond_the_skin_is_refused() {
    let mut strip_file = Strip::default();
    strip_file.joints[4] = [2, 0, 0, 0];
    let e = refused("joint_oob", &strip(strip_file));
    assert!(
        e.contains("meshes[0].primitives[0].attributes.JOINTS_0 (nodes[0] 'Strip'): vertex 4 names joint 2 (weight 1), but skins[0] has 2 joints"),
        "{e}"
    );
    let mut zero = Strip::default();
    zero.joints[4] = [1, 2, 0, 0];
    let s = load_json("joint_oob_zero_weight", &strip(zero));
    assert_close(
        &world_positions(object(&s, "Strip")),
        &skinned_strip(),
        "zero weight",
    );
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("have a joint index not below the 2 joints of skins[0]")),
        "{:?}",
        s.warnings
    );
}

/// One inverse bind matrix for two joints: refused (glTF 2.0 asks one for each joint).
/// More than the joints are allowed ("greater than or equal"): the extra is not used.
#[test]
fn too_few_inverse_bind_matrices_are_refused() {
    let e = refused(
        "ibm_count",
        &strip(Strip {
            inverse_bind: Some(vec![Mat4::IDENTITY]),
            ..Strip::default()
        }),
    );
    assert!(
        e.contains("skins[0].inverseBindMatrices: accessor 4 has 1 matrices for 2 joints"),
        "{e}"
    );
    let mut three = Strip::default().inverse_bind.unwrap();
    three.push(Mat4::from_scale(Vec3::ZERO));
    let s = load_json(
        "ibm_more",
        &strip(Strip {
            inverse_bind: Some(three),
            ..Strip::default()
        }),
    );
    assert_close(
        &world_positions(object(&s, "Strip")),
        &skinned_strip(),
        "3 IBMs",
    );
}

/// A vertex whose weights are all zero has no place by its skin (the blended matrix is
/// zero; glTF 2.0 asks the weights to sum to 1), yet a valid file may have one (an accessor
/// without bufferView is all zeros, and the validator does not look into it): it is left
/// unskinned, placed by the node's own transform (here a translation by (0, 0, -2)), with a
/// warning naming the primitive, the node and how many vertices.
#[test]
fn a_vertex_without_weight_stays_with_its_node_and_is_warned_of() {
    let mut s = Strip {
        node: json!({"translation": [0.0, 0.0, -2.0]}),
        ..Strip::default()
    };
    s.weights[3] = [0.0; 4];
    let s = load_json("zero_weights", &strip(s));
    let mut want = skinned_strip();
    want[3] = Vec3::new(1.0, 1.0, -2.0);
    assert_close(&world_positions(object(&s, "Strip")), &want, "zero weights");
    let w = "meshes[0].primitives[0].attributes.WEIGHTS_0 (nodes[0] 'Strip'): 1 of 6 vertices have every weight zero (first: vertex 3)";
    assert!(
        s.warnings.iter().any(|x| x.contains(w)),
        "no warning says '{w}': {:#?}",
        s.warnings
    );
}

/// A joint scaled to zero at rest flattens the vertices it carries alone (how a rig hides a
/// part): their blended matrix is singular. They are placed where it puts them, with a
/// warning naming the first; the file loads (a node scaled to zero is hidden likewise).
#[test]
fn a_singular_blended_matrix_flattens_its_vertices_with_a_warning() {
    let mut tip = Strip::default().tip;
    tip["scale"] = json!([0.0, 1.0, 1.0]);
    let s = load_json(
        "singular",
        &strip(Strip {
            tip,
            ..Strip::default()
        }),
    );
    let w = "meshes[0].primitives[0] (nodes[0] 'Strip'): the blended skinning matrix of 2 of 6 vertices is singular (first: vertex 4";
    assert!(
        s.warnings.iter().any(|x| x.contains(w)),
        "no warning says '{w}': {:#?}",
        s.warnings
    );
    // The tip's own x is scaled away, then turned about +y onto z: x = 2 goes where x = 1
    // does, (1, y, 5).
    let p = world_positions(object(&s, "Strip"));
    assert_close(
        &p[4..],
        &[Vec3::new(1.0, 0.0, 5.0), Vec3::new(1.0, 1.0, 5.0)],
        "flattened",
    );
}

/// A skin whose joint is a node that does not exist is refused before anything is read.
/// (`validate` refused it before skins were read too.)
#[test]
fn a_skin_naming_a_missing_node_is_refused() {
    let mut file = strip(Strip::default());
    file["skins"][0]["joints"] = json!([1, 7]);
    let e = refused("missing_joint", &file);
    assert!(e.contains("skins[0].joints[1]"), "{e}");
    assert!(e.contains('7'), "{e}");
}

/// Khronos' SimpleSkin (tests/data/khronos, CC0): a 1 x 2 strip of ten vertices in the XY
/// plane, skinned by two joints that rest at their bind pose, so at rest it is where its
/// vertices say, and an animation turns its upper joint (nodes[2]). Its bounds, and those
/// with nodes[2] turned 90 degrees about +z at rest (rotation [0, 0, 0.7071068, 0.7071068]),
/// computed independently by a plain-Python skinning of the file (JSON, base64 and struct
/// only: the joints' TRS composed, times the inverse bind matrices, blended by WEIGHTS_0;
/// `tests/data/khronos/simple_skin_rest.py`):
///
/// - as published: min (-0.5, 0, 0), max (0.5, 2, 0);
/// - nodes[2] turned: min (-1, 0, 0), max (0.5, 1.5, 0); vertices 8 and 9 (weight 1 on
///   nodes[2]) at (-1, 0.5, 0) and (-1, 1.5, 0), vertex 2 (weights 0.75 / 0.25) at
///   (-0.25, 0.5, 0).
///
/// As published (its animation turns nodes[2] from no rotation at t = 0) it loads as rigid
/// parts, one per joint, with the warning, and at t = 0 they span the published bounds; the
/// turned strip, without the animation, is one object skinned at rest.
#[test]
fn khronos_simple_skin_at_rest() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/khronos/SimpleSkin.gltf");
    let published: Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let mut turned = published.clone();
    let h = std::f32::consts::FRAC_1_SQRT_2;
    turned["nodes"][2]["rotation"] = json!([0.0, 0.0, h, h]);
    turned.as_object_mut().unwrap().remove("animations");
    let cases = [
        ("published", published, [-0.5, 0.0, 0.0], [0.5, 2.0, 0.0]),
        ("turned", turned, [-1.0, 0.0, 0.0], [0.5, 1.5, 0.0]),
    ];
    for (name, file, lo, hi) in cases {
        let s = load_json(&format!("simple_skin_{name}"), &file);
        let parts = if name == "published" { 2 } else { 1 };
        assert_eq!(s.objects.len(), parts, "{name}: {:?}", s.warnings);
        let b = (s.objects.iter())
            .map(|o| o.world_bounds().unwrap())
            .reduce(|a, b| a.union(b))
            .unwrap();
        let (lo, hi) = (Vec3::from(lo), Vec3::from(hi));
        assert!(
            (b.min - lo).abs().max_element() < 1e-5 && (b.max - hi).abs().max_element() < 1e-5,
            "{name}: bounds {b:?}, expected {lo} .. {hi}"
        );
        let w = "nodes[0]: skinned mesh moved as rigid parts, one per joint";
        assert_eq!(
            s.warnings.iter().any(|x| x.contains(w)),
            name == "published",
            "{name}: the warning '{w}' where it should not be, or missing: {:#?}",
            s.warnings
        );
        if name == "turned" {
            let o = &s.objects[0];
            assert_eq!(o.world_from_object, glam::Affine3A::IDENTITY, "{name}");
            let p = world_positions(o);
            let want = [(2, [-0.25, 0.5]), (8, [-1.0, 0.5]), (9, [-1.0, 1.5])];
            for (k, [x, y]) in want {
                assert!(
                    (p[k] - Vec3::new(x, y, 0.0)).abs().max_element() < 1e-5,
                    "vertex {k} at {}",
                    p[k]
                );
            }
        }
    }
}
