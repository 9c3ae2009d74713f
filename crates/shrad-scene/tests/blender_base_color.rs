//! A material whose Base Color is keyed in Blender, exported by Blender's own glTF exporter
//! with "Animation Pointer" (`tests/data/blender/keyed_base_color.py`: `/materials/0/
//! pbrMetallicRoughness/baseColorFactor` through `KHR_animation_pointer`), against what
//! Blender has at five frames (`keyed_base_color.json`): shrad's reflectance of the cube at
//! each frame's time must be Blender's Base Color then. With /tmp/bpyenv (Blender as the bpy
//! module) the fixture is rebuilt by Blender first and checked too.
//!
//! Before shrad read this pointer the channel was ignored with a warning, and the cube kept
//! its first frame's red.

use std::path::Path;

use glam::Vec3;
use serde_json::Value;
use shrad_scene::{load, LoadOptions};

use crate::common::blender::{check_fresh_export, data};

fn check(glb: &Path, json: &Path) {
    let scene = load(glb, &LoadOptions::default()).unwrap();
    assert!(
        !scene.warnings.iter().any(|w| w.contains("baseColorFactor")),
        "{:?}",
        scene.warnings
    );
    let blender: Value = serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let paint = scene.objects.iter().find(|o| o.name == "Paint").unwrap();
    let frames = blender["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 5);
    for f in frames {
        let t = f["time"].as_f64().unwrap() as f32;
        let c = &f["base_color"];
        let rgb = |k: usize| c[k].as_f64().unwrap() as f32;
        let blenders = Vec3::new(rgb(0), rgb(1), rgb(2));
        let ours = paint.material_at(t).reflectance;
        assert!(
            (ours - blenders).abs().max_element() < 1e-4,
            "at {t} s (frame {}): {ours} against Blender's {blenders}",
            f["frame"]
        );
    }
    // Red at the first frame, blue at the last.
    let (first, last) = (paint.material_at(0.0), paint.material_at(2.0));
    assert!(first.reflectance.x > 0.7 && last.reflectance.z > 0.7);
}

#[test]
fn shrads_reflectance_follows_blenders_keyed_base_color() {
    check(
        &data().join("keyed_base_color.glb"),
        &data().join("keyed_base_color.json"),
    );
}

#[test]
fn fresh_blender_keyed_base_color_export_when_blender_is_installed() {
    check_fresh_export("keyed_base_color", check);
}
