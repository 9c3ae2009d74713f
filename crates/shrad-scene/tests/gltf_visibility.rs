//! `KHR_node_visibility`: a node whose `visible` is false is not drawn, nor is anything below
//! it, whatever their own `visible`; its meshes and punctual lights are left out, its camera
//! is not (the extension's specification). Before, hidden nodes were drawn (the extension was
//! ignored with a warning) and a file that required it was refused.

use serde_json::{json, Value};

use crate::common::gltf_bin::Bin;
use crate::common::{err_of, gltf_json_file, load_gltf_json};

const SUITE: &str = "visibility";

/// Nodes: "Hidden" (visible false) with a child "Shown below" (visible true); "Shown"; and
/// "Hidden lamp" (visible false) holding a point light and the camera. Each named node but
/// the lamp draws the same quad.
fn file() -> Value {
    let mut b = Bin::default();
    let (pos, idx) = b.unit_square();
    let hidden = json!({"KHR_node_visibility": {"visible": false}});
    b.finish(json!({
        "extensionsUsed": ["KHR_node_visibility", "KHR_lights_punctual"],
        "extensionsRequired": ["KHR_node_visibility"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 10.0}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 2, 3]}],
        "nodes": [
            {"name": "Hidden", "mesh": 0, "children": [1], "extensions": hidden},
            {"name": "Shown below", "mesh": 0, "translation": [0.0, 2.0, 0.0],
             "extensions": {"KHR_node_visibility": {"visible": true}}},
            {"name": "Shown", "mesh": 0, "translation": [3.0, 0.0, 0.0]},
            {"name": "Hidden lamp", "translation": [0.0, 0.0, 5.0], "camera": 0,
             "extensions": {"KHR_node_visibility": {"visible": false},
                            "KHR_lights_punctual": {"light": 0}}}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}]
    }))
}

#[test]
fn hidden_nodes_and_their_descendants_are_left_out_but_not_their_camera() {
    let s = load_gltf_json(SUITE, "hidden", &file());
    let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(names, ["Shown"]);
    assert!(
        s.lights.is_empty(),
        "the hidden node's light: {:?}",
        s.lights
    );
    assert!(
        s.camera.is_some(),
        "a hidden node's camera is still the camera"
    );
    let said = |who: &str| {
        s.warnings
            .iter()
            .any(|w| w.contains(who) && w.contains("hidden"))
    };
    assert!(
        said("'Hidden'") && said("'Hidden lamp'"),
        "{:?}",
        s.warnings
    );
    // One warning for a hidden subtree, not one for each node in it.
    assert!(!said("'Shown below'"), "{:?}", s.warnings);
}

#[test]
fn a_visible_that_is_not_a_boolean_is_refused_naming_the_node() {
    let mut v = file();
    v["nodes"][2]["extensions"] = json!({"KHR_node_visibility": {"visible": "no"}});
    let p = gltf_json_file(SUITE, "not-bool", &v);
    let e = err_of(shrad_scene::load(&p, &shrad_scene::LoadOptions::default()));
    assert!(
        e.contains("nodes[2].extensions.KHR_node_visibility.visible"),
        "{e}"
    );
}
