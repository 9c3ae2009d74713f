//! The raw JSON checked against the specification before the gltf crate sees it: every
//! index in range, every length inside its buffer, every enum known, every factor in range.
//! The gltf crate's own validation indexes arrays with unchecked references and panics on
//! some malformed files; after these checks it has nothing left to trip on.
//!
//! Here: the JSON accessors, the asset and extensions; `data`: buffers, buffer views,
//! accessors and meshes; `scene`: materials, textures, cameras, nodes, scenes, skins and
//! animations. Then `lint`, `lint_layout` and `lint_ext`: rules about what shrad reads past
//! or ignores (morph targets, skins, vertex layout, extensions), which only warn; `values`:
//! rules on the values of attributes shrad does not use (normals, tangents, joints and
//! weights), which only warn, checked once the buffers are loaded.

mod data;
mod lint;
mod lint_ext;
mod lint_layout;
mod scene;
mod values;

pub(super) use values::{check as check_values, plan as plan_values, Floats};

use serde_json::Value;

/// Extensions shrad implements: the only ones a file may require.
const IMPLEMENTED_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_texture_transform",
    "KHR_mesh_quantization",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_draco_mesh_compression",
    "EXT_texture_webp",
    "KHR_lights_punctual",
    "EXT_mesh_gpu_instancing",
    "KHR_texture_basisu",
    "KHR_node_visibility",
    "KHR_animation_pointer",
    "KHR_materials_pbrSpecularGlossiness",
];

/// Khronos material extensions that refine how a surface shades beyond its base colour and
/// emission (which shrad reads): a file that requires one still has the base material they
/// refine, so shrad loads it (as three.js does) with the warning it gives when one is only
/// used, rather than refusing it (3ds Max's and other exporters list them as required).
/// (`KHR_materials_pbrSpecularGlossiness`, whose diffuse colour is in the extension itself,
/// shrad implements: `material::base_color`.)
pub(super) const SHADING_EXTENSIONS: &[&str] = &[
    "KHR_materials_anisotropy",
    "KHR_materials_clearcoat",
    "KHR_materials_diffuse_transmission",
    "KHR_materials_dispersion",
    "KHR_materials_ior",
    "KHR_materials_iridescence",
    "KHR_materials_sheen",
    "KHR_materials_specular",
    "KHR_materials_transmission",
    "KHR_materials_unlit",
    "KHR_materials_variants",
    "KHR_materials_volume",
];

/// What shrad loses when it ignores an extension the file only uses (the specification
/// says a file must then still load without it).
fn ignored_extension_note(name: &str) -> &'static str {
    match name {
        "KHR_materials_unlit" => "unlit materials are read as diffuse reflectors",
        "MSFT_texture_dds" => "the fallback image is used",
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
    /// `KHR_mesh_quantization` is in `extensionsUsed`: integer positions and texture
    /// coordinates are allowed.
    quantized: bool,
    /// Accessors whose type glTF 2.0 does not define (filled by `accessors`), with it: none
    /// may be referred to.
    unknown_accessors: Vec<(usize, String)>,
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
        let here = join(at, key);
        let i = self.index(i, &here, kind)?;
        if kind == "accessors" {
            if let Some((_, ty)) = self.unknown_accessors.iter().find(|u| u.0 == i) {
                return Err(format!(
                    "{here}: accessor {i} has type '{ty}', which glTF 2.0 does not define: shrad cannot read it"
                ));
            }
        }
        Ok(Some(i))
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
        self.lints(&accessors);
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
        let used = names("extensionsUsed")?;
        for (i, e) in required.iter().enumerate() {
            if SHADING_EXTENSIONS.contains(&e.as_str()) {
                // Warned about below, as used (a required extension must be used too).
                if !used.contains(e) {
                    self.warnings.push(format!(
                        "extensionsRequired[{i}]: '{e}' is not in extensionsUsed (glTF requires it there); {}",
                        ignored_extension_note(e)
                    ));
                }
                continue;
            }
            if !IMPLEMENTED_EXTENSIONS.contains(&e.as_str()) {
                return Err(format!(
                    "extensionsRequired[{i}]: the file requires extension '{e}', which shrad does not implement (shrad implements {})",
                    IMPLEMENTED_EXTENSIONS.join(", ")
                ));
            }
        }
        for e in used {
            if !IMPLEMENTED_EXTENSIONS.contains(&e.as_str()) {
                let required = if required.contains(&e) {
                    " (and required)"
                } else {
                    ""
                };
                self.warnings.push(format!(
                    "extension '{e}' is used{required} but not implemented by shrad: {}",
                    ignored_extension_note(&e)
                ));
            }
        }
        Ok(())
    }
}

/// Check the raw JSON of a glTF against the specification (see [`JsonCheck`]); `glb_bin` is
/// the length of the GLB's BIN chunk, if any. Warnings (extensions ignored, ...) are added.
pub(super) fn check_json(
    root: &Value,
    glb_bin: Option<usize>,
    warnings: &mut Vec<String>,
) -> Result<(), String> {
    JsonCheck {
        root,
        warnings,
        parents: Vec::new(),
        unknown_accessors: Vec::new(),
        quantized: root["extensionsUsed"]
            .as_array()
            .is_some_and(|e| e.iter().any(|e| e == "KHR_mesh_quantization")),
    }
    .run(glb_bin)
}

/// Why buffer view `v` of `root` reads a buffer without data (a placeholder: no uri, no
/// BIN chunk), if it does.
fn without_data(root: &Value, buffers: &[Vec<u8>], v: usize) -> Option<String> {
    let b = root["bufferViews"][v]["buffer"].as_u64().unwrap_or(0) as usize;
    buffers.get(b).is_none_or(Vec::is_empty).then(|| {
        format!(
            "bufferView {v} reads buffer {b}, which has no data (no uri, and not a GLB's BIN chunk)"
        )
    })
}

/// The bytes of buffer view `v` of `root`, or why there are none.
fn view_data<'b>(root: &Value, buffers: &'b [Vec<u8>], v: usize) -> Result<&'b [u8], String> {
    if let Some(e) = without_data(root, buffers, v) {
        return Err(e);
    }
    let view = &root["bufferViews"][v];
    let b = view["buffer"].as_u64().unwrap_or(0) as usize;
    let start = view["byteOffset"].as_u64().unwrap_or(0) as usize;
    let len = view["byteLength"].as_u64().unwrap_or(0) as usize;
    let data = buffers.get(b).map_or(&[][..], Vec::as_slice);
    data.get(start..start.saturating_add(len)).ok_or_else(|| {
        format!(
            "bufferView {v} lies outside buffer {b} ({} bytes)",
            data.len()
        )
    })
}

/// Whether accessor `a` reads a buffer without data: then nothing reads it (`unpack`'s
/// `no_data` marked every primitive and animation sampler that does, to be skipped).
fn accessor_without_data(root: &Value, buffers: &[Vec<u8>], a: &Value) -> bool {
    [
        &a["bufferView"],
        &a["sparse"]["indices"]["bufferView"],
        &a["sparse"]["values"]["bufferView"],
    ]
    .into_iter()
    .filter_map(Value::as_u64)
    .any(|v| without_data(root, buffers, v as usize).is_some())
}

/// Every buffer view an accessor (sparse parts included) or an image reads has its bytes
/// within its buffer. An accessor that reads a placeholder buffer (no uri, no BIN chunk) is
/// read by nothing (see [`accessor_without_data`]); an image that does is refused.
pub(super) fn check_views_have_data(root: &Value, buffers: &[Vec<u8>]) -> Result<(), String> {
    let view = |v: &Value| v["bufferView"].as_u64().map(|v| v as usize);
    for (i, a) in array(root, "accessors", "")?.iter().enumerate() {
        if accessor_without_data(root, buffers, a) {
            continue;
        }
        let at = format!("accessors[{i}]");
        for (part, v) in [
            ("", view(a)),
            (".sparse.indices", view(&a["sparse"]["indices"])),
            (".sparse.values", view(&a["sparse"]["values"])),
        ] {
            if let Some(v) = v {
                view_data(root, buffers, v).map_err(|e| format!("{at}{part}: {e}"))?;
            }
        }
    }
    for (i, im) in array(root, "images", "")?.iter().enumerate() {
        if let Some(v) = view(im) {
            view_data(root, buffers, v).map_err(|e| format!("images[{i}]: {e}"))?;
        }
    }
    Ok(())
}

/// Sparse accessor indices strictly increasing and below the accessor's count (the gltf
/// crate's reader would silently drop the others). Lengths were checked by [`check_json`],
/// data by [`check_views_have_data`].
pub(super) fn check_sparse_indices(root: &Value, buffers: &[Vec<u8>]) -> Result<(), String> {
    for (i, a) in array(root, "accessors", "")?.iter().enumerate() {
        let Some(sp) = a.get("sparse").filter(|v| !v.is_null()) else {
            continue;
        };
        if accessor_without_data(root, buffers, a) {
            continue;
        }
        let at = format!("accessors[{i}].sparse.indices");
        let count = a["count"].as_u64().unwrap_or(0);
        let n = sp["count"].as_u64().unwrap_or(0) as usize;
        let ind = &sp["indices"];
        let size = match ind["componentType"].as_u64() {
            Some(5121) => 1,
            Some(5123) => 2,
            _ => 4,
        };
        let data = view_data(
            root,
            buffers,
            ind["bufferView"].as_u64().unwrap_or(0) as usize,
        )
        .map_err(|e| format!("{at}: {e}"))?;
        let start = ind["byteOffset"].as_u64().unwrap_or(0) as usize;
        let bytes = data
            .get(start..start.saturating_add(n.saturating_mul(size)))
            .ok_or_else(|| format!("{at}: outside its buffer view"))?;
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
