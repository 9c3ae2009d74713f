//! A glTF camera on an animated node, or under one, follows the node: `Scene::camera_at(t)`
//! is the camera node's world transform at `t` (scale dropped); a camera nothing animates
//! stays where it is at every time.

use std::f32::consts::FRAC_PI_4;
use std::path::{Path, PathBuf};

use glam::{Quat, Vec3};
use serde_json::{json, Value};
use shrad_scene::{load, LoadOptions, Scene};

fn temp_dir(name: &str) -> PathBuf {
    crate::common::temp_dir(&format!("shrad-cam-anim-{}-{name}", std::process::id()))
}

const TIMES: [f32; 3] = [0.0, 1.0, 2.0];
const MOVES: [[f32; 3]; 3] = [[1.0, 0.0, 0.0], [3.0, 0.0, 0.0], [3.0, 0.0, 0.0]];

/// Rotation keys: none, none, a quarter turn about +Y.
fn turns() -> [Quat; 3] {
    [
        Quat::IDENTITY,
        Quat::IDENTITY,
        Quat::from_rotation_y(std::f32::consts::FRAC_PI_2),
    ]
}

/// The camera's offset in its (animated) parent's frame.
const OFFSET: Vec3 = Vec3::new(0.0, 1.0, 5.0);

/// A floor quad (static), a "rig" node at the origin with the camera node as its child at
/// `OFFSET`, and one animation whose translation and rotation channels target node
/// `animated` (`None`: no animation in the file).
fn file(animated: Option<usize>) -> Value {
    let mut bin: Vec<u8> = Vec::new();
    let mut put = |xs: &[f32]| xs.iter().for_each(|x| bin.extend(x.to_le_bytes()));
    put(&[0., 0., 0., 0., 0., 1., 1., 0., 1., 1., 0., 0.]); // 0..48 quad
    put(&TIMES); // 48..60
    put(&MOVES.concat()); // 60..96
    put(&turns()
        .iter()
        .flat_map(|q| q.to_array())
        .collect::<Vec<_>>()); // 96..144
    for i in [0u16, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes()); // 144..156
    }
    let uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::encode(&bin)
    );
    let mut v = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"name": "floor", "mesh": 0},
            {"name": "rig", "children": [2]},
            {"name": "cam", "camera": 0, "translation": OFFSET.to_array()}
        ],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 4}]}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 0.0, 1.0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "SCALAR",
             "min": [0.0], "max": [2.0]},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 3, "componentType": 5126, "count": 3, "type": "VEC4"},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 12},
            {"buffer": 0, "byteOffset": 60, "byteLength": 36},
            {"buffer": 0, "byteOffset": 96, "byteLength": 48},
            {"buffer": 0, "byteOffset": 144, "byteLength": 12}
        ],
        "buffers": [{"byteLength": bin.len(), "uri": uri}]
    });
    if let Some(node) = animated {
        v["animations"] = json!([{
            "name": "move",
            "samplers": [
                {"input": 1, "output": 2, "interpolation": "LINEAR"},
                {"input": 1, "output": 3, "interpolation": "LINEAR"}
            ],
            "channels": [
                {"sampler": 0, "target": {"node": node, "path": "translation"}},
                {"sampler": 1, "target": {"node": node, "path": "rotation"}}
            ]
        }]);
    }
    v
}

fn load_file(dir: &Path, name: &str, v: &Value) -> Scene {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string(v).unwrap()).unwrap();
    load(&p, &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// The channels' values at `t`, interpolated here independently of the reader.
fn channels_at(t: f32) -> (Vec3, Quat) {
    let t = t.clamp(0.0, 2.0);
    let i = if t < 1.0 { 0 } else { 1 };
    let s = t - i as f32;
    let tr = Vec3::from(MOVES[i]).lerp(Vec3::from(MOVES[i + 1]), s);
    (tr, turns()[i].slerp(turns()[i + 1], s))
}

fn assert_close(a: Vec3, b: Vec3, what: &str) {
    assert!((a - b).length() < 1e-4, "{what}: {a} != {b}");
}

#[test]
fn a_camera_under_an_animated_parent_follows_it() {
    let dir = temp_dir("parent");
    let s = load_file(&dir, "parent.gltf", &file(Some(1)));
    assert!(s.camera_animation.is_some());
    // Only the camera moves: the scene still has a duration.
    assert!(!s.objects.iter().any(|o| o.is_animated()));
    assert_eq!(s.duration(), 2.0);
    for t in [0.0, 0.5, 1.0, 1.5, 2.0, 3.0, -1.0] {
        let (tr, rot) = channels_at(t);
        let cam = s.camera_at(t).unwrap();
        let m = cam.world_from_camera;
        assert_close(
            m.translation.into(),
            tr + rot * OFFSET,
            &format!("eye at {t}"),
        );
        assert_close(
            m.transform_vector3(-Vec3::Z),
            rot * -Vec3::Z,
            &format!("view direction at {t}"),
        );
        assert_close(
            m.transform_vector3(Vec3::Y),
            rot * Vec3::Y,
            &format!("up at {t}"),
        );
        assert_eq!(cam.yfov, 0.8);
        assert_eq!(s.camera_or_default_at(t), cam);
    }
    // At 1.5 s: 3 along +X, an eighth turn about +Y.
    let eye: Vec3 = s
        .camera_at(1.5)
        .unwrap()
        .world_from_camera
        .translation
        .into();
    assert_close(
        eye,
        Vec3::new(3.0 + 5.0 * FRAC_PI_4.sin(), 1.0, 5.0 * FRAC_PI_4.cos()),
        "eye at 1.5",
    );
    // The rest camera is the pose at time 0, as for animated objects.
    assert_eq!(s.camera, s.camera_at(0.0));
}

#[test]
fn an_animated_camera_node_follows_its_channels() {
    let dir = temp_dir("own");
    let s = load_file(&dir, "own.gltf", &file(Some(2)));
    assert!(s.camera_animation.is_some());
    for t in [0.0, 0.25, 1.0, 1.75, 2.0] {
        let (tr, rot) = channels_at(t);
        let m = s.camera_at(t).unwrap().world_from_camera;
        // The channels replace the node's own translation.
        assert_close(m.translation.into(), tr, &format!("eye at {t}"));
        assert_close(
            m.transform_vector3(-Vec3::Z),
            rot * -Vec3::Z,
            &format!("view at {t}"),
        );
    }
}

#[test]
fn a_camera_nothing_animates_stays_put() {
    let dir = temp_dir("still");
    // No animation at all, and an animation of the floor only.
    let mut floor = file(Some(1));
    for c in floor["animations"][0]["channels"].as_array_mut().unwrap() {
        c["target"]["node"] = json!(0);
    }
    for (name, v) in [("none.gltf", file(None)), ("floor.gltf", floor)] {
        let s = load_file(&dir, name, &v);
        assert!(s.camera_animation.is_none(), "{name}");
        let cam = s.camera.unwrap();
        assert_close(cam.world_from_camera.translation.into(), OFFSET, name);
        for t in [0.0, 0.7, 2.0, 9.0] {
            assert_eq!(s.camera_at(t), Some(cam), "{name} at {t}");
        }
    }
    // A scene without a camera: the default one, at every time.
    let mut v = file(Some(1));
    v["nodes"][2].as_object_mut().unwrap().remove("camera");
    v.as_object_mut().unwrap().remove("cameras");
    let s = load_file(&dir, "nocam.gltf", &v);
    assert_eq!(s.camera_at(1.0), None);
    assert_eq!(s.camera_or_default_at(1.0), s.camera_or_default());
}
