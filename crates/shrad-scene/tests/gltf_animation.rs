//! glTF node animation import (issue 10): LINEAR, STEP and CUBICSPLINE channels checked
//! against hand-computed poses, children moving with their animated parent, one animation
//! selected by name or index, and malformed animation data refused with the JSON path.
//! The fixtures are written as Blender's exporter writes them: one animation per animated
//! object, translation / rotation / scale channels, one shared time range.

use std::path::{Path, PathBuf};

use glam::{Affine3A, Quat, Vec3};
use serde_json::{json, Value};
use shrad_scene::{load, LoadOptions, Scene, SceneError};

use crate::common::gltf_bin::Bin;

fn temp_dir(name: &str) -> PathBuf {
    crate::common::temp_dir(&format!("shrad-gltf-anim-{}-{name}", std::process::id()))
}

fn b64(data: &[u8]) -> String {
    base64::encode(data)
}

impl Bin {
    /// A normalized SHORT VEC4 accessor (quantised rotations, as glTF allows).
    fn normalized_shorts(&mut self, data: &[i16]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        self.accessor(
            &bytes,
            data.len() / 4,
            "VEC4",
            5122,
            json!({"normalized": true}),
        )
    }
}

fn flat(v: &[[f32; 3]]) -> Vec<f32> {
    v.iter().flatten().copied().collect()
}

fn quat_z(deg: f32) -> [f32; 4] {
    Quat::from_rotation_z(deg.to_radians()).to_array()
}

/// A unit square in the node's XY plane (facing +Z) and a light panel; nodes:
/// 0 "Mover" (animation "MoverAction": translation LINEAR 0 -> (2,0,0) -> (2,2,0) at
/// t = 0, 1, 2, rotation LINEAR 0 -> 90 deg about Z over 0..2), its child 1 "Child" at
/// (1, 0, 0) in the Mover's frame, 2 "Scaler" at (5, 0, 0) (animation "ScalerAction":
/// scale STEP 1 -> 2 at t = 1, translation CUBICSPLINE from (5,0,0) to (5,4,0) over 0..2
/// with out-tangent (0,1,0) and in-tangent (0,3,0)), 3 "Lamp" (static).
fn fixture() -> (Value, Bin) {
    let mut b = Bin::default();
    let pos = b.floats_of(
        "VEC3",
        &flat(&[[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]]),
    );
    b.accessors[pos]["min"] = json!([0.0, 0.0, 0.0]);
    b.accessors[pos]["max"] = json!([1.0, 1.0, 0.0]);
    let idx = b.indices(&[0, 1, 2, 0, 2, 3]);
    let t3 = b.floats_of("SCALAR", &[0.0, 1.0, 2.0]);
    let mover_t = b.floats_of("VEC3", &flat(&[[0., 0., 0.], [2., 0., 0.], [2., 2., 0.]]));
    let t2 = b.floats_of("SCALAR", &[0.0, 2.0]);
    let mover_r = b.floats_of("VEC4", &[quat_z(0.0), quat_z(90.0)].concat());
    let step_t = b.floats_of("SCALAR", &[0.0, 1.0]);
    let scaler_s = b.floats_of("VEC3", &flat(&[[1., 1., 1.], [2., 2., 2.]]));
    let cubic_t = b.floats_of("SCALAR", &[0.0, 2.0]);
    // in-tangent, value, out-tangent per key; the unused outer tangents are odd on purpose.
    let scaler_t = b.floats_of(
        "VEC3",
        &flat(&[
            [9., 9., 9.],
            [5., 0., 0.],
            [0., 1., 0.],
            [0., 3., 0.],
            [5., 4., 0.],
            [-9., 9., -9.],
        ]),
    );
    let v = json!({
        "asset": {"version": "2.0", "generator": "Khronos glTF Blender I/O (test fixture)"},
        "scene": 0,
        "scenes": [{"nodes": [0, 2, 3]}],
        "nodes": [
            {"name": "Mover", "mesh": 0, "children": [1]},
            {"name": "Child", "mesh": 0, "translation": [1.0, 0.0, 0.0]},
            {"name": "Scaler", "mesh": 0, "translation": [5.0, 0.0, 0.0]},
            {"name": "Lamp", "mesh": 1, "translation": [0.0, 0.0, 5.0]}
        ],
        "meshes": [
            {"name": "Square", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]},
            {"name": "Panel", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx, "material": 0}]}
        ],
        "materials": [{"name": "light", "emissiveFactor": [1.0, 1.0, 1.0]}],
        "animations": [
            {"name": "MoverAction",
             "channels": [
                {"sampler": 0, "target": {"node": 0, "path": "translation"}},
                {"sampler": 1, "target": {"node": 0, "path": "rotation"}}
             ],
             "samplers": [
                {"input": t3, "output": mover_t, "interpolation": "LINEAR"},
                {"input": t2, "output": mover_r}
             ]},
            {"name": "ScalerAction",
             "channels": [
                {"sampler": 0, "target": {"node": 2, "path": "scale"}},
                {"sampler": 1, "target": {"node": 2, "path": "translation"}}
             ],
             "samplers": [
                {"input": step_t, "output": scaler_s, "interpolation": "STEP"},
                {"input": cubic_t, "output": scaler_t, "interpolation": "CUBICSPLINE"}
             ]}
        ]
    });
    (v, b)
}

/// The glTF JSON with the buffer of `b` embedded.
fn finish(mut v: Value, b: &Bin) -> Value {
    v["accessors"] = json!(b.accessors);
    v["bufferViews"] = json!(b.views);
    v["buffers"] = json!([{"byteLength": b.bytes.len(),
        "uri": format!("data:application/octet-stream;base64,{}", b64(&b.bytes))}]);
    v
}

fn write(dir: &Path, name: &str, v: &Value) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, serde_json::to_string_pretty(v).unwrap()).unwrap();
    p
}

fn load_fixture(name: &str, animation: Option<&str>) -> Result<Scene, SceneError> {
    let dir = temp_dir(name);
    let (v, b) = fixture();
    let p = write(&dir, "anim.gltf", &finish(v, &b));
    load(
        &p,
        &LoadOptions {
            animation: animation.map(str::to_string),
            ..Default::default()
        },
    )
}

fn object<'s>(s: &'s Scene, name: &str) -> &'s shrad_scene::Object {
    s.objects.iter().find(|o| o.name == name).unwrap()
}

fn assert_near(a: Affine3A, b: Affine3A, what: &str) {
    let d = (a.matrix3 - b.matrix3)
        .to_cols_array()
        .iter()
        .fold(0f32, |m, x| m.max(x.abs()))
        .max((a.translation - b.translation).abs().max_element());
    assert!(
        d < 1e-5,
        "{what}: got {a:?}, expected {b:?} (max difference {d})"
    );
}

fn trs(t: Vec3, deg_z: f32, s: f32) -> Affine3A {
    Affine3A::from_scale_rotation_translation(
        Vec3::splat(s),
        Quat::from_rotation_z(deg_z.to_radians()),
        t,
    )
}

#[test]
fn linear_translation_and_slerp_rotation_with_a_child() {
    let s = load_fixture("linear", None).unwrap();
    assert!(
        s.warnings.iter().all(|w| !w.contains("animation")),
        "{:?}",
        s.warnings
    );
    let mover = object(&s, "Mover");
    let child = object(&s, "Child");
    assert!(mover.is_animated() && child.is_animated());
    assert!(!object(&s, "Lamp").is_animated());
    assert_eq!(s.duration(), 2.0);
    // t = 0.5: translation (1, 0, 0), rotation a quarter of 90 deg.
    for (t, pos, deg) in [
        (0.0, Vec3::ZERO, 0.0),
        (0.5, Vec3::new(1.0, 0.0, 0.0), 22.5),
        (1.0, Vec3::new(2.0, 0.0, 0.0), 45.0),
        (1.5, Vec3::new(2.0, 1.0, 0.0), 67.5),
        (2.0, Vec3::new(2.0, 2.0, 0.0), 90.0),
        (7.0, Vec3::new(2.0, 2.0, 0.0), 90.0),
        (-1.0, Vec3::ZERO, 0.0),
    ] {
        let m = trs(pos, deg, 1.0);
        assert_near(mover.world_from_object_at(t), m, &format!("Mover at {t}"));
        // The child sits 1 along the Mover's own (turned) X axis.
        let c = m * Affine3A::from_translation(Vec3::X);
        assert_near(child.world_from_object_at(t), c, &format!("Child at {t}"));
    }
    let c = child.world_from_object_at(0.5).translation;
    let a = 22.5f32.to_radians();
    assert!((Vec3::from(c) - Vec3::new(1.0 + a.cos(), a.sin(), 0.0)).length() < 1e-5);
    // The rest transform is the pose at time 0.
    assert_near(
        mover.world_from_object,
        mover.world_from_object_at(0.0),
        "rest",
    );
}

#[test]
fn step_scale_and_cubic_spline_translation() {
    let s = load_fixture("step-cubic", None).unwrap();
    let o = object(&s, "Scaler");
    // STEP: scale 1 until t = 1, then 2.
    assert_eq!(o.world_from_object_at(0.99).matrix3.x_axis.x, 1.0);
    assert_eq!(o.world_from_object_at(1.0).matrix3.x_axis.x, 2.0);
    assert_eq!(o.world_from_object_at(1.5).matrix3.x_axis.x, 2.0);
    // CUBICSPLINE, td = 2, s = 0.5: h00 = h01 = 0.5, h10 = 0.125, h11 = -0.125:
    // y = 0.5 * 0 + 2 * 0.125 * 1 + 0.5 * 4 - 2 * 0.125 * 3 = 1.5.
    let p = Vec3::from(o.world_from_object_at(1.0).translation);
    assert!((p - Vec3::new(5.0, 1.5, 0.0)).length() < 1e-5, "{p}");
    // s = 0.25 (t = 0.5): h00 = 0.84375, h10 = 0.140625, h01 = 0.15625, h11 = -0.046875:
    // y = 2 * 0.140625 * 1 + 0.15625 * 4 - 2 * 0.046875 * 3 = 0.625.
    let p = Vec3::from(o.world_from_object_at(0.5).translation);
    assert!((p - Vec3::new(5.0, 0.625, 0.0)).length() < 1e-5, "{p}");
    // The ends are the key values (not the odd outer tangents).
    let p = Vec3::from(o.world_from_object_at(2.0).translation);
    assert!((p - Vec3::new(5.0, 4.0, 0.0)).length() < 1e-6, "{p}");
    let p = Vec3::from(o.world_from_object_at(0.0).translation);
    assert!((p - Vec3::new(5.0, 0.0, 0.0)).length() < 1e-6, "{p}");
}

#[test]
fn one_animation_by_name_or_index() {
    let s = load_fixture("select-name", Some("ScalerAction")).unwrap();
    assert!(!object(&s, "Mover").is_animated());
    assert!(!object(&s, "Child").is_animated());
    assert!(object(&s, "Scaler").is_animated());
    assert_eq!(s.animations.len(), 2);
    assert!(!s.animations[0].playing && s.animations[1].playing);
    assert_eq!(s.animations[1].name, "ScalerAction");
    assert_eq!(s.animations[1].channels, 2);
    assert_eq!((s.animations[1].start, s.animations[1].end), (0.0, 2.0));
    let s = load_fixture("select-index", Some("0")).unwrap();
    assert!(object(&s, "Mover").is_animated());
    assert!(!object(&s, "Scaler").is_animated());
    let e = load_fixture("select-unknown", Some("Nope"))
        .unwrap_err()
        .to_string();
    for w in ["anim.gltf", "Nope", "0 'MoverAction'", "1 'ScalerAction'"] {
        assert!(e.contains(w), "does not say {w}: {e}");
    }
    let e = load_fixture("select-range", Some("2"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("available"), "{e}");
}

#[test]
fn scene_file_keys_compose_on_top_of_the_gltf_animation() {
    let dir = temp_dir("toml");
    let (v, b) = fixture();
    write(&dir, "anim.gltf", &finish(v, &b));
    std::fs::write(
        dir.join("scene.toml"),
        r#"
[[object]]
name = "mover"
shape = "mesh"
file = "anim.gltf"
node = "Mover"
position = [0, 0, 10]

[[object.key]]
time = 0.0
translation = [0, 0, 0]

[[object.key]]
time = 4.0
translation = [0, 0, 4]

[[object]]
name = "lamp"
shape = "mesh"
file = "anim.gltf"
node = "Lamp"
"#,
    )
    .unwrap();
    let s = load(&dir.join("scene.toml"), &LoadOptions::default()).unwrap();
    let o = object(&s, "mover");
    assert_eq!(s.duration(), 4.0);
    // glTF pose at t = 1 (translation (2,0,0), 45 deg), under the rest position (0,0,10),
    // then the scene file's key translation (0,0,1) at t = 1 on top.
    let want =
        Affine3A::from_translation(Vec3::new(0.0, 0.0, 11.0)) * trs(Vec3::X * 2.0, 45.0, 1.0);
    assert_near(o.world_from_object_at(1.0), want, "mover at 1");
    // After the glTF's 2 s its last pose holds; the keys go on to 4 s.
    let want = Affine3A::from_translation(Vec3::new(0.0, 0.0, 13.0))
        * trs(Vec3::new(2.0, 2.0, 0.0), 90.0, 1.0);
    assert_near(o.world_from_object_at(3.0), want, "mover at 3");
    // A selected animation in the scene file.
    std::fs::write(
        dir.join("one.toml"),
        "[[object]]\nshape = \"mesh\"\nfile = \"anim.gltf\"\nanimation = \"ScalerAction\"\n",
    )
    .unwrap();
    let s = load(&dir.join("one.toml"), &LoadOptions::default()).unwrap();
    assert!(s.objects.iter().filter(|o| o.is_animated()).count() == 1);
    std::fs::write(
        dir.join("bad.toml"),
        "[[object]]\nshape = \"mesh\"\nfile = \"anim.gltf\"\nanimation = \"Nope\"\n",
    )
    .unwrap();
    let e = load(&dir.join("bad.toml"), &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("Nope") && e.contains("MoverAction"), "{e}");
}

#[test]
fn morph_weights_and_pointer_channels_are_ignored_with_a_warning() {
    let dir = temp_dir("weights");
    let (mut v, mut b) = fixture();
    let t = b.floats_of("SCALAR", &[0.0, 1.0]);
    let w = b.floats_of("SCALAR", &[0.0, 1.0]);
    v["animations"].as_array_mut().unwrap().push(json!({
        "name": "Shape",
        "channels": [
            {"sampler": 0, "target": {"node": 0, "path": "weights"}},
            {"sampler": 0, "target": {"path": "pointer",
              "extensions": {"KHR_animation_pointer": {"pointer": "/materials/0/alphaCutoff"}}}}
        ],
        "samplers": [{"input": t, "output": w}]
    }));
    let p = write(&dir, "w.gltf", &finish(v, &b));
    let s = load(&p, &LoadOptions::default()).unwrap();
    let said = |x: &str| s.warnings.iter().any(|w| w.contains(x));
    assert!(
        said("animation 'Shape' channel 0 targets morph weights: ignored"),
        "{:?}",
        s.warnings
    );
    assert!(
        said("channel 1 animates /materials/0/alphaCutoff"),
        "{:?}",
        s.warnings
    );
    assert!(
        said("animation 'Shape' has no playable channel"),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.animations[2].ignored, 2);
    // The other animations still play.
    assert!(object(&s, "Mover").is_animated());
}

#[test]
fn quantised_rotation_keys() {
    let dir = temp_dir("quantised");
    let (mut v, mut b) = fixture();
    // 0 and 90 deg about Z as normalized SHORTs: (0, 0, 0, 32767), (0, 0, 23170, 23170).
    let r = b.normalized_shorts(&[0, 0, 0, 32767, 0, 0, 23170, 23170]);
    v["animations"][0]["samplers"][1]["output"] = json!(r);
    let p = write(&dir, "q.gltf", &finish(v, &b));
    let s = load(&p, &LoadOptions::default()).unwrap();
    let m = object(&s, "Mover").world_from_object_at(1.0);
    assert_near(m, trs(Vec3::X * 2.0, 45.0, 1.0), "Mover at 1");
}

/// A sampler that cannot play is skipped with a warning naming it, and the rest plays: key
/// times not strictly increasing (glTF 2.0 requires them so; an accessor without data, all
/// zeros, has them so in files the glTF-Validator finds valid), or key times in a buffer
/// without data (no uri in a .gltf). Viewers load such a file and play what they can.
#[test]
fn a_sampler_that_cannot_play_is_skipped_and_the_rest_plays() {
    let dir = temp_dir("skipped-sampler");
    let (mut v, mut b) = fixture();
    // MoverAction's translation keys at 0, 1, 1.
    let t = b.floats_of("SCALAR", &[0.0, 1.0, 1.0]);
    v["animations"][0]["samplers"][0]["input"] = json!(t);
    // ScalerAction's scale keys in a second buffer, which has no uri.
    let n = b.accessors.len();
    b.accessors.push(
        json!({"bufferView": b.views.len(), "componentType": 5126, "count": 2,
                     "type": "SCALAR", "min": [0.0], "max": [1.0]}),
    );
    b.views.push(json!({"buffer": 1, "byteLength": 8}));
    v["animations"][1]["samplers"][0]["input"] = json!(n);
    let mut v = finish(v, &b);
    v["buffers"]
        .as_array_mut()
        .unwrap()
        .push(json!({"byteLength": 8}));
    let p = write(&dir, "skipped.gltf", &v);
    let s = load(&p, &LoadOptions::default()).unwrap();
    let said = |f: &str| s.warnings.iter().any(|w| w.contains(f));
    assert!(
        said("animation 'MoverAction': animations[0].samplers[0].input: key times of accessor")
            && said("must be strictly increasing (key 2: 1 after 1)")
            && said("the sampler is skipped, and its channels do not play"),
        "{:?}",
        s.warnings
    );
    assert!(
        said(&format!(
            "animation 'ScalerAction': animations[1].samplers[0].input: accessors[{n}]: bufferView"
        )) && said("reads buffer 1, which has no data"),
        "{:?}",
        s.warnings
    );
    assert_eq!((s.animations[0].channels, s.animations[0].ignored), (1, 1));
    assert_eq!((s.animations[1].channels, s.animations[1].ignored), (1, 1));
    // The rotation still turns the Mover (90 deg at t = 2, no translation); the Scaler
    // still moves up by its cubic spline, at scale 1.
    let m = object(&s, "Mover").world_from_object_at(2.0);
    assert_near(m, trs(Vec3::ZERO, 90.0, 1.0), "Mover at 2");
    let m = object(&s, "Scaler").world_from_object_at(2.0);
    assert_near(m, trs(Vec3::new(5.0, 4.0, 0.0), 0.0, 1.0), "Scaler at 2");
}

/// The fixture with `edit` applied (before the buffer is embedded), expected refused with
/// every one of `faults` in the message.
fn refused(name: &str, edit: impl FnOnce(&mut Value, &mut Bin), faults: &[&str]) {
    let dir = temp_dir(name);
    let (mut v, mut b) = fixture();
    edit(&mut v, &mut b);
    let p = write(&dir, &format!("{name}.gltf"), &finish(v, &b));
    let e = match load(&p, &LoadOptions::default()) {
        Ok(_) => panic!("{name}: loaded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains(&format!("{name}.gltf")), "{e}");
    assert!(
        !e.contains("gave up"),
        "{name}: the panic guard answered: {e}"
    );
    for f in faults {
        assert!(e.contains(f), "{name}: does not say '{f}': {e}");
    }
}

#[test]
fn malformed_animation_data_is_refused() {
    refused(
        "nan-time",
        |v, b| {
            let t = b.floats_of("SCALAR", &[0.0, f32::NAN, 2.0]);
            v["animations"][0]["samplers"][0]["input"] = json!(t);
        },
        &["animations[0].samplers[0].input", "not finite"],
    );
    refused(
        "vec3-times",
        |v, b| {
            let t = b.floats_of("VEC3", &[0.0, 1.0, 2.0]);
            v["animations"][0]["samplers"][0]["input"] = json!(t);
        },
        &["animations[0].samplers[0].input", "SCALAR FLOAT"],
    );
    refused(
        "count",
        |v, b| {
            let o = b.floats_of("VEC3", &flat(&[[0., 0., 0.], [1., 0., 0.]]));
            v["animations"][0]["samplers"][0]["output"] = json!(o);
        },
        &["animations[0].samplers[0].output", "2 values", "3 keys"],
    );
    refused(
        "cubic-count",
        |v, _| v["animations"][1]["samplers"][0]["interpolation"] = json!("CUBICSPLINE"),
        &["animations[1].samplers[0].output", "CUBICSPLINE", "need 6"],
    );
    refused(
        "cubic-one-key",
        |v, b| {
            let t = b.floats_of("SCALAR", &[0.0]);
            let o = b.floats_of("VEC3", &[0.0; 9]);
            v["animations"][1]["samplers"][1]["input"] = json!(t);
            v["animations"][1]["samplers"][1]["output"] = json!(o);
        },
        &["animations[1].samplers[1]", "at least 2 keys"],
    );
    refused(
        "interpolation",
        |v, _| v["animations"][0]["samplers"][0]["interpolation"] = json!("QUADRATIC"),
        &["animations[0].samplers[0].interpolation", "QUADRATIC"],
    );
    refused(
        "rotation-vec3",
        |v, _| v["animations"][0]["channels"][1]["sampler"] = json!(0),
        &["animations[0].samplers[0].output", "rotation", "VEC4"],
    );
    refused(
        "no-sampler",
        |v, _| v["animations"][0]["channels"][0]["sampler"] = json!(7),
        &["animations[0].channels[0].sampler", "7"],
    );
    refused(
        "no-node",
        |v, _| v["animations"][1]["channels"][1]["target"]["node"] = json!(42),
        &["animations[1].channels[1].target.node", "42"],
    );
    refused(
        "no-path",
        |v, _| {
            v["animations"][0]["channels"][0]["target"]
                .as_object_mut()
                .unwrap()
                .remove("path");
        },
        &["animations[0].channels[0].target.path", "missing"],
    );
    refused(
        "zero-quaternion",
        |v, b| {
            let o = b.floats_of("VEC4", &[0.0; 8]);
            v["animations"][0]["samplers"][1]["output"] = json!(o);
        },
        &["animations[0].samplers[1].output", "zero quaternion"],
    );
}
