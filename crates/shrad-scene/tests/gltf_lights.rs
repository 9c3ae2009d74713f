//! `KHR_lights_punctual` read from glTF: a file that requires the extension loads, each
//! light sits on its node (transform and animation followed, shining along the node's -Z),
//! and bad values are errors naming the file and the JSON path.

use std::f32::consts::FRAC_PI_2;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use serde_json::{json, Value};
use shrad_scene::{load, Light, LightKind, LoadOptions, Scene};

fn temp_dir(name: &str) -> PathBuf {
    crate::common::temp_dir(&format!("shrad-lights-{}-{name}", std::process::id()))
}

/// A floor quad, a point light on node 1 at (0.5, 2, 0.5), a spot on node 2 under an
/// animated parent (node 3, moving along +X over 2 s), a sun on node 4 turned to shine
/// straight down; the extension required.
fn file() -> Value {
    let mut bin: Vec<u8> = Vec::new();
    let mut put = |xs: &[f32]| xs.iter().for_each(|x| bin.extend(x.to_le_bytes()));
    put(&[0., 0., 0., 0., 0., 1., 1., 0., 1., 1., 0., 0.]); // 0..48 quad
    put(&[0.0, 2.0]); // 48..56 times
    put(&[0., 0., 0., 2., 0., 0.]); // 56..80 translations
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes()); // 80..92
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::encode(&bin)
    );
    let down = Quat::from_rotation_x(-FRAC_PI_2).to_array();
    json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensionsRequired": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "bulb", "type": "point", "intensity": 683.0, "color": [1.0, 0.5, 0.25], "range": 10.0},
            {"name": "spot", "type": "spot", "intensity": 100.0,
             "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
            {"name": "sun", "type": "directional", "intensity": 1366.0}
        ]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 3, 4]}],
        "nodes": [
            {"name": "floor", "mesh": 0},
            {"name": "bulb", "translation": [0.5, 2.0, 0.5],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "spot", "translation": [0.0, 3.0, 0.0], "rotation": down,
             "extensions": {"KHR_lights_punctual": {"light": 1}}},
            {"name": "rig", "children": [2]},
            {"name": "sun", "rotation": down, "scale": [2.0, 2.0, 2.0],
             "extensions": {"KHR_lights_punctual": {"light": 2}}}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 3}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 1, "componentType": 5126, "count": 2, "type": "SCALAR",
             "min": [0.0], "max": [2.0]},
            {"bufferView": 2, "componentType": 5126, "count": 2, "type": "VEC3"},
            {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 8},
            {"buffer": 0, "byteOffset": 56, "byteLength": 24},
            {"buffer": 0, "byteOffset": 80, "byteLength": 12}
        ],
        "buffers": [{"byteLength": bin.len(), "uri": uri}],
        "animations": [{
            "samplers": [{"input": 1, "output": 2, "interpolation": "LINEAR"}],
            "channels": [{"sampler": 0, "target": {"node": 3, "path": "translation"}}]
        }]
    })
}

fn write(dir: &Path, name: &str, v: &Value) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string(v).unwrap()).unwrap();
    p
}

fn load_ok(dir: &Path, name: &str, v: &Value) -> Scene {
    let p = write(dir, name, v);
    load(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn close(a: Vec3, b: Vec3, what: &str) {
    assert!((a - b).length() < 1e-5, "{what}: {a} != {b}");
}

#[test]
fn a_file_that_requires_punctual_lights_loads_them_on_their_nodes() {
    let dir = temp_dir("load");
    let s = load_ok(&dir, "lights.gltf", &file());
    assert!(
        !s.warnings.iter().any(|w| w.contains("punctual")),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.lights.len(), 3);
    let (bulb, spot, sun) = (&s.lights[0], &s.lights[1], &s.lights[2]);
    assert_eq!(bulb.kind, LightKind::Point);
    assert_eq!(bulb.range, Some(10.0));
    // 683 cd of colour (1, 0.5, 0.25): 1 W/sr in red.
    close(bulb.radiometric(), Vec3::new(1.0, 0.5, 0.25), "bulb W/sr");
    close(
        Light::position(&bulb.world_from_light),
        Vec3::new(0.5, 2.0, 0.5),
        "bulb position",
    );
    assert!(
        matches!(spot.kind, LightKind::Spot { inner_cone_angle, outer_cone_angle }
        if inner_cone_angle == 0.3 && outer_cone_angle == 0.6)
    );
    // The sun's node turns -Z to -Y; its scale changes nothing.
    close(
        Light::direction(&sun.world_from_light).unwrap(),
        -Vec3::Y,
        "sun direction",
    );
    close(sun.radiometric(), Vec3::splat(2.0), "sun W/m^2");
    // The spot follows its animated parent: (0, 3, 0) + t (1, 0, 0), pointing down.
    assert!(spot.is_animated() && !bulb.is_animated());
    assert_eq!(s.duration(), 2.0);
    for t in [0.0, 1.0, 2.0, 5.0] {
        let m = spot.world_from_light_at(t);
        let x = t.min(2.0);
        close(
            Light::position(&m),
            Vec3::new(x, 3.0, 0.0),
            &format!("spot at {t}"),
        );
        close(
            Light::direction(&m).unwrap(),
            -Vec3::Y,
            &format!("spot dir at {t}"),
        );
    }
}

#[test]
fn bad_light_values_name_the_file_and_json_path() {
    let dir = temp_dir("bad");
    type Edit = fn(&mut Value);
    let cases: [(&str, Edit, &str); 4] = [
        (
            "negative.gltf",
            |v| v["extensions"]["KHR_lights_punctual"]["lights"][0]["intensity"] = json!(-5.0),
            "extensions.KHR_lights_punctual.lights[0].intensity",
        ),
        (
            "cone-order.gltf",
            |v| {
                v["extensions"]["KHR_lights_punctual"]["lights"][1]["spot"]["innerConeAngle"] =
                    json!(0.7)
            },
            "extensions.KHR_lights_punctual.lights[1].spot.innerConeAngle",
        ),
        (
            "wide-cone.gltf",
            |v| {
                v["extensions"]["KHR_lights_punctual"]["lights"][1]["spot"]["outerConeAngle"] =
                    json!(1.8)
            },
            "extensions.KHR_lights_punctual.lights[1].spot.outerConeAngle",
        ),
        (
            "index.gltf",
            |v| v["nodes"][4]["extensions"]["KHR_lights_punctual"]["light"] = json!(7),
            "nodes[4].extensions.KHR_lights_punctual.light",
        ),
    ];
    for (name, edit, path) in cases {
        let mut v = file();
        edit(&mut v);
        let p = write(&dir, name, &v);
        let e = load(&p, &LoadOptions::default()).unwrap_err().to_string();
        assert!(e.contains(name) && e.contains(path), "{name}: {e}");
    }
    // Equal cones, as Blender's exporter writes a spot of blend 0: refused, with a hint,
    // unless Blender wrote the file (then a hard edge: `ConeFalloff::Blender`).
    let mut v = file();
    v["extensions"]["KHR_lights_punctual"]["lights"][1]["spot"]["innerConeAngle"] = json!(0.6);
    let p = write(&dir, "equal-cones.gltf", &v);
    let e = load(&p, &LoadOptions::default()).unwrap_err().to_string();
    assert!(
        e.contains("lights[1].spot.innerConeAngle") && e.contains("names Blender"),
        "{e}"
    );
    v["asset"]["generator"] = json!("Khronos glTF Blender I/O v5.0.21");
    let p = write(&dir, "equal-cones-blender.gltf", &v);
    let s = load(&p, &LoadOptions::default()).unwrap();
    let spot = s.lights.iter().find(|l| l.kind.name() == "spot").unwrap();
    assert_eq!(spot.cone_falloff, shrad_scene::ConeFalloff::Blender);
}
