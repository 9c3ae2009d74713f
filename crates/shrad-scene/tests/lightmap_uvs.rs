//! glTF `TEXCOORD_1` is kept as the mesh's `lightmap_uvs` (the lightmap's layout, whether
//! or not a texture reads it): floats and `KHR_mesh_quantization`'s normalized integers read
//! to the same values; a non-finite or short set is dropped with a warning naming the
//! primitive; an accessor past its buffer is refused as any other.

use std::path::PathBuf;

use glam::Vec2;
use serde_json::{json, Value};
use shrad_scene::{load, LoadOptions};

fn temp_dir(name: &str) -> PathBuf {
    crate::common::temp_dir(&format!("shrad-lmuv-{name}-{}", std::process::id()))
}

/// The floor quad's UV1: a sub-rectangle, corners in the positions' order.
const UV1: [[f32; 2]; 4] = [[0.25, 0.5], [0.25, 1.0], [0.75, 1.0], [0.75, 0.5]];

/// A floor quad whose TEXCOORD_1 is `uv_bytes` of `component_type` (`normalized`), with
/// `count` elements; the extension list `used`.
fn quad(
    uv_bytes: &[u8],
    component_type: u32,
    normalized: bool,
    count: usize,
    used: &[&str],
) -> Value {
    let mut bin = Vec::new();
    for p in [
        [0.0f32, 0.0, 0.0],
        [0.0, 0.0, 1.0],
        [1.0, 0.0, 1.0],
        [1.0, 0.0, 0.0],
    ] {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    let uv_at = bin.len();
    bin.extend_from_slice(uv_bytes);
    while bin.len() % 4 != 0 {
        bin.push(0);
    }
    let mut root = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "floor", "mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": 0, "TEXCOORD_1": 2}, "indices": 1, "material": 0}
        ]}],
        "materials": [{"emissiveFactor": [1.0, 1.0, 1.0]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"},
            {"bufferView": 2, "componentType": component_type, "normalized": normalized,
             "count": count, "type": "VEC2"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12},
            {"buffer": 0, "byteOffset": uv_at, "byteLength": uv_bytes.len()}
        ],
        "buffers": [{"byteLength": bin.len(),
                     "uri": format!("data:application/octet-stream;base64,{}", base64::encode(&bin))}]
    });
    if !normalized {
        root["accessors"][2]
            .as_object_mut()
            .unwrap()
            .remove("normalized");
    }
    if !used.is_empty() {
        root["extensionsUsed"] = json!(used);
        root["extensionsRequired"] = json!(used);
    }
    root
}

fn floats(uv: &[[f32; 2]]) -> Vec<u8> {
    uv.iter().flatten().flat_map(|c| c.to_le_bytes()).collect()
}

fn load_json(name: &str, root: &Value) -> Result<shrad_scene::Scene, String> {
    let d = temp_dir(name);
    let p = d.join(format!("{name}.gltf"));
    std::fs::write(&p, serde_json::to_string(root).unwrap()).unwrap();
    load(&p, &LoadOptions::default()).map_err(|e| e.to_string())
}

fn expected() -> Vec<Vec2> {
    UV1.iter().map(|&q| Vec2::from(q)).collect()
}

#[test]
fn float_texcoord_1_is_kept_without_a_texture_reading_it() {
    let s = load_json("float", &quad(&floats(&UV1), 5126, false, 4, &[])).unwrap();
    assert_eq!(s.objects.len(), 1);
    assert_eq!(s.objects[0].mesh.lightmap_uvs, expected());
    // No texture reads it: the texture sets stay empty.
    assert!(s.objects[0].mesh.uvs.is_empty());
}

#[test]
fn quantized_texcoord_1_reads_to_the_same_values() {
    let q = ["KHR_mesh_quantization"];
    let u16s: Vec<u8> = UV1
        .iter()
        .flatten()
        .flat_map(|&c| ((c * 65535.0).round() as u16).to_le_bytes())
        .collect();
    let s = load_json("u16", &quad(&u16s, 5123, true, 4, &q)).unwrap();
    let got = &s.objects[0].mesh.lightmap_uvs;
    assert_eq!(got.len(), 4);
    for (a, b) in got.iter().zip(expected()) {
        assert!((*a - b).abs().max_element() < 1e-4, "{a} vs {b}");
    }
    // 0.25 is not a multiple of 1/255: unsigned bytes give the nearest steps.
    let u8s: Vec<u8> = UV1
        .iter()
        .flatten()
        .map(|&c| (c * 255.0).round() as u8)
        .collect();
    let s = load_json("u8", &quad(&u8s, 5121, true, 4, &q)).unwrap();
    for (a, b) in s.objects[0].mesh.lightmap_uvs.iter().zip(expected()) {
        assert!(
            (*a - b).abs().max_element() < 0.5 / 255.0 + 1e-6,
            "{a} vs {b}"
        );
    }
}

#[test]
fn a_non_finite_texcoord_1_is_dropped_with_a_warning() {
    let mut bad = UV1;
    bad[2][0] = f32::NAN;
    let s = load_json("nan", &quad(&floats(&bad), 5126, false, 4, &[])).unwrap();
    assert!(s.objects[0].mesh.lightmap_uvs.is_empty());
    let w = s.warnings.join("\n");
    assert!(
        w.contains("meshes[0].primitives[0]")
            && w.contains("TEXCOORD_1: element 2 is not finite: not used as a lightmap layout"),
        "{w}"
    );
}

#[test]
fn a_texcoord_1_past_its_buffer_is_refused() {
    // Five elements in a view of four.
    let err = load_json("short", &quad(&floats(&UV1), 5126, false, 5, &[])).unwrap_err();
    assert!(err.contains("accessors[2]"), "{err}");
}
