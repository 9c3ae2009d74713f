//! glTF 2.0 import (`.gltf` with embedded or external buffers, `.glb`) and export.
//!
//! Import: every triangle primitive of every node of the default scene becomes one
//! [`Object`] whose mesh is in the node's frame and whose `world_from_object` is the node's
//! accumulated transform. Export: each object one node (matrix), one mesh, one material.

use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat4, Vec3};
use gltf::mesh::Mode;
use serde_json::{json, Value};

use crate::{
    base64, Camera, Filter, Material, Mesh, Object, Role, Scene, SceneError, Texture, TextureImage,
    UvTransform, Wrap,
};

/// The names an imported object came from, for the scene file's `node` / `mesh` filters.
#[derive(Clone, Debug, Default)]
pub(crate) struct PartNames {
    /// Name of the node that instanced it.
    pub node: Option<String>,
    /// Name of the mesh.
    pub mesh: Option<String>,
}

/// Deepest node hierarchy accepted (guards against cyclic node graphs).
const MAX_DEPTH: usize = 512;

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

fn read_bytes(
    path: &Path,
    bytes: &[u8],
    animation: Option<&str>,
) -> Result<(Scene, Vec<PartNames>), SceneError> {
    let bad = |m: String| SceneError::invalid(path, m);
    let mut warnings = Vec::new();
    let (json_bytes, blob) = if bytes.starts_with(b"glTF") {
        let glb = split_glb(bytes).map_err(bad)?;
        warnings.extend(glb.warning);
        (glb.json, glb.bin)
    } else {
        (bytes, None)
    };
    let value: Value =
        serde_json::from_slice(json_bytes).map_err(|e| bad(format!("invalid glTF: JSON: {e}")))?;
    check_json(&value, blob.map(<[u8]>::len), &mut warnings).map_err(bad)?;
    // Animations are read by `gltf_anim` and skins are not read; both are left out of what
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
    let root: gltf::json::Root =
        serde_json::from_value(for_crate).map_err(|e| bad(format!("invalid glTF: {e}")))?;
    let doc = gltf::Document::from_json(root).map_err(|e| bad(format!("invalid glTF: {e}")))?;
    let base = path.parent().unwrap_or(Path::new("."));
    let buffers = load_buffers(path, base, &doc, blob.map(<[u8]>::to_vec))?;
    check_sparse_indices(&kept, &buffers).map_err(bad)?;
    let animations =
        crate::gltf_anim::read(&raw_animations, &doc, &buffers, animation, &mut warnings)
            .map_err(bad)?;
    let mut cx = Walk {
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

/// The chunks of a GLB.
struct Glb<'a> {
    json: &'a [u8],
    bin: Option<&'a [u8]>,
    /// Bytes after the declared length.
    warning: Option<String>,
}

/// Split a GLB into its JSON and BIN chunks, every length checked against the file.
fn split_glb(bytes: &[u8]) -> Result<Glb<'_>, String> {
    const JSON: u32 = 0x4E4F_534A;
    const BIN: u32 = 0x004E_4942;
    let n = bytes.len();
    let word = |at: usize| -> Option<u32> {
        let b = bytes.get(at..at.checked_add(4)?)?;
        Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(format!(
            "GLB: the 12-byte header is truncated (the file has {n} bytes)"
        ));
    };
    if version != 2 {
        return Err(format!(
            "GLB: container version {version} (shrad reads glTF 2.0, GLB version 2)"
        ));
    }
    let length = length as usize;
    if length > n {
        return Err(format!(
            "GLB: the header declares {length} bytes but the file has {n} (truncated file?)"
        ));
    }
    let warning = (length < n).then(|| {
        format!(
            "GLB: {} byte(s) after the declared length ignored",
            n - length
        )
    });
    // (type, body, offset of the next chunk) of the chunk at `at`; None at the end.
    type Chunk<'b> = Option<(u32, &'b [u8], usize)>;
    let chunk = |at: usize| -> Result<Chunk<'_>, String> {
        if at == length {
            return Ok(None);
        }
        let (Some(len), Some(ty)) = (word(at), word(at + 4)) else {
            return Err(format!(
                "GLB: the chunk header at byte {at} is truncated (the GLB has {length} bytes)"
            ));
        };
        let start = at + 8;
        if start > length {
            return Err(format!(
                "GLB: the chunk header at byte {at} is truncated (the GLB has {length} bytes)"
            ));
        }
        let end = start
            .checked_add(len as usize)
            .filter(|&e| e <= length)
            .ok_or_else(|| {
                format!(
                    "GLB: the chunk at byte {at} declares {len} bytes but only {} remain (truncated file?)",
                    length - start
                )
            })?;
        Ok(Some((ty, &bytes[start..end], end)))
    };
    let Some((ty, json, mut at)) = chunk(12)? else {
        return Err("GLB: no JSON chunk".into());
    };
    if ty != JSON {
        return Err(format!(
            "GLB: the first chunk is of type 0x{ty:08X}, not JSON"
        ));
    }
    let mut bin = None;
    while let Some((ty, body, next)) = chunk(at)? {
        match ty {
            BIN if bin.is_some() => return Err("GLB: more than one BIN chunk".into()),
            BIN => bin = Some(body),
            JSON => return Err("GLB: more than one JSON chunk".into()),
            // Chunks of other types are skipped, as the specification says.
            _ => {}
        }
        at = next;
    }
    Ok(Glb { json, bin, warning })
}

fn load_buffers(
    path: &Path,
    base: &Path,
    doc: &gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<gltf::buffer::Data>, SceneError> {
    let mut out = Vec::new();
    for b in doc.buffers() {
        let i = b.index();
        let data = match b.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                SceneError::invalid(
                    path,
                    format!("buffers[{i}]: has no uri and there is no GLB BIN chunk"),
                )
            })?,
            gltf::buffer::Source::Uri(uri) => read_uri(base, uri)
                .map_err(|m| SceneError::invalid(path, format!("buffers[{i}].uri: {m}")))?,
        };
        if data.len() < b.length() {
            return Err(SceneError::invalid(
                path,
                format!(
                    "buffers[{i}]: has {} bytes but declares byteLength {} (truncated file?)",
                    data.len(),
                    b.length()
                ),
            ));
        }
        out.push(gltf::buffer::Data(data));
    }
    Ok(out)
}

/// The bytes behind a glTF URI: a base64 data URI or a file relative to `base`.
fn read_uri(base: &Path, uri: &str) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, data)) = rest.split_once(";base64,") else {
            return Err("data URI is not base64 (shrad reads ';base64,' data URIs only)".into());
        };
        return base64::decode(data).map_err(|e| format!("data URI: {e}"));
    }
    if uri.contains("://") && !uri.starts_with("file://") {
        return Err(format!("unsupported URI scheme in '{uri}'"));
    }
    let rel = percent_decode(uri.strip_prefix("file://").unwrap_or(uri));
    let file: PathBuf = base.join(&rel);
    std::fs::read(&file).map_err(|e| format!("cannot read '{}': {e}", file.display()))
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let hex = |c: u8| (c as char).to_digit(16);
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

// ---------------------------------------------------------------------------------------
// The raw JSON checked against the specification before the gltf crate sees it: every
// index in range, every length inside its buffer, every enum known, every factor in range.
// The gltf crate's own validation indexes arrays with unchecked references and panics on
// some malformed files; after these checks it has nothing left to trip on.

/// Extensions shrad implements: the only ones a file may require.
const IMPLEMENTED_EXTENSIONS: &[&str] =
    &["KHR_materials_emissive_strength", "KHR_texture_transform"];

/// What shrad loses when it ignores an extension the file only uses (the specification
/// says a file must then still load without it).
fn ignored_extension_note(name: &str) -> &'static str {
    match name {
        "KHR_materials_unlit" => "unlit materials are read as diffuse reflectors",
        "KHR_lights_punctual" => "punctual lights are ignored: only emissive surfaces emit",
        "KHR_draco_mesh_compression" | "EXT_meshopt_compression" => {
            "the uncompressed fallback data is read"
        }
        "KHR_texture_basisu" | "EXT_texture_webp" | "MSFT_texture_dds" => {
            "the fallback image is used"
        }
        "KHR_materials_variants" => "the default material of each primitive is used",
        n if n.starts_with("KHR_materials_") => {
            "only the diffuse base colour and emission are used"
        }
        _ => "ignored",
    }
}

/// `at.key`, or `key` at the top level.
fn join(at: &str, key: &str) -> String {
    if at.is_empty() {
        key.to_string()
    } else {
        format!("{at}.{key}")
    }
}

/// The array `key` of `obj` (empty when absent).
fn array<'v>(obj: &'v Value, key: &str, at: &str) -> Result<&'v [Value], String> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(&[]),
        Some(Value::Array(a)) => Ok(a),
        Some(v) => Err(format!("{}: must be an array, not {v}", join(at, key))),
    }
}

/// The non-negative integer `key` of `obj`, if present.
fn uint(obj: &Value, key: &str, at: &str) -> Result<Option<u64>, String> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => v
            .as_u64()
            .map(Some)
            .ok_or_else(|| format!("{}: {v} is not a non-negative integer", join(at, key))),
    }
}

/// The number `key` of `obj`, if present (JSON numbers are finite; serde_json refuses
/// out-of-range ones while parsing).
fn number(obj: &Value, key: &str, at: &str) -> Result<Option<f64>, String> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(v) => match v.as_f64() {
            Some(x) if x.is_finite() => Ok(Some(x)),
            _ => Err(format!("{}: {v} is not a finite number", join(at, key))),
        },
    }
}

/// The array of `n` finite numbers `key` of `obj`, if present.
fn numbers(obj: &Value, key: &str, at: &str, n: usize) -> Result<Option<Vec<f64>>, String> {
    let here = join(at, key);
    match obj.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Array(a)) if a.len() == n => a
            .iter()
            .enumerate()
            .map(|(k, v)| match v.as_f64() {
                Some(x) if x.is_finite() => Ok(x),
                _ => Err(format!("{here}[{k}]: {v} is not a finite number")),
            })
            .collect::<Result<Vec<f64>, String>>()
            .map(Some),
        Some(v) => Err(format!("{here}: must be an array of {n} numbers, not {v}")),
    }
}

/// Each component of the factor `key` of `obj` in [0, 1].
fn unit_factors(obj: &Value, key: &str, at: &str, n: usize) -> Result<(), String> {
    if let Some(v) = numbers(obj, key, at, n)? {
        for (k, x) in v.iter().enumerate() {
            if !(0.0..=1.0).contains(x) {
                let here = join(at, key);
                let here = if n > 1 { format!("{here}[{k}]") } else { here };
                return Err(format!("{here}: {x} is outside [0, 1]"));
            }
        }
    }
    Ok(())
}

fn unit_factor(obj: &Value, key: &str, at: &str) -> Result<(), String> {
    if let Some(x) = number(obj, key, at)? {
        if !(0.0..=1.0).contains(&x) {
            return Err(format!("{}: {x} is outside [0, 1]", join(at, key)));
        }
    }
    Ok(())
}

/// The glTF name of one element of the top-level array `kind`.
fn singular(kind: &str) -> &str {
    match kind {
        "meshes" => "mesh",
        k => k.strip_suffix('s').unwrap_or(k),
    }
}

/// Size in bytes and name of an accessor component type.
fn component(ty: u64) -> Option<(u64, &'static str)> {
    Some(match ty {
        5120 => (1, "BYTE"),
        5121 => (1, "UNSIGNED_BYTE"),
        5122 => (2, "SHORT"),
        5123 => (2, "UNSIGNED_SHORT"),
        5125 => (4, "UNSIGNED_INT"),
        5126 => (4, "FLOAT"),
        _ => return None,
    })
}

/// What an accessor holds, once checked.
#[derive(Clone, Debug)]
struct AccessorInfo {
    ty: String,
    component_type: u64,
    normalized: bool,
    count: u64,
}

impl AccessorInfo {
    fn describe(&self) -> String {
        let c = component(self.component_type).map_or("?", |c| c.1);
        let n = if self.normalized { " normalized" } else { "" };
        format!("{}{n} {c}", self.ty)
    }
}

struct JsonCheck<'v> {
    root: &'v Value,
    warnings: &'v mut Vec<String>,
    /// Parent of each node (filled by `nodes`).
    parents: Vec<Option<usize>>,
}

impl JsonCheck<'_> {
    fn len(&self, kind: &str) -> usize {
        self.root
            .get(kind)
            .and_then(Value::as_array)
            .map_or(0, Vec::len)
    }

    /// The reference `key` of `obj` to an element of the top-level array `kind`.
    fn reference(
        &self,
        obj: &Value,
        key: &str,
        at: &str,
        kind: &str,
    ) -> Result<Option<usize>, String> {
        let Some(i) = uint(obj, key, at)? else {
            return Ok(None);
        };
        self.index(i, &join(at, key), kind).map(Some)
    }

    fn index(&self, i: u64, here: &str, kind: &str) -> Result<usize, String> {
        let n = self.len(kind);
        match usize::try_from(i) {
            Ok(i) if i < n => Ok(i),
            _ => Err(format!(
                "{here}: {} {i} does not exist (the file has {n})",
                singular(kind)
            )),
        }
    }

    /// The array of references `key` of `obj`.
    fn references(
        &self,
        obj: &Value,
        key: &str,
        at: &str,
        kind: &str,
    ) -> Result<Vec<usize>, String> {
        let here = join(at, key);
        array(obj, key, at)?
            .iter()
            .enumerate()
            .map(|(k, v)| {
                let i = v
                    .as_u64()
                    .ok_or_else(|| format!("{here}[{k}]: {v} is not a non-negative integer"))?;
                self.index(i, &format!("{here}[{k}]"), kind)
            })
            .collect()
    }

    /// A required reference.
    fn required(&self, obj: &Value, key: &str, at: &str, kind: &str) -> Result<usize, String> {
        self.reference(obj, key, at, kind)?
            .ok_or_else(|| format!("{}: missing (required)", join(at, key)))
    }

    fn texture_info(&self, obj: &Value, key: &str, at: &str) -> Result<(), String> {
        if let Some(info) = obj.get(key).filter(|v| !v.is_null()) {
            let here = join(at, key);
            self.required(info, "index", &here, "textures")?;
            uint(info, "texCoord", &here)?;
            if let Some(x) = info
                .get("extensions")
                .and_then(|e| e.get("KHR_texture_transform"))
            {
                let here = format!("{here}.extensions.KHR_texture_transform");
                if !x.is_object() {
                    return Err(format!("{here}: must be an object"));
                }
                numbers(x, "offset", &here, 2)?;
                numbers(x, "scale", &here, 2)?;
                number(x, "rotation", &here)?;
                uint(x, "texCoord", &here)?;
            }
        }
        Ok(())
    }

    fn run(&mut self, glb_bin: Option<usize>) -> Result<(), String> {
        let root = self.root;
        if !root.is_object() {
            return Err("invalid glTF: the JSON is not an object".into());
        }
        self.asset()?;
        self.extensions()?;
        for kind in [
            "accessors",
            "animations",
            "buffers",
            "bufferViews",
            "cameras",
            "images",
            "materials",
            "meshes",
            "nodes",
            "samplers",
            "scenes",
            "skins",
            "textures",
        ] {
            for (i, v) in array(root, kind, "")?.iter().enumerate() {
                if !v.is_object() {
                    return Err(format!("{kind}[{i}]: must be an object, not {v}"));
                }
            }
        }
        let buffer_lengths = self.buffers(glb_bin)?;
        let views = self.buffer_views(&buffer_lengths)?;
        let accessors = self.accessors(&views)?;
        self.meshes(&accessors)?;
        self.materials()?;
        self.textures_and_images()?;
        self.cameras()?;
        self.nodes()?;
        self.scenes()?;
        self.skins_and_animations()?;
        Ok(())
    }

    fn asset(&mut self) -> Result<(), String> {
        let asset = self
            .root
            .get("asset")
            .filter(|a| a.is_object())
            .ok_or("asset: missing (required by glTF 2.0)")?;
        let parse = |key: &str| -> Result<Option<(u64, u64, String)>, String> {
            let Some(v) = asset.get(key) else {
                return Ok(None);
            };
            let s = v
                .as_str()
                .ok_or_else(|| format!("asset.{key}: {v} is not a string"))?;
            let (major, minor) = s
                .split_once('.')
                .and_then(|(a, b)| Some((a.parse::<u64>().ok()?, b.parse::<u64>().ok()?)))
                .ok_or_else(|| {
                    format!("asset.{key}: '{s}' is not a version of the form <major>.<minor>")
                })?;
            Ok(Some((major, minor, s.to_string())))
        };
        let (major, minor, version) =
            parse("version")?.ok_or("asset.version: missing (required by glTF 2.0)")?;
        if major != 2 {
            return Err(format!(
                "asset.version: glTF {version} is not supported (shrad reads glTF 2.x{})",
                if major < 2 {
                    "; convert a glTF 1.0 file to 2.0 first"
                } else {
                    ""
                }
            ));
        }
        if let Some((min_major, min_minor, min)) = parse("minVersion")? {
            if (min_major, min_minor) > (major, minor) {
                return Err(format!(
                    "asset.minVersion: {min} is newer than the file's version {version}"
                ));
            }
            if (min_major, min_minor) > (2, 0) {
                return Err(format!(
                    "asset.minVersion: the file needs glTF {min}; shrad implements glTF 2.0"
                ));
            }
        }
        if minor > 0 {
            self.warnings.push(format!(
                "asset.version: glTF {version} read as glTF 2.0 (features newer than 2.0 are ignored)"
            ));
        }
        Ok(())
    }

    fn extensions(&mut self) -> Result<(), String> {
        let names = |key: &str| -> Result<Vec<String>, String> {
            array(self.root, key, "")?
                .iter()
                .enumerate()
                .map(|(i, v)| {
                    v.as_str()
                        .map(str::to_string)
                        .ok_or_else(|| format!("{key}[{i}]: {v} is not a string"))
                })
                .collect()
        };
        let required = names("extensionsRequired")?;
        for (i, e) in required.iter().enumerate() {
            if !IMPLEMENTED_EXTENSIONS.contains(&e.as_str()) {
                return Err(format!(
                    "extensionsRequired[{i}]: the file requires extension '{e}', which shrad does not implement (shrad implements {})",
                    IMPLEMENTED_EXTENSIONS.join(", ")
                ));
            }
        }
        for e in names("extensionsUsed")? {
            if !IMPLEMENTED_EXTENSIONS.contains(&e.as_str()) {
                self.warnings.push(format!(
                    "extension '{e}' is used but not implemented by shrad: {}",
                    ignored_extension_note(&e)
                ));
            }
        }
        Ok(())
    }

    /// Declared byte lengths of the buffers.
    fn buffers(&mut self, glb_bin: Option<usize>) -> Result<Vec<u64>, String> {
        let mut out = Vec::new();
        for (i, b) in array(self.root, "buffers", "")?.iter().enumerate() {
            let at = format!("buffers[{i}]");
            let len = uint(b, "byteLength", &at)?
                .ok_or_else(|| format!("{at}.byteLength: missing (required)"))?;
            if len == 0 {
                return Err(format!("{at}.byteLength: must be at least 1"));
            }
            match b.get("uri") {
                None | Some(Value::Null) => match glb_bin {
                    _ if i > 0 => {
                        return Err(format!(
                            "{at}: has no uri (only buffer 0 of a GLB may refer to its BIN chunk)"
                        ))
                    }
                    None => {
                        return Err(format!(
                            "{at}: has no uri, and there is no GLB BIN chunk it could refer to"
                        ))
                    }
                    Some(n) if (n as u64) < len => {
                        return Err(format!(
                            "{at}: declares byteLength {len} but the GLB BIN chunk has {n} bytes (truncated file?)"
                        ))
                    }
                    Some(_) => {}
                },
                Some(Value::String(_)) => {}
                Some(v) => return Err(format!("{at}.uri: {v} is not a string")),
            }
            out.push(len);
        }
        Ok(out)
    }

    /// (byteOffset + byteLength within its buffer, byteLength, byteStride) of each view.
    fn buffer_views(&mut self, buffers: &[u64]) -> Result<Vec<(u64, u64, Option<u64>)>, String> {
        let mut out = Vec::new();
        for (i, v) in array(self.root, "bufferViews", "")?.iter().enumerate() {
            let at = format!("bufferViews[{i}]");
            let b = self.required(v, "buffer", &at, "buffers")?;
            let offset = uint(v, "byteOffset", &at)?.unwrap_or(0);
            let len = uint(v, "byteLength", &at)?
                .ok_or_else(|| format!("{at}.byteLength: missing (required)"))?;
            if len == 0 {
                return Err(format!("{at}.byteLength: must be at least 1"));
            }
            let end = offset.saturating_add(len);
            if end > buffers[b] {
                return Err(format!(
                    "{at}: bytes {offset}..{end} lie outside buffer {b} ({} bytes)",
                    buffers[b]
                ));
            }
            let stride = uint(v, "byteStride", &at)?;
            if let Some(s) = stride {
                if !(4..=252).contains(&s) || s % 4 != 0 {
                    return Err(format!(
                        "{at}.byteStride: {s} must be a multiple of 4 in [4, 252]"
                    ));
                }
            }
            if let Some(t) = uint(v, "target", &at)? {
                if t != 34962 && t != 34963 {
                    return Err(format!(
                        "{at}.target: {t} is neither ARRAY_BUFFER (34962) nor ELEMENT_ARRAY_BUFFER (34963)"
                    ));
                }
            }
            out.push((offset, len, stride));
        }
        Ok(out)
    }

    fn accessors(
        &mut self,
        views: &[(u64, u64, Option<u64>)],
    ) -> Result<Vec<AccessorInfo>, String> {
        let mut out = Vec::new();
        for (i, a) in array(self.root, "accessors", "")?.iter().enumerate() {
            let at = format!("accessors[{i}]");
            let ct = uint(a, "componentType", &at)?
                .ok_or_else(|| format!("{at}.componentType: missing (required)"))?;
            let (size, cname) = component(ct)
                .ok_or_else(|| format!("{at}.componentType: {ct} is not a glTF component type"))?;
            let ty = a
                .get("type")
                .and_then(Value::as_str)
                .ok_or_else(|| format!("{at}.type: missing or not a string (required)"))?;
            let comps: u64 = match ty {
                "SCALAR" => 1,
                "VEC2" => 2,
                "VEC3" => 3,
                "VEC4" | "MAT2" => 4,
                "MAT3" => 9,
                "MAT4" => 16,
                _ => return Err(format!("{at}.type: '{ty}' is not a glTF accessor type")),
            };
            // Matrix columns start on 4-byte boundaries.
            let elem = match (ty, size) {
                ("MAT2", 1) => 8,
                ("MAT3", 1) => 12,
                ("MAT3", 2) => 24,
                _ => comps * size,
            };
            let count =
                uint(a, "count", &at)?.ok_or_else(|| format!("{at}.count: missing (required)"))?;
            if count == 0 {
                return Err(format!("{at}.count: must be at least 1"));
            }
            let normalized = match a.get("normalized") {
                None | Some(Value::Null) => false,
                Some(Value::Bool(b)) => *b,
                Some(v) => return Err(format!("{at}.normalized: {v} is not a boolean")),
            };
            if normalized && (ct == 5126 || ct == 5125) {
                return Err(format!("{at}.normalized: must not be true for {cname}"));
            }
            let offset = uint(a, "byteOffset", &at)?;
            match self.reference(a, "bufferView", &at, "bufferViews")? {
                None if offset.is_some_and(|o| o != 0) => {
                    // The specification forbids it; harmless, and some exporters write it.
                    self.warnings.push(format!(
                        "{at}.byteOffset: ignored (the accessor has no bufferView)"
                    ));
                }
                None => {}
                Some(v) => {
                    let (view_offset, view_len, stride) = views[v];
                    let offset = offset.unwrap_or(0);
                    if offset % size != 0 || (view_offset + offset) % size != 0 {
                        return Err(format!(
                            "{at}.byteOffset: {offset} (plus bufferView {v}'s {view_offset}) is not a multiple of the {cname} size {size}"
                        ));
                    }
                    let stride = match stride {
                        Some(s) if s < elem => {
                            return Err(format!(
                                "{at}: bufferView {v}'s byteStride {s} is smaller than the {elem}-byte {ty} {cname} element"
                            ))
                        }
                        Some(s) => s,
                        None => elem,
                    };
                    let need = u128::from(offset)
                        + u128::from(stride) * u128::from(count - 1)
                        + u128::from(elem);
                    if need > u128::from(view_len) {
                        return Err(format!(
                            "{at}: {count} elements of {elem} bytes (stride {stride}) from byte {offset} need {need} bytes, but bufferView {v} has {view_len}"
                        ));
                    }
                }
            }
            for key in ["min", "max"] {
                if a.get(key).is_some_and(|v| !v.is_null()) {
                    numbers(a, key, &at, comps as usize)?;
                }
            }
            if let Some(sp) = a.get("sparse").filter(|v| !v.is_null()) {
                self.sparse(sp, &format!("{at}.sparse"), count, elem, views)?;
            }
            out.push(AccessorInfo {
                ty: ty.to_string(),
                component_type: ct,
                normalized,
                count,
            });
        }
        Ok(out)
    }

    fn sparse(
        &mut self,
        sp: &Value,
        at: &str,
        count: u64,
        elem: u64,
        views: &[(u64, u64, Option<u64>)],
    ) -> Result<(), String> {
        let n = uint(sp, "count", at)?.ok_or_else(|| format!("{at}.count: missing (required)"))?;
        if n == 0 || n > count {
            return Err(format!(
                "{at}.count: {n} must be in [1, {count}] (the accessor's count)"
            ));
        }
        for (key, default_size) in [("indices", 0u64), ("values", elem)] {
            let here = join(at, key);
            let part = sp
                .get(key)
                .filter(|v| v.is_object())
                .ok_or_else(|| format!("{here}: missing (required)"))?;
            let v = self.required(part, "bufferView", &here, "bufferViews")?;
            let offset = uint(part, "byteOffset", &here)?.unwrap_or(0);
            let size = if key == "indices" {
                let ct = uint(part, "componentType", &here)?
                    .ok_or_else(|| format!("{here}.componentType: missing (required)"))?;
                match ct {
                    5121 => 1,
                    5123 => 2,
                    5125 => 4,
                    _ => {
                        return Err(format!(
                            "{here}.componentType: {ct} is not UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT"
                        ))
                    }
                }
            } else {
                default_size
            };
            let (_, view_len, stride) = views[v];
            if stride.is_some() {
                return Err(format!(
                    "{here}: bufferView {v} of sparse {key} must not have a byteStride"
                ));
            }
            let need = u128::from(offset) + u128::from(size) * u128::from(n);
            if need > u128::from(view_len) {
                return Err(format!(
                    "{here}: {n} elements of {size} bytes from byte {offset} need {need} bytes, but bufferView {v} has {view_len}"
                ));
            }
        }
        Ok(())
    }

    fn meshes(&mut self, accessors: &[AccessorInfo]) -> Result<(), String> {
        for (m, mesh) in array(self.root, "meshes", "")?.iter().enumerate() {
            let at = format!("meshes[{m}]");
            let prims = array(mesh, "primitives", &at)?;
            if prims.is_empty() {
                return Err(format!("{at}.primitives: missing or empty (required)"));
            }
            for (p, prim) in prims.iter().enumerate() {
                let at = format!("{at}.primitives[{p}]");
                if !prim.is_object() {
                    return Err(format!("{at}: must be an object"));
                }
                let attrs = prim
                    .get("attributes")
                    .and_then(Value::as_object)
                    .ok_or_else(|| format!("{at}.attributes: missing (required)"))?;
                let attrs_at = format!("{at}.attributes");
                let mut counts = Vec::new();
                for name in attrs.keys() {
                    let known = ["POSITION", "NORMAL", "TANGENT"].contains(&name.as_str())
                        || ["TEXCOORD_", "COLOR_", "JOINTS_", "WEIGHTS_"]
                            .iter()
                            .any(|s| {
                                name.strip_prefix(s)
                                    .is_some_and(|n| !n.is_empty() && n.parse::<u32>().is_ok())
                            })
                        || name.starts_with('_');
                    if !known {
                        return Err(format!(
                            "{attrs_at}.{name}: not a glTF attribute name (application-specific ones start with '_')"
                        ));
                    }
                    let a = self.required(&prim["attributes"], name, &attrs_at, "accessors")?;
                    counts.push((name.clone(), a, accessors[a].count));
                }
                let Some(&(_, pos, n)) = counts.iter().find(|c| c.0 == "POSITION") else {
                    return Err(format!(
                        "{attrs_at}.POSITION: missing (shrad needs positions)"
                    ));
                };
                let info = &accessors[pos];
                if info.ty != "VEC3" || info.component_type != 5126 || info.normalized {
                    return Err(format!(
                        "{attrs_at}.POSITION: accessor {pos} is {}, but positions must be VEC3 FLOAT (quantized positions need KHR_mesh_quantization, which shrad does not implement)",
                        info.describe()
                    ));
                }
                let pos_json = &self.root["accessors"][pos];
                if pos_json.get("min").is_none_or(Value::is_null)
                    || pos_json.get("max").is_none_or(Value::is_null)
                {
                    return Err(format!(
                        "{attrs_at}.POSITION: accessor {pos} has no min and max (the specification requires them)"
                    ));
                }
                for (name, a, _) in &counts {
                    let info = &accessors[*a];
                    let (ty, c, norm) = (info.ty.as_str(), info.component_type, info.normalized);
                    let ok = if name.starts_with("TEXCOORD_") {
                        ty == "VEC2" && (c == 5126 || (norm && matches!(c, 5121 | 5123)))
                    } else if name.starts_with("COLOR_") {
                        matches!(ty, "VEC3" | "VEC4")
                            && (c == 5126 || (norm && matches!(c, 5121 | 5123)))
                    } else {
                        true
                    };
                    if !ok {
                        return Err(format!(
                            "{attrs_at}.{name}: accessor {a} is {}, but {} must be {} FLOAT or normalized UNSIGNED_BYTE / UNSIGNED_SHORT",
                            info.describe(),
                            if name.starts_with("COLOR_") { "colours" } else { "texture coordinates" },
                            if name.starts_with("COLOR_") { "VEC3 / VEC4" } else { "VEC2" },
                        ));
                    }
                }
                if let Some((name, a, c)) = counts.iter().find(|c| c.2 != n) {
                    return Err(format!(
                        "{attrs_at}.{name}: accessor {a} has {c} elements but POSITION has {n} (all attributes of a primitive have the same count)"
                    ));
                }
                if let Some(i) = self.reference(prim, "indices", &at, "accessors")? {
                    let info = &accessors[i];
                    if info.ty != "SCALAR"
                        || !matches!(info.component_type, 5121 | 5123 | 5125)
                        || info.normalized
                    {
                        return Err(format!(
                            "{at}.indices: accessor {i} is {}, but indices must be SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT or UNSIGNED_INT",
                            info.describe()
                        ));
                    }
                }
                self.reference(prim, "material", &at, "materials")?;
                if let Some(mode) = uint(prim, "mode", &at)? {
                    if mode > 6 {
                        return Err(format!(
                            "{at}.mode: {mode} is not a glTF primitive mode (0 to 6)"
                        ));
                    }
                }
                for (t, target) in array(prim, "targets", &at)?.iter().enumerate() {
                    let here = format!("{at}.targets[{t}]");
                    let Some(obj) = target.as_object() else {
                        return Err(format!("{here}: must be an object"));
                    };
                    for name in obj.keys() {
                        self.required(target, name, &here, "accessors")?;
                    }
                }
            }
        }
        Ok(())
    }

    fn materials(&mut self) -> Result<(), String> {
        for (i, m) in array(self.root, "materials", "")?.iter().enumerate() {
            let at = format!("materials[{i}]");
            if let Some(pbr) = m.get("pbrMetallicRoughness").filter(|v| !v.is_null()) {
                let here = format!("{at}.pbrMetallicRoughness");
                unit_factors(pbr, "baseColorFactor", &here, 4)?;
                unit_factor(pbr, "metallicFactor", &here)?;
                unit_factor(pbr, "roughnessFactor", &here)?;
                self.texture_info(pbr, "baseColorTexture", &here)?;
                self.texture_info(pbr, "metallicRoughnessTexture", &here)?;
            }
            unit_factors(m, "emissiveFactor", &at, 3)?;
            for key in ["normalTexture", "occlusionTexture", "emissiveTexture"] {
                self.texture_info(m, key, &at)?;
            }
            if let Some(occ) = m.get("occlusionTexture").filter(|v| !v.is_null()) {
                unit_factor(occ, "strength", &format!("{at}.occlusionTexture"))?;
            }
            if let Some(x) = number(m, "alphaCutoff", &at)? {
                if x < 0.0 {
                    return Err(format!("{at}.alphaCutoff: {x} must be >= 0"));
                }
            }
            match m.get("alphaMode") {
                None | Some(Value::Null) => {}
                Some(Value::String(s)) if ["OPAQUE", "MASK", "BLEND"].contains(&s.as_str()) => {}
                Some(v) => return Err(format!("{at}.alphaMode: {v} is not OPAQUE, MASK or BLEND")),
            }
            if let Some(ext) = m
                .get("extensions")
                .and_then(|e| e.get("KHR_materials_emissive_strength"))
            {
                let here = format!("{at}.extensions.KHR_materials_emissive_strength");
                if let Some(x) = number(ext, "emissiveStrength", &here)? {
                    if x < 0.0 {
                        return Err(format!("{here}.emissiveStrength: {x} must be >= 0"));
                    }
                }
            }
        }
        Ok(())
    }

    fn textures_and_images(&mut self) -> Result<(), String> {
        for (i, t) in array(self.root, "textures", "")?.iter().enumerate() {
            let at = format!("textures[{i}]");
            self.reference(t, "source", &at, "images")?;
            self.reference(t, "sampler", &at, "samplers")?;
        }
        for (i, s) in array(self.root, "samplers", "")?.iter().enumerate() {
            let at = format!("samplers[{i}]");
            for (key, ok) in [
                ("magFilter", &[9728u64, 9729][..]),
                ("minFilter", &[9728, 9729, 9984, 9985, 9986, 9987][..]),
                ("wrapS", &[33071, 33648, 10497][..]),
                ("wrapT", &[33071, 33648, 10497][..]),
            ] {
                if let Some(v) = uint(s, key, &at)? {
                    if !ok.contains(&v) {
                        return Err(format!("{at}.{key}: {v} is not a glTF sampler value"));
                    }
                }
            }
        }
        for (i, img) in array(self.root, "images", "")?.iter().enumerate() {
            let at = format!("images[{i}]");
            let view = self.reference(img, "bufferView", &at, "bufferViews")?;
            let uri = img.get("uri").filter(|v| !v.is_null());
            match (uri, view) {
                (Some(_), Some(_)) => {
                    return Err(format!(
                        "{at}: has both uri and bufferView (the specification allows one)"
                    ))
                }
                (None, None) => return Err(format!("{at}: has neither uri nor bufferView")),
                (Some(u), None) if !u.is_string() => {
                    return Err(format!("{at}.uri: {u} is not a string"))
                }
                (None, Some(_)) if !img.get("mimeType").is_some_and(Value::is_string) => {
                    return Err(format!(
                        "{at}.mimeType: missing (required with a bufferView)"
                    ))
                }
                _ => {}
            }
        }
        Ok(())
    }

    fn cameras(&mut self) -> Result<(), String> {
        for (i, c) in array(self.root, "cameras", "")?.iter().enumerate() {
            let at = format!("cameras[{i}]");
            let ty = c
                .get("type")
                .and_then(Value::as_str)
                .ok_or_else(|| format!("{at}.type: missing (required)"))?;
            let here = format!("{at}.{ty}");
            let p = match ty {
                "perspective" | "orthographic" => c
                    .get(ty)
                    .filter(|v| v.is_object())
                    .ok_or_else(|| format!("{here}: missing (required by type '{ty}')"))?,
                _ => {
                    return Err(format!(
                        "{at}.type: '{ty}' is neither perspective nor orthographic"
                    ))
                }
            };
            let need = |key: &str| -> Result<f64, String> {
                number(p, key, &here)?.ok_or_else(|| format!("{here}.{key}: missing (required)"))
            };
            let znear = need("znear")?;
            let zfar = number(p, "zfar", &here)?;
            if ty == "perspective" {
                let yfov = need("yfov")?;
                if !(yfov > 0.0 && yfov < std::f64::consts::PI) {
                    return Err(format!("{here}.yfov: {yfov} must be in (0, pi) radians"));
                }
                if znear <= 0.0 {
                    return Err(format!("{here}.znear: {znear} must be > 0"));
                }
                if let Some(a) = number(p, "aspectRatio", &here)? {
                    if a <= 0.0 {
                        return Err(format!("{here}.aspectRatio: {a} must be > 0"));
                    }
                }
            } else {
                for key in ["xmag", "ymag"] {
                    if need(key)? == 0.0 {
                        return Err(format!("{here}.{key}: must not be zero"));
                    }
                }
                if znear < 0.0 {
                    return Err(format!("{here}.znear: {znear} must be >= 0"));
                }
                if zfar.is_none() {
                    return Err(format!("{here}.zfar: missing (required)"));
                }
            }
            if let Some(f) = zfar {
                if f <= znear {
                    return Err(format!(
                        "{here}.zfar: {f} must be greater than znear {znear}"
                    ));
                }
            }
        }
        Ok(())
    }

    fn nodes(&mut self) -> Result<(), String> {
        let nodes = array(self.root, "nodes", "")?;
        let mut parent: Vec<Option<usize>> = vec![None; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            let at = format!("nodes[{i}]");
            for (k, c) in self
                .references(n, "children", &at, "nodes")?
                .into_iter()
                .enumerate()
            {
                if let Some(p) = parent[c] {
                    return Err(format!(
                        "{at}.children[{k}]: node {c} is already a child of node {p} (the node hierarchy must be a set of trees)"
                    ));
                }
                parent[c] = Some(i);
            }
            self.reference(n, "mesh", &at, "meshes")?;
            self.reference(n, "camera", &at, "cameras")?;
            self.reference(n, "skin", &at, "skins")?;
            let matrix = numbers(n, "matrix", &at, 16)?;
            let t = numbers(n, "translation", &at, 3)?;
            let r = numbers(n, "rotation", &at, 4)?;
            let s = numbers(n, "scale", &at, 3)?;
            if let Some(m) = &matrix {
                if t.is_some() || r.is_some() || s.is_some() {
                    return Err(format!(
                        "{at}: has both a matrix and translation/rotation/scale (the specification allows one or the other)"
                    ));
                }
                if m[3] != 0.0 || m[7] != 0.0 || m[11] != 0.0 || m[15] != 1.0 {
                    return Err(format!(
                        "{at}.matrix: not an affine transform (its last row must be 0 0 0 1)"
                    ));
                }
            }
            if let Some(q) = &r {
                let len = q.iter().map(|x| x * x).sum::<f64>().sqrt();
                if (len - 1.0).abs() > 1e-2 {
                    return Err(format!(
                        "{at}.rotation: {q:?} is not a unit quaternion (length {len})"
                    ));
                }
            }
        }
        // With at most one parent each, a node no root reaches lies on a cycle.
        let mut reached = vec![false; nodes.len()];
        let mut stack: Vec<usize> = (0..nodes.len()).filter(|&i| parent[i].is_none()).collect();
        while let Some(i) = stack.pop() {
            reached[i] = true;
            for c in array(&nodes[i], "children", "")? {
                stack.extend(c.as_u64().map(|c| c as usize));
            }
        }
        if let Some(i) = reached.iter().position(|r| !r) {
            return Err(format!(
                "nodes[{i}]: lies on a cycle of the node hierarchy (it must be a set of trees)"
            ));
        }
        self.parents = parent;
        Ok(())
    }

    fn scenes(&mut self) -> Result<(), String> {
        self.reference(self.root, "scene", "", "scenes")?;
        for (i, s) in array(self.root, "scenes", "")?.iter().enumerate() {
            let at = format!("scenes[{i}]");
            for (k, n) in self
                .references(s, "nodes", &at, "nodes")?
                .into_iter()
                .enumerate()
            {
                if let Some(p) = self.parents[n] {
                    return Err(format!(
                        "{at}.nodes[{k}]: node {n} is not a root node (it is a child of node {p})"
                    ));
                }
            }
        }
        Ok(())
    }

    fn skins_and_animations(&mut self) -> Result<(), String> {
        for (i, s) in array(self.root, "skins", "")?.iter().enumerate() {
            let at = format!("skins[{i}]");
            self.reference(s, "inverseBindMatrices", &at, "accessors")?;
            self.reference(s, "skeleton", &at, "nodes")?;
            if self.references(s, "joints", &at, "nodes")?.is_empty() {
                return Err(format!("{at}.joints: missing or empty (required)"));
            }
        }
        for (i, a) in array(self.root, "animations", "")?.iter().enumerate() {
            let at = format!("animations[{i}]");
            let samplers = array(a, "samplers", &at)?;
            for (k, s) in samplers.iter().enumerate() {
                let here = format!("{at}.samplers[{k}]");
                self.required(s, "input", &here, "accessors")?;
                self.required(s, "output", &here, "accessors")?;
            }
            for (k, c) in array(a, "channels", &at)?.iter().enumerate() {
                let here = format!("{at}.channels[{k}]");
                let s = uint(c, "sampler", &here)?
                    .ok_or_else(|| format!("{here}.sampler: missing (required)"))?;
                if s as usize >= samplers.len() {
                    return Err(format!(
                        "{here}.sampler: sampler {s} does not exist (the animation has {})",
                        samplers.len()
                    ));
                }
                let target = c
                    .get("target")
                    .filter(|t| t.is_object())
                    .ok_or_else(|| format!("{here}.target: missing (required)"))?;
                self.reference(target, "node", &format!("{here}.target"), "nodes")?;
            }
        }
        Ok(())
    }
}

/// Check the raw JSON of a glTF against the specification (see [`JsonCheck`]); `glb_bin` is
/// the length of the GLB's BIN chunk, if any. Warnings (extensions ignored, ...) are added.
fn check_json(
    root: &Value,
    glb_bin: Option<usize>,
    warnings: &mut Vec<String>,
) -> Result<(), String> {
    JsonCheck {
        root,
        warnings,
        parents: Vec::new(),
    }
    .run(glb_bin)
}

/// Sparse accessor indices strictly increasing and below the accessor's count (the gltf
/// crate's reader would silently drop the others). Lengths were checked by [`check_json`].
fn check_sparse_indices(root: &Value, buffers: &[gltf::buffer::Data]) -> Result<(), String> {
    for (i, a) in array(root, "accessors", "")?.iter().enumerate() {
        let Some(sp) = a.get("sparse").filter(|v| !v.is_null()) else {
            continue;
        };
        let at = format!("accessors[{i}].sparse.indices");
        let count = a["count"].as_u64().unwrap_or(0);
        let n = sp["count"].as_u64().unwrap_or(0) as usize;
        let ind = &sp["indices"];
        let size = match ind["componentType"].as_u64() {
            Some(5121) => 1,
            Some(5123) => 2,
            _ => 4,
        };
        let view = &root["bufferViews"][ind["bufferView"].as_u64().unwrap_or(0) as usize];
        let buffer = view["buffer"].as_u64().unwrap_or(0) as usize;
        let start = view["byteOffset"].as_u64().unwrap_or(0) as usize
            + ind["byteOffset"].as_u64().unwrap_or(0) as usize;
        let bytes = buffers
            .get(buffer)
            .and_then(|b| b.0.get(start..start + n * size))
            .ok_or_else(|| format!("{at}: outside its buffer"))?;
        let mut last: Option<u64> = None;
        for (k, c) in bytes.chunks_exact(size).enumerate() {
            let v = c.iter().rev().fold(0u64, |acc, &b| acc << 8 | u64::from(b));
            if v >= count || last.is_some_and(|l| v <= l) {
                return Err(format!(
                    "{at}: index {v} (element {k}) must be below the count {count} and greater than the one before"
                ));
            }
            last = Some(v);
        }
    }
    Ok(())
}

struct Walk<'a> {
    /// The node hierarchy with the animations that play (None: nothing moves).
    graph: Option<std::sync::Arc<crate::NodeGraph>>,
    path: &'a Path,
    base: &'a Path,
    doc: &'a gltf::Document,
    /// The accessors, bufferViews and textures of the raw JSON (checked by [`check_json`]).
    json: &'a Value,
    buffers: &'a [gltf::buffer::Data],
    scene: Scene,
    names: Vec<PartNames>,
    /// Each image decoded once (None: could not be loaded), shared by the materials.
    textures: std::collections::HashMap<usize, Option<std::sync::Arc<TextureImage>>>,
    /// Each material once converted (None: the default material).
    materials: std::collections::HashMap<Option<usize>, Material>,
}

/// The `shrad_role` and `shrad_patch_size` of a node's or mesh's extras.
fn extras_of(raw: &gltf::json::Extras, what: &str) -> Result<(Option<Role>, Option<f32>), String> {
    let Some(raw) = raw else {
        return Ok((None, None));
    };
    let Ok(v) = serde_json::from_str::<Value>(raw.get()) else {
        return Ok((None, None));
    };
    let role = match v.get("shrad_role") {
        None | Some(Value::Null) => None,
        Some(Value::String(s)) => Some(match s.as_str() {
            "boundary" => Role::Boundary,
            "interior" => Role::Interior,
            "light" => Role::Light,
            other => {
                return Err(format!(
                    "{what}: unknown shrad_role '{other}' (expected boundary, interior or light)"
                ))
            }
        }),
        Some(other) => return Err(format!("{what}: shrad_role must be a string, not {other}")),
    };
    let patch = v
        .get("shrad_patch_size")
        .and_then(Value::as_f64)
        .map(|x| x as f32);
    Ok((role, patch))
}

impl Walk<'_> {
    /// Give `object`, instanced by node `node`, its node animation if the node or an
    /// ancestor is animated; its rest transform becomes its pose at time 0.
    fn animate(&self, object: &mut Object, node: usize) {
        if let Some(graph) = self.graph.as_ref().filter(|g| g.moves(node)) {
            let anim = crate::NodeAnimation {
                graph: graph.clone(),
                node,
                outer: Affine3A::IDENTITY,
            };
            object.world_from_object = anim.world_from_object_at(0.0);
            object.node_animation = Some(anim);
        }
    }

    fn node(&mut self, node: gltf::Node, parent: Mat4, depth: usize) -> Result<(), SceneError> {
        if depth > MAX_DEPTH {
            return Err(SceneError::invalid(
                self.path,
                format!("nodes[{}]: hierarchy deeper than {MAX_DEPTH}", node.index()),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        let node_label = match node.name() {
            Some(n) => format!("nodes[{}] '{n}'", node.index()),
            None => format!("nodes[{}]", node.index()),
        };
        if !world.is_finite() {
            return Err(SceneError::invalid(
                self.path,
                format!("{node_label}: transform is not finite"),
            ));
        }
        if let Some(cam) = node.camera() {
            if self.scene.camera.is_none() {
                match cam.projection() {
                    gltf::camera::Projection::Perspective(p) => {
                        let (_, r, t) = world.to_scale_rotation_translation();
                        self.scene.camera = Some(Camera {
                            world_from_camera: Affine3A::from_rotation_translation(
                                r.normalize(),
                                t,
                            ),
                            yfov: p.yfov(),
                            aspect_ratio: p.aspect_ratio(),
                        });
                    }
                    gltf::camera::Projection::Orthographic(_) => self
                        .scene
                        .warnings
                        .push(format!("{node_label}: orthographic camera ignored")),
                }
            }
        }
        if let Some(mesh) = node.mesh() {
            self.mesh(&node, &mesh, world, &node_label)?;
        }
        for child in node.children() {
            self.node(child, world, depth + 1)?;
        }
        Ok(())
    }

    fn mesh(
        &mut self,
        node: &gltf::Node,
        mesh: &gltf::Mesh,
        world: Mat4,
        node_label: &str,
    ) -> Result<(), SceneError> {
        let (path, buffers) = (self.path, self.buffers);
        let bad = |m: String| SceneError::invalid(path, m);
        let (node_role, node_patch) = extras_of(node.extras(), node_label).map_err(bad)?;
        let (mesh_role, mesh_patch) =
            extras_of(mesh.extras(), &format!("meshes[{}]", mesh.index())).map_err(bad)?;
        let base_name = node
            .name()
            .or(mesh.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("node{}", node.index()));
        // A mirroring transform (negative determinant) is kept as it is: the mesh stays
        // counter-clockwise from the front in its own frame, and the world normal is the
        // inverse transpose of the local one (glTF 2.0, "Transformations").
        let world_from_object = Affine3A::from_mat4(world);
        let n_prims = mesh.primitives().len();
        for prim in mesh.primitives() {
            let name = if n_prims > 1 {
                format!("{base_name}.{}", prim.index())
            } else {
                base_name.clone()
            };
            let who = format!("meshes[{}].primitives[{}]", mesh.index(), prim.index());
            let inst = format!(" ({node_label})");
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.scene.warnings.push(format!(
                    "{who}{inst}: {mode:?} primitive skipped (only triangles are used)"
                ));
                continue;
            }
            let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
                return Err(bad(format!(
                    "{who}{inst}: primitive has no POSITION attribute"
                )));
            };
            if pos_acc.count() == 0 || prim.indices().is_some_and(|a| a.count() == 0) {
                self.scene
                    .warnings
                    .push(format!("{who}{inst}: empty primitive skipped"));
                continue;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.0.as_slice()));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| {
                    bad(format!(
                        "{who}.attributes.POSITION{inst}: cannot be read (an accessor without bufferView is all zeros)"
                    ))
                })?
                .map(Vec3::from)
                .collect();
            if positions.len() != pos_acc.count() {
                return Err(bad(format!(
                    "{who}.attributes.POSITION{inst}: has {} of {} elements",
                    positions.len(),
                    pos_acc.count()
                )));
            }
            let indices: Vec<u32> = match prim.indices() {
                Some(acc) => {
                    let v: Vec<u32> = reader
                        .read_indices()
                        .ok_or_else(|| {
                            bad(format!(
                                "{who}.indices{inst}: cannot be read (an accessor without bufferView is all zeros)"
                            ))
                        })?
                        .into_u32()
                        .collect();
                    if v.len() != acc.count() {
                        return Err(bad(format!(
                            "{who}.indices{inst}: has fewer elements than its count"
                        )));
                    }
                    v
                }
                None => (0..positions.len() as u32).collect(),
            };
            let n = positions.len();
            if let Some(k) = indices.iter().position(|&i| i as usize >= n) {
                return Err(bad(format!(
                    "{who}.indices{inst}: index {} (element {k}) is out of range: POSITION has {n} vertices",
                    indices[k]
                )));
            }
            if let Some(k) = positions.iter().position(|p| !p.is_finite()) {
                return Err(bad(format!(
                    "{who}.attributes.POSITION{inst}: vertex {k} is not finite ({})",
                    positions[k]
                )));
            }
            let triangles = to_triangles(mode, &indices);
            if mode == Mode::Triangles && indices.len() % 3 != 0 {
                self.scene.warnings.push(format!(
                    "{who}{inst}: {} index(es) beyond the last whole triangle ignored",
                    indices.len() % 3
                ));
            }
            let mut material = self.material(&prim.material());
            let mut shape = Mesh::new(positions, triangles);
            self.attributes(&reader, &mut shape, &mut material, &format!("{who}{inst}"))
                .map_err(bad)?;
            let mut object = Object::new(name, shape, material);
            object.world_from_object = world_from_object;
            self.animate(&mut object, node.index());
            object.role = node_role.or(mesh_role);
            object.patch_size = node_patch.or(mesh_patch);
            self.scene.objects.push(object);
            self.names.push(PartNames {
                node: node.name().map(str::to_string),
                mesh: mesh.name().map(str::to_string),
            });
        }
        Ok(())
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

    /// The shrad material of a glTF material (converted once per material). A reflectance
    /// of exactly 1 (allowed by glTF, but it does not conserve energy) becomes 0.999 with a
    /// warning; factors outside [0, 1] were refused by [`check_json`].
    fn material(&mut self, m: &gltf::Material) -> Material {
        if let Some(done) = self.materials.get(&m.index()) {
            return done.clone();
        }
        let who = match (m.index(), m.name()) {
            (Some(i), Some(n)) => format!("materials[{i}] '{n}'"),
            (Some(i), None) => format!("materials[{i}]"),
            (None, _) => "the default material (a primitive without one)".to_string(),
        };
        let pbr = m.pbr_metallic_roughness();
        let f = pbr.base_color_factor();
        let mut reflectance = Vec3::new(f[0], f[1], f[2]);
        let base_color_texture = pbr
            .base_color_texture()
            .and_then(|info| self.texture(&who, "base colour", &info));
        if reflectance.max_element() >= 1.0 {
            let clamped = reflectance.min(Vec3::splat(0.999));
            self.scene.warnings.push(format!(
                "{who}: reflectance {reflectance} clamped to {clamped} (a reflectance of 1 does not conserve energy; it must be < 1)"
            ));
            reflectance = clamped;
        }
        let e = m.emissive_factor();
        let strength = m.emissive_strength().unwrap_or(1.0);
        let emissive_texture = m
            .emissive_texture()
            .and_then(|info| self.texture(&who, "emissive", &info));
        let material = Material {
            reflectance,
            emitted_radiance: Vec3::from(e) * strength,
            double_sided: m.double_sided(),
            base_color_texture,
            emissive_texture,
        };
        self.materials.insert(m.index(), material.clone());
        material
    }

    /// The texture of a material's texture info: its image decoded once (shared by every
    /// material that uses it), its sampler and `KHR_texture_transform`. `None` (with a
    /// warning) when the image cannot be loaded.
    fn texture(&mut self, who: &str, what: &str, info: &gltf::texture::Info) -> Option<Texture> {
        let texture = info.texture().index();
        // The texture's source, from the raw JSON: the gltf crate's `source()` panics when
        // an extension (not read by shrad) provides the image instead.
        let Some(image) = self.json["textures"][texture]["source"]
            .as_u64()
            .map(|i| i as usize)
        else {
            self.scene.warnings.push(format!(
                "{who}: {what} texture {texture} has no image shrad can read; using the factor alone"
            ));
            return None;
        };
        let decoded = match self.textures.get(&image) {
            Some(d) => d.clone(),
            None => {
                let d = match self.texture_image(image) {
                    Ok(d) => Some(std::sync::Arc::new(d)),
                    Err(e) => {
                        let name = self.image_label(image);
                        self.scene.warnings.push(format!(
                            "{who}: {what} {name} cannot be loaded ({e}); using the factor alone"
                        ));
                        None
                    }
                };
                self.textures.insert(image, d.clone());
                d
            }
        }?;
        let sampler = info.texture().sampler();
        let wrap = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        };
        let mut t = Texture::new(decoded);
        t.tex_coord = info.tex_coord();
        t.wrap_s = wrap(sampler.wrap_s());
        t.wrap_t = wrap(sampler.wrap_t());
        if sampler.mag_filter() == Some(gltf::texture::MagFilter::Nearest) {
            t.filter = Filter::Nearest;
        }
        if let Some(x) = info.texture_transform() {
            t.transform = UvTransform {
                offset: x.offset().into(),
                rotation: x.rotation(),
                scale: x.scale().into(),
            };
            if let Some(k) = x.tex_coord() {
                t.tex_coord = k;
            }
        }
        Some(t)
    }

    /// `image N 'name'` (or its URI) for messages.
    fn image_label(&self, index: usize) -> String {
        let json = self.doc.as_json().images.get(index);
        match json.and_then(|j| j.name.clone().or_else(|| j.uri.clone())) {
            Some(n) if !n.starts_with("data:") => format!("image {index} '{n}'"),
            _ => format!("image {index}"),
        }
    }

    /// Image `index`, decoded to 8-bit sRGB RGB (see [`TextureImage`]).
    fn texture_image(&self, index: usize) -> Result<TextureImage, String> {
        let json = self
            .doc
            .as_json()
            .images
            .get(index)
            .ok_or_else(|| format!("no image {index}"))?;
        let bytes: Vec<u8> = if let Some(view) = &json.buffer_view {
            let view = self
                .doc
                .views()
                .nth(view.value())
                .ok_or("image buffer view out of range")?;
            let data = self
                .buffers
                .get(view.buffer().index())
                .ok_or("buffer out of range")?;
            data.0
                .get(view.offset()..view.offset() + view.length())
                .ok_or("image buffer view outside its buffer")?
                .to_vec()
        } else if let Some(uri) = &json.uri {
            read_uri(self.base, uri)?
        } else {
            return Err("image has neither uri nor bufferView".into());
        };
        TextureImage::decode(&bytes, self.image_label(index))
    }
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

// ---------------------------------------------------------------------------------------
// Export

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
            .map_or(1.0, |(lo, hi)| (hi - lo).length())
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

/// Write `bytes` to `path` through a temporary file beside it and a rename, so no
/// half-written file is ever left at `path`.
pub(crate) fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), SceneError> {
    let io = |source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| SceneError::invalid(path, "not a file path"))?
        .to_string_lossy();
    let tmp = path.with_file_name(format!(".{file_name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
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
        let mut text = serde_json::to_vec(&root).expect("JSON serialises");
        while text.len() % 4 != 0 {
            text.push(b' ');
        }
        let total = 12 + 8 + text.len() + 8 + bin.len();
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(text.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&text);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    } else {
        let mut t = serde_json::to_vec_pretty(&root).expect("JSON serialises");
        t.push(b'\n');
        t
    };
    write_atomic(path, &bytes)
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

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("a%20b%2"), "a b%2");
        assert_eq!(percent_decode("%zz%41"), "%zzA");
    }
}
