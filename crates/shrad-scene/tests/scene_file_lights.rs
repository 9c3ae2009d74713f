//! The scene file's `[[lights]]`: each kind, each way to give its strength, and bad values
//! as errors naming the file, the light and its line.

use std::f32::consts::PI;

use glam::Vec3;
use shrad_scene::{load, Light, LightKind, LoadOptions};

const FLOOR: &str = r#"
[[object]]
shape = "quad"
corners = [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]
"#;

fn write(name: &str, lights: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("shrad-toml-lights-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(name);
    std::fs::write(&p, format!("{FLOOR}\n{lights}")).unwrap();
    p
}

#[test]
fn lights_of_each_kind_load_in_radiometric_units() {
    let p = write(
        "ok.toml",
        r#"
[[lights]]
name = "bulb"
kind = "point"
position = [0, 2, 0]
power = 100.0

[[lights]]
kind = "spot"
position = [0, 3, 0]
direction = [0, -1, 0]
intensity = 683.0
color = [1, 0.5, 0.5]
inner_cone_deg = 10
outer_cone_deg = 30

[[lights]]
kind = "directional"
direction = [1, -1, 0]
irradiance = 2.0
"#,
    );
    let s = load(&p, &LoadOptions::default()).unwrap();
    let [bulb, spot, sun] = &s.lights[..] else {
        panic!("{:?}", s.lights)
    };
    // A 100 W lamp: 100 / (4 pi) W/sr, as Blender and Cycles have it.
    assert!((bulb.radiometric().x - 100.0 / (4.0 * PI)).abs() < 1e-4);
    assert_eq!(
        Light::position(&bulb.world_from_light),
        Vec3::new(0.0, 2.0, 0.0)
    );
    assert_eq!(spot.radiometric(), Vec3::new(1.0, 0.5, 0.5));
    assert!(matches!(spot.kind, LightKind::Spot { outer_cone_angle, .. }
        if (outer_cone_angle - 30f32.to_radians()).abs() < 1e-6));
    let d = Light::direction(&spot.world_from_light).unwrap();
    assert!((d + Vec3::Y).length() < 1e-6, "{d}");
    assert!((sun.radiometric().x - 2.0).abs() < 1e-5);
    let d = Light::direction(&sun.world_from_light).unwrap();
    assert!(
        (d - Vec3::new(1.0, -1.0, 0.0).normalize()).length() < 1e-6,
        "{d}"
    );
}

#[test]
fn bad_lights_name_the_file_the_light_and_the_line() {
    let cases = [
        ("neg.toml", "kind = \"point\"\nposition = [0, 1, 0]\nintensity = -1.0", "intensity"),
        // The value as written (it was "intensity -543.5141", converted from the power).
        ("negpower.toml", "kind = \"point\"\nposition = [0, 1, 0]\npower = -10", "power -10 must be"),
        ("nanirr.toml", "kind = \"directional\"\ndirection = [0, -1, 0]\nirradiance = nan", "irradiance NaN must be"),
        ("both.toml", "kind = \"point\"\nposition = [0, 1, 0]\npower = 1.0\nintensity = 1.0", "one of"),
        (
            "cone.toml",
            "kind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\ninner_cone_deg = 40\nouter_cone_deg = 30",
            // In the file's degrees (it was "innerConeAngle 0.6981317 must be less than
            // outerConeAngle 0.5235988").
            "the inner cone angle 40 deg must be less than the outer 30 deg",
        ),
        (
            "wide.toml",
            "kind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\nouter_cone_deg = 100",
            "the outer cone angle 100 deg is beyond 90 deg",
        ),
        (
            "nancone.toml",
            "kind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\nouter_cone_deg = nan",
            "the cone angles must be finite",
        ),
        // As an object's coordinates: it loaded, and lit the floor 100 times too dimly.
        (
            "far.toml",
            "kind = \"point\"\nposition = [1e13, 2, 0]\npower = 100",
            "is beyond the 1e12",
        ),
        (
            "blendtwice.toml",
            "kind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\ninner_cone_deg = 10\nblend = 0.3",
            "give inner_cone_deg or blend (Blender's), not both",
        ),
        (
            "blendbig.toml",
            "kind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\nblend = 1.5",
            "blend 1.5 must be within [0, 1]",
        ),
        (
            "blendpoint.toml",
            "kind = \"point\"\nposition = [0, 1, 0]\nintensity = 1\nblend = 0.5",
            "only a spot light has cone angles or a blend",
        ),
        (
            "blendnocone.toml",
            "kind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\nouter_cone_deg = 0\nblend = 0.3",
            "the outer cone angle 0 deg must be > 0",
        ),
        (
            "blendneg.toml",
            "kind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\nouter_cone_deg = -10\nblend = 0.3",
            "the outer cone angle -10 deg must be > 0",
        ),
        (
            "justover.toml",
            "kind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\nouter_cone_deg = 90.001",
            "the outer cone angle 90.001 deg is beyond 90 deg",
        ),
        ("nodir.toml", "kind = \"directional\"\nirradiance = 1", "direction missing"),
        ("nopos.toml", "kind = \"point\"\npower = 1", "position missing"),
        // Finite, but beyond what a solve's 32-bit sums hold (it was "intensity inf").
        ("hugepower.toml", "kind = \"point\"\nposition = [0, 1, 0]\npower = 1e38", "power 1e38 is beyond"),
        ("hugesun.toml", "kind = \"directional\"\ndirection = [0, -1, 0]\nirradiance = 1e30", "irradiance 1e30 is beyond"),
    ];
    for (name, body, what) in cases {
        let p = write(name, &format!("[[lights]]\n{body}\n"));
        let e = load(&p, &LoadOptions::default()).unwrap_err().to_string();
        assert!(
            e.contains(name) && e.contains("lights 0 (line ") && e.contains(what),
            "{name}: {e}"
        );
    }
}

/// An emitting object's own `emission` (and `reflectance`) beside keys that start later is
/// its value until then, a key at time 0: with one key at 2 s, the lamp shone the key's
/// colour from the start and `shrad info` called it not animated.
#[test]
fn an_objects_own_emission_holds_until_its_first_key() {
    let keyed = |interpolation: &str| {
        write(
            &format!("keys-{interpolation}.toml"),
            &format!(
                r#"
[[object]]
name = "lamp"
shape = "quad"
corners = [[-1, 2, -1], [1, 2, -1], [1, 2, 1], [-1, 2, 1]]
emission = [10, 10, 10]
reflectance = [0.5, 0.5, 0.5]
interpolation = "{interpolation}"

[[object.emission_key]]
time = 2.0
emission = [4, 12, 17]

[[object.reflectance_key]]
time = 2.0
reflectance = [0.1, 0.2, 0.7]
"#
            ),
        )
    };
    let scene = load(&keyed("step"), &LoadOptions::default()).unwrap();
    let lamp = scene.objects.iter().find(|o| o.name == "lamp").unwrap();
    assert!(lamp.is_animated());
    for (t, e, r) in [
        (0.0, Vec3::splat(10.0), Vec3::splat(0.5)),
        (1.9, Vec3::splat(10.0), Vec3::splat(0.5)),
        (2.1, Vec3::new(4.0, 12.0, 17.0), Vec3::new(0.1, 0.2, 0.7)),
    ] {
        let m = lamp.material_at(t);
        assert_eq!((m.emitted_radiance, m.reflectance), (e, r), "at {t} s");
    }
    // Linear: from the object's own value at 0 to the key's at 2.
    let scene = load(&keyed("linear"), &LoadOptions::default()).unwrap();
    let lamp = scene.objects.iter().find(|o| o.name == "lamp").unwrap();
    let m = lamp.material_at(1.0);
    assert!(
        (m.emitted_radiance - Vec3::new(7.0, 11.0, 13.5))
            .abs()
            .max_element()
            < 1e-5
    );
    assert!(
        (m.reflectance - Vec3::new(0.3, 0.35, 0.6))
            .abs()
            .max_element()
            < 1e-5
    );
}

/// Two lights of one name are an error, as two objects of one name are: the second was kept
/// and `set_light("bulb")` changed only the first.
#[test]
fn two_lights_of_one_name_are_refused() {
    let bulb = "[[lights]]\nname = \"bulb\"\nkind = \"point\"\nposition = [0, 1, 0]\npower = 1\n";
    let p = write("twice.toml", &format!("{bulb}\n{bulb}"));
    let e = load(&p, &LoadOptions::default()).unwrap_err().to_string();
    assert!(
        e.contains("twice.toml")
            && e.contains("lights 1 (line ")
            && e.contains("the name 'bulb' is already light 0's"),
        "{e}"
    );
}

/// A box of side 2 about (0, 1, 0) with the given extra keys.
fn lamp_in_a_box(name: &str, box_keys: &str, lamp_at: [f32; 3]) -> Vec<String> {
    let p = write(
        name,
        &format!(
            r#"
[[object]]
name = "crate"
shape = "box"
size = [2, 2, 2]
position = [0, 1, 0]
{box_keys}

[[lights]]
name = "lamp"
kind = "point"
position = {lamp_at:?}
power = 100.0
"#
        ),
    );
    load(&p, &LoadOptions::default()).unwrap().warnings
}

#[test]
fn a_light_shut_inside_a_closed_object_is_warned_of() {
    let enclosed = |w: &Vec<String>| {
        w.iter()
            .any(|w| w.contains("light 'lamp' is inside object 'crate'"))
    };
    // Inside a box whose faces look out: its light reaches none of them.
    let w = lamp_in_a_box("shut.toml", "", [0.2, 1.3, -0.4]);
    assert!(enclosed(&w), "{w:?}");
    // Outside it, inside a room facing in, or inside a double-sided box: no warning.
    for (name, keys, at) in [
        ("outside.toml", "", [3.0, 1.0, 0.0]),
        ("room.toml", "inward = true", [0.2, 1.3, -0.4]),
        ("two-sided.toml", "double_sided = true", [0.2, 1.3, -0.4]),
    ] {
        let w = lamp_in_a_box(name, keys, at);
        assert!(!enclosed(&w), "{name}: {w:?}");
    }
}

/// A spot given Blender's `blend` falls off as Blender's: its inner angle the outer times
/// 1 - blend, and a blend of 0 (equal cones) is a hard edge, not an error.
#[test]
fn a_spot_with_blenders_blend_falls_off_as_blenders() {
    for (name, blend) in [("blend3.toml", 0.3f32), ("blend0.toml", 0.0)] {
        let body = format!(
            "[[lights]]\nkind = \"spot\"\nposition = [0, 1, 0]\ndirection = [0, -1, 0]\nintensity = 1\nouter_cone_deg = 40\nblend = {blend}\n"
        );
        let s = load(&write(name, &body), &LoadOptions::default()).unwrap();
        let l = &s.lights[0];
        assert_eq!(l.cone_falloff, shrad_scene::ConeFalloff::Blender);
        let LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } = l.kind
        else {
            panic!("{:?}", l.kind)
        };
        assert!((outer_cone_angle - 40f32.to_radians()).abs() < 1e-6);
        assert!((inner_cone_angle - outer_cone_angle * (1.0 - blend)).abs() < 1e-6);
    }
}
