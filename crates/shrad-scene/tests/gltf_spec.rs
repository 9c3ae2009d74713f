//! The glTF 2.0 reader against the specification: malformed files are refused with an error
//! that names the file and the JSON path of the fault, and never panic (not even inside the
//! gltf crate, which the reader's `catch_unwind` guard would hide: a panic hook counts every
//! panic on the test's thread); mirrored nodes keep their winding (glTF: counter-clockwise
//! from the front in the node's frame, world normal = inverse transpose of the local one).

use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat3, Vec3};
use serde_json::{json, Value};
use shrad_scene::{load, write_gltf, Aabb, LoadOptions, Material, Mesh, Object, Scene, SceneError};

mod common;

use common::panics::{count_panics, panics};

/// A fresh empty temporary directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    common::temp_dir(&format!("shrad-gltf-spec-{}-{name}", std::process::id()))
}

/// Load `path`, asserting that no panic happened anywhere on the way.
fn load_no_panic(path: &Path) -> Result<Scene, SceneError> {
    count_panics();
    let before = panics();
    let r = load(path, &LoadOptions::default());
    assert_eq!(panics(), before, "loading {} panicked", path.display());
    r
}

fn b64(data: &[u8]) -> String {
    base64::encode(data)
}

/// Floor quad at y = 0 facing +Y, counter-clockwise from above.
const QUAD: [[f32; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [1.0, 0.0, 0.0],
];
const QUAD_TRIS: [u16; 6] = [0, 1, 2, 0, 2, 3];

/// The quad's buffer: 48 bytes of positions, then 12 bytes of u16 indices.
fn quad_bin() -> Vec<u8> {
    let mut bin = Vec::new();
    for p in QUAD {
        for c in p {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in QUAD_TRIS {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    bin
}

/// A valid glTF of the floor quad (an emitter, so the scene is not black), buffer embedded.
fn quad_gltf() -> Value {
    let bin = quad_bin();
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "floor", "mesh": 0}],
        "meshes": [{"name": "quad", "primitives": [
            {"attributes": {"POSITION": 0}, "indices": 1, "material": 0}
        ]}],
        "materials": [{
            "name": "lamp",
            "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0},
            "emissiveFactor": [1.0, 1.0, 1.0]
        }],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48, "target": 34962},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12, "target": 34963}
        ],
        "buffers": [{"byteLength": bin.len(),
                     "uri": format!("data:application/octet-stream;base64,{}", b64(&bin))}]
    })
}

fn write_json(dir: &Path, name: &str, root: &Value) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string_pretty(root).unwrap()).unwrap();
    p
}

/// The error of loading `root` as `name`, checked to name the file, to say each of `faults`,
/// and to come from a check rather than from the reader's panic guard.
fn assert_refused(dir: &Path, name: &str, root: &Value, faults: &[&str]) -> String {
    let p = write_json(dir, name, root);
    refused_file(&p, faults)
}

fn refused_file(p: &Path, faults: &[&str]) -> String {
    let name = p.file_name().unwrap().to_string_lossy().into_owned();
    let msg = match load_no_panic(p) {
        Ok(s) => panic!(
            "{name}: expected an error, got a scene of {} objects",
            s.objects.len()
        ),
        Err(e) => e.to_string(),
    };
    assert!(msg.contains(&name), "does not name the file {name}: {msg}");
    assert!(
        !msg.contains("gave up"),
        "{name}: the panic guard answered: {msg}"
    );
    for f in faults {
        assert!(msg.contains(f), "{name}: does not say '{f}': {msg}");
    }
    msg
}

/// Load `root` as `name`: a scene without objects, whose warnings say each of `warnings`.
fn assert_loads_empty(dir: &Path, name: &str, root: &Value, warnings: &[&str]) -> Scene {
    let p = write_json(dir, name, root);
    let s = load_no_panic(&p).unwrap_or_else(|e| panic!("{name}: refused: {e}"));
    assert!(s.objects.is_empty(), "{name}: {} objects", s.objects.len());
    for w in warnings {
        assert!(
            s.warnings.iter().any(|x| x.contains(w)),
            "{name}: no warning says '{w}': {:?}",
            s.warnings
        );
    }
    s
}

/// A change to a glTF's JSON.
type Edit = Box<dyn Fn(&mut Value)>;

/// Apply `edit` to a fresh quad glTF.
fn quad_with(edit: impl FnOnce(&mut Value)) -> Value {
    let mut v = quad_gltf();
    edit(&mut v);
    v
}

#[test]
fn the_quad_itself_loads() {
    let dir = temp_dir("quad");
    let p = write_json(&dir, "quad.gltf", &quad_gltf());
    let s = load_no_panic(&p).unwrap();
    assert_eq!(s.objects.len(), 1);
    assert_eq!(s.objects[0].mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

/// Rules about what shrad reads past (morph targets, KHR_materials_variants, extension
/// declarations) broken: the file loads as before, with a warning naming the JSON path and
/// the rule (`gltf_io/validate/lint*.rs`).
#[test]
fn broken_rules_of_what_shrad_ignores_are_warnings() {
    let dir = temp_dir("lint");
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "morph_count.gltf",
            Box::new(|v: &mut Value| {
                v["accessors"].as_array_mut().unwrap().push(json!({
                    "componentType": 5126, "count": 3, "type": "VEC3",
                    "min": [0.0, 0.0, 0.0], "max": [0.0, 0.0, 0.0]}));
                v["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": 2}]);
            }),
            "meshes[0].primitives[0].targets[0].POSITION: accessor 2 count 3 differs from the primitive's POSITION count 4 (glTF 2.0, Morph Targets)",
        ),
        (
            "weights.gltf",
            Box::new(|v: &mut Value| v["meshes"][0]["weights"] = json!([0.5])),
            "meshes[0].weights: 1 weight(s), but the primitives have 0 morph target(s)",
        ),
        (
            "variants.gltf",
            Box::new(|v: &mut Value| {
                v["extensionsUsed"] = json!(["KHR_materials_variants"]);
                v["extensions"] = json!({"KHR_materials_variants": {"variants": [{"name": "a"}]}});
                v["meshes"][0]["primitives"][0]["extensions"] = json!({"KHR_materials_variants":
                    {"mappings": [{"material": 5, "variants": [0]}]}});
            }),
            "mappings[0].material: material 5 does not exist (the file has 1) (KHR_materials_variants)",
        ),
        (
            "undeclared.gltf",
            Box::new(|v: &mut Value| {
                v["materials"][0]["extensions"] = json!({"KHR_materials_sheen": {}});
            }),
            "materials[0].extensions.KHR_materials_sheen: extension 'KHR_materials_sheen' is not listed in extensionsUsed (glTF 2.0, Specifying Extensions)",
        ),
    ];
    for (name, edit, warning) in cases {
        let p = write_json(&dir, name, &quad_with(edit));
        let s = load_no_panic(&p).unwrap_or_else(|e| panic!("{name}: refused: {e}"));
        assert_eq!(s.objects.len(), 1, "{name}");
        assert!(
            s.warnings.iter().any(|w| w.contains(warning)),
            "{name}: no warning says '{warning}': {:?}",
            s.warnings
        );
    }
}

/// `v` with one more buffer (a data URI of `data`) and a view of all of it; returns the view.
fn add_buffer_view(v: &mut Value, data: &[u8]) -> usize {
    let b = v["buffers"].as_array().unwrap().len();
    v["buffers"]
        .as_array_mut()
        .unwrap()
        .push(json!({"byteLength": data.len(),
        "uri": format!("data:application/octet-stream;base64,{}", b64(data))}));
    let views = v["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": b, "byteLength": data.len()}));
    views.len() - 1
}

fn le_bytes<T: Copy, const N: usize>(values: &[T], to: impl Fn(T) -> [u8; N]) -> Vec<u8> {
    values.iter().flat_map(|&x| to(x)).collect()
}

/// glTF 2.0 ("Meshes", "Skins") rules on the values of attributes shrad does not use, or
/// uses only to skin: normals and tangents of unit length, a tangent's W 1 or -1, joint
/// indices within the skin, weights summing to 1. Broken, the file loads with its object,
/// warned once for each accessor with how many elements break the rule and the first. (The
/// joint beyond the skin has a zero weight: with a weight, the skinned mesh is refused,
/// `gltf_skin.rs`.)
#[test]
fn values_of_unused_attributes_are_checked_and_only_warn() {
    let dir = temp_dir("values");
    let normals: [f32; 12] = [0.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0, 1.0, 0.0];
    let tangents: [f32; 16] = [
        1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0, 1.0,
    ];
    let joints: [u8; 16] = [0, 0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0, 0, 0, 0];
    let weights: [f32; 16] = [
        1.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
    ];
    let attribute = |v: &mut Value, name: &str, data: Vec<u8>, ty: &str, ct: u32| {
        let view = add_buffer_view(v, &data);
        let accessors = v["accessors"].as_array_mut().unwrap();
        accessors.push(json!({"bufferView": view, "componentType": ct, "count": 4, "type": ty}));
        let a = accessors.len() - 1;
        v["meshes"][0]["primitives"][0]["attributes"][name] = json!(a);
    };
    let file = quad_with(|v| {
        attribute(
            v,
            "NORMAL",
            le_bytes(&normals, f32::to_le_bytes),
            "VEC3",
            5126,
        );
        attribute(
            v,
            "TANGENT",
            le_bytes(&tangents, f32::to_le_bytes),
            "VEC4",
            5126,
        );
        attribute(v, "JOINTS_0", joints.to_vec(), "VEC4", 5121);
        attribute(
            v,
            "WEIGHTS_0",
            le_bytes(&weights, f32::to_le_bytes),
            "VEC4",
            5126,
        );
        v["nodes"]
            .as_array_mut()
            .unwrap()
            .push(json!({"name": "bone"}));
        v["nodes"][0]["skin"] = json!(0);
        v["scenes"][0]["nodes"] = json!([0, 1]);
        v["skins"] = json!([{"joints": [1]}]);
    });
    let p = write_json(&dir, "values.gltf", &file);
    let s = load_no_panic(&p).unwrap_or_else(|e| panic!("refused: {e}"));
    assert_eq!(s.objects.len(), 1, "{:?}", s.warnings);
    let at = "meshes[0].primitives[0].attributes";
    for w in [
        format!("{at}.NORMAL: accessor 2: 2 of 4 normals are not unit length (first: element 0, length 0.5000); a NORMAL is a unit XYZ vector (glTF 2.0, Meshes)"),
        format!("{at}.TANGENT: accessor 3: 1 of 4 tangents have a W that is neither 1 nor -1 (first: element 1, W 0)"),
        format!("{at}.JOINTS_0: accessor 4: 1 of 4 vertices have a joint index not below the 1 joints of skins[0], which skins this mesh (first: vertex 2, component 1, joint 3) (glTF 2.0, Skins)"),
        format!("{at}: 2 of 4 vertices have weights (WEIGHTS_0, accessor(s) 5) that do not sum to 1 (first: vertex 1, sum 0.5) (glTF 2.0, Skins)"),
    ] {
        assert!(
            s.warnings.iter().any(|x| x.contains(&w)),
            "no warning says '{w}': {:#?}",
            s.warnings
        );
    }
    assert!(
        !s.warnings
            .iter()
            .any(|w| w.contains("TANGENT: accessor 3: ") && w.contains("unit length")),
        "the tangents' XYZ are unit: {:#?}",
        s.warnings
    );
}

#[test]
fn version_must_be_2() {
    let dir = temp_dir("version");
    assert_refused(
        &dir,
        "v1.gltf",
        &quad_with(|v| v["asset"]["version"] = json!("1.0")),
        &["asset.version", "1.0", "2.x"],
    );
    assert_refused(
        &dir,
        "v3.gltf",
        &quad_with(|v| v["asset"]["version"] = json!("3.0")),
        &["asset.version", "3.0"],
    );
    assert_refused(
        &dir,
        "vbad.gltf",
        &quad_with(|v| v["asset"]["version"] = json!("two")),
        &["asset.version", "'two'"],
    );
    assert_refused(
        &dir,
        "noasset.gltf",
        &quad_with(|v| {
            v.as_object_mut().unwrap().remove("asset");
        }),
        &["asset: missing"],
    );
    assert_refused(
        &dir,
        "minversion.gltf",
        &quad_with(|v| {
            v["asset"]["version"] = json!("2.1");
            v["asset"]["minVersion"] = json!("2.1");
        }),
        &["asset.minVersion", "2.1"],
    );
    // 2.1 without a minVersion: readable as 2.0, with a warning.
    let p = write_json(
        &dir,
        "v21.gltf",
        &quad_with(|v| v["asset"]["version"] = json!("2.1")),
    );
    let s = load_no_panic(&p).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("2.1")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn missing_references_are_errors_with_their_json_path() {
    let dir = temp_dir("refs");
    // The user's file: a primitive naming a missing accessor (the gltf crate's own
    // validation indexes with it and panics).
    assert_refused(
        &dir,
        "scene.gltf",
        &quad_with(|v| v["meshes"][0]["primitives"][0]["attributes"]["POSITION"] = json!(7)),
        &["meshes[0].primitives[0].attributes.POSITION: accessor 7 does not exist (the file has 2)"],
    );
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "indices",
            Box::new(|v| v["meshes"][0]["primitives"][0]["indices"] = json!(5)),
            "meshes[0].primitives[0].indices: accessor 5 does not exist",
        ),
        (
            "normal",
            Box::new(|v| v["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(2)),
            "meshes[0].primitives[0].attributes.NORMAL: accessor 2 does not exist",
        ),
        (
            "material",
            Box::new(|v| v["meshes"][0]["primitives"][0]["material"] = json!(3)),
            "meshes[0].primitives[0].material: material 3 does not exist (the file has 1)",
        ),
        (
            "mesh",
            Box::new(|v| v["nodes"][0]["mesh"] = json!(1)),
            "nodes[0].mesh: mesh 1 does not exist",
        ),
        (
            "camera",
            Box::new(|v| v["nodes"][0]["camera"] = json!(0)),
            "nodes[0].camera: camera 0 does not exist (the file has 0)",
        ),
        (
            "child",
            Box::new(|v| v["nodes"][0]["children"] = json!([4])),
            "nodes[0].children[0]: node 4 does not exist",
        ),
        (
            "scene_node",
            Box::new(|v| v["scenes"][0]["nodes"] = json!([0, 9])),
            "scenes[0].nodes[1]: node 9 does not exist",
        ),
        (
            "scene",
            Box::new(|v| v["scene"] = json!(2)),
            "scene: scene 2 does not exist",
        ),
        (
            "view",
            Box::new(|v| v["accessors"][1]["bufferView"] = json!(6)),
            "accessors[1].bufferView: bufferView 6 does not exist",
        ),
        (
            "buffer",
            Box::new(|v| v["bufferViews"][0]["buffer"] = json!(1)),
            "bufferViews[0].buffer: buffer 1 does not exist",
        ),
        (
            "texture",
            Box::new(|v| {
                v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0})
            }),
            "materials[0].pbrMetallicRoughness.baseColorTexture.index: texture 0 does not exist",
        ),
        (
            "image",
            Box::new(|v| v["textures"] = json!([{"source": 1}])),
            "textures[0].source: image 1 does not exist",
        ),
        (
            "sampler",
            Box::new(|v| v["textures"] = json!([{"sampler": 0}])),
            "textures[0].sampler: sampler 0 does not exist",
        ),
        (
            "negative",
            Box::new(|v| v["nodes"][0]["mesh"] = json!(-1)),
            "nodes[0].mesh: -1 is not a non-negative integer",
        ),
        (
            "string_index",
            Box::new(|v| v["meshes"][0]["primitives"][0]["indices"] = json!("1")),
            "meshes[0].primitives[0].indices",
        ),
    ];
    for (name, edit, fault) in cases {
        let mut v = quad_gltf();
        edit(&mut v);
        assert_refused(&dir, &format!("{name}.gltf"), &v, &[fault]);
    }
}

#[test]
fn accessor_and_buffer_view_bounds() {
    let dir = temp_dir("bounds");
    let cases: Vec<(&str, Edit, &[&str])> = vec![
        (
            "count",
            Box::new(|v| v["accessors"][0]["count"] = json!(5)),
            &["accessors[0]", "need 60 bytes", "bufferView 0 has 48"],
        ),
        (
            "count0",
            Box::new(|v| v["accessors"][0]["count"] = json!(0)),
            &["accessors[0].count: must be at least 1"],
        ),
        (
            "offset",
            Box::new(|v| v["accessors"][1]["byteOffset"] = json!(4)),
            &["accessors[1]", "bufferView 1 has 12"],
        ),
        (
            "misaligned",
            Box::new(|v| v["accessors"][0]["byteOffset"] = json!(2)),
            &["accessors[0].byteOffset", "multiple"],
        ),
        (
            "component",
            Box::new(|v| v["accessors"][0]["componentType"] = json!(5130)),
            &["accessors[0].componentType: 5130"],
        ),
        (
            "type",
            Box::new(|v| v["accessors"][0]["type"] = json!("VEC5")),
            // Any string is a type in the schema (for later versions): refused where used.
            &["attributes.POSITION: accessor 0 has type 'VEC5', which glTF 2.0 does not define"],
        ),
        (
            "view",
            Box::new(|v| v["bufferViews"][1]["byteLength"] = json!(16)),
            &["bufferViews[1]", "outside buffer 0 (60 bytes)"],
        ),
        (
            "stride_small",
            Box::new(|v| v["bufferViews"][0]["byteStride"] = json!(2)),
            &["bufferViews[0].byteStride: 2", "[4, 252]"],
        ),
        (
            "stride_odd",
            Box::new(|v| v["bufferViews"][0]["byteStride"] = json!(14)),
            &["bufferViews[0].byteStride: 14"],
        ),
        (
            "stride_big",
            Box::new(|v| v["bufferViews"][0]["byteStride"] = json!(256)),
            &["bufferViews[0].byteStride: 256"],
        ),
        (
            "stride_elem",
            Box::new(|v| v["bufferViews"][0]["byteStride"] = json!(8)),
            &["accessors[0]", "byteStride 8 is smaller than the 12-byte"],
        ),
        (
            "stride_fit",
            // 4 elements of 12 bytes at stride 16 need 60 bytes.
            Box::new(|v| v["bufferViews"][0]["byteStride"] = json!(16)),
            &["accessors[0]", "stride 16", "need 60 bytes"],
        ),
        (
            "index_type",
            Box::new(|v| {
                v["accessors"][1]["componentType"] = json!(5126);
                v["accessors"][1]["count"] = json!(3);
            }),
            &["meshes[0].primitives[0].indices: accessor 1 is SCALAR FLOAT"],
        ),
        (
            "attr_count",
            Box::new(|v| {
                v["accessors"].as_array_mut().unwrap().push(
                    json!({"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}),
                );
                v["meshes"][0]["primitives"][0]["attributes"]["_ID"] = json!(2);
            }),
            &["attributes._ID: accessor 2 has 3 elements but POSITION has 4"],
        ),
        (
            "semantic",
            Box::new(|v| v["meshes"][0]["primitives"][0]["attributes"]["FOO"] = json!(0)),
            &["attributes.FOO: not a glTF attribute name"],
        ),
        (
            "mode",
            Box::new(|v| v["meshes"][0]["primitives"][0]["mode"] = json!(9)),
            &["meshes[0].primitives[0].mode: 9"],
        ),
        (
            "no_primitives",
            Box::new(|v| v["meshes"][0]["primitives"] = json!([])),
            &["meshes[0].primitives: missing or empty"],
        ),
    ];
    for (name, edit, faults) in cases {
        let mut v = quad_gltf();
        edit(&mut v);
        assert_refused(&dir, &format!("{name}.gltf"), &v, faults);
    }
}

#[test]
fn index_values_beyond_the_vertices() {
    let dir = temp_dir("index_values");
    let mut bin = quad_bin();
    bin[48 + 10] = 4; // the last index 3 -> 4: one past the four vertices
    let root = quad_with(|v| {
        v["buffers"][0]["uri"] = json!(format!(
            "data:application/octet-stream;base64,{}",
            b64(&bin)
        ))
    });
    assert_refused(
        &dir,
        "idx.gltf",
        &root,
        &[
            "meshes[0].primitives[0].indices (nodes[0] 'floor'): index 4 (element 5) is out of range",
            "floor",
        ],
    );
}

#[test]
fn factors_outside_0_1_are_errors_and_exactly_1_is_clamped() {
    let dir = temp_dir("factors");
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "base",
            Box::new(|v| {
                v["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] =
                    json!([1.5, 0.5, 0.5, 1.0])
            }),
            "materials[0].pbrMetallicRoughness.baseColorFactor[0]: 1.5 is outside [0, 1]",
        ),
        (
            "alpha",
            Box::new(|v| {
                v["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] =
                    json!([0.5, 0.5, 0.5, -0.5])
            }),
            "baseColorFactor[3]: -0.5 is outside [0, 1]",
        ),
        (
            "base_len",
            Box::new(|v| {
                v["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.5, 0.5])
            }),
            "baseColorFactor: must be an array of 4 numbers",
        ),
        (
            "emissive",
            Box::new(|v| v["materials"][0]["emissiveFactor"] = json!([1.0, 2.0, 0.0])),
            "materials[0].emissiveFactor[1]: 2 is outside [0, 1]",
        ),
        (
            "metallic",
            Box::new(|v| v["materials"][0]["pbrMetallicRoughness"]["metallicFactor"] = json!(1.2)),
            "materials[0].pbrMetallicRoughness.metallicFactor: 1.2 is outside [0, 1]",
        ),
        (
            "roughness",
            Box::new(|v| {
                v["materials"][0]["pbrMetallicRoughness"]["roughnessFactor"] = json!(-0.1)
            }),
            "materials[0].pbrMetallicRoughness.roughnessFactor: -0.1 is outside [0, 1]",
        ),
        (
            "strength",
            Box::new(|v| {
                v["materials"][0]["extensions"] =
                    json!({"KHR_materials_emissive_strength": {"emissiveStrength": -2.0}});
                v["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
            }),
            "materials[0].extensions.KHR_materials_emissive_strength.emissiveStrength: -2 must be >= 0",
        ),
    ];
    for (name, edit, fault) in cases {
        let mut v = quad_gltf();
        edit(&mut v);
        assert_refused(&dir, &format!("{name}.gltf"), &v, &[fault]);
    }
    // Exactly 1: allowed by glTF, not energy conserving: 0.999 with a warning naming the
    // material.
    let p = write_json(
        &dir,
        "white.gltf",
        &quad_with(|v| {
            v["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] =
                json!([1.0, 0.25, 1.0, 1.0])
        }),
    );
    let s = load_no_panic(&p).unwrap();
    assert_eq!(
        s.objects[0].material.reflectance,
        Vec3::new(0.999, 0.25, 0.999)
    );
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("materials[0] 'lamp'") && w.contains("clamped")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn camera_parameters() {
    let dir = temp_dir("camera");
    let with_camera = |cam: Value| {
        quad_with(|v| {
            v["cameras"] = json!([cam]);
            v["nodes"][0]["camera"] = json!(0);
        })
    };
    let persp = |p: Value| json!({"type": "perspective", "perspective": p});
    let cases = [
        (
            "yfov0",
            persp(json!({"yfov": 0.0, "znear": 0.1})),
            "cameras[0].perspective.yfov: 0 must be > 0",
        ),
        (
            "noyfov",
            persp(json!({"znear": 0.1})),
            "cameras[0].perspective.yfov: missing",
        ),
        (
            "znear",
            persp(json!({"yfov": 0.8, "znear": 0.0})),
            "cameras[0].perspective.znear: 0 must be > 0",
        ),
        (
            "zfar",
            persp(json!({"yfov": 0.8, "znear": 1.0, "zfar": 0.5})),
            "cameras[0].perspective.zfar: 0.5 must be greater than znear 1",
        ),
        (
            "aspect",
            persp(json!({"yfov": 0.8, "znear": 0.1, "aspectRatio": 0.0})),
            "cameras[0].perspective.aspectRatio: 0 must be > 0",
        ),
        (
            "type",
            json!({"type": "fisheye"}),
            "cameras[0].type: 'fisheye'",
        ),
        (
            "noobj",
            json!({"type": "perspective"}),
            "cameras[0].perspective: missing",
        ),
        (
            "ortho",
            json!({"type": "orthographic", "orthographic": {"xmag": 0.0, "ymag": 1.0, "znear": 0.0, "zfar": 1.0}}),
            "cameras[0].orthographic.xmag: must not be zero",
        ),
    ];
    // A yfov of pi or more is allowed (the specification says SHOULD be below pi): a warning.
    let p = write_json(
        &dir,
        "yfov4.gltf",
        &with_camera(persp(json!({"yfov": 4.0, "znear": 0.1}))),
    );
    let s = load_no_panic(&p).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.starts_with("cameras[0].perspective.yfov: 4 radians is not below pi")),
        "{:?}",
        s.warnings
    );
    let yfov = s.camera.as_ref().unwrap().yfov;
    assert!((yfov - 179f32.to_radians()).abs() < 1e-6, "{yfov}");
    for (name, cam, fault) in cases {
        assert_refused(&dir, &format!("{name}.gltf"), &with_camera(cam), &[fault]);
    }
    let p = write_json(
        &dir,
        "good.gltf",
        &with_camera(persp(
            json!({"yfov": 0.8, "znear": 0.1, "zfar": 100.0, "aspectRatio": 1.5}),
        )),
    );
    let cam = load_no_panic(&p).unwrap().camera.unwrap();
    assert!((cam.yfov - 0.8).abs() < 1e-6);
    assert_eq!(cam.aspect_ratio, Some(1.5));
}

#[test]
fn required_extensions_shrad_lacks_are_errors_but_shading_ones_are_read_as_their_base() {
    let dir = temp_dir("extensions");
    // KHR_mesh_quantization, EXT_meshopt_compression, KHR_draco_mesh_compression and
    // EXT_texture_webp are implemented (tests/compressed.rs), KHR_texture_basisu too
    // (tests/gltf_ktx2.rs).
    let ext = "EXT_made_up_by_someone";
    let root = quad_with(|v| {
        v["extensionsUsed"] = json!([ext]);
        v["extensionsRequired"] = json!([ext]);
    });
    assert_refused(
        &dir,
        &format!("{ext}.gltf"),
        &root,
        &[
            "extensionsRequired[0]",
            &format!("'{ext}'"),
            "does not implement",
        ],
    );
    // Only used: the file loads; an extension shrad ignores gives a warning naming it
    // (KHR_texture_transform loads either way: ignored or implemented).
    let root = quad_with(|v| {
        v["extensionsUsed"] = json!(["KHR_materials_unlit", "KHR_texture_transform", "EXT_other"]);
        v["materials"][0]["extensions"] = json!({"KHR_materials_unlit": {}});
    });
    let p = write_json(&dir, "used.gltf", &root);
    let s = load_no_panic(&p).unwrap();
    for ext in ["KHR_materials_unlit", "EXT_other"] {
        assert!(
            s.warnings.iter().any(|w| w.contains(ext)),
            "{ext}: {:?}",
            s.warnings
        );
    }
    // A shading extension a file requires (as 3ds Max's exporter writes them, e.g. Khronos'
    // PotOfCoalsAnimationPointer) is read as the base material it refines, with a warning.
    let root = quad_with(|v| {
        let shading = json!(["KHR_materials_transmission", "KHR_materials_volume"]);
        v["extensionsUsed"] = shading.clone();
        v["extensionsRequired"] = shading;
        v["materials"][0]["extensions"] = json!({"KHR_materials_transmission":
            {"transmissionFactor": 1.0}, "KHR_materials_volume": {"thicknessFactor": 0.02}});
    });
    let p = write_json(&dir, "shading.gltf", &root);
    let s = load_no_panic(&p).unwrap();
    for ext in ["KHR_materials_transmission", "KHR_materials_volume"] {
        let said = format!("extension '{ext}' is used (and required) but not implemented");
        assert!(
            s.warnings.iter().any(|w| w.contains(&said)),
            "{ext}: {:?}",
            s.warnings
        );
    }
    // Specular-glossiness (archived, in older files, often required): its diffuse colour is
    // the reflectance, in place of the metallic-roughness base colour.
    let ext = "KHR_materials_pbrSpecularGlossiness";
    let root = quad_with(|v| {
        v["extensionsUsed"] = json!([ext]);
        v["extensionsRequired"] = json!([ext]);
        v["materials"][0]["pbrMetallicRoughness"] =
            json!({"baseColorFactor": [0.9, 0.9, 0.9, 1.0]});
        v["materials"][0]["extensions"] = json!({ext: {"diffuseFactor": [0.2, 0.4, 0.6, 1.0],
            "specularFactor": [1.0, 1.0, 1.0], "glossinessFactor": 0.3}});
    });
    let p = write_json(&dir, "spec-gloss.gltf", &root);
    let s = load_no_panic(&p).unwrap();
    assert_eq!(s.objects[0].material.reflectance, Vec3::new(0.2, 0.4, 0.6));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    // The one shrad implements may be required.
    let root = quad_with(|v| {
        v["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
        v["extensionsRequired"] = json!(["KHR_materials_emissive_strength"]);
        v["materials"][0]["extensions"] =
            json!({"KHR_materials_emissive_strength": {"emissiveStrength": 5.0}});
    });
    let p = write_json(&dir, "strength.gltf", &root);
    let s = load_no_panic(&p).unwrap();
    assert_eq!(s.objects[0].material.emitted_radiance, Vec3::splat(5.0));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn quantized_positions_are_refused() {
    let dir = temp_dir("quantized");
    let root = quad_with(|v| {
        // Normalized unsigned shorts (what KHR_mesh_quantization allows), without the
        // extension being declared.
        v["accessors"][0] = json!({"bufferView": 0, "componentType": 5123, "normalized": true,
            "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 1]});
    });
    assert_refused(
        &dir,
        "quant.gltf",
        &root,
        &[
            "attributes.POSITION: accessor 0 is VEC3 normalized UNSIGNED_SHORT",
            "KHR_mesh_quantization",
        ],
    );
}

/// A glTF whose .bin is missing: an error that names both files and says the file was not
/// found (an I/O error, which Python raises as `FileNotFoundError`), not a malformed file.
#[test]
fn a_missing_bin_is_an_unreadable_file_naming_both() {
    let dir = temp_dir("missing_bin");
    let p = write_json(
        &dir,
        "lost.gltf",
        &quad_with(|v| v["buffers"][0]["uri"] = json!("lost.bin")),
    );
    match load_no_panic(&p) {
        Err(e @ SceneError::Unreadable { kind, .. }) => {
            assert_eq!(kind, std::io::ErrorKind::NotFound);
            let msg = e.to_string();
            for f in ["lost.gltf", "buffers[0].uri", "cannot read", "lost.bin"] {
                assert!(msg.contains(f), "does not say '{f}': {msg}");
            }
        }
        other => panic!("expected SceneError::Unreadable, got {other:?}"),
    }
}

#[test]
fn buffers_data_uris_and_glb_chunks() {
    let dir = temp_dir("buffers");
    assert_refused(
        &dir,
        "short.gltf",
        &quad_with(|v| v["buffers"][0]["byteLength"] = json!(64)),
        &["buffers[0]: has 60 bytes but declares byteLength 64"],
    );
    assert_refused(
        &dir,
        "notb64.gltf",
        // Percent-encoded (RFC 2397), read as 2 bytes: too short for the buffer.
        &quad_with(|v| v["buffers"][0]["uri"] = json!("data:application/octet-stream,%00%01")),
        &["buffers[0]: has 2 bytes but declares byteLength"],
    );
    assert_refused(
        &dir,
        "badb64.gltf",
        &quad_with(|v| v["buffers"][0]["uri"] = json!("data:application/octet-stream;base64,AA*A")),
        &["buffers[0].uri", "data URI"],
    );
    // A percent-escape that decodes to bytes that are not UTF-8 (the gltf crate's importer
    // panics on it): a file that does not exist, named.
    assert_refused(
        &dir,
        "notutf8.gltf",
        &quad_with(|v| v["buffers"][0]["uri"] = json!("quad%FF.bin")),
        &["buffers[0].uri", "cannot read", "quad\u{FFFD}.bin"],
    );
    // A buffer without uri in a .gltf has no data (valid: the validator does not look into
    // it): the primitive that reads it is skipped, naming what it reads, and the file loads.
    assert_loads_empty(
        &dir,
        "nouri.gltf",
        &quad_with(|v| {
            v["buffers"][0].as_object_mut().unwrap().remove("uri");
        }),
        &[
            "meshes[0].primitives[0] (nodes[0] 'floor'): skipped, its data is not in the file: accessors[0]: bufferView 0 reads buffer 0, which has no data (no uri",
            "nothing to light: the scene draws no triangle with area (skipped: 1 primitive(s) whose data is not in the file); the scene is empty",
        ],
    );
    assert_refused(
        &dir,
        "nolength.gltf",
        &quad_with(|v| {
            v["buffers"][0]
                .as_object_mut()
                .unwrap()
                .remove("byteLength");
        }),
        &["buffers[0].byteLength: missing"],
    );

    // GLB: a valid one, then its lengths broken one by one.
    let mut scene = Scene::default();
    let mut lamp = Material::diffuse(Vec3::splat(0.5));
    lamp.emitted_radiance = Vec3::ONE;
    scene.objects.push(Object::new("floor", quad_mesh(), lamp));
    let glb = dir.join("quad.glb");
    write_gltf(&scene, &glb).unwrap();
    load_no_panic(&glb).unwrap();
    let bytes = std::fs::read(&glb).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let patched = |name: &str, at: usize, value: u32| {
        let mut b = bytes.clone();
        b[at..at + 4].copy_from_slice(&value.to_le_bytes());
        let p = dir.join(name);
        std::fs::write(&p, b).unwrap();
        p
    };
    refused_file(&patched("version.glb", 4, 1), &["GLB: container version 1"]);
    refused_file(
        &patched("total.glb", 8, bytes.len() as u32 + 100),
        &["GLB: the header declares", "truncated"],
    );
    refused_file(
        &patched("json.glb", 12, u32::MAX - 3),
        &["GLB: the chunk at byte 12 declares", "truncated"],
    );
    refused_file(
        &patched("bin.glb", 20 + json_len, 1 << 20),
        &[&format!("GLB: the chunk at byte {}", 20 + json_len)],
    );
    // A BIN chunk shorter than buffer 0 (the file cut after 8 bytes of it, its lengths
    // consistent).
    let mut short = bytes[..20 + json_len + 16].to_vec();
    let total = short.len() as u32;
    short[8..12].copy_from_slice(&total.to_le_bytes());
    short[20 + json_len..24 + json_len].copy_from_slice(&8u32.to_le_bytes());
    let p = dir.join("binshort.glb");
    std::fs::write(&p, short).unwrap();
    refused_file(
        &p,
        &[
            "buffers[0]: declares byteLength",
            "the GLB BIN chunk has 8 bytes",
        ],
    );
    refused_file(
        &patched("tiny.glb", 8, 4),
        &["GLB: the chunk header at byte 12 is truncated"],
    );
    refused_file(
        &patched("type.glb", 16, 0x1234_5678),
        &["GLB: the first chunk is of type 0x12345678"],
    );
    // Another magic number: said so, not "invalid glTF: JSON: expected value".
    refused_file(
        &patched("magic.glb", 0, u32::from_le_bytes(*b"gLTF")),
        &["not a GLB file: it starts with \"gLTF\""],
    );
    // Cut anywhere: an error, never a panic.
    for n in 0..bytes.len() {
        let p = dir.join("cut.glb");
        std::fs::write(&p, &bytes[..n]).unwrap();
        assert!(load_no_panic(&p).is_err(), "cut at {n}");
    }
}

fn quad_mesh() -> Mesh {
    Mesh {
        positions: QUAD.iter().map(|&p| Vec3::from(p)).collect(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        ..Default::default()
    }
}

#[test]
fn sparse_accessors_are_applied() {
    let dir = temp_dir("sparse");
    // The base positions, then vertex 2 moved to (2, 0, 2) by a sparse substitution:
    // one u8 index (padded to 4) and one VEC3.
    let mut bin = quad_bin();
    let at = bin.len();
    bin.extend_from_slice(&[2, 0, 0, 0]);
    for c in [2.0f32, 0.0, 2.0] {
        bin.extend_from_slice(&c.to_le_bytes());
    }
    let sparse = |index: u8| {
        let mut b = bin.clone();
        b[at] = index;
        quad_with(|v| {
            v["buffers"][0] = json!({"byteLength": b.len(),
                "uri": format!("data:application/octet-stream;base64,{}", b64(&b))});
            let views = v["bufferViews"].as_array_mut().unwrap();
            views.push(json!({"buffer": 0, "byteOffset": at, "byteLength": 4}));
            views.push(json!({"buffer": 0, "byteOffset": at + 4, "byteLength": 12}));
            v["accessors"][0]["sparse"] = json!({"count": 1,
                "indices": {"bufferView": 2, "componentType": 5121},
                "values": {"bufferView": 3}});
            v["accessors"][0]["max"] = json!([2.0, 0.0, 2.0]);
        })
    };
    let p = write_json(&dir, "sparse.gltf", &sparse(2));
    let s = load_no_panic(&p).unwrap();
    assert_eq!(s.objects[0].mesh.positions[2], Vec3::new(2.0, 0.0, 2.0));
    assert_eq!(s.objects[0].mesh.positions[1], Vec3::new(0.0, 0.0, 1.0));
    assert_refused(
        &dir,
        "sparse_index.gltf",
        &sparse(7),
        &["accessors[0].sparse.indices: index 7 (element 0) must be below the count 4"],
    );
    assert_refused(
        &dir,
        "sparse_count.gltf",
        &quad_with(|v| {
            v["accessors"][0]["sparse"] = json!({"count": 9,
                "indices": {"bufferView": 1, "componentType": 5123},
                "values": {"bufferView": 0}});
        }),
        &["accessors[0].sparse.count: 9 must be in [1, 4]"],
    );
    assert_refused(
        &dir,
        "sparse_values.gltf",
        &quad_with(|v| {
            v["accessors"][0]["sparse"] = json!({"count": 2,
                "indices": {"bufferView": 1, "componentType": 5123},
                "values": {"bufferView": 1}});
        }),
        &[
            "accessors[0].sparse.values: 2 elements of 12 bytes",
            "bufferView 1 has 12",
        ],
    );
}

#[test]
fn node_transforms_and_hierarchy() {
    let dir = temp_dir("nodes");
    let m = Affine3A::from_translation(Vec3::new(1.0, 2.0, 3.0));
    let cols: Vec<f32> = glam::Mat4::from(m).to_cols_array().to_vec();
    assert_refused(
        &dir,
        "matrix_trs.gltf",
        &quad_with(|v| {
            v["nodes"][0]["matrix"] = json!(cols);
            v["nodes"][0]["scale"] = json!([2.0, 2.0, 2.0]);
        }),
        &["nodes[0]: has both a matrix and translation/rotation/scale"],
    );
    let mut projective = cols.clone();
    projective[3] = 0.5;
    assert_refused(
        &dir,
        "projective.gltf",
        &quad_with(|v| v["nodes"][0]["matrix"] = json!(projective)),
        &["nodes[0].matrix: not an affine transform"],
    );
    assert_refused(
        &dir,
        "short_matrix.gltf",
        &quad_with(|v| v["nodes"][0]["matrix"] = json!([1.0, 0.0])),
        &["nodes[0].matrix: must be an array of 16 numbers"],
    );
    assert_refused(
        &dir,
        "quat.gltf",
        &quad_with(|v| v["nodes"][0]["rotation"] = json!([0.0, 0.0, 0.0, 2.0])),
        &["nodes[0].rotation", "not a unit quaternion"],
    );
    assert_refused(
        &dir,
        "cycle.gltf",
        &quad_with(|v| {
            v["nodes"] = json!([{"mesh": 0}, {"children": [2]}, {"children": [1]}]);
        }),
        &["cycle"],
    );
    assert_refused(
        &dir,
        "two_parents.gltf",
        &quad_with(|v| {
            v["nodes"] = json!([{"children": [2]}, {"children": [2]}, {"mesh": 0}]);
            v["scenes"][0]["nodes"] = json!([0, 1]);
        }),
        &["nodes[1].children[0]: node 2 is already a child of node 0"],
    );
    assert_refused(
        &dir,
        "not_root.gltf",
        &quad_with(|v| {
            v["nodes"] = json!([{"children": [1]}, {"mesh": 0}]);
            v["scenes"][0]["nodes"] = json!([0, 1]);
        }),
        &["scenes[0].nodes[1]: node 1 is not a root node"],
    );
    // A number too large for a double is refused by the JSON parser, with the file's name.
    let p = dir.join("huge.gltf");
    let text = serde_json::to_string(&quad_gltf())
        .unwrap()
        .replace("\"metallicFactor\":0.0", "\"metallicFactor\":1e999");
    assert!(text.contains("1e999"));
    std::fs::write(&p, text).unwrap();
    refused_file(&p, &["invalid glTF"]);
}

#[test]
fn non_finite_positions_name_the_accessor_path() {
    let dir = temp_dir("nan");
    let mut bin = quad_bin();
    bin[12..16].copy_from_slice(&f32::INFINITY.to_le_bytes());
    let root = quad_with(|v| {
        v["buffers"][0]["uri"] = json!(format!(
            "data:application/octet-stream;base64,{}",
            b64(&bin)
        ))
    });
    assert_refused(
        &dir,
        "inf.gltf",
        &root,
        &["meshes[0].primitives[0].attributes.POSITION (nodes[0] 'floor'): vertex 1 is not finite"],
    );
}

/// POSITION without min / max (the specification requires them, some exporters omit them,
/// three.js and Blender load such files): loaded with a warning, the bounds those of the
/// vertices; non-finite positions without min / max are still refused.
#[test]
fn positions_without_min_max_load_with_a_warning() {
    let dir = temp_dir("no-minmax");
    let strip = |v: &mut Value| {
        let a = v["accessors"][0].as_object_mut().unwrap();
        a.remove("min");
        a.remove("max");
    };
    let reference = load_no_panic(&write_json(&dir, "with.gltf", &quad_gltf())).unwrap();
    for (name, edit) in [
        ("no-min-max.gltf", Box::new(strip) as Edit),
        (
            "no-min.gltf",
            Box::new(|v: &mut Value| {
                v["accessors"][0].as_object_mut().unwrap().remove("min");
            }),
        ),
        (
            "null-max.gltf",
            Box::new(|v: &mut Value| v["accessors"][0]["max"] = Value::Null),
        ),
    ] {
        // A second primitive on the same accessor: one warning for the accessor.
        let root = quad_with(|v| {
            edit(v);
            let p = v["meshes"][0]["primitives"][0].clone();
            v["meshes"][0]["primitives"].as_array_mut().unwrap().push(p);
        });
        let s = load_no_panic(&write_json(&dir, name, &root)).unwrap();
        let warned: Vec<_> = s
            .warnings
            .iter()
            .filter(|w| w.contains("POSITION: accessor 0 has no min and max"))
            .collect();
        assert_eq!(warned.len(), 1, "{name}: {:?}", s.warnings);
        assert!(
            warned[0].contains("meshes[0].primitives[0].attributes"),
            "{}",
            warned[0]
        );
        // One object per primitive, each the quad as read with min / max.
        assert_eq!(s.objects.len(), 2, "{name}");
        for o in &s.objects {
            assert_eq!(o.mesh, reference.objects[0].mesh, "{name}");
        }
        assert_eq!(s.bounds(), reference.bounds(), "{name}");
        assert_eq!(
            s.bounds(),
            Some(Aabb::new(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0)))
        );
    }
    for (k, bad) in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY]
        .into_iter()
        .enumerate()
    {
        let mut bin = quad_bin();
        bin[24..28].copy_from_slice(&bad.to_le_bytes());
        let root = quad_with(|v| {
            strip(v);
            v["buffers"][0]["uri"] = json!(format!(
                "data:application/octet-stream;base64,{}",
                b64(&bin)
            ))
        });
        assert_refused(
            &dir,
            &format!("non-finite-{k}.gltf"),
            &root,
            &["attributes.POSITION (nodes[0] 'floor'): vertex 2 is not finite"],
        );
    }
}

/// World-space normal of each triangle: the inverse transpose of the local cross product.
fn world_normals(o: &Object) -> Vec<Vec3> {
    let it: Mat3 = Mat3::from(o.world_from_object.matrix3)
        .inverse()
        .transpose();
    o.mesh
        .triangles
        .iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| o.mesh.positions[i as usize]);
            (it * (b - a).cross(c - a)).normalize()
        })
        .collect()
}

fn world_points(o: &Object) -> Vec<[Vec3; 3]> {
    o.mesh
        .triangles
        .iter()
        .map(|t| {
            t.map(|i| {
                o.world_from_object
                    .transform_point3(o.mesh.positions[i as usize])
            })
        })
        .collect()
}

#[test]
fn mirrored_node_keeps_its_winding() {
    let dir = temp_dir("mirror");
    let root = quad_with(|v| v["nodes"][0]["scale"] = json!([-1.0, 1.0, 1.0]));
    let p = write_json(&dir, "mirror.gltf", &root);
    let s = load_no_panic(&p).unwrap();
    let o = &s.objects[0];
    // The triangles as written in the file, the transform mirrors.
    assert_eq!(o.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(o.world_from_object.matrix3.determinant() < 0.0);
    // The front still faces +Y in world space (the quad lies in the mirror's plane of
    // symmetry's normal direction, so only x changes sign).
    for n in world_normals(o) {
        assert!(n.abs_diff_eq(Vec3::Y, 1e-6), "world normal {n}");
    }

    // Two mirrors in a hierarchy (as in Khronos NegativeScaleTest: a parent scaled
    // (-1, -1, -1) with a rotation, a child scaled (-1, -1, -1)): they cancel; the winding is
    // still the file's.
    let nested = quad_with(|v| {
        v["nodes"] = json!([
            {"name": "parent", "rotation": [0.0, 0.0, -1.0, 0.0], "scale": [-1.0, -1.0, -1.0],
             "translation": [1.0, -3.5, 0.0], "children": [1]},
            {"name": "child", "mesh": 0, "rotation": [0.0, 0.0, -1.0, 0.0],
             "scale": [-1.0, -1.0, -1.0], "translation": [2.0, 0.0, 0.0]}
        ]);
    });
    let p = write_json(&dir, "nested.gltf", &nested);
    let n = load_no_panic(&p).unwrap();
    let c = &n.objects[0];
    assert_eq!(c.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(c.world_from_object.matrix3.determinant() > 0.0);
    for n in world_normals(c) {
        assert!(n.abs_diff_eq(Vec3::Y, 1e-6), "world normal {n}");
    }

    // Round trip through the writer: same triangles, same transform, same world geometry
    // and front side.
    let out = dir.join("round.gltf");
    write_gltf(&s, &out).unwrap();
    let s2 = load_no_panic(&out).unwrap();
    let o2 = &s2.objects[0];
    assert_eq!(o2.mesh.triangles, o.mesh.triangles);
    assert!(o2.world_from_object.abs_diff_eq(o.world_from_object, 1e-6));
    assert_eq!(world_points(o2), world_points(o));
    assert_eq!(world_normals(o2), world_normals(o));
    let glb = dir.join("round.glb");
    write_gltf(&s, &glb).unwrap();
    let s3 = load_no_panic(&glb).unwrap();
    assert_eq!(world_normals(&s3.objects[0]), world_normals(o));
    assert_eq!(s3.objects[0].mesh.triangles, o.mesh.triangles);

    // A mirrored object built in code, with a rotation too: the same through the writer.
    let mut scene = Scene::default();
    let mut lamp = Material::diffuse(Vec3::splat(0.5));
    lamp.emitted_radiance = Vec3::ONE;
    let mut obj = Object::new("m", quad_mesh(), lamp);
    obj.world_from_object = Affine3A::from_scale_rotation_translation(
        Vec3::new(1.0, -2.0, 1.0),
        glam::Quat::from_rotation_z(0.5),
        Vec3::new(3.0, 1.0, 0.0),
    );
    scene.objects.push(obj.clone());
    let out = dir.join("code.gltf");
    write_gltf(&scene, &out).unwrap();
    let back = load_no_panic(&out).unwrap();
    let b = &back.objects[0];
    assert_eq!(b.mesh.triangles, obj.mesh.triangles);
    for (x, y) in world_normals(b).iter().zip(world_normals(&obj)) {
        assert!(x.abs_diff_eq(y, 1e-5), "{x} vs {y}");
    }
    for (x, y) in world_points(b).iter().zip(world_points(&obj)) {
        for k in 0..3 {
            assert!(x[k].abs_diff_eq(y[k], 1e-5));
        }
    }
}

/// Every number of a valid file replaced by awkward values, and every key removed, one at
/// a time: each load is an `Ok` or an `Err`, never a panic.
#[test]
fn mutations_never_panic() {
    let dir = temp_dir("mutations");
    let base = quad_with(|v| {
        v["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}]);
        v["nodes"] = json!([{"name": "floor", "mesh": 0, "children": [1]},
                            {"camera": 0, "translation": [0.0, 1.0, 3.0]}]);
        v["accessors"][0]["sparse"] = json!({"count": 1,
            "indices": {"bufferView": 1, "componentType": 5123},
            "values": {"bufferView": 0}});
    });
    load_no_panic(&write_json(&dir, "base.gltf", &base)).unwrap();
    fn paths(v: &Value, at: Vec<Value>, out: &mut Vec<Vec<Value>>) {
        match v {
            Value::Object(m) => {
                for (k, c) in m {
                    let mut p = at.clone();
                    p.push(json!(k));
                    out.push(p.clone());
                    paths(c, p, out);
                }
            }
            Value::Array(a) => {
                for (i, c) in a.iter().enumerate() {
                    let mut p = at.clone();
                    p.push(json!(i));
                    out.push(p.clone());
                    paths(c, p, out);
                }
            }
            _ => {}
        }
    }
    fn get<'a>(v: &'a mut Value, path: &[Value]) -> &'a mut Value {
        path.iter().fold(v, |v, k| match k {
            Value::String(s) => &mut v[s.as_str()],
            k => &mut v[k.as_u64().unwrap() as usize],
        })
    }
    let mut all = Vec::new();
    paths(&base, Vec::new(), &mut all);
    let p = dir.join("m.gltf");
    let mut n = 0;
    for path in &all {
        let mut replacements = vec![json!(null), json!("x"), json!([]), json!({})];
        if get(&mut base.clone(), path).is_number() {
            replacements.extend([
                json!(0),
                json!(1),
                json!(3),
                json!(-1),
                json!(4_294_967_296u64),
                json!(0.5),
            ]);
        }
        for r in replacements {
            let mut v = base.clone();
            *get(&mut v, path) = r;
            std::fs::write(&p, serde_json::to_string(&v).unwrap()).unwrap();
            if let Err(e) = load_no_panic(&p) {
                assert!(!e.to_string().contains("gave up"), "{e}");
            }
            n += 1;
        }
        // Removed.
        let mut v = base.clone();
        let (last, parent) = path.split_last().unwrap();
        let parent = get(&mut v, parent);
        match last {
            Value::String(k) => {
                parent.as_object_mut().unwrap().remove(k);
            }
            k => {
                parent
                    .as_array_mut()
                    .unwrap()
                    .remove(k.as_u64().unwrap() as usize);
            }
        }
        std::fs::write(&p, serde_json::to_string(&v).unwrap()).unwrap();
        if let Err(e) = load_no_panic(&p) {
            assert!(!e.to_string().contains("gave up"), "{e}");
        }
        n += 1;
    }
    assert!(n > 300, "{n} mutations");
}

fn khronos(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/khronos")
        .join(name)
}

/// Small Khronos sample models (see tests/data/khronos/README.md).
#[test]
fn khronos_samples() {
    // Box: a node hierarchy with matrices, a byteStride-less shared vertex view.
    let s = load_no_panic(&khronos("Box.gltf")).unwrap();
    assert_eq!(s.objects.len(), 1);
    assert_eq!(s.objects[0].mesh.triangles.len(), 12);
    assert!(s.objects[0]
        .material
        .reflectance
        .abs_diff_eq(Vec3::new(0.8, 0.0, 0.0), 1e-6));
    let Aabb { min: lo, max: hi } = s.bounds().unwrap();
    assert!(lo.abs_diff_eq(Vec3::splat(-0.5), 1e-6) && hi.abs_diff_eq(Vec3::splat(0.5), 1e-6));
    // The same box, Draco-compressed, without its .bin (only the JSON is kept here): the
    // missing file is named (Draco files load: tests/compressed.rs).
    refused_file(&khronos("Box-Draco.gltf"), &["buffers[0].uri", "Box0.bin"]);
    // A sparse accessor moving vertices 8, 10 and 12 up.
    let s = load_no_panic(&khronos("SimpleSparseAccessor.gltf")).unwrap();
    let o = &s.objects[0];
    assert_eq!(o.mesh.triangles.len(), 12);
    assert_eq!(o.mesh.positions[8], Vec3::new(1.0, 2.0, 0.0));
    assert_eq!(o.mesh.positions[10], Vec3::new(3.0, 3.0, 0.0));
    assert_eq!(o.mesh.positions[12], Vec3::new(5.0, 4.0, 0.0));
    assert_eq!(o.mesh.positions[9], Vec3::new(2.0, 1.0, 0.0));
}

/// A texture larger than the decode limit: the factor alone, with a warning (a small file
/// can decode huge); a grey 16-bit texture is averaged like an 8-bit one.
#[test]
fn texture_limits_and_formats() {
    let dir = temp_dir("texture");
    let png = |img: image::DynamicImage| {
        let mut bytes = Vec::new();
        img.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .unwrap();
        format!("data:image/png;base64,{}", b64(&bytes))
    };
    let with_image = |uri: String| {
        quad_with(|v| {
            v["images"] = json!([{"uri": uri}]);
            v["textures"] = json!([{"source": 0}]);
            v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
        })
    };
    let wide = image::DynamicImage::ImageLuma8(image::GrayImage::new(9000, 1));
    let p = write_json(&dir, "wide.gltf", &with_image(png(wide)));
    let s = load_no_panic(&p).unwrap();
    assert_eq!(s.objects[0].material.reflectance, Vec3::splat(0.5));
    assert!(
        s.warnings.iter().any(|w| w.contains("cannot be loaded")),
        "{:?}",
        s.warnings
    );
    // Half white, half black, in 16-bit grey: linear mean 0.5, times the factor 0.5.
    let grey = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(2, 2, |x, _| {
        image::Luma([if x == 0 { 65535 } else { 0 }])
    });
    let grey = png(image::DynamicImage::ImageLuma16(grey));
    let p = write_json(&dir, "grey16.gltf", &with_image(grey.clone()));
    let s = load_no_panic(&p).unwrap();
    assert!(
        s.objects[0]
            .material
            .reflectance
            .abs_diff_eq(Vec3::splat(0.25), 1e-6),
        "{}",
        s.objects[0].material.reflectance
    );
    // The same image as a specular-glossiness material's diffuse texture, times its
    // diffuse factor; the metallic-roughness base colour (white, untextured) is not read.
    let mut spec_gloss = with_image(grey);
    let m = &mut spec_gloss["materials"][0];
    m["pbrMetallicRoughness"] = json!({"baseColorFactor": [0.9, 0.9, 0.9, 1.0]});
    m["extensions"] = json!({"KHR_materials_pbrSpecularGlossiness":
        {"diffuseFactor": [0.5, 0.25, 0.8, 1.0], "diffuseTexture": {"index": 0}}});
    spec_gloss["extensionsUsed"] = json!(["KHR_materials_pbrSpecularGlossiness"]);
    let p = write_json(&dir, "spec-gloss-texture.gltf", &spec_gloss);
    let s = load_no_panic(&p).unwrap();
    let rho = s.objects[0].material.reflectance;
    assert!(rho.abs_diff_eq(Vec3::new(0.25, 0.125, 0.4), 1e-6), "{rho}");
}

/// `EXT_texture_webp` (a texture whose only source is the extension's WebP image) decodes;
/// a `KHR_texture_basisu` image that is not a readable KTX2 file (a header alone) falls back
/// to the factor with a warning naming the texture, as does a texture without any source
/// (readable KTX2 images: tests/gltf_ktx2.rs).
#[test]
fn webp_and_ktx2_textures() {
    let dir = temp_dir("webp");
    let red =
        image::DynamicImage::ImageRgb8(image::RgbImage::from_pixel(2, 2, image::Rgb([255, 0, 0])));
    let mut webp = Vec::new();
    red.write_to(
        &mut std::io::Cursor::new(&mut webp),
        image::ImageFormat::WebP,
    )
    .unwrap();
    let with_texture = |uri: String, texture: Value, ext: &str| {
        let ext = ext.to_string();
        quad_with(move |v| {
            v["extensionsUsed"] = json!([ext]);
            v["images"] = json!([{ "uri": uri }]);
            v["textures"] = json!([texture]);
            v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
        })
    };
    let mut root = with_texture(
        format!("data:image/webp;base64,{}", b64(&webp)),
        json!({"extensions": {"EXT_texture_webp": {"source": 0}}}),
        "EXT_texture_webp",
    );
    root["extensionsRequired"] = json!(["EXT_texture_webp"]);
    let s = load_no_panic(&write_json(&dir, "webp.gltf", &root)).unwrap();
    // The quad has no TEXCOORD_0: the texture is averaged into the factor (red).
    let r = s.objects[0].material.reflectance;
    assert!(
        r.x > 0.1 && r.y == 0.0 && r.z == 0.0,
        "{r} {:?}",
        s.warnings
    );
    assert!(
        !s.warnings.iter().any(|w| w.contains("cannot be loaded")),
        "{:?}",
        s.warnings
    );

    let ktx2 = b"\xABKTX 20\xBB\r\n\x1A\n\0\0\0\0";
    let root = with_texture(
        format!("data:image/ktx2;base64,{}", b64(ktx2)),
        json!({"extensions": {"KHR_texture_basisu": {"source": 0}}}),
        "KHR_texture_basisu",
    );
    let s = load_no_panic(&write_json(&dir, "ktx2.gltf", &root)).unwrap();
    assert!(s.objects[0].material.base_color_texture.is_none());
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("base colour image 0") && w.contains("KTX2 / Basis Universal")),
        "{:?}",
        s.warnings
    );
    // No source at all (allowed when an extension shrad ignores provides the image).
    let root = with_texture(
        "unused.png".into(),
        json!({"extensions": {"EXT_made_up_images": {"source": 0}}}),
        "EXT_made_up_images",
    );
    let s = load_no_panic(&write_json(&dir, "nosource.gltf", &root)).unwrap();
    assert!(s.objects[0].material.base_color_texture.is_none());
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("texture 0 has no image shrad can read")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn a_file_without_scenes_is_a_library_of_meshes() {
    let dir = temp_dir("library");
    // glTF 2.0, "Scenes": without scenes, a library of meshes. No nodes at all: the mesh is
    // placed once at the origin, named after it, with a warning.
    let p = write_json(
        &dir,
        "no-nodes.gltf",
        &quad_with(|v| {
            let o = v.as_object_mut().unwrap();
            for k in ["scene", "scenes", "nodes"] {
                o.remove(k);
            }
        }),
    );
    let s = load_no_panic(&p).unwrap();
    assert_eq!(s.objects.len(), 1);
    assert_eq!(s.objects[0].name, "quad");
    assert_eq!(s.objects[0].world_from_object, glam::Affine3A::IDENTITY);
    assert_eq!(s.objects[0].mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(
        s.warnings.iter().any(
            |w| w.contains("meshes[0] 'quad' that no node instances placed once at the origin")
        ),
        "{:?}",
        s.warnings
    );
    // Nodes but no scene: the root nodes are drawn as they are, and a mesh no node instances
    // once at the origin.
    let p = write_json(
        &dir,
        "root-node-and-free-mesh.gltf",
        &quad_with(|v| {
            let o = v.as_object_mut().unwrap();
            o.remove("scene");
            o.remove("scenes");
            let quad = v["meshes"][0].clone();
            v["meshes"].as_array_mut().unwrap().push(quad);
            v["meshes"][1]["name"] = json!("spare");
            v["nodes"][0]["translation"] = json!([0.0, 2.0, 0.0]);
        }),
    );
    let s = load_no_panic(&p).unwrap();
    let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["floor", "spare"]);
    assert_eq!(
        s.objects[0].world_from_object.translation,
        glam::Vec3A::new(0.0, 2.0, 0.0)
    );
    assert_eq!(s.objects[1].world_from_object, glam::Affine3A::IDENTITY);
    // A scene that draws no mesh draws nothing: the file's scene says what is in it. It
    // loads empty, as a viewer opens it, saying so.
    assert_loads_empty(
        &dir,
        "scene-without-mesh.gltf",
        &quad_with(|v| {
            v["nodes"][0].as_object_mut().unwrap().remove("mesh");
        }),
        &["nothing to light: no node of the scene instances a triangle mesh (the file has 1 mesh(es)); the scene is empty"],
    );
    // Points only: nothing to light, said so.
    assert_loads_empty(
        &dir,
        "points.gltf",
        &quad_with(|v| v["meshes"][0]["primitives"][0]["mode"] = json!(0)),
        &["nothing to light: the scene draws no triangle with area (skipped: 1 primitive(s) of points or lines)"],
    );
}

#[test]
fn accessor_types_gltf_2_0_does_not_define() {
    let dir = temp_dir("accessor-type");
    // The schema allows any string as accessor.type (for later versions) and the validator
    // only warns: an accessor nothing reads may have one.
    let unknown = json!({"componentType": 5126, "count": 3, "type": "NotaVEC3",
                         "bufferView": 0});
    let p = write_json(
        &dir,
        "unused.gltf",
        &quad_with(|v| v["accessors"].as_array_mut().unwrap().push(unknown.clone())),
    );
    let s = load_no_panic(&p).unwrap();
    assert_eq!(s.objects[0].mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("accessors[2].type: 'NotaVEC3' is not a glTF 2.0 accessor type")),
        "{:?}",
        s.warnings
    );
    // Read by a mesh, or an animation: refused, naming the reference.
    assert_refused(
        &dir,
        "used.gltf",
        &quad_with(|v| {
            v["accessors"].as_array_mut().unwrap().push(unknown.clone());
            v["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = json!(2);
        }),
        &["meshes[0].primitives[0].attributes.NORMAL: accessor 2 has type 'NotaVEC3', which glTF 2.0 does not define"],
    );
    assert_refused(
        &dir,
        "animated.gltf",
        &quad_with(|v| {
            v["accessors"].as_array_mut().unwrap().push(unknown.clone());
            v["animations"] = json!([{"samplers": [{"input": 2, "output": 0}],
                "channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}]}]);
        }),
        &["animations[0].samplers[0].input: accessor 2 has type 'NotaVEC3'"],
    );
    // glTF 2.1 that a 2.0 reader may read (minVersion 2.0): loads, with a warning.
    let p = write_json(
        &dir,
        "v21-min20.gltf",
        &quad_with(|v| v["asset"] = json!({"version": "2.1", "minVersion": "2.0"})),
    );
    let s = load_no_panic(&p).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("glTF 2.1 read as glTF 2.0")),
        "{:?}",
        s.warnings
    );
}

/// gltfpack (meshoptimizer) moves each mesh of a named node to an unnamed child (which holds
/// the dequantizing transform): an unnamed mesh node with a named parent takes the parent's
/// name, and the roles of the parent's extras when it has none of its own. A named child
/// keeps its name; an unnamed one without a named parent is named by its mesh.
#[test]
fn an_unnamed_mesh_node_takes_its_named_parents_name_and_roles() {
    use shrad_scene::Role;
    let dir = temp_dir("parent-name");
    let p = write_json(
        &dir,
        "packed.gltf",
        &quad_with(|v| {
            v["scenes"][0]["nodes"] = json!([0, 2, 4, 6]);
            v["nodes"] = json!([
                {"name": "panel", "children": [1],
                 "extras": {"shrad_role": "interior", "shrad_patch_size": 0.25}},
                {"mesh": 0, "scale": [2.0, 2.0, 2.0]},
                {"name": "group", "children": [3], "extras": {"shrad_role": "boundary"}},
                {"name": "lamp", "mesh": 0},
                {"name": "shelf", "children": [5], "extras": {"shrad_role": "boundary"}},
                {"mesh": 0, "extras": {"shrad_role": "interior"}},
                {"children": [7]},
                {"mesh": 0}
            ]);
        }),
    );
    let s = load_no_panic(&p).unwrap();
    let got: Vec<(&str, Option<Role>, Option<f32>)> = s
        .objects
        .iter()
        .map(|o| (o.name.as_str(), o.role, o.patch_size))
        .collect();
    // The quad is emissive: a role not given is inferred as a light.
    assert_eq!(
        got,
        [
            ("panel", Some(Role::Interior), Some(0.25)),
            ("lamp", Some(Role::Light), None),
            ("shelf", Some(Role::Interior), None),
            ("quad", Some(Role::Light), None),
        ]
    );
}

/// A node scaled to zero (how glTF and Blender's exporter hide one) is left out with a
/// warning, its children with it, not the whole file refused; a node at a micrometre's
/// scale is not singular (the check is relative to the transform's own scale).
#[test]
fn nodes_scaled_to_zero_are_left_out_and_tiny_ones_kept() {
    let dir = temp_dir("zero-scale");
    let root = quad_with(|v| {
        v["nodes"] = json!([
            {"name": "floor", "mesh": 0},
            {"name": "hidden", "mesh": 0, "scale": [0.0, 1.0, 1.0], "children": [3]},
            {"name": "tiny", "mesh": 0, "scale": [1e-5, 1e-5, 1e-5]},
            {"name": "child", "mesh": 0, "translation": [0.0, 1.0, 0.0]}
        ]);
        v["scenes"][0]["nodes"] = json!([0, 1, 2]);
    });
    let p = write_json(&dir, "hidden.gltf", &root);
    let s = load_no_panic(&p).unwrap_or_else(|e| panic!("refused: {e}"));
    let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(s.objects.len(), 2, "{names:?}");
    assert!(names.iter().any(|n| n.contains("floor")), "{names:?}");
    assert!(names.iter().any(|n| n.contains("tiny")), "{names:?}");
    for hidden in ["nodes[1] 'hidden'", "nodes[3] 'child'"] {
        assert!(
            s.warnings
                .iter()
                .any(|w| w.contains(hidden) && w.contains("scale is zero")),
            "no warning for {hidden}: {:?}",
            s.warnings
        );
    }
}

/// A node scaled so far that areas overflow 32-bit floats is refused with an error that
/// says so (it was "patch size inf must be a positive number", from the engine), and so is
/// one scaled so small that they vanish (it loaded as patches of no area).
#[test]
fn coordinates_too_large_for_f32_are_refused_saying_so() {
    let dir = temp_dir("huge-scale");
    for (name, scale) in [("huge.gltf", 1e30), ("large.gltf", 1e19)] {
        let root = quad_with(|v| v["nodes"][0]["scale"] = json!([scale, scale, scale]));
        assert_refused(
            &dir,
            name,
            &root,
            &["world coordinates reach", "scale the scene down"],
        );
    }
    // Nor so wide that a triangle's area overflows, though its coordinates are in range
    // (a room of side 1e10 had infinite areas: "patch size inf").
    let root = quad_with(|v| v["nodes"][0]["scale"] = json!([1e10, 1e10, 1e10]));
    assert_refused(
        &dir,
        "wide.gltf",
        &root,
        &[
            "world size is 1.4e10, beyond the 1e9",
            "scale the scene down",
        ],
    );
    // Nor too small: its areas would vanish.
    let root = quad_with(|v| v["nodes"][0]["scale"] = json!([1e-30, 1e-30, 1e-30]));
    assert_refused(
        &dir,
        "tiny.gltf",
        &root,
        &["world size is", "scale the scene up"],
    );
    // A corner that far in the buffer itself is refused the same way (its triangles were
    // dropped as of zero area, beside the mesh's size, and the scene loaded empty).
    for (name, far) in [("far13.gltf", 1e13f32), ("far37.gltf", 1e37)] {
        let root = quad_with(|v| {
            let mut bin = quad_bin();
            bin[36..40].copy_from_slice(&far.to_le_bytes());
            v["accessors"][0]["max"] = json!([far, 0.0, 1.0]);
            v["buffers"][0]["uri"] = json!(format!(
                "data:application/octet-stream;base64,{}",
                b64(&bin)
            ));
        });
        assert_refused(&dir, name, &root, &["world coordinates reach"]);
    }
    // A kilometre-wide scene in millimetres is fine.
    let root = quad_with(|v| v["nodes"][0]["scale"] = json!([1e6, 1e6, 1e6]));
    let p = write_json(&dir, "mm.gltf", &root);
    assert_eq!(load_no_panic(&p).unwrap().objects.len(), 1);
}
