//! Warning-only rules (see `lint`) on materials against the primitives that use them, and
//! on extensions: declared, where each may be, and `KHR_materials_variants`' mappings.

use serde_json::Value;

use super::lint::primitives;
use super::{join, JsonCheck};

/// Extensions whose place shrad knows (a name, or a prefix ending in `_`), with the
/// objects that may hold them; the first that matches a name counts. Others may be
/// anywhere.
const PLACES: &[(&str, &[&str])] = &[
    ("KHR_materials_variants", &["root", "primitive"]),
    // Its attributes are core ones with more component types: it has no object.
    ("KHR_mesh_quantization", &[]),
    ("KHR_texture_transform", &["textureInfo"]),
    ("KHR_lights_punctual", &["root", "node"]),
    ("EXT_mesh_gpu_instancing", &["node"]),
    ("KHR_node_visibility", &["node"]),
    ("KHR_draco_mesh_compression", &["primitive"]),
    ("EXT_meshopt_compression", &["buffer", "bufferView"]),
    ("KHR_meshopt_compression", &["buffer", "bufferView"]),
    ("EXT_texture_webp", &["texture"]),
    ("KHR_texture_basisu", &["texture"]),
    ("KHR_materials_", &["material"]),
];

/// What kind of object the value under `key` (of the object at `at`) is, for [`PLACES`].
fn kind_of(key: &str, at: &str) -> &'static str {
    match key {
        "meshes" if at.is_empty() => "mesh",
        "nodes" if at.is_empty() => "node",
        "materials" if at.is_empty() => "material",
        "textures" if at.is_empty() => "texture",
        "buffers" if at.is_empty() => "buffer",
        "bufferViews" if at.is_empty() => "bufferView",
        "accessors" if at.is_empty() => "accessor",
        "primitives" => "primitive",
        k if k.ends_with("Texture") => "textureInfo",
        _ => "other",
    }
}

/// One extension object: (path of its `extensions`, name, kind of the object holding it).
type ExtObject = (String, String, &'static str);

/// Every extension object under `v` (at `at`, an object of kind `kind`), `extras` left out
/// (application data, which may use any key).
fn extension_objects(v: &Value, at: &str, kind: &'static str, out: &mut Vec<ExtObject>) {
    match v {
        Value::Object(o) => {
            for (k, child) in o.iter().filter(|(k, _)| *k != "extras") {
                let here = join(at, k);
                if k != "extensions" {
                    extension_objects(child, &here, kind_of(k, at), out);
                    continue;
                }
                for (name, x) in child.as_object().into_iter().flatten() {
                    out.push((here.clone(), name.clone(), kind));
                    extension_objects(x, &format!("{here}.{name}"), "other", out);
                }
            }
        }
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                extension_objects(x, &format!("{at}[{i}]"), kind, out);
            }
        }
        _ => {}
    }
}

/// Every texture binding under `v` (at `at`): (its path, the TEXCOORD_n set it reads, which
/// `KHR_texture_transform` may override).
fn texture_bindings(v: &Value, at: &str, out: &mut Vec<(String, u64)>) {
    for (k, child) in v.as_object().into_iter().flatten() {
        let here = join(at, k);
        if k.ends_with("Texture") && !child["index"].is_null() {
            let set = child
                .pointer("/extensions/KHR_texture_transform/texCoord")
                .and_then(Value::as_u64)
                .or_else(|| child["texCoord"].as_u64());
            out.push((here, set.unwrap_or(0)));
        } else if k != "extras" {
            texture_bindings(child, &here, out);
        }
    }
}

fn strings(v: &Value) -> Vec<&str> {
    v.as_array()
        .into_iter()
        .flatten()
        .filter_map(Value::as_str)
        .collect()
}

impl JsonCheck<'_> {
    /// Push `at: what (cite)`, for rules of an extension's specification.
    fn note(&mut self, at: &str, what: &str, cite: &str) {
        self.warnings.push(format!("{at}: {what} ({cite})"));
    }

    /// The primitive at `at` has the TEXCOORD_n set each texture of its material reads
    /// (glTF 2.0, "Materials": `texCoord` names an attribute of the primitive), and a
    /// tangent space where the material needs one.
    pub(super) fn lint_material_needs(&mut self, prim: &Value, at: &str) {
        let Some(mi) = prim["material"].as_u64() else {
            return;
        };
        let material = &self.root["materials"][mi as usize];
        let attrs = &prim["attributes"];
        let mut bindings = Vec::new();
        texture_bindings(material, &format!("materials[{mi}]"), &mut bindings);
        for (binding, set) in bindings {
            if attrs.get(format!("TEXCOORD_{set}")).is_none() {
                let what =
                    format!("{binding} reads TEXCOORD_{set}, which the primitive does not have");
                self.lint(&format!("{at}.material"), &what, "Materials");
            }
        }
        self.lint_tangent_space(material, mi, attrs, at);
    }

    /// Anisotropy and a clearcoat normal map are defined in the tangent space: the
    /// primitive gives it (TANGENT), or the material's normal texture lets a reader make
    /// one (KHR_materials_anisotropy, KHR_materials_clearcoat).
    fn lint_tangent_space(&mut self, material: &Value, mi: u64, attrs: &Value, at: &str) {
        let needs = [
            "/KHR_materials_anisotropy",
            "/KHR_materials_clearcoat/clearcoatNormalTexture",
        ]
        .into_iter()
        .find(|p| material["extensions"].pointer(p).is_some());
        let Some(ext) = needs else { return };
        if attrs.get("TANGENT").is_none() && material["normalTexture"].is_null() {
            let what = format!("materials[{mi}] needs a tangent space ({}), but the primitive has no TANGENT and the material no normal texture to make one from", &ext[1..]);
            let cite = ext[1..].split('/').next().unwrap_or_default();
            self.note(&format!("{at}.material"), &what, cite);
        }
    }

    /// Extensions: each object's declared in `extensionsUsed` and in a place its
    /// specification defines; each required one used; KHR_mesh_quantization required;
    /// KHR_materials_variants' mappings resolved.
    pub(super) fn lint_extensions(&mut self) {
        let root = self.root;
        let used = strings(&root["extensionsUsed"]);
        let mut objects = Vec::new();
        extension_objects(root, "", "root", &mut objects);
        let mut undeclared: Vec<&str> = Vec::new();
        for (at, name, kind) in &objects {
            let here = format!("{at}.{name}");
            if !used.contains(&name.as_str()) && !undeclared.contains(&name.as_str()) {
                undeclared.push(name);
                let what = format!("extension '{name}' is not listed in extensionsUsed");
                self.lint(&here, &what, "Specifying Extensions");
            }
            let place = PLACES
                .iter()
                .find(|(p, _)| name == p || (p.ends_with('_') && name.starts_with(p)));
            if let Some((_, places)) = place.filter(|(_, places)| !places.contains(kind)) {
                let what = format!(
                    "{name} does not extend a {kind} (it extends {})",
                    if places.is_empty() {
                        "no object".into()
                    } else {
                        places.join(", ")
                    }
                );
                self.note(&here, &what, name);
            }
        }
        for (i, e) in strings(&root["extensionsRequired"]).into_iter().enumerate() {
            if !used.contains(&e) {
                let what = format!("'{e}' is required but not listed in extensionsUsed");
                self.lint(
                    &format!("extensionsRequired[{i}]"),
                    &what,
                    "Specifying Extensions",
                );
            }
        }
        let required = strings(&root["extensionsRequired"]);
        let q = "KHR_mesh_quantization";
        if let Some(i) = used
            .iter()
            .position(|e| *e == q)
            .filter(|_| !required.contains(&q))
        {
            let what = "not in extensionsRequired: the extension cannot be optional (a reader without it would misread its quantized attributes)";
            self.note(&format!("extensionsUsed[{i}]"), what, q);
        }
        self.lint_variants();
    }

    /// Each primitive's `KHR_materials_variants` maps existing materials to existing
    /// variants of the file, each variant once (KHR_materials_variants).
    fn lint_variants(&mut self) {
        let root = self.root;
        const EXT: &str = "KHR_materials_variants";
        let variants = root.pointer("/extensions/KHR_materials_variants/variants");
        let n_variants = variants.and_then(Value::as_array).map_or(0, Vec::len);
        for (m, mesh) in root["meshes"].as_array().into_iter().flatten().enumerate() {
            for (p, prim) in primitives(mesh).iter().enumerate() {
                let Some(x) = prim.pointer("/extensions/KHR_materials_variants") else {
                    continue;
                };
                let at = format!("meshes[{m}].primitives[{p}].extensions.{EXT}");
                if variants.is_none() {
                    self.note(&at, "the file defines no variants (extensions.KHR_materials_variants.variants at the top level)", EXT);
                }
                match x["mappings"].as_array() {
                    None => self.note(&format!("{at}.mappings"), "missing (required)", EXT),
                    Some(maps) if maps.is_empty() => {
                        self.note(&format!("{at}.mappings"), "must not be empty", EXT)
                    }
                    Some(maps) => self.lint_mappings(maps, &at, n_variants),
                }
            }
        }
    }

    fn lint_mappings(&mut self, maps: &[Value], at: &str, n_variants: usize) {
        const EXT: &str = "KHR_materials_variants";
        let n_materials = self.len("materials");
        let mut seen: Vec<u64> = Vec::new();
        for (k, map) in maps.iter().enumerate() {
            let here = format!("{at}.mappings[{k}]");
            match map["material"].as_u64() {
                None => self.note(&format!("{here}.material"), "missing (required)", EXT),
                Some(i) if i as usize >= n_materials => {
                    let what = format!("material {i} does not exist (the file has {n_materials})");
                    self.note(&format!("{here}.material"), &what, EXT);
                }
                Some(_) => {}
            }
            let Some(list) = map["variants"].as_array() else {
                self.note(&format!("{here}.variants"), "missing (required)", EXT);
                continue;
            };
            if list.is_empty() {
                self.note(&format!("{here}.variants"), "must not be empty", EXT);
            }
            for (j, v) in list.iter().enumerate() {
                let at_v = format!("{here}.variants[{j}]");
                match v.as_u64() {
                    Some(v) if (v as usize) < n_variants && seen.contains(&v) => self.note(
                        &at_v,
                        &format!("variant {v} is mapped more than once for this primitive"),
                        EXT,
                    ),
                    Some(v) if (v as usize) < n_variants => seen.push(v),
                    _ => {
                        let what =
                            format!("variant {v} does not exist (the file has {n_variants})");
                        self.note(&at_v, &what, EXT);
                    }
                }
            }
        }
    }
}
