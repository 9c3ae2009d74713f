//! A camera Blender animates (`tests/data/blender/animated_camera.py`: a camera parented to a
//! sliding, turning empty, with a rise of its own), exported by Blender's glTF exporter
//! (`animated_camera.glb`, sampled every frame) with Blender's camera pose at a few frames
//! (`animated_camera.json`, in glTF's +Y-up axes): `Scene::camera_at(t)` must put the camera
//! where Blender has it, looking the same way. With /tmp/bpyenv (Blender as the bpy module)
//! the fixture is rebuilt by Blender first and checked too.

use std::path::Path;

use glam::Vec3;
use serde_json::Value;
use shrad_scene::{load, LoadOptions};

use crate::common::blender::{check_fresh_export, data, matrix};

/// Largest (eye distance, angle between view directions, angle between up vectors in
/// radians) over the recorded frames; frames between the exporter's per-frame samples
/// (12.5, 30.25) included.
fn worst(glb: &Path, json: &Path) -> (f32, f32, f32) {
    let scene = load(glb, &LoadOptions::default()).unwrap();
    assert!(
        scene.camera_animation.is_some(),
        "{}: camera does not move",
        glb.display()
    );
    let v: Value = serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let mut out = (0f32, 0f32, 0f32);
    for p in v["camera"].as_array().unwrap() {
        let blender = matrix(p);
        let t = p["time"].as_f64().unwrap() as f32;
        let m = scene.camera_at(t).unwrap().world_from_camera;
        let eye = (Vec3::from(m.translation) - blender.w_axis.truncate()).length();
        let view = m
            .transform_vector3(-Vec3::Z)
            .angle_between(blender.transform_vector3(-Vec3::Z));
        let up = m
            .transform_vector3(Vec3::Y)
            .angle_between(blender.transform_vector3(Vec3::Y));
        out = (out.0.max(eye), out.1.max(view), out.2.max(up));
    }
    out
}

fn check(glb: &Path, json: &Path) {
    let (eye, view, up) = worst(glb, json);
    eprintln!(
        "{}: worst eye error {eye:.2e} m, view {view:.2e} rad, up {up:.2e} rad",
        glb.display()
    );
    // Between samples Blender's Bezier and the exporter's per-frame LINEAR keys differ by
    // millimetres (the dolly moves ~0.1 m a frame); at the samples they agree to rounding.
    assert!(eye < 5e-3, "eye {eye}");
    assert!(view < 2e-3 && up < 2e-3, "view {view}, up {up}");
}

#[test]
fn shrad_puts_the_camera_where_blender_has_it() {
    check(
        &data().join("animated_camera.glb"),
        &data().join("animated_camera.json"),
    );
}

/// The same file rewritten by gltfpack (`animated_camera_gltfpack.glb`: `gltfpack -i
/// animated_camera.glb -o animated_camera_gltfpack.glb -cc`, gltfpack 1.x from npm): its
/// keys in meshopt-compressed views, translations with the EXPONENTIAL filter and rotations
/// (normalized shorts) with the QUATERNION filter. (The dolly's turn has no negative
/// component, so this file would not have shown meshopt-rs's QUATERNION bug: the instancing
/// fixture and `unpack::meshopt`'s unit test do.)
#[test]
fn gltfpacks_compressed_keys_put_the_camera_where_blender_has_it() {
    let (eye, view, up) = worst(
        &data().join("animated_camera_gltfpack.glb"),
        &data().join("animated_camera.json"),
    );
    eprintln!("gltfpack: worst eye error {eye:.2e} m, view {view:.2e} rad, up {up:.2e} rad");
    assert!(eye < 1e-2, "eye {eye}");
    assert!(view < 1e-2 && up < 1e-2, "view {view}, up {up}");
}

#[test]
fn fresh_blender_camera_export_when_blender_is_installed() {
    check_fresh_export("animated_camera", check);
}
