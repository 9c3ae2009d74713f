//! glTF 2.0 import (`.gltf` with embedded or external buffers, `.glb`) and export.
//!
//! Import: every triangle primitive of every node of the default scene becomes one
//! [`Object`](crate::Object) whose mesh is in the node's frame and whose `world_from_object` is the node's
//! accumulated transform (a skinned node's mesh: placed by its skin, in world space, with
//! the identity; see `skin`). Export: each object one node (matrix), one mesh, one material.
//!
//! A file is read in this order, one file a step:
//! - `container`: a GLB split into its JSON and BIN chunks;
//! - `validate`: the raw JSON checked against the specification before the gltf crate sees
//!   it (every index, length, enum and factor), so that crate has nothing to trip on;
//! - `buffers`: the buffers loaded (GLB BIN chunk, data URIs, files);
//! - `unpack`: compressed (meshopt, Draco), quantized and implicit (zero) data decoded into
//!   plain buffer views of one new buffer, so the gltf crate reads only what it can; then
//!   `instancing` reads the instanced nodes' instances (`EXT_mesh_gpu_instancing`);
//! - `validate` again, once the gltf crate has the document: the values of the attributes
//!   shrad does not use (normals, tangents, joints, weights), warnings only;
//! - `anim`: the animations, into a node graph and the lights' and materials' tracks
//!   (`KHR_animation_pointer`), which `blender_quirks` reads as Blender means them;
//! - `walk`, `mesh`, `material`: the default scene's nodes walked into objects (an
//!   instanced node's mesh once per instance), with the role and patch size of their
//!   `extras`; `skin`
//!   places the meshes of skinned nodes by their skins at rest (in world space).
//!
//! `write` is the exporter, on `builder` (accessors, buffer and GLB container), which
//! `shrad::bake` writes its lit meshes with too.

mod anim;
mod blender_quirks;
mod buffers;
pub mod builder;
mod container;
mod cutout;
mod extras;
mod instancing;
mod lights;
mod material;
mod mesh;
mod morph;
mod skin;
mod unpack;
mod validate;
mod visibility;
mod walk;
mod write;

use std::path::Path;

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

/// JSON numbers written as floats with an integral value (`1.0`) made integers: JSON has one
/// number type, and the glTF schema's integers are numbers with an integral value, which
/// serde (and so the gltf crate) refuses as a float where it expects an integer. A float
/// property (a factor, a matrix entry) reads an integer as the same float.
fn integral_floats_to_integers(v: &mut Value) {
    match v {
        Value::Number(n) if n.is_f64() => {
            if let Some(x) = n.as_f64() {
                if x.fract() == 0.0 && x.abs() < 9.0e15 {
                    *v = json!(x as i64);
                }
            }
        }
        Value::Array(a) => a.iter_mut().for_each(integral_floats_to_integers),
        Value::Object(o) => o.values_mut().for_each(integral_floats_to_integers),
        _ => {}
    }
}

/// What the gltf crate refuses though the specification allows it, or which shrad has
/// already done: the extensions `unpack` decoded (the texture extensions, whose images
/// the material reader picks, the punctual lights, which `lights` reads, the instancing,
/// which `instancing` reads, the visibility, which `visibility` reads, and the animation
/// pointers, which `anim` reads) out of `extensionsRequired` / `extensionsUsed` (the crate
/// refuses a required extension it does not know); a scene without `nodes` given an empty
/// list (optional in the specification, required by the crate); primitives without
/// POSITION removed (returns how many); accessors of a type glTF 2.0 does not define made
/// SCALAR.
fn crate_compatible(root: &mut Value) -> usize {
    const DONE: &[&str] = &[
        "KHR_mesh_quantization",
        "EXT_meshopt_compression",
        "KHR_meshopt_compression",
        "KHR_draco_mesh_compression",
        "EXT_texture_webp",
        "KHR_texture_basisu",
        lights::EXTENSION,
        instancing::EXTENSION,
        visibility::EXTENSION,
        "KHR_animation_pointer",
    ];
    for key in ["extensionsRequired", "extensionsUsed"] {
        if let Some(list) = root.get_mut(key).and_then(Value::as_array_mut) {
            list.retain(|e| !e.as_str().is_some_and(|e| DONE.contains(&e)));
        }
    }
    // Shading extensions a file requires are read as the base material they refine
    // (`validate::SHADING_EXTENSIONS`, which warned); the crate would refuse them.
    if let Some(list) = root
        .get_mut("extensionsRequired")
        .and_then(Value::as_array_mut)
    {
        list.retain(|e| {
            !e.as_str()
                .is_some_and(|e| validate::SHADING_EXTENSIONS.contains(&e))
        });
    }
    // A primitive without POSITION is skipped (warned about by `validate`); the crate
    // requires POSITION.
    let mut no_position = 0;
    for m in root
        .get_mut("meshes")
        .and_then(Value::as_array_mut)
        .into_iter()
        .flatten()
    {
        if let Some(p) = m.get_mut("primitives").and_then(Value::as_array_mut) {
            let before = p.len();
            p.retain(|p| p["attributes"].get("POSITION").is_some());
            no_position += before - p.len();
        }
    }
    // An accessor of a type glTF 2.0 does not define is refused wherever it is referred to
    // (`validate`); unreferenced, it is never read, and the crate needs a type it knows.
    for a in root
        .get_mut("accessors")
        .and_then(Value::as_array_mut)
        .into_iter()
        .flatten()
    {
        let known = ["SCALAR", "VEC2", "VEC3", "VEC4", "MAT2", "MAT3", "MAT4"];
        if !a["type"].as_str().is_some_and(|t| known.contains(&t)) {
            a["type"] = json!("SCALAR");
        }
    }
    for s in root
        .get_mut("scenes")
        .and_then(Value::as_array_mut)
        .into_iter()
        .flatten()
    {
        if s.get("nodes").is_none_or(Value::is_null) {
            s["nodes"] = json!([]);
        }
    }
    no_position
}

/// The image each texture reads: `EXT_texture_webp`'s (shrad decodes WebP), else the core
/// `source` (a PNG or JPEG, lossless or closer to the original than a GPU format), else
/// `KHR_texture_basisu`'s (a KTX2 image, transcoded to RGBA). A texture may have none (the specification requires `source` only
/// when no extension provides the image): the material then warns and uses its factor.
fn choose_texture_sources(root: &mut Value) {
    for t in root
        .get_mut("textures")
        .and_then(Value::as_array_mut)
        .into_iter()
        .flatten()
    {
        let ext = |name: &str| t.pointer(&format!("/extensions/{name}/source")).cloned();
        let chosen = ext("EXT_texture_webp")
            .filter(Value::is_u64)
            .or_else(|| t.get("source").filter(|s| s.is_u64()).cloned())
            .or_else(|| ext("KHR_texture_basisu").filter(Value::is_u64));
        if let Some(s) = chosen {
            t["source"] = s;
        }
    }
}

/// The gltf crate requires a `source` on every texture: one without is pointed at an empty
/// placeholder image, which is never decoded (the material reader reads each texture's
/// source from the raw JSON kept before this).
fn placeholder_sources(root: &mut Value) {
    let missing = |t: &Value| !t["source"].is_u64();
    let any = root["textures"]
        .as_array()
        .is_some_and(|t| t.iter().any(missing));
    let Some(obj) = root.as_object_mut().filter(|_| any) else {
        return;
    };
    let Value::Array(images) = obj.entry("images").or_insert_with(|| json!([])) else {
        return;
    };
    images.push(json!({ "name": "placeholder for a texture without a source" }));
    let placeholder = images.len() - 1;
    if let Some(textures) = root.get_mut("textures").and_then(Value::as_array_mut) {
        for t in textures.iter_mut().filter(|t| missing(t)) {
            t["source"] = json!(placeholder);
        }
    }
}

/// Take the animations (which `anim` reads from the raw JSON) out of `root`, for the gltf
/// crate.
fn take_animations(root: &mut Value) -> Vec<Value> {
    match root.as_object_mut().and_then(|r| r.remove("animations")) {
        Some(Value::Array(a)) => a,
        _ => Vec::new(),
    }
}

/// The checked and unpacked JSON split four ways: what the reader needs of the raw JSON
/// later (accessors, bufferViews and textures: small, no buffer data), the raw animations
/// (read by `anim`), the skins (read by `skin`), and the document made acceptable to the
/// gltf crate (which it takes uncopied: base64 buffers can be large). Animations and skins
/// are left out of what the gltf crate sees, which would refuse some valid ones (an
/// animation channel without a target node, as the specification allows).
fn split_for_crate(mut value: Value) -> ForCrate {
    let kept = json!({
        "accessors": value["accessors"].clone(),
        "bufferViews": value["bufferViews"].clone(),
        "textures": value["textures"].clone(),
    });
    let raw_animations = take_animations(&mut value);
    let skins = skin::FileSkins::take(&mut value);
    fill_position_bounds(&mut value);
    placeholder_sources(&mut value);
    let no_position = crate_compatible(&mut value);
    ForCrate {
        kept,
        raw_animations,
        skins,
        root: value,
        no_position,
    }
}

/// What [`split_for_crate`] gives.
struct ForCrate {
    kept: Value,
    raw_animations: Vec<Value>,
    skins: skin::FileSkins,
    root: Value,
    /// Primitives without POSITION taken out.
    no_position: usize,
}

/// The file's animations (`anim`), the lights' keys read as Blender means them in a file
/// Blender wrote (`blender_quirks`).
fn read_animations(
    raw: &[Value],
    (doc, buffers): (&gltf::Document, &[gltf::buffer::Data]),
    file_lights: &lights::FileLights,
    which: Option<&str>,
    warnings: &mut Vec<String>,
) -> Result<anim::Animations, String> {
    let lights = &file_lights.lights;
    let mut animations = anim::read(raw, (doc, lights.len()), buffers, which, warnings)?;
    let generator = doc.as_json().asset.generator.as_deref();
    blender_quirks::animated_lights(&mut animations.lights, lights, generator, warnings);
    Ok(animations)
}

/// The glTF's JSON (`json_bytes`, the whole file's `bytes` or a GLB's chunk), or what is
/// wrong with it: a `.glb` that is not JSON either is said not to be a GLB, with the bytes
/// it starts with.
fn parse_json(path: &Path, bytes: &[u8], json_bytes: &[u8]) -> Result<Value, String> {
    serde_json::from_slice(json_bytes).map_err(|e| {
        let glb = path.extension().is_some_and(|x| x.eq_ignore_ascii_case("glb"));
        match (glb, !bytes.starts_with(b"glTF")) {
            (true, true) => format!(
                "not a GLB file: it starts with {:?}, where a GLB starts with \"glTF\" (and it is not glTF JSON either: {e})",
                String::from_utf8_lossy(&bytes[..bytes.len().min(4)])
            ),
            _ => format!("invalid glTF: JSON: {e}"),
        }
    })
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
    let mut value = parse_json(path, bytes, json_bytes).map_err(bad)?;
    integral_floats_to_integers(&mut value);
    validate::check_json(&value, blob.map(<[u8]>::len), &mut warnings).map_err(bad)?;
    let file_lights = lights::read(&value, &mut warnings).map_err(bad)?;
    let visible = visibility::read(&value).map_err(bad)?;
    if value["meshes"].as_array().is_none_or(Vec::is_empty) {
        return Err(bad(
            "the file has no mesh (shrad lights triangle meshes, and this glTF defines none)"
                .into(),
        ));
    }
    let base = path.parent().unwrap_or(Path::new("."));
    let mut buffers = buffers::load_buffers(path, base, &value, blob.map(<[u8]>::to_vec))?;
    let unpacked = unpack::unpack(&mut value, &buffers).map_err(bad)?;
    if !unpacked.bytes.is_empty() {
        buffers.push(unpacked.bytes);
    }
    let instances = unpacked.instances;
    validate::check_views_have_data(&value, &buffers).map_err(bad)?;
    validate::check_sparse_indices(&value, &buffers).map_err(bad)?;
    // Planned on the JSON before the skins are taken out of it; read once the crate has it.
    let value_checks = validate::plan_values(&value, &unpacked.zeros);
    choose_texture_sources(&mut value);
    let ForCrate {
        kept,
        raw_animations,
        mut skins,
        root,
        no_position,
    } = split_for_crate(value);
    // The gltf crate's own messages begin "invalid glTF: " already.
    let root: gltf::json::Root =
        serde_json::from_value(root).map_err(|e| bad(format!("invalid glTF: {e}")))?;
    let doc = gltf::Document::from_json(root).map_err(|e| bad(e.to_string()))?;
    let buffers: Vec<gltf::buffer::Data> = buffers.into_iter().map(gltf::buffer::Data).collect();
    validate::check_values(&value_checks, &doc, &buffers, &mut warnings);
    let animations = read_animations(
        &raw_animations,
        (&doc, &buffers),
        &file_lights,
        animation,
        &mut warnings,
    )
    .map_err(bad)?;
    skins.place(&doc);
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
        light_tracks: animations.lights,
        material_tracks: animations.materials,
        camera_yfov: animations.cameras,
        names: Vec::new(),
        textures: std::collections::HashMap::new(),
        texels: crate::texture::TexelBudget::default(),
        materials: std::collections::HashMap::new(),
        mask_images: std::collections::HashSet::new(),
        cutout_left: crate::cutout::MAX_ADDED,
        cutout_capped: false,
        file_lights,
        skins,
        instances,
        visible,
        skipped: walk::Skipped {
            no_position,
            ..Default::default()
        },
    };
    cx.mask_images = cx.mask_sources();
    cx.scene()?;
    Ok((cx.scene, cx.names))
}
