//! The exporter: a scene as glTF 2.0 (`.gltf` with the buffer embedded, or `.glb`).

use std::path::Path;

use glam::{Affine3A, Mat4, Vec3};
use serde_json::{json, Value};

use crate::{Scene, SceneError};

/// An f32 as the JSON number with the same shortest decimal form (559.2, not 559.2000122).
fn num(x: f32) -> Value {
    x.to_string()
        .parse::<f64>()
        .map_or(Value::Null, |v| json!(v))
}

fn nums(xs: &[f32]) -> Value {
    Value::Array(xs.iter().map(|&x| num(x)).collect())
}

fn mat4_array(m: Affine3A) -> Value {
    nums(&Mat4::from(m).to_cols_array())
}

/// The glTF JSON and binary buffer of a scene.
fn build(scene: &Scene, embed: bool) -> (Value, Vec<u8>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut meshes = Vec::new();
    let mut materials = Vec::new();
    let mut nodes = Vec::new();
    let mut uses_strength = false;
    for (i, o) in scene.objects.iter().enumerate() {
        // Positions.
        let offset = bin.len();
        for p in &o.mesh.positions {
            for c in p.to_array() {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        let (lo, hi) = o.mesh.positions.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), &p| (lo.min(p), hi.max(p)),
        );
        let (lo, hi) = if o.mesh.positions.is_empty() {
            (Vec3::ZERO, Vec3::ZERO)
        } else {
            (lo, hi)
        };
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bin.len() - offset, "target": 34962}));
        accessors.push(json!({
            "bufferView": views.len() - 1, "componentType": 5126, "count": o.mesh.positions.len(),
            "type": "VEC3", "min": nums(&lo.to_array()), "max": nums(&hi.to_array())
        }));
        // Indices, as they are: the mesh is counter-clockwise from the front in its own frame,
        // which is what glTF says also under a mirroring node transform.
        let offset = bin.len();
        for t in &o.mesh.triangles {
            for v in t {
                bin.extend_from_slice(&v.to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bin.len() - offset, "target": 34963}));
        accessors.push(json!({
            "bufferView": views.len() - 1, "componentType": 5125, "count": 3 * o.mesh.triangles.len(), "type": "SCALAR"
        }));
        // Material.
        let m = &o.material;
        let r = m.reflectance;
        let e = m.emitted_radiance;
        let emax = e.max_element();
        let mut mat = json!({
            "name": o.name,
            "pbrMetallicRoughness": {"baseColorFactor": nums(&[r.x, r.y, r.z, 1.0]), "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "doubleSided": m.double_sided,
        });
        if emax > 1.0 {
            uses_strength = true;
            mat["emissiveFactor"] = nums(&(e / emax).to_array());
            mat["extensions"] =
                json!({"KHR_materials_emissive_strength": {"emissiveStrength": num(emax)}});
        } else if emax > 0.0 {
            mat["emissiveFactor"] = nums(&e.to_array());
        }
        materials.push(mat);
        meshes.push(json!({
            "name": o.name,
            "primitives": [{"attributes": {"POSITION": 2 * i}, "indices": 2 * i + 1, "material": i, "mode": 4}]
        }));
        let mut extras = serde_json::Map::new();
        if let Some(role) = o.role {
            extras.insert("shrad_role".into(), json!(role.name()));
        }
        if let Some(h) = o.patch_size {
            extras.insert("shrad_patch_size".into(), num(h));
        }
        let mut node = json!({"name": o.name, "mesh": i});
        if o.world_from_object != Affine3A::IDENTITY {
            node["matrix"] = mat4_array(o.world_from_object);
        }
        if !extras.is_empty() {
            node["extras"] = Value::Object(extras);
        }
        nodes.push(node);
    }
    let mut root = json!({
        "asset": {"version": "2.0", "generator": "shrad"},
        "scene": 0,
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
    });
    if let Some(cam) = &scene.camera {
        let size = scene
            .bounds()
            .map_or(1.0, |b| b.diagonal())
            .max(f32::MIN_POSITIVE);
        let mut persp = json!({"yfov": num(cam.yfov), "znear": num(1e-3 * size)});
        if let Some(a) = cam.aspect_ratio {
            persp["aspectRatio"] = num(a);
        }
        root["cameras"] = json!([{"type": "perspective", "perspective": persp}]);
        root["nodes"]
            .as_array_mut()
            .expect("nodes is an array")
            .push(
                json!({"name": "camera", "camera": 0, "matrix": mat4_array(cam.world_from_camera)}),
            );
    }
    let n_nodes = root["nodes"].as_array().map_or(0, Vec::len);
    root["scenes"] = json!([{"name": scene.source, "nodes": (0..n_nodes).collect::<Vec<_>>()}]);
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let mut buffer = json!({"byteLength": bin.len()});
    if embed {
        buffer["uri"] = json!(format!(
            "data:application/octet-stream;base64,{}",
            base64::encode(&bin)
        ));
    }
    root["buffers"] = json!([buffer]);
    if uses_strength {
        root["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    }
    (root, bin)
}

/// Write the scene as glTF 2.0: a `.gltf` with the buffer embedded as a base64 data URI,
/// or, when `path` ends in `.glb`, a binary glTF. Each object is one node (its
/// `world_from_object` as a matrix) with one mesh and one material (`baseColorFactor` =
/// reflectance, `emissiveFactor` x `KHR_materials_emissive_strength` = emitted radiance,
/// `doubleSided`); the role and patch size go to the node's `extras` (`shrad_role`,
/// `shrad_patch_size`); the camera is a node of its own. Animations are not written.
pub fn write_gltf(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let glb = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("glb"));
    let (root, bin) = build(scene, !glb);
    let bytes = if glb {
        let text = serde_json::to_vec(&root).expect("JSON serialises");
        super::container::join_glb(text, bin).map_err(|e| SceneError::invalid(path, e))?
    } else {
        let mut t = serde_json::to_vec_pretty(&root).expect("JSON serialises");
        t.push(b'\n');
        t
    };
    crate::write_atomic(path, |tmp| {
        std::fs::write(tmp, &bytes).map_err(|e| e.to_string())
    })?;
    Ok(())
}
