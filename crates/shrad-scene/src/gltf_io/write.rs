//! The exporter: a scene as glTF 2.0 (`.gltf` with the buffer embedded, or `.glb`).

use std::path::Path;

use glam::{Affine3A, Mat4};
use serde_json::{json, Value};

use super::builder::{bounds, BufferAt, GltfBuffer, TRIANGLES};
use crate::{Camera, Object, Scene, SceneError};

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
    let mut buffer = GltfBuffer::new();
    let mut meshes = Vec::new();
    let mut materials = Vec::new();
    let mut nodes = Vec::new();
    let mut uses_strength = false;
    for (i, o) in scene.objects.iter().enumerate() {
        let (lo, hi) = bounds(&o.mesh.positions);
        let position = buffer.vec3s(
            &o.mesh.positions,
            Some((nums(&lo.to_array()), nums(&hi.to_array()))),
        );
        // Indices, as they are: the mesh is counter-clockwise from the front in its own frame,
        // which is what glTF says also under a mirroring node transform.
        let indices = buffer.triangles(&o.mesh.triangles);
        let (material, strength) = material(o);
        uses_strength |= strength;
        materials.push(material);
        meshes.push(json!({
            "name": o.name,
            "primitives": [{"attributes": {"POSITION": position}, "indices": indices, "material": i, "mode": TRIANGLES}]
        }));
        nodes.push(node(o, i));
    }
    if let Some(cam) = &scene.camera {
        nodes.push(
            json!({"name": "camera", "camera": 0, "matrix": mat4_array(cam.world_from_camera)}),
        );
    }
    let at = if embed {
        BufferAt::Embedded
    } else {
        BufferAt::Glb
    };
    let buffer = buffer.finish(at);
    let mut root = json!({
        "asset": {"version": "2.0", "generator": "shrad"},
        "scene": 0,
        "scenes": [{"name": scene.source, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": buffer.accessors,
        "bufferViews": buffer.buffer_views,
        "buffers": buffer.buffers,
    });
    if let Some(cam) = &scene.camera {
        root["cameras"] = json!([camera(scene, cam)]);
    }
    if uses_strength {
        root["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    }
    (root, buffer.bin)
}

/// An object's material, and whether it needs `KHR_materials_emissive_strength`.
fn material(o: &Object) -> (Value, bool) {
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
        mat["emissiveFactor"] = nums(&(e / emax).to_array());
        mat["extensions"] =
            json!({"KHR_materials_emissive_strength": {"emissiveStrength": num(emax)}});
    } else if emax > 0.0 {
        mat["emissiveFactor"] = nums(&e.to_array());
    }
    (mat, emax > 1.0)
}

/// Object `i`'s node: its mesh, its transform unless the identity, role and patch size.
fn node(o: &Object, i: usize) -> Value {
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
    node
}

/// The camera's perspective (its node is written with the objects').
fn camera(scene: &Scene, cam: &Camera) -> Value {
    let size = scene
        .bounds()
        .map_or(1.0, |b| b.diagonal())
        .max(f32::MIN_POSITIVE);
    let mut persp = json!({"yfov": num(cam.yfov), "znear": num(1e-3 * size)});
    if let Some(a) = cam.aspect_ratio {
        persp["aspectRatio"] = num(a);
    }
    json!({"type": "perspective", "perspective": persp})
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
        super::builder::join_glb(text, bin).map_err(|e| SceneError::invalid(path, e))?
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
