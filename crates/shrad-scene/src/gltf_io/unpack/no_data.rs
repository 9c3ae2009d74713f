//! Primitives and animation samplers whose data is not in the file, marked to be skipped.
//!
//! In a .gltf, a buffer without `uri` has its bytes nowhere (glTF 2.0, "Buffers": `uri` may
//! be undefined only for a GLB's BIN chunk or for data an extension provides), yet the file
//! is valid: the glTF-Validator does not look into data that is not there. A viewer loads
//! such a file and leaves out what it cannot read; so does shrad. A primitive that reads an
//! accessor without data (an attribute, its indices, a morph target; for a Draco primitive,
//! its compressed stream) is marked with [`MARK`] and the reason, skipped with a warning by
//! the walk (`mesh.rs`) and left alone by the decoders here; an animation sampler that reads
//! one is marked likewise and skipped by `anim`. Only a skin's inverse bind matrices are
//! read elsewhere (`skin`, for a skinned mesh the scene draws): without data, that is an error
//! saying so. No other accessor without data is read.

use serde_json::{json, Value};

use super::Unpack;

/// The key under which a primitive's `extras` or a raw animation sampler carries why it is
/// skipped.
pub(in crate::gltf_io) const MARK: &str = "shrad_skipped_no_data";

/// Why a primitive or sampler marked by [`mark`] is skipped, if it is.
pub(in crate::gltf_io) fn skipped(v: &Value) -> Option<&str> {
    v.get(MARK)
        .or_else(|| v.pointer(&format!("/extras/{MARK}")))
        .and_then(Value::as_str)
}

impl Unpack<'_> {
    /// Why buffer view `v` has no data (its buffer has none), if it has none. A view of the
    /// new buffer (meshopt decoded it) has data.
    fn view_without_data(&self, v: usize) -> Option<String> {
        let b = self.root["bufferViews"][v]["buffer"].as_u64().unwrap_or(0) as usize;
        let empty = b != self.out_buffer() && self.buffers.get(b).is_none_or(Vec::is_empty);
        empty.then(|| {
            format!(
                "bufferView {v} reads buffer {b}, which has no data (no uri, and not a GLB's BIN chunk)"
            )
        })
    }

    /// Why accessor `a` cannot be read (a view of it, sparse parts included, has no data).
    fn accessor_without_data(&self, a: usize) -> Option<String> {
        let acc = &self.root["accessors"][a];
        let view = |v: &Value| v["bufferView"].as_u64().map(|v| v as usize);
        [
            ("", view(acc)),
            (".sparse.indices", view(&acc["sparse"]["indices"])),
            (".sparse.values", view(&acc["sparse"]["values"])),
        ]
        .into_iter()
        .find_map(|(part, v)| {
            Some(format!(
                "accessors[{a}]{part}: {}",
                self.view_without_data(v?)?
            ))
        })
    }

    /// Why primitive `prim` cannot be read, if it cannot.
    fn primitive_without_data(&self, prim: &Value) -> Option<String> {
        if let Some(ext) = prim.pointer("/extensions/KHR_draco_mesh_compression") {
            // The Draco stream replaces the attributes and indices.
            let v = ext["bufferView"].as_u64()? as usize;
            return self
                .view_without_data(v)
                .map(|e| format!("its Draco stream: {e}"));
        }
        let accessors = |m: &Value| -> Vec<usize> {
            m.as_object()
                .into_iter()
                .flat_map(|o| o.values())
                .filter_map(|a| a.as_u64().map(|a| a as usize))
                .collect()
        };
        let mut read = accessors(&prim["attributes"]);
        read.extend(prim["indices"].as_u64().map(|a| a as usize));
        for t in prim["targets"].as_array().into_iter().flatten() {
            read.extend(accessors(t));
        }
        read.into_iter().find_map(|a| self.accessor_without_data(a))
    }

    /// Mark every primitive and every raw animation sampler that reads an accessor without
    /// data (see the module's note). Run after the meshopt views are decoded, before
    /// anything reads an accessor.
    pub(super) fn mark_without_data(&mut self) {
        let mut marks: Vec<(String, String)> = Vec::new();
        for (m, mesh) in items(&self.root["meshes"]) {
            for (p, prim) in items(&mesh["primitives"]) {
                if let Some(why) = self.primitive_without_data(prim) {
                    marks.push((format!("/meshes/{m}/primitives/{p}"), why));
                }
            }
        }
        for (i, anim) in items(&self.root["animations"]) {
            for (s, sampler) in items(&anim["samplers"]) {
                let why = ["input", "output"].into_iter().find_map(|k| {
                    let a = sampler[k].as_u64()? as usize;
                    Some(format!("{k}: {}", self.accessor_without_data(a)?))
                });
                if let Some(why) = why {
                    marks.push((format!("/animations/{i}/samplers/{s}"), why));
                }
            }
        }
        for (at, why) in marks {
            let Some(target) = self.root.pointer_mut(&at) else {
                continue;
            };
            if at.starts_with("/meshes") {
                // A primitive's extras are the user's; this one is never drawn.
                target["extras"] = json!({ MARK: why });
            } else {
                target[MARK] = json!(why);
            }
        }
    }
}

/// The elements of a JSON array with their indices (none when `v` is not an array).
fn items(v: &Value) -> impl Iterator<Item = (usize, &Value)> {
    v.as_array().into_iter().flatten().enumerate()
}
