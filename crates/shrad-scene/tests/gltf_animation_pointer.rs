//! `KHR_animation_pointer` channels: a node's transform through a pointer moves it as the
//! core channel does; a punctual light's intensity, colour and cone and a material's
//! emission strength and base colour follow their keys (LINEAR, STEP, CUBICSPLINE; the cone in the
//! extension's spelling and in Blender's); pointers to what shrad does not light are
//! ignored with a warning; a pointer to a light the file does not have, or keys of the wrong
//! type, are refused naming the channel.

use glam::{Affine3A, Vec3};
use serde_json::{json, Value};
use shrad_scene::{load, LightKind, LoadOptions, Scene};

use crate::common::err_of;
use crate::common::gltf_bin::Bin;

const SUITE: &str = "gltf-pointer";

fn pointer(sampler: usize, to: &str) -> Value {
    json!({"sampler": sampler, "target": {"path": "pointer",
        "extensions": {"KHR_animation_pointer": {"pointer": to}}}})
}

/// Nodes 0 "Panel" (an emissive unit square: factor (1, 0.5, 0.25), strength 2), 1 "Lamp"
/// (a spot of 100 cd, cone 0.2 / 0.5), 2 "Mover" (a unit square); and the animation
/// "Pointers" with `channels` over these samplers:
/// 0: LINEAR t 0, 2 of SCALAR 100, 300; 1: STEP t 0, 1 of VEC3 white, red;
/// 2: LINEAR t 0, 2 of VEC3 (0,0,0), (4,0,0); 3: LINEAR t 0, 2 of SCALAR 0.5, 1.0;
/// 4: CUBICSPLINE t 0, 2 of SCALAR 2 -> 6 with zero tangents; 5: LINEAR t 0, 2 of VEC4
/// (0.2, 0.4, 0.8, 1) -> (1, 0, 0.6, 0.5).
fn file(channels: Vec<Value>) -> Value {
    let mut b = Bin::default();
    let (pos, idx) = b.unit_square();
    let t2 = b.floats_of("SCALAR", &[0.0, 2.0]);
    let t01 = b.floats_of("SCALAR", &[0.0, 1.0]);
    let intensity = b.floats_of("SCALAR", &[100.0, 300.0]);
    let color = b.floats_of("VEC3", &[1.0, 1.0, 1.0, 1.0, 0.0, 0.0]);
    let moves = b.floats_of("VEC3", &[0.0, 0.0, 0.0, 4.0, 0.0, 0.0]);
    let cone = b.floats_of("SCALAR", &[0.5, 1.0]);
    let strength = b.floats_of("SCALAR", &[0.0, 2.0, 0.0, 0.0, 6.0, 0.0]);
    let base = b.floats_of("VEC4", &[0.2, 0.4, 0.8, 1.0, 1.0, 0.0, 0.6, 0.5]);
    b.finish(json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "extensionsUsed": ["KHR_lights_punctual", "KHR_animation_pointer",
            "KHR_materials_emissive_strength"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"name": "spot", "type": "spot",
            "intensity": 100.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.5}}]}},
        "nodes": [
            {"name": "Panel", "mesh": 1},
            {"name": "Lamp", "translation": [0.0, 3.0, 0.0],
             "extensions": {"KHR_lights_punctual": {"light": 0}}},
            {"name": "Mover", "mesh": 0, "translation": [0.0, 0.0, 1.0]}
        ],
        "meshes": [
            {"name": "Square", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]},
            {"name": "Glow", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx,
                "material": 0}]}
        ],
        "materials": [{"name": "glow", "emissiveFactor": [1.0, 0.5, 0.25],
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2.0}}}],
        "animations": [{"name": "Pointers", "channels": channels, "samplers": [
            {"input": t2, "output": intensity},
            {"input": t01, "output": color, "interpolation": "STEP"},
            {"input": t2, "output": moves},
            {"input": t2, "output": cone},
            {"input": t2, "output": strength, "interpolation": "CUBICSPLINE"},
            {"input": t2, "output": base}
        ]}]
    }))
}

fn every_channel() -> Vec<Value> {
    let light = "/extensions/KHR_lights_punctual/lights/0";
    vec![
        pointer(0, &format!("{light}/intensity")),
        pointer(1, &format!("{light}/color")),
        pointer(2, "/nodes/2/translation"),
        // Blender's spelling of the cone (the extension's is `spot/outerConeAngle`).
        pointer(3, &format!("{light}/spot.outerConeAngle")),
        pointer(
            4,
            "/materials/0/extensions/KHR_materials_emissive_strength/emissiveStrength",
        ),
        pointer(5, "/materials/0/pbrMetallicRoughness/baseColorFactor"),
    ]
}

fn object<'s>(s: &'s Scene, name: &str) -> &'s shrad_scene::Object {
    s.objects.iter().find(|o| o.name == name).unwrap()
}

#[test]
fn lights_emission_and_nodes_follow_their_pointer_channels() {
    let s = crate::common::load_gltf_json(SUITE, "all", &file(every_channel()));
    assert!(
        !s.warnings.iter().any(|w| w.contains("pointer")),
        "{:?}",
        s.warnings
    );
    let lamp = &s.lights[0];
    assert!(lamp.is_animated());
    assert_eq!(lamp.duration(), 2.0);
    let at = |t: f32| lamp.at(t);
    assert_eq!(at(0.0).intensity, 100.0);
    assert_eq!(at(1.0).intensity, 200.0);
    assert_eq!(at(0.5).color, Vec3::ONE);
    assert_eq!(at(1.5).color, Vec3::X);
    let LightKind::Spot {
        inner_cone_angle,
        outer_cone_angle,
    } = at(1.0).kind
    else {
        panic!("the lamp is a spot");
    };
    assert_eq!(inner_cone_angle, 0.2);
    assert!((outer_cone_angle - 0.75).abs() < 1e-6, "{outer_cone_angle}");

    let panel = object(&s, "Panel");
    assert!(panel.is_animated());
    assert_eq!(panel.duration(), 2.0);
    let glow = |t: f32| panel.material_at(t).emitted_radiance;
    assert_eq!(glow(0.0), Vec3::new(1.0, 0.5, 0.25) * 2.0);
    // A cubic spline with zero tangents is halfway at half time.
    assert!((glow(1.0) - Vec3::new(1.0, 0.5, 0.25) * 4.0).length() < 1e-5);
    assert_eq!(glow(2.0), Vec3::new(1.0, 0.5, 0.25) * 6.0);
    // The base colour's RGB is the reflectance; a key of 1 is read as the largest that
    // conserves energy.
    let rho = |t: f32| panel.material_at(t).reflectance;
    assert!((rho(0.0) - Vec3::new(0.2, 0.4, 0.8)).length() < 1e-6);
    assert!(
        (rho(1.0) - Vec3::new(0.6, 0.2, 0.7)).length() < 1e-6,
        "{}",
        rho(1.0)
    );
    let top = shrad_scene::MAX_REFLECTANCE;
    assert!(
        (rho(2.0) - Vec3::new(top, 0.0, 0.6)).length() < 1e-6,
        "{}",
        rho(2.0)
    );

    // The keys replace the node's translation at rest, (0, 0, 1).
    let mover = object(&s, "Mover").world_from_object_at(1.0);
    assert!((Vec3::from(mover.translation) - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-6);
}

#[test]
fn a_node_pointer_moves_its_node_as_the_core_channel_does() {
    let core = json!({"sampler": 2, "target": {"node": 2, "path": "translation"}});
    let by_pointer = crate::common::load_gltf_json(
        SUITE,
        "pointer",
        &file(vec![pointer(2, "/nodes/2/translation")]),
    );
    let by_core = crate::common::load_gltf_json(SUITE, "core", &file(vec![core]));
    for t in [0.0, 0.3, 1.0, 1.7, 2.5] {
        let (a, b): (Affine3A, Affine3A) = (
            object(&by_pointer, "Mover").world_from_object_at(t),
            object(&by_core, "Mover").world_from_object_at(t),
        );
        assert_eq!(a, b, "t {t}");
    }
}

#[test]
fn only_the_selected_animations_pointers_play() {
    let mut v = file(every_channel());
    let core = json!({"sampler": 0, "target": {"node": 2, "path": "translation"}});
    let moves = v["animations"][0]["samplers"][2].clone();
    v["animations"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "Other", "channels": [core], "samplers": [moves]}));
    let p = crate::common::gltf_json_file(SUITE, "select", &v);
    let options = LoadOptions {
        animation: Some("Other".into()),
        ..Default::default()
    };
    let s = load(&p, &options).unwrap();
    assert!(!s.lights[0].is_animated());
    assert!(!object(&s, "Panel").is_animated());
    assert!(object(&s, "Mover").is_animated());
}

#[test]
fn pointers_to_what_shrad_does_not_light_are_ignored_with_a_warning() {
    let s = crate::common::load_gltf_json(
        SUITE,
        "ignored",
        &file(vec![
            pointer(0, "/materials/0/pbrMetallicRoughness/metallicFactor"),
            pointer(0, "/nodes/0/weights"),
        ]),
    );
    let said = |x: &str| s.warnings.iter().any(|w| w.contains(x));
    assert!(
        said("channel 0 animates /materials/0/pbrMetallicRoughness/metallicFactor"),
        "{:?}",
        s.warnings
    );
    assert!(said("channel 1 targets morph weights"), "{:?}", s.warnings);
    assert_eq!(s.animations[0].ignored, 2);
    assert!(!object(&s, "Panel").is_animated());
}

#[test]
fn a_pointer_to_nothing_or_keys_of_the_wrong_type_are_refused_naming_the_channel() {
    let refused = |name: &str, channel: Value| {
        let p = crate::common::gltf_json_file(SUITE, name, &file(vec![channel]));
        err_of(load(&p, &LoadOptions::default()))
    };
    let e = refused(
        "no-light",
        pointer(0, "/extensions/KHR_lights_punctual/lights/5/intensity"),
    );
    assert!(
        e.contains("animations[0].channels[0]") && e.contains("the file has 1 lights"),
        "{e}"
    );
    let e = refused("no-material", pointer(4, "/materials/3/emissiveFactor"));
    assert!(e.contains("the file has 1 materials"), "{e}");
    // Colour keys (VEC3) on an intensity (SCALAR).
    let e = refused(
        "wrong-type",
        pointer(1, "/extensions/KHR_lights_punctual/lights/0/intensity"),
    );
    assert!(
        e.contains("samplers[1].output") && e.contains("needs SCALAR FLOAT"),
        "{e}"
    );
    // Colour keys of three components on a base colour (RGBA).
    let e = refused(
        "rgb-base-colour",
        pointer(1, "/materials/0/pbrMetallicRoughness/baseColorFactor"),
    );
    assert!(
        e.contains("samplers[1].output") && e.contains("needs VEC4 FLOAT"),
        "{e}"
    );
}
