//! `KHR_draco_mesh_compression`: a primitive whose geometry is a Draco stream in a buffer
//! view, decoded by draco-oxide-decoder into its own accessors (which declare count and type
//! but no bufferView): attributes as FLOAT, indices as UNSIGNED_INT.
//!
//! Specification: KhronosGroup/glTF, `extensions/2.0/Khronos/KHR_draco_mesh_compression`.
//! The extension's `attributes` map a glTF attribute name to the Draco attribute's unique id.

use draco_oxide_core::attribute::{Attribute, ComponentDataType};
use serde_json::{json, Value};

use super::Unpack;

const EXT: &str = "KHR_draco_mesh_compression";

/// Decode every Draco primitive into its accessors.
pub(super) fn decode_primitives(u: &mut Unpack) -> Result<(), String> {
    let mut done: Vec<usize> = Vec::new();
    let n_meshes = u.root["meshes"].as_array().map_or(0, Vec::len);
    for m in 0..n_meshes {
        let n_prims = u.root["meshes"][m]["primitives"]
            .as_array()
            .map_or(0, Vec::len);
        for p in 0..n_prims {
            let prim = &u.root["meshes"][m]["primitives"][p];
            if super::no_data::skipped(prim).is_some() {
                continue;
            }
            let Some(ext) = prim.pointer(&format!("/extensions/{EXT}")).cloned() else {
                continue;
            };
            let at = format!("meshes[{m}].primitives[{p}]");
            decode_primitive(u, &at, &ext, m, p, &mut done)?;
            if let Some(e) = u.root["meshes"][m]["primitives"][p]
                .get_mut("extensions")
                .and_then(Value::as_object_mut)
            {
                e.remove(EXT);
            }
        }
    }
    Ok(())
}

fn decode_primitive(
    u: &mut Unpack,
    at: &str,
    ext: &Value,
    m: usize,
    p: usize,
    done: &mut Vec<usize>,
) -> Result<(), String> {
    let here = format!("{at}.extensions.{EXT}");
    let views = u.root["bufferViews"].as_array().map_or(0, Vec::len);
    let view = ext["bufferView"]
        .as_u64()
        .map(|v| v as usize)
        .filter(|&v| v < views)
        .ok_or_else(|| format!("{here}.bufferView: missing or not a bufferView of the file"))?;
    let Some(map) = ext["attributes"].as_object() else {
        return Err(format!("{here}.attributes: missing (required)"));
    };
    let bytes = u.view_bytes(view, &here)?;
    // The decoder sizes its allocations from the stream and refuses absurd ones; a stream
    // cannot decode to more than a bounded multiple of its own size, checked on the result.
    // draco-oxide-decoder 0.1.0-alpha.12 can still panic on a corrupt stream (a wrapped
    // prediction transform whose min exceeds its max reaches `i32::clamp`: found by
    // `tests/compressed.rs`, which flips every byte of a stream), so the decoder runs behind
    // its own guard, and such a stream is an error like any other.
    let mesh = std::panic::catch_unwind(|| draco_oxide_decoder::decode_mesh(bytes))
        .map_err(|_| format!("{here}: the Draco stream is malformed (the decoder gave up on it)"))?
        .map_err(|e| format!("{here}: cannot decode the Draco stream: {e}"))?;
    let prim = u.root["meshes"][m]["primitives"][p].clone();
    let mut claim = |a: usize, what: &str| -> Result<(), String> {
        if done.contains(&a) {
            return Err(format!(
                "{at}.{what}: accessor {a} is shared by two Draco primitives"
            ));
        }
        done.push(a);
        Ok(())
    };
    // Indices.
    let faces = mesh.get_faces();
    if let Some(a) = prim["indices"].as_u64().map(|a| a as usize) {
        claim(a, "indices")?;
        let count = u.root["accessors"][a]["count"].as_u64().unwrap_or(0);
        if count != 3 * faces.len() as u64 {
            return Err(format!(
                "{at}.indices: accessor {a} declares {count} indices but the Draco stream has {} triangles ({} indices)",
                faces.len(),
                3 * faces.len()
            ));
        }
        u.budget(count * 4, &here)?;
        let idx: Vec<u8> = faces
            .iter()
            .flatten()
            .flat_map(|&i| (usize::from(i) as u32).to_le_bytes())
            .collect();
        let v = u.push_view(&idx)?;
        let acc = &mut u.root["accessors"][a];
        acc["bufferView"] = json!(v);
        acc["componentType"] = json!(5125);
        if let Some(o) = acc.as_object_mut() {
            o.remove("byteOffset");
        }
    }
    // Attributes.
    for (name, id) in map {
        let id = id
            .as_u64()
            .ok_or_else(|| format!("{here}.attributes.{name}: {id} is not a Draco attribute id"))?;
        let Some(a) = prim["attributes"][name].as_u64().map(|a| a as usize) else {
            // An attribute in the stream that the primitive does not list is not read.
            continue;
        };
        claim(a, &format!("attributes.{name}"))?;
        let attr = mesh
            .get_attributes()
            .iter()
            .find(|x| x.get_id().as_usize() as u64 == id)
            .ok_or_else(|| {
                format!("{here}.attributes.{name}: the Draco stream has no attribute with id {id}")
            })?;
        let acc = &u.root["accessors"][a];
        let count = acc["count"].as_u64().unwrap_or(0) as usize;
        let nc = super::components(acc["type"].as_str().unwrap_or("SCALAR")) as usize;
        let normalized = acc["normalized"].as_bool().unwrap_or(false);
        if attr.len() != count || attr.get_num_components() != nc {
            return Err(format!(
                "{at}.attributes.{name}: accessor {a} declares {count} x {nc} components but the Draco stream's attribute {id} has {} x {}",
                attr.len(),
                attr.get_num_components()
            ));
        }
        u.budget((count * nc * 4) as u64, &here)?;
        let values =
            floats(attr, normalized).map_err(|e| format!("{here}.attributes.{name}: {e}"))?;
        u.set_f32(a, &values)?;
    }
    Ok(())
}

/// An attribute's values per point as floats (normalized integers mapped as glTF says).
fn floats(attr: &Attribute, normalized: bool) -> Result<Vec<f32>, String> {
    let ct = match attr.get_component_type() {
        ComponentDataType::F32 => 5126,
        ComponentDataType::I8 => 5120,
        ComponentDataType::U8 => 5121,
        ComponentDataType::I16 => 5122,
        ComponentDataType::U16 => 5123,
        ComponentDataType::U32 => 5125,
        t => return Err(format!("component type {t:?} is not one glTF reads")),
    };
    let size = super::component_size(ct) as usize;
    let nc = attr.get_num_components();
    let data = attr.get_data_as_bytes();
    let map = attr.point_map_as_slice();
    let mut out = Vec::with_capacity(attr.len() * nc);
    for point in 0..attr.len() {
        let value = match map {
            Some(m) => usize::from(m[point]),
            None => point,
        };
        let at = value * nc * size;
        let bytes = data
            .get(at..at + nc * size)
            .ok_or("the stream's value index is out of range")?;
        out.extend(
            bytes
                .chunks_exact(size)
                .map(|c| super::component_f32(c, ct, normalized)),
        );
    }
    Ok(out)
}
