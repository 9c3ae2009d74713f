//! glTF 2.0 import (`.gltf` with embedded or external buffers, `.glb`) and export.
//!
//! Import: every triangle primitive of every node of the default scene becomes one
//! [`Object`](crate::Object) whose mesh is in the node's frame and whose `world_from_object` is the node's
//! accumulated transform. Export: each object one node (matrix), one mesh, one material.
//!
//! A file is read in this order, one file a step:
//! - `container`: a GLB split into its JSON and BIN chunks;
//! - `validate`: the raw JSON checked against the specification before the gltf crate sees
//!   it (every index, length, enum and factor), so that crate has nothing to trip on;
//! - `buffers`: the buffers loaded (GLB BIN chunk, data URIs, files);
//! - `anim`: the animations, into a node graph;
//! - `walk`, `mesh`, `material`: the default scene's nodes walked into objects.
//!
//! `write` is the exporter, on `builder` (accessors, buffer and GLB container), which
//! `shrad::bake` writes its lit meshes with too.

mod anim;
mod buffers;
pub mod builder;
mod container;
mod material;
mod mesh;
mod validate;
mod walk;
mod write;

use std::path::Path;

use glam::Mat4;
use serde_json::{json, Value};

use crate::{Scene, SceneError};

pub use write::write_gltf;

/// The names an imported object came from, for the scene file's `node` / `mesh` filters.
#[derive(Clone, Debug, Default)]
pub(crate) struct PartNames {
    /// Name of the node that instanced it.
    pub node: Option<String>,
    /// Name of the mesh.
    pub mesh: Option<String>,
}

/// Read a glTF or GLB file into a scene (no role inference, no validation).
pub(crate) fn read(
    path: &Path,
    animation: Option<&str>,
) -> Result<(Scene, Vec<PartNames>), SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // Every reference, length and enum is checked on the raw JSON before the gltf crate sees
    // it, so nothing below should panic; this guard is a last resort only.
    match std::panic::catch_unwind(|| read_bytes(path, &bytes, animation)) {
        Ok(r) => r,
        Err(_) => Err(SceneError::invalid(
            path,
            "malformed glTF (the reader gave up on it)",
        )),
    }
}

/// Give every POSITION accessor without `min` / `max` (warned about by the validator) a
/// placeholder pair, so the gltf crate, which requires them, accepts the file. shrad never
/// reads them: it bounds the vertices it reads and refuses non-finite ones.
fn fill_position_bounds(root: &mut Value) {
    let mut positions: Vec<usize> = Vec::new();
    if let Some(meshes) = root.get("meshes").and_then(Value::as_array) {
        for prim in meshes
            .iter()
            .filter_map(|m| m.get("primitives")?.as_array())
            .flatten()
        {
            if let Some(a) = prim.pointer("/attributes/POSITION").and_then(Value::as_u64) {
                positions.push(a as usize);
            }
        }
    }
    let Some(accessors) = root.get_mut("accessors").and_then(Value::as_array_mut) else {
        return;
    };
    for a in positions {
        if let Some(acc) = accessors.get_mut(a).and_then(Value::as_object_mut) {
            for key in ["min", "max"] {
                if acc.get(key).is_none_or(Value::is_null) {
                    acc.insert(key.into(), json!([0.0, 0.0, 0.0]));
                }
            }
        }
    }
}

fn read_bytes(
    path: &Path,
    bytes: &[u8],
    animation: Option<&str>,
) -> Result<(Scene, Vec<PartNames>), SceneError> {
    let bad = |m: String| SceneError::invalid(path, m);
    let mut warnings = Vec::new();
    let (json_bytes, blob) = if bytes.starts_with(b"glTF") {
        let glb = container::split_glb(bytes).map_err(bad)?;
        warnings.extend(glb.warning);
        (glb.json, glb.bin)
    } else {
        (bytes, None)
    };
    let value: Value =
        serde_json::from_slice(json_bytes).map_err(|e| bad(format!("invalid glTF: JSON: {e}")))?;
    validate::check_json(&value, blob.map(<[u8]>::len), &mut warnings).map_err(bad)?;
    // Animations are read by `anim` and skins are not read; both are left out of what
    // the gltf crate sees, which would refuse some valid ones (an animation channel without
    // a target node, as the specification allows).
    // What the reader needs of the raw JSON later (small: no buffer data), so the document
    // itself (base64 buffers can be large) moves to the gltf crate uncopied.
    let kept = json!({
        "accessors": value["accessors"].clone(),
        "bufferViews": value["bufferViews"].clone(),
        "textures": value["textures"].clone(),
    });
    let mut for_crate = value;
    let mut raw_animations = Vec::new();
    if let Some(root) = for_crate.as_object_mut() {
        if let Some(Value::Array(a)) = root.remove("animations") {
            raw_animations = a;
        }
        if root
            .remove("skins")
            .is_some_and(|s| s.as_array().is_some_and(|s| !s.is_empty()))
        {
            warnings.push(
                "glTF skins ignored: skinned meshes stay in their bind pose (joints still move as nodes)".into(),
            );
        }
        if let Some(Value::Array(nodes)) = root.get_mut("nodes") {
            for n in nodes.iter_mut().filter_map(Value::as_object_mut) {
                n.remove("skin");
            }
        }
    }
    fill_position_bounds(&mut for_crate);
    let root: gltf::json::Root =
        serde_json::from_value(for_crate).map_err(|e| bad(format!("invalid glTF: {e}")))?;
    let doc = gltf::Document::from_json(root).map_err(|e| bad(format!("invalid glTF: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = buffers::load_buffers(path, base, &doc, blob.map(<[u8]>::to_vec))?;
    validate::check_sparse_indices(&kept, &buffers).map_err(bad)?;
    let animations =
        anim::read(&raw_animations, &doc, &buffers, animation, &mut warnings).map_err(bad)?;
    let mut cx = walk::Walk {
        path,
        base,
        doc: &doc,
        json: &kept,
        buffers: &buffers,
        scene: Scene {
            source: path.display().to_string(),
            warnings,
            animations: animations.info,
            ..Default::default()
        },
        graph: animations.graph,
        names: Vec::new(),
        textures: std::collections::HashMap::new(),
        texels_left: crate::texture::MAX_FILE_TEXELS,
        materials: std::collections::HashMap::new(),
    };
    let roots: Vec<gltf::Node> = match doc.default_scene().or_else(|| doc.scenes().next()) {
        Some(s) => s.nodes().collect(),
        None => {
            let mut is_child = vec![false; doc.nodes().len()];
            for n in doc.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            cx.scene
                .warnings
                .push("glTF has no scene: taking every root node".into());
            doc.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    for node in roots {
        cx.node(node, Mat4::IDENTITY, 0)?;
    }
    if doc.meshes().len() > 0 && cx.scene.objects.is_empty() {
        cx.scene
            .warnings
            .push("no node of the scene instances a triangle mesh".into());
    }
    Ok((cx.scene, cx.names))
}
