//! Lamps and an emissive material keyed in Blender, exported by Blender's own glTF exporter
//! with "Animation Pointer" (`tests/data/blender/animated_lights.py`: a point lamp's power
//! and colour, a spot's size and blend, a material's emission strength, through
//! `KHR_animation_pointer`), against what Blender has at five frames
//! (`animated_lights.json`): shrad's light at each frame's time must shine as Blender's lamp
//! then does (power P W as P / (4 pi) W/sr, Blender's standard lighting mode), its cone be
//! Blender's (outer half the spot size, inner the outer less the blend's share), and the
//! cube emit Blender's colour times strength, and the camera have the field of view Blender's
//! still export of that frame writes (its focal length is keyed). With /tmp/bpyenv (Blender as the bpy module)
//! the fixture is rebuilt by Blender first and checked too.
//!
//! Before shrad read the extension every one of these channels was ignored: the lamps and
//! the glow stayed as they were at rest.

use std::f32::consts::PI;
use std::path::Path;

use glam::Vec3;
use serde_json::Value;
use shrad_scene::{load, LightKind, LoadOptions};

use crate::common::blender::{check_fresh_export, data};

fn vec3(v: &Value) -> Vec3 {
    Vec3::new(
        v[0].as_f64().unwrap() as f32,
        v[1].as_f64().unwrap() as f32,
        v[2].as_f64().unwrap() as f32,
    )
}

fn close(a: Vec3, b: Vec3, what: &str) {
    let off = (a - b).abs().max_element();
    assert!(
        off <= 1e-4 * b.abs().max_element().max(1.0),
        "{what}: {a} against Blender's {b}"
    );
}

fn check(glb: &Path, json: &Path) {
    let scene = load(glb, &LoadOptions::default()).unwrap();
    let blender: Value = serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap();
    let light = |name: &str| scene.lights.iter().find(|l| l.name == name).unwrap();
    let glow = scene.objects.iter().find(|o| o.name == "Glow").unwrap();
    let frames = blender["frames"].as_array().unwrap();
    assert_eq!(frames.len(), 5);
    for f in frames {
        let t = f["time"].as_f64().unwrap() as f32;
        let at = |what: &str| format!("{what} at {t} s (frame {})", f["frame"]);
        for name in ["bulb", "spot"] {
            let lamp = &f["lamps"][name];
            let watts = lamp["energy"].as_f64().unwrap() as f32;
            let shines = vec3(&lamp["color"]) * (watts / (4.0 * PI));
            let now = light(name).at(t);
            close(now.radiometric(), shines, &at(name));
            if let LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } = now.kind
            {
                let outer = lamp["spot_size"].as_f64().unwrap() as f32 / 2.0;
                let inner = outer - outer * lamp["spot_blend"].as_f64().unwrap() as f32;
                let cone = Vec3::new(inner_cone_angle, outer_cone_angle, 0.0);
                close(cone, Vec3::new(inner, outer, 0.0), &at("spot cone"));
            }
        }
        let strength = f["emission_strength"].as_f64().unwrap() as f32;
        let emits = vec3(&f["emission_color"]) * strength;
        close(glow.material_at(t).emitted_radiance, emits, &at("glow"));
        let yfov = scene.camera_at(t).unwrap().yfov;
        let blenders = f["camera_yfov"].as_f64().unwrap() as f32;
        assert!(
            (yfov - blenders).abs() < 1e-5,
            "{}: {yfov} against {blenders}",
            at("yfov")
        );
    }
    // Every one of them changes over the frames.
    let (first, last) = (frames[0]["time"].as_f64().unwrap() as f32, 2.0);
    for name in ["bulb", "spot"] {
        assert_ne!(light(name).at(first), light(name).at(last), "{name}");
    }
}

#[test]
fn shrads_lamps_and_glow_follow_blenders_keys() {
    check(
        &data().join("animated_lights.glb"),
        &data().join("animated_lights.json"),
    );
}

#[test]
fn fresh_blender_animated_lights_export_when_blender_is_installed() {
    check_fresh_export("animated_lights", check);
}
