//! Morph targets at rest and alpha modes in glTF import.
//!
//! Morph targets (glTF 2.0, "Morph Targets"): the static shape is the base POSITION plus
//! each target's displacements times its weight, the node's `weights` overriding the mesh's
//! (default 0); targets read as any accessor is (sparse, normalized SHORT with
//! KHR_mesh_quantization); a weights animation is not played, with a warning saying the
//! pose at rest is used. The fixture is Khronos' SimpleMorph triangle: apex (0.5, 0.5, 0),
//! target 0 moves it by (-1, 1, 0) and target 1 by (1, 1, 0), so weights [0.5, 0.5] put it
//! at (0.5, 1.5, 0).
//!
//! Alpha modes ("Alpha Coverage"): a MASK material whose base colour alpha factor is below
//! its alphaCutoff, or a BLEND one whose alpha factor is 0, is seen nowhere: its primitives
//! are left out (they neither reflect nor block light), with a warning naming material and
//! mesh. A textured MASK material is cut by its texture (see `gltf_mask_cutout`); other
//! BLEND materials stay opaque, with a warning once per material.

use glam::Vec3;
use serde_json::{json, Value};
use shrad_scene::{Object, Scene};

use crate::common::gltf_bin::{bounds, Bin};

impl Bin {
    /// A VEC3 accessor of normalized SHORTs (`KHR_mesh_quantization`), each element padded
    /// to 8 bytes (byteStride 8, as vertex attributes are aligned to 4 bytes).
    fn vec3_short(&mut self, data: &[[i16; 3]]) -> usize {
        let mut bytes = Vec::new();
        for e in data {
            for c in e {
                bytes.extend_from_slice(&c.to_le_bytes());
            }
            bytes.extend_from_slice(&[0, 0]);
        }
        let v = self.view(&bytes, json!({"byteStride": 8}));
        let f = |e: &[i16; 3]| e.map(|c| f32::from(c) / 32767.0);
        let (lo, hi) = bounds(&data.iter().map(f).collect::<Vec<_>>());
        self.push(
            json!({"bufferView": v, "componentType": 5122, "normalized": true,
                         "count": data.len(), "type": "VEC3", "min": lo, "max": hi}),
        )
    }

    /// A sparse VEC3 FLOAT accessor of `count` elements, zeros but for `values` at `indices`
    /// (no bufferView: the base is zeros).
    fn vec3_sparse(&mut self, count: usize, indices: &[u16], values: &[[f32; 3]]) -> usize {
        let ib: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let iv = self.view(&ib, json!({}));
        let vb: Vec<u8> = values
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let vv = self.view(&vb, json!({}));
        let mut all = vec![[0.0; 3]; count];
        for (&i, &v) in indices.iter().zip(values) {
            all[i as usize] = v;
        }
        let (lo, hi) = bounds(&all);
        self.push(
            json!({"componentType": 5126, "count": count, "type": "VEC3",
                         "min": lo, "max": hi,
                         "sparse": {"count": indices.len(),
                                    "indices": {"bufferView": iv, "componentType": 5123},
                                    "values": {"bufferView": vv}}}),
        )
    }

    /// A VEC2 FLOAT accessor of `data`.
    fn vec2(&mut self, data: &[[f32; 2]]) -> usize {
        let bytes: Vec<u8> = data
            .iter()
            .flatten()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let v = self.view(&bytes, json!({}));
        self.push(
            json!({"bufferView": v, "componentType": 5126, "count": data.len(),
                         "type": "VEC2"}),
        )
    }

    /// A SCALAR FLOAT accessor of `data`, with min and max.
    fn scalars(&mut self, data: &[f32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let v = self.view(&bytes, json!({}));
        let lo = data.iter().copied().fold(f32::INFINITY, f32::min);
        let hi = data.iter().copied().fold(f32::NEG_INFINITY, f32::max);
        self.push(
            json!({"bufferView": v, "componentType": 5126, "count": data.len(),
                         "type": "SCALAR", "min": [lo], "max": [hi]}),
        )
    }
}

fn load_json(name: &str, root: &Value) -> Scene {
    crate::common::load_gltf_json("gltf-morph-alpha", name, root)
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

fn said(s: &Scene, parts: &[&str]) -> bool {
    s.warnings
        .iter()
        .any(|w| parts.iter().all(|p| w.contains(p)))
}

/// SimpleMorph's base triangle (apex at (0.5, 0.5, 0)).
const BASE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.5, 0.0]];
/// SimpleMorph's targets: the apex moved by (-1, 1, 0) and by (1, 1, 0).
const TARGET0: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [-1.0, 1.0, 0.0]];
const TARGET1: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [1.0, 1.0, 0.0]];

/// A SimpleMorph mesh ("Morph", mesh weights `mesh_weights`) whose targets are accessors
/// `targets` of `b`, instanced by the `nodes` given (each a root of the scene). Returns the
/// JSON before `finish`.
fn morph_file(b: &mut Bin, targets: [usize; 2], mesh_weights: Value, nodes: Value) -> Value {
    let pos = b.vec3(&BASE);
    let idx = b.indices(&[0, 1, 2]);
    let mut mesh = json!({"name": "Morph", "primitives": [{
        "attributes": {"POSITION": pos}, "indices": idx,
        "targets": [{"POSITION": targets[0]}, {"POSITION": targets[1]}]
    }]});
    if !mesh_weights.is_null() {
        mesh["weights"] = mesh_weights;
    }
    let n = nodes.as_array().unwrap().len();
    json!({
        "scene": 0,
        "scenes": [{"nodes": (0..n).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": [mesh],
    })
}

fn apex(s: &Scene, name: &str) -> Vec3 {
    let o = object(s, name);
    assert_eq!(o.mesh.positions.len(), 3, "{name}");
    assert_eq!(o.mesh.positions[0], Vec3::ZERO, "{name}: vertex 0 moved");
    assert_eq!(o.mesh.positions[1], Vec3::X, "{name}: vertex 1 moved");
    o.mesh.positions[2]
}

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() < 1e-4
}

/// Mesh weights [0.5, 0.5] put the apex at (0.5, 1.5, 0) (where SimpleMorph without its
/// animation was drawn at y = 0.5); a node's weights override them; no weights at all are 0.
#[test]
fn morph_targets_take_the_nodes_weights_else_the_meshs() {
    let mut b = Bin::default();
    let t0 = b.vec3(&TARGET0);
    let t1 = b.vec3(&TARGET1);
    let nodes = json!([
        {"name": "mesh_weights", "mesh": 0},
        {"name": "node_weights", "mesh": 0, "weights": [1.0, 0.0], "translation": [3.0, 0.0, 0.0]},
        {"name": "node_zero", "mesh": 0, "weights": [0.0, 0.0], "translation": [6.0, 0.0, 0.0]}
    ]);
    let file = morph_file(&mut b, [t0, t1], json!([0.5, 0.5]), nodes);
    let s = load_json("weights", &b.finish(file));
    assert!(close(apex(&s, "mesh_weights"), Vec3::new(0.5, 1.5, 0.0)));
    assert!(close(apex(&s, "node_weights"), Vec3::new(-0.5, 1.5, 0.0)));
    assert!(close(apex(&s, "node_zero"), Vec3::new(0.5, 0.5, 0.0)));
    assert!(!said(&s, &["morph"]), "{:?}", s.warnings);

    // Without mesh weights, a node without weights has the base shape.
    let mut b = Bin::default();
    let t0 = b.vec3(&TARGET0);
    let t1 = b.vec3(&TARGET1);
    let nodes = json!([
        {"name": "rest", "mesh": 0},
        {"name": "morphed", "mesh": 0, "weights": [0.25, 0.75], "translation": [3.0, 0.0, 0.0]}
    ]);
    let file = morph_file(&mut b, [t0, t1], Value::Null, nodes);
    let s = load_json("no-mesh-weights", &b.finish(file));
    assert!(close(apex(&s, "rest"), Vec3::new(0.5, 0.5, 0.0)));
    // x: 0.5 + 0.25 * -1 + 0.75 * 1 = 1.0; y: 0.5 + 0.25 + 0.75 = 1.5.
    assert!(close(apex(&s, "morphed"), Vec3::new(1.0, 1.5, 0.0)));
}

/// A target given as a sparse accessor without bufferView (zeros but the apex), and one of
/// normalized SHORTs (KHR_mesh_quantization, strided), read as a FLOAT one is.
#[test]
fn sparse_and_quantized_targets_are_read() {
    let mut b = Bin::default();
    let t0 = b.vec3_short(&[[0, 0, 0], [0, 0, 0], [-32767, 32767, 0]]);
    let t1 = b.vec3_sparse(3, &[2], &[[1.0, 1.0, 0.0]]);
    let nodes = json!([{"name": "packed", "mesh": 0}]);
    let mut file = morph_file(&mut b, [t0, t1], json!([0.5, 0.5]), nodes);
    file["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
    file["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    let s = load_json("sparse-quantized", &b.finish(file));
    assert!(
        close(apex(&s, "packed"), Vec3::new(0.5, 1.5, 0.0)),
        "{}",
        apex(&s, "packed")
    );
    // The sparse target alone (weights of the node): only the apex moves.
    let mut b = Bin::default();
    let t0 = b.vec3(&TARGET0);
    let t1 = b.vec3_sparse(3, &[2], &[[1.0, 1.0, 0.0]]);
    let nodes = json!([{"name": "sparse", "mesh": 0, "weights": [0.0, 2.0]}]);
    let file = morph_file(&mut b, [t0, t1], json!([0.5, 0.5]), nodes);
    let s = load_json("sparse-only", &b.finish(file));
    assert!(close(apex(&s, "sparse"), Vec3::new(2.5, 2.5, 0.0)));
}

/// A weights animation is not played: the pose at rest is drawn, and the warning says so.
#[test]
fn a_morph_animation_leaves_the_pose_at_rest_with_a_warning() {
    let mut b = Bin::default();
    let t0 = b.vec3(&TARGET0);
    let t1 = b.vec3(&TARGET1);
    let times = b.scalars(&[0.0, 1.0]);
    let values = b.scalars(&[1.0, 0.0, 0.0, 1.0]);
    let nodes = json!([{"name": "animated", "mesh": 0}]);
    let mut file = morph_file(&mut b, [t0, t1], json!([0.5, 0.5]), nodes);
    file["animations"] = json!([{
        "name": "Shape",
        "channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
        "samplers": [{"input": times, "output": values}]
    }]);
    let s = load_json("animated", &b.finish(file));
    assert!(close(apex(&s, "animated"), Vec3::new(0.5, 1.5, 0.0)));
    assert!(
        said(
            &s,
            &[
                "'Shape' channel 0 targets morph weights: ignored",
                "pose at rest"
            ]
        ),
        "{:?}",
        s.warnings
    );
}

/// A target that cannot be read as displacements (a SCALAR accessor) is ignored with a
/// warning naming it; the others still apply, and the file loads.
#[test]
fn an_unreadable_target_is_ignored_with_a_warning() {
    let mut b = Bin::default();
    let t0 = b.scalars(&[0.0, 0.0, 1.0]);
    let t1 = b.vec3(&TARGET1);
    let nodes = json!([{"name": "half", "mesh": 0}]);
    let file = morph_file(&mut b, [t0, t1], json!([0.5, 0.5]), nodes);
    let s = load_json("unreadable", &b.finish(file));
    assert!(close(apex(&s, "half"), Vec3::new(1.0, 1.0, 0.0)));
    assert!(
        said(
            &s,
            &["meshes[0].primitives[0].targets[0].POSITION", "is ignored"]
        ),
        "{:?}",
        s.warnings
    );
}

/// Two floor quads side by side (with texture coordinates), one primitive each in mesh
/// "Pair", with materials `materials` (index 0 on the first, 1 on the second), and a lamp
/// quad above.
fn alpha_file(materials: Value) -> Value {
    let mut b = Bin::default();
    let quad = |x: f32, y: f32| {
        [
            [x, y, 0.0],
            [x, y, 1.0],
            [x + 1.0, y, 1.0],
            [x + 1.0, y, 0.0],
        ]
    };
    let idx = b.indices(&[0, 1, 2, 0, 2, 3]);
    let a = b.vec3(&quad(0.0, 0.0));
    let c = b.vec3(&quad(2.0, 0.0));
    let lamp = b.vec3(&quad(0.0, 2.0));
    let lamp_idx = b.indices(&[0, 2, 1, 0, 3, 2]);
    let uv = b.vec2(&[[0.0, 0.0], [0.0, 1.0], [1.0, 1.0], [1.0, 0.0]]);
    let mut mats = materials.as_array().unwrap().clone();
    mats.push(json!({"name": "lamp", "pbrMetallicRoughness": grey(1.0),
                     "emissiveFactor": [1.0, 1.0, 1.0]}));
    let file = json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"name": "lamp", "mesh": 1}],
        "meshes": [
            {"name": "Pair", "primitives": [
                {"attributes": {"POSITION": a, "TEXCOORD_0": uv}, "indices": idx, "material": 0},
                {"attributes": {"POSITION": c, "TEXCOORD_0": uv}, "indices": idx, "material": 1}
            ]},
            {"name": "Lamp", "primitives": [
                {"attributes": {"POSITION": lamp}, "indices": lamp_idx, "material": mats.len() - 1}
            ]}
        ],
        "materials": mats
    });
    b.finish(file)
}

fn grey(alpha: f32) -> Value {
    json!({"baseColorFactor": [0.5, 0.5, 0.5, alpha], "metallicFactor": 0.0})
}

fn triangles(s: &Scene) -> usize {
    s.objects.iter().map(|o| o.mesh.triangles.len()).sum()
}

/// A MASK material whose alpha factor is below its cutoff (default 0.5) is cut away: its
/// primitive is not in the scene, the other primitive of the mesh is, and the warning
/// names the material and the mesh. At or above the cutoff it stays, without a warning.
#[test]
fn a_fully_masked_primitive_is_left_out() {
    let s = load_json(
        "mask",
        &alpha_file(json!([
            {"name": "Solid", "pbrMetallicRoughness": grey(1.0)},
            {"name": "Hidden", "pbrMetallicRoughness": grey(0.3), "alphaMode": "MASK"}
        ])),
    );
    let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["Pair.0", "lamp"], "{:?}", s.warnings);
    assert_eq!(triangles(&s), 4);
    assert_eq!(object(&s, "Pair.0").mesh.positions[0], Vec3::ZERO);
    assert!(
        said(
            &s,
            &[
                "meshes[0].primitives[1] of mesh 'Pair' (nodes[0])",
                "materials[1] 'Hidden' is alphaMode MASK",
                "alpha 0.3 below its alphaCutoff 0.5",
                "neither reflects nor blocks light",
            ]
        ),
        "{:?}",
        s.warnings
    );

    // An explicit cutoff below the factor keeps it (alpha 0.3 >= 0.25): drawn opaque, silently.
    let s = load_json(
        "mask-kept",
        &alpha_file(json!([
            {"name": "Solid", "pbrMetallicRoughness": grey(1.0)},
            {"name": "Kept", "pbrMetallicRoughness": grey(0.3), "alphaMode": "MASK",
             "alphaCutoff": 0.25}
        ])),
    );
    assert_eq!(s.objects.len(), 3, "{:?}", s.warnings);
    assert_eq!(triangles(&s), 6);
    assert!(!said(&s, &["alpha"]), "{:?}", s.warnings);
}

/// A 2 x 2 RGBA PNG (half its texels transparent) as a data URI.
fn rgba_png() -> String {
    crate::common::rgba_png_uri(2, 2, [200, 200, 200], |x, _| if x == 0 { 255 } else { 0 })
}

/// A textured MASK material (foliage) is cut by its texture's alpha (`gltf_mask_cutout`
/// tests how), with a warning for each primitive drawn; a BLEND material with alpha above
/// 0 stays opaque, with one warning however many primitives use it. A BLEND one with alpha
/// 0 is seen nowhere: left out like a cut-away MASK.
#[test]
fn textured_mask_is_cut_and_blend_stays_opaque_with_a_warning() {
    let mut file = alpha_file(json!([
        {"name": "Leaves", "alphaMode": "MASK",
         "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0,
                                  "baseColorTexture": {"index": 0}}},
        {"name": "Glass", "pbrMetallicRoughness": grey(0.4), "alphaMode": "BLEND"}
    ]));
    file["images"] = json!([{"uri": rgba_png()}]);
    file["textures"] = json!([{"source": 0}]);
    // A second node draws the mesh again: still one warning for the material.
    file["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "again", "mesh": 0, "translation": [0.0, 0.0, 3.0]}));
    file["scenes"][0]["nodes"] = json!([0, 1, 2]);
    let s = load_json("textured", &file);
    assert_eq!(s.objects.len(), 5, "{:?}", s.warnings);
    assert!(
        s.objects[0].material.base_color_texture.is_some(),
        "{:?}",
        s.warnings
    );
    let leaves = "materials[0] 'Leaves' alphaMode MASK cut-outs resolved to";
    assert_eq!(
        s.warnings.iter().filter(|w| w.contains(leaves)).count(),
        2,
        "{:?}",
        s.warnings
    );
    assert!(
        said(
            &s,
            &["materials[1] 'Glass': alphaMode BLEND", "treated as opaque"]
        ),
        "{:?}",
        s.warnings
    );

    let s = load_json(
        "blend-zero",
        &alpha_file(json!([
            {"name": "Solid", "pbrMetallicRoughness": grey(1.0)},
            {"name": "Invisible", "pbrMetallicRoughness": grey(0.0), "alphaMode": "BLEND"}
        ])),
    );
    assert_eq!(s.objects.len(), 2, "{:?}", s.warnings);
    assert_eq!(triangles(&s), 4);
    assert!(
        said(
            &s,
            &[
                "meshes[0].primitives[1] of mesh 'Pair'",
                "materials[1] 'Invisible' is alphaMode BLEND with a base colour alpha of 0",
            ]
        ),
        "{:?}",
        s.warnings
    );
}
