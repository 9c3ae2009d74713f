//! Importers and exporters: glTF, GLB, OBJ, the TOML scene file, and their error messages.

use std::path::{Path, PathBuf};

use glam::{Affine3A, Mat4, Quat, Vec3};
use serde_json::{json, Value};
use shrad_scene::{
    cornell_box, load, write_gltf, write_obj, Aabb, LoadOptions, Material, Mesh, Object, Role,
    Scene, SceneError,
};

use crate::common::err_of;

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes")
}

/// A fresh empty temporary directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    crate::common::temp_dir(&format!("shrad-scene-{}-{name}", std::process::id()))
}

fn opts() -> LoadOptions {
    LoadOptions::default()
}

/// World-space triangles of an object.
fn world_triangles(o: &Object) -> Vec<[Vec3; 3]> {
    let m = o.mesh.transformed(o.world_from_object);
    m.triangles
        .iter()
        .map(|t| t.map(|i| m.positions[i as usize]))
        .collect()
}

/// World-space triangles of an object, counter-clockwise seen from their front side (flipped
/// when `world_from_object` mirrors).
fn front_world_triangles(o: &Object) -> Vec<[Vec3; 3]> {
    let mut t = world_triangles(o);
    if o.world_from_object.matrix3.determinant() < 0.0 {
        for [_, b, c] in &mut t {
            std::mem::swap(b, c);
        }
    }
    t
}

/// Same triangle with the same orientation (up to a cyclic shift of its corners).
fn same_triangle(a: &[Vec3; 3], b: &[Vec3; 3], tol: f32) -> bool {
    (0..3).any(|s| (0..3).all(|k| a[k].distance(b[(k + s) % 3]) <= tol))
}

/// Same triangle in either orientation.
fn same_triangle_any(a: &[Vec3; 3], b: &[Vec3; 3], tol: f32) -> bool {
    same_triangle(a, b, tol) || same_triangle(a, &[b[0], b[2], b[1]], tol)
}

fn same_triangle_sets(a: &[[Vec3; 3]], b: &[[Vec3; 3]], tol: f32, oriented: bool) -> bool {
    a.len() == b.len()
        && a.iter().all(|ta| {
            b.iter().any(|tb| {
                if oriented {
                    same_triangle(ta, tb, tol)
                } else {
                    same_triangle_any(ta, tb, tol)
                }
            })
        })
}

/// `got` has the objects of `want` (by name): world-space triangles within 1e-3 (same
/// orientation), reflectance and emission within 1e-4, same roles.
fn assert_same_objects(want: &Scene, got: &Scene) {
    assert_eq!(want.objects.len(), got.objects.len(), "object count");
    for w in &want.objects {
        let g = got
            .objects
            .iter()
            .find(|o| o.name == w.name)
            .unwrap_or_else(|| panic!("no object '{}' in {}", w.name, got.source));
        assert!(
            same_triangle_sets(&world_triangles(w), &world_triangles(g), 1e-3, true),
            "object '{}': world triangles differ",
            w.name
        );
        assert!(
            w.material
                .reflectance
                .abs_diff_eq(g.material.reflectance, 1e-4),
            "object '{}': reflectance {} vs {}",
            w.name,
            w.material.reflectance,
            g.material.reflectance
        );
        assert!(
            w.material
                .emitted_radiance
                .abs_diff_eq(g.material.emitted_radiance, 1e-4),
            "object '{}': emission {} vs {}",
            w.name,
            w.material.emitted_radiance,
            g.material.emitted_radiance
        );
        assert_eq!(w.role, g.role, "object '{}': role", w.name);
    }
}

fn assert_err_names(r: Result<Scene, SceneError>, file: &str, fault: &str) {
    let msg = err_of(r);
    assert!(
        msg.contains(file),
        "message does not name the file {file}: {msg}"
    );
    assert!(msg.contains(fault), "message does not say '{fault}': {msg}");
}

// ----------------------------------------------------------------------------------------
// The committed Cornell box files

#[test]
fn cornell_gltf_matches_builtin() {
    let s = load(&scenes_dir().join("cornell.gltf"), &opts()).unwrap();
    let want = cornell_box();
    assert_same_objects(&want, &s);
    let (a, b) = (want.camera.unwrap(), s.camera.expect("camera"));
    assert!((a.yfov - b.yfov).abs() < 1e-5);
    assert!(a.world_from_camera.abs_diff_eq(b.world_from_camera, 1e-3));
    assert_eq!(b.aspect_ratio, Some(1.0));
}

#[test]
fn cornell_obj_matches_builtin() {
    let s = load(&scenes_dir().join("cornell.obj"), &opts()).unwrap();
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_same_objects(&cornell_box(), &s);
}

#[test]
fn glb_round_trip_and_truncated_glb() {
    let dir = temp_dir("glb");
    let path = dir.join("cornell.glb");
    write_gltf(&cornell_box(), &path).unwrap();
    let s = load(&path, &opts()).unwrap();
    assert_same_objects(&cornell_box(), &s);
    // Cut in half: an error naming the file, not a panic.
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.join("cut.glb");
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let msg = err_of(load(&cut, &opts()));
    assert!(msg.contains("cut.glb"), "{msg}");
    // Cut at every few bytes: never a panic.
    for n in (0..bytes.len()).step_by(97) {
        std::fs::write(&cut, &bytes[..n]).unwrap();
        assert!(load(&cut, &opts()).is_err(), "cut at {n}");
    }
}

#[test]
fn builtin_by_name() {
    let s = load(Path::new("cornell"), &opts()).unwrap();
    assert_eq!(s.objects.len(), cornell_box().objects.len());
    let msg = err_of(load(Path::new("no_such_scene"), &opts()));
    assert!(
        msg.contains("no_such_scene") && msg.contains("cornell"),
        "{msg}"
    );
}

// ----------------------------------------------------------------------------------------
// glTF node hierarchy

/// A one-object glTF (unit-ish box mesh at the origin) as JSON, to be rearranged by tests.
fn one_box_gltf() -> Value {
    let mut s = Scene {
        source: "test".into(),
        ..Default::default()
    };
    let mut light = Material::diffuse(Vec3::ZERO);
    light.emitted_radiance = Vec3::splat(2.0);
    let mesh = Mesh {
        // A closed tetrahedron, counter-clockwise from outside.
        positions: vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 0.0, 3.0),
        ],
        triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        ..Default::default()
    };
    s.objects.push(Object::new("tet", mesh, light));
    // A folder of its own per call: the tests that call this run in parallel, and each
    // `temp_dir` empties its folder first (a shared one failed a test now and then).
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let n = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = temp_dir(&format!("one_box-{}-{n}", std::process::id()));
    let p = dir.join("one.gltf");
    write_gltf(&s, &p).unwrap();
    let json = serde_json::from_str(&std::fs::read_to_string(&p).unwrap()).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    json
}

fn tet_world(m: Mat4) -> Vec<[Vec3; 3]> {
    let a = Affine3A::from_mat4(m);
    let p = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
        Vec3::new(0.0, 0.0, 3.0),
    ]
    .map(|v| a.transform_point3(v));
    [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
        .iter()
        .map(|t: &[usize; 3]| t.map(|i| p[i]))
        .collect()
}

/// Signed volume: positive for a closed mesh whose front faces point outward.
fn signed_volume(tris: &[[Vec3; 3]]) -> f32 {
    tris.iter().map(|[a, b, c]| a.dot(b.cross(*c)) / 6.0).sum()
}

#[test]
fn gltf_hierarchy_trs_matrix_and_negative_scale() {
    let mut root = one_box_gltf();
    let q = Quat::from_rotation_y(0.7) * Quat::from_rotation_x(-0.3);
    let parent = Mat4::from_scale_rotation_translation(
        Vec3::new(2.0, 2.0, 2.0),
        q,
        Vec3::new(10.0, 0.0, -5.0),
    );
    let child =
        Mat4::from_rotation_translation(Quat::from_rotation_z(0.4), Vec3::new(1.0, 2.0, 3.0));
    let mirror = Mat4::from_scale_rotation_translation(
        Vec3::new(-1.0, 1.0, 1.0),
        Quat::IDENTITY,
        Vec3::new(-4.0, 0.0, 0.0),
    );
    root["nodes"] = json!([
        {"name": "parent", "translation": [10.0, 0.0, -5.0], "rotation": q.to_array(), "scale": [2.0, 2.0, 2.0],
         "children": [1, 2]},
        {"name": "child", "matrix": child.to_cols_array(), "mesh": 0, "extras": {"shrad_role": "interior"}},
        {"name": "mirrored", "scale": [-1.0, 1.0, 1.0], "translation": [-4.0, 0.0, 0.0], "mesh": 0},
        {"name": "cam", "camera": 0, "translation": [0.0, 1.0, 20.0]}
    ]);
    root["cameras"] = json!([{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.01}}]);
    root["scenes"] = json!([{"nodes": [0, 3]}]);
    let dir = temp_dir("hierarchy");
    let path = dir.join("h.gltf");
    std::fs::write(&path, serde_json::to_string(&root).unwrap()).unwrap();
    let s = load(&path, &opts()).unwrap();
    assert_eq!(s.objects.len(), 2);
    let child_obj = s.objects.iter().find(|o| o.name == "child").unwrap();
    let mirror_obj = s.objects.iter().find(|o| o.name == "mirrored").unwrap();
    assert_eq!(child_obj.role, Some(Role::Interior));
    assert!(same_triangle_sets(
        &world_triangles(child_obj),
        &tet_world(parent * child),
        1e-4,
        true
    ));
    // Mirrored: same points and the winding as in the file (glTF: counter-clockwise from the
    // front in the node's frame; the world normal is the inverse transpose of the local one).
    // The baked world triangles are then clockwise from outside, and the negative
    // determinant turns them back: the front side faces out.
    let got = world_triangles(mirror_obj);
    assert!(same_triangle_sets(
        &got,
        &tet_world(parent * mirror),
        1e-4,
        true
    ));
    assert!(mirror_obj.world_from_object.matrix3.determinant() < 0.0);
    assert!(
        signed_volume(&front_world_triangles(mirror_obj)) > 0.0,
        "mirrored object is inside out"
    );
    assert!(signed_volume(&world_triangles(child_obj)) > 0.0);
    // Camera: the node's transform.
    let cam = s.camera.unwrap();
    assert!((cam.yfov - 0.8).abs() < 1e-6);
    assert!(cam
        .world_from_camera
        .translation
        .abs_diff_eq(Vec3::new(0.0, 1.0, 20.0).into(), 1e-5));

    // Round trip through the writer keeps world-space geometry and orientation.
    let out = dir.join("round.gltf");
    write_gltf(&s, &out).unwrap();
    let s2 = load(&out, &opts()).unwrap();
    assert_same_objects(&s, &s2);
    let out_obj = dir.join("round.obj");
    write_obj(&s, &out_obj).unwrap();
    let s3 = load(&out_obj, &opts()).unwrap();
    // OBJ bakes world positions: a mirrored object's triangles are flipped there so that
    // they stay front faces.
    for o in &s.objects {
        let g = s3.objects.iter().find(|g| g.name == o.name).unwrap();
        assert!(same_triangle_sets(
            &front_world_triangles(o),
            &front_world_triangles(g),
            1e-3,
            true
        ));
    }
}

#[test]
fn gltf_non_indexed_strip_and_points() {
    let mut root = one_box_gltf();
    // Non-indexed triangle list over the 4 positions would leave one vertex over: use a
    // strip (0 1 2, 2 1 3) and a points primitive that must be skipped with a warning.
    root["meshes"][0]["primitives"] = json!([
        {"attributes": {"POSITION": 0}, "mode": 5, "material": 0},
        {"attributes": {"POSITION": 0}, "mode": 0, "material": 0}
    ]);
    let dir = temp_dir("strip");
    let path = dir.join("strip.gltf");
    std::fs::write(&path, serde_json::to_string(&root).unwrap()).unwrap();
    let s = load(&path, &opts()).unwrap();
    assert_eq!(s.objects.len(), 1);
    assert_eq!(s.objects[0].mesh.triangles, vec![[0, 1, 2], [2, 1, 3]]);
    assert!(
        s.warnings.iter().any(|w| w.contains("Points")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn gltf_texture_is_averaged_and_emission_strength_applies() {
    let mut root = one_box_gltf();
    let dir = temp_dir("texture");
    // 2 x 1 image, white and black: linear mean 0.5.
    let img = image::RgbImage::from_fn(2, 1, |x, _| {
        if x == 0 {
            image::Rgb([255, 255, 255])
        } else {
            image::Rgb([0, 0, 0])
        }
    });
    img.save(dir.join("tex.png")).unwrap();
    root["images"] = json!([{"uri": "tex.png"}]);
    root["textures"] = json!([{"source": 0}]);
    let m = &mut root["materials"][0];
    m["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.8, 0.6, 0.4, 1.0]);
    m["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    m["emissiveFactor"] = json!([1.0, 0.5, 0.25]);
    m["extensions"] = json!({"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}});
    root["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    let path = dir.join("tex.gltf");
    std::fs::write(&path, serde_json::to_string(&root).unwrap()).unwrap();
    let s = load(&path, &opts()).unwrap();
    let mat = s.objects[0].material.clone();
    assert!(
        mat.reflectance.abs_diff_eq(Vec3::new(0.4, 0.3, 0.2), 1e-3),
        "{}",
        mat.reflectance
    );
    assert!(mat
        .emitted_radiance
        .abs_diff_eq(Vec3::new(8.0, 4.0, 2.0), 1e-5));
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("texture averaged to one colour")),
        "{:?}",
        s.warnings
    );
    // An image that cannot be loaded: warning, factor alone.
    std::fs::remove_file(dir.join("tex.png")).unwrap();
    let s = load(&path, &opts()).unwrap();
    assert!(s.objects[0]
        .material
        .reflectance
        .abs_diff_eq(Vec3::new(0.8, 0.6, 0.4), 1e-6));
    assert!(
        s.warnings.iter().any(|w| w.contains("cannot be loaded")),
        "{:?}",
        s.warnings
    );
}

/// A scene file's own reflectance is at most 1 (read as 0.999, with a warning), as a
/// reflectance key's: 1.5, even 1e6, was clamped with a warning, and the same object in a
/// Python dict refused.
#[test]
fn a_scene_files_reflectance_above_one_is_an_error_and_one_is_clamped() {
    let dir = temp_dir("toml-reflectance");
    let quad = "shape = \"quad\"\ncorners = [[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]]";
    let path = dir.join("bright.toml");
    let body = format!("[[object]]\nname = \"floor\"\n{quad}\nreflectance = [1.5, 0.5, 0.5]\n");
    std::fs::write(&path, body).unwrap();
    let e = load(&path, &opts()).unwrap_err().to_string();
    assert!(
        e.contains("bright.toml")
            && e.contains("'floor'")
            && e.contains("reflectance [1.5, 0.5, 0.5] must be within [0, 1]"),
        "{e}"
    );
    let body = format!("[[object]]\nname = \"floor\"\n{quad}\nreflectance = [1, 0.5, 0.5]\n");
    std::fs::write(&path, body).unwrap();
    let s = load(&path, &opts()).unwrap();
    assert_eq!(s.objects[0].material.reflectance.x, 0.999);
    assert!(
        s.warnings.iter().any(|w| w.contains("clamped")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn reflectance_one_is_clamped_with_a_warning() {
    let mut root = one_box_gltf();
    root["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 1.0, 0.5, 1.0]);
    let dir = temp_dir("clamp");
    let path = dir.join("white.gltf");
    std::fs::write(&path, serde_json::to_string(&root).unwrap()).unwrap();
    let s = load(&path, &opts()).unwrap();
    assert_eq!(
        s.objects[0].material.reflectance,
        Vec3::new(0.999, 0.999, 0.5)
    );
    assert!(
        s.warnings.iter().any(|w| w.contains("clamped")),
        "{:?}",
        s.warnings
    );
}

// ----------------------------------------------------------------------------------------
// TOML scene files

#[test]
fn example_toml_loads() {
    let s = load(&scenes_dir().join("example.toml"), &opts()).unwrap();
    let names: Vec<&str> = s.objects.iter().map(|o| o.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "room",
            "light",
            "red_box",
            "ball",
            "tall_block",
            "spinner",
            "glow"
        ]
    );
    let get = |n: &str| s.objects.iter().find(|o| o.name == n).unwrap();
    assert_eq!(get("room").role, Some(Role::Boundary));
    assert_eq!(get("red_box").role, Some(Role::Interior), "inferred");
    assert_eq!(get("red_box").patch_size, Some(10.0));
    assert_eq!(s.settings.patch_size, Some(20.0));
    assert_eq!(
        s.settings.solver.get("per_frame").map(String::as_str),
        Some("1")
    );
    assert_eq!(
        s.settings.solver.get("solver").map(String::as_str),
        Some("dispersive")
    );
    // The mesh part sits where it does in the Cornell box.
    let tall = cornell_box()
        .objects
        .into_iter()
        .find(|o| o.name == "tall_block")
        .unwrap();
    assert!(same_triangle_sets(
        &world_triangles(&tall),
        &world_triangles(get("tall_block")),
        1e-3,
        true
    ));
    // The room box faces inward: negative signed volume.
    assert!(signed_volume(&world_triangles(get("room"))) < 0.0);
    // Rotated box: rotation_deg about Y.
    let Aabb { min: lo, max: hi } = get("red_box").world_bounds().unwrap();
    assert!((lo.y).abs() < 1e-3 && (hi.y - 165.0).abs() < 1e-3);
    assert!(
        hi.x - lo.x > 160.0 + 1.0,
        "rotated box is wider than 160: {lo} {hi}"
    );
    // Animation.
    let spinner = get("spinner");
    assert!(spinner.is_animated());
    let c0 = spinner.world_bounds().unwrap().centre();
    let c2 = spinner
        .mesh
        .transformed(spinner.world_from_object_at(2.0))
        .bounds()
        .unwrap()
        .centre();
    assert!(
        c2.abs_diff_eq(c0 + Vec3::new(0.0, 40.0, 0.0), 1e-3),
        "{c0} {c2}"
    );
    let glow = get("glow");
    assert_eq!(glow.material.emitted_radiance, Vec3::splat(2.0));
    assert!(glow
        .material_at(1.0)
        .emitted_radiance
        .abs_diff_eq(Vec3::splat(1.0), 1e-5));
    assert!(glow.material.double_sided);
    assert!(s.camera.is_some());
}

#[test]
fn moving_box_toml() {
    let s = load(&scenes_dir().join("moving_box.toml"), &opts()).unwrap();
    assert_eq!(s.objects.len(), 7);
    let get = |n: &str| s.objects.iter().find(|o| o.name == n).unwrap();
    let b = get("box");
    let at = |t: f32| {
        b.mesh
            .transformed(b.world_from_object_at(t))
            .bounds()
            .unwrap()
    };
    let Aabb { min: lo0, max: hi0 } = at(0.0);
    assert!((lo0.y).abs() < 1e-3 && (hi0.y - 120.0).abs() < 1e-3);
    let lo4 = at(4.0).min;
    assert!(
        lo4.x < lo0.x - 250.0,
        "moves from the red (x = 556) side to the green (x = 0) side"
    );
    assert!(lo4.x > 0.0);
    assert!((s.duration() - 4.0).abs() < 1e-6);
    let light = get("light");
    assert_eq!(
        light.material_at(1.9).emitted_radiance,
        Vec3::new(17.0, 12.0, 4.0)
    );
    assert_eq!(
        light.material_at(2.0).emitted_radiance,
        Vec3::new(4.0, 12.0, 17.0)
    );
    assert_eq!(
        light.material_at(3.5).emitted_radiance,
        Vec3::new(4.0, 12.0, 17.0)
    );
    // Walls and light are those of the built-in box.
    let cornell = cornell_box();
    for name in [
        "floor",
        "ceiling",
        "back",
        "left_red",
        "right_green",
        "light",
    ] {
        let w = cornell.objects.iter().find(|o| o.name == name).unwrap();
        assert!(
            same_triangle_sets(&world_triangles(w), &world_triangles(get(name)), 1e-3, true),
            "{name}"
        );
        assert!(
            w.material
                .reflectance
                .abs_diff_eq(get(name).material.reflectance, 1e-6),
            "{name}"
        );
        assert_eq!(w.role, get(name).role, "{name}");
    }
}

fn write_toml(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

const GOOD_OBJECT: &str = r#"
[[object]]
name = "lamp"
shape = "quad"
corners = [[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]
emission = [1, 1, 1]
"#;

/// Two objects of one name: the second could never be found by it (`Engine::object`,
/// Python, the viewer), and was accepted silently. An animation asked of a built-in scene
/// (which has none) was ignored silently too.
#[test]
fn a_name_twice_and_an_animation_of_a_builtin_are_errors() {
    let dir = temp_dir("toml_dup");
    let p = write_toml(&dir, "dup.toml", &format!("{GOOD_OBJECT}{GOOD_OBJECT}"));
    assert_err_names(
        load(&p, &opts()),
        "dup.toml",
        "the name 'lamp' is already object 0's",
    );
    let asked = LoadOptions {
        animation: Some("walk".into()),
        ..opts()
    };
    let msg = err_of(load(Path::new("cornell"), &asked));
    assert!(msg.contains("a built-in scene has none"), "{msg}");
}

#[test]
fn toml_errors_name_file_object_and_key() {
    let dir = temp_dir("toml_err");
    let ok = write_toml(&dir, "ok.toml", GOOD_OBJECT);
    load(&ok, &opts()).unwrap();
    // Unknown key, with its line.
    let p = write_toml(
        &dir,
        "unknown_key.toml",
        &format!("{GOOD_OBJECT}colour = [1, 0, 0]\n"),
    );
    let msg = err_of(load(&p, &opts()));
    assert!(
        msg.contains("unknown_key.toml") && msg.contains("colour") && msg.contains("line 7"),
        "{msg}"
    );
    // Unknown role value.
    let p = write_toml(
        &dir,
        "bad_role.toml",
        &format!("{GOOD_OBJECT}role = \"wall\"\n"),
    );
    assert_err_names(load(&p, &opts()), "bad_role.toml", "wall");
    // Wrong type.
    let p = write_toml(
        &dir,
        "bad_type.toml",
        &GOOD_OBJECT.replace("emission = [1, 1, 1]", "emission = \"bright\""),
    );
    assert_err_names(load(&p, &opts()), "bad_type.toml", "emission");
    // Negative size: names the object and its line.
    let p = write_toml(
        &dir,
        "neg.toml",
        &format!(
            "{GOOD_OBJECT}\n[[object]]\nname = \"crate\"\nshape = \"box\"\nsize = [1, -2, 1]\n"
        ),
    );
    let msg = err_of(load(&p, &opts()));
    assert!(
        msg.contains("neg.toml")
            && msg.contains("'crate'")
            && msg.contains("line 8")
            && msg.contains("size"),
        "{msg}"
    );
    // A key of another shape.
    let p = write_toml(&dir, "radius.toml", &format!("{GOOD_OBJECT}radius = 2\n"));
    assert_err_names(
        load(&p, &opts()),
        "radius.toml",
        "'radius' does not apply to shape 'quad'",
    );
    // Missing mesh file: names both files, and why it cannot be read (the OS's reason was
    // lost in the nested message: "nowhere.glb: cannot read file").
    let p = write_toml(
        &dir,
        "missing_mesh.toml",
        &format!("{GOOD_OBJECT}\n[[object]]\nshape = \"mesh\"\nfile = \"nowhere.glb\"\n"),
    );
    let err = load(&p, &opts()).err();
    let msg = err.as_ref().map(|e| e.to_string()).unwrap_or_default();
    assert!(
        msg.contains("missing_mesh.toml")
            && msg.contains("nowhere.glb")
            && msg.contains("cannot read file: No such file"),
        "{msg}"
    );
    // And it stays a file that is not there (Python's FileNotFoundError), not a bad scene.
    assert!(
        matches!(
            err,
            Some(SceneError::Unreadable {
                kind: std::io::ErrorKind::NotFound,
                ..
            })
        ),
        "{err:?}"
    );
    // A file that includes itself, and two that include each other: the cycle named once
    // (each turn had wrapped the next one's message, nine times over).
    let include = |name: &str| format!("[[object]]\nshape = \"mesh\"\nfile = \"{name}\"\n");
    let p = write_toml(&dir, "self.toml", &include("self.toml"));
    let a = write_toml(&dir, "a.toml", &include("b.toml"));
    write_toml(&dir, "b.toml", &include("a.toml"));
    for (p, turns) in [(&p, 1), (&a, 2)] {
        let msg = load(p, &opts())
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(msg.contains("an include cycle"), "{msg}");
        assert_eq!(msg.matches("object 0 (line 1)").count(), turns, "{msg}");
    }
    // Filter that matches nothing.
    let cornell = scenes_dir().join("cornell.gltf");
    let p = write_toml(
        &dir,
        "filter.toml",
        &format!(
            "{GOOD_OBJECT}\n[[object]]\nshape = \"mesh\"\nfile = {:?}\nnode = \"teapot\"\n",
            cornell.display().to_string()
        ),
    );
    assert_err_names(load(&p, &opts()), "filter.toml", "filter");
    // Bad TOML syntax.
    let p = write_toml(&dir, "syntax.toml", "[[object]\nshape = ");
    assert_err_names(load(&p, &opts()), "syntax.toml", "line 1");
    // Both patch settings.
    let p = write_toml(
        &dir,
        "patches.toml",
        &format!("[settings]\npatch_size = 1.0\npatches = 10\n{GOOD_OBJECT}"),
    );
    assert_err_names(load(&p, &opts()), "patches.toml", "not both");
}

#[test]
fn toml_mesh_file_expands_into_parts() {
    let dir = temp_dir("toml_mesh");
    let cornell = scenes_dir().join("cornell.obj");
    let p = write_toml(
        &dir,
        "whole.toml",
        &format!("[[object]]\nname = \"cb\"\nshape = \"mesh\"\nfile = {:?}\nrole = \"interior\"\nposition = [0, 100, 0]\n", cornell.display().to_string()),
    );
    let s = load(&p, &opts()).unwrap();
    assert_eq!(s.objects.len(), 8);
    assert!(s.objects.iter().all(|o| o.role == Some(Role::Interior)));
    assert!(s
        .objects
        .iter()
        .any(|o| o.name == "cb/light" && o.material.is_emissive()));
    let lo = s.bounds().unwrap().min;
    assert!((lo.y - 100.0).abs() < 1e-3);
}

// ----------------------------------------------------------------------------------------
// Bad input: errors that name the file, never panics

#[test]
fn missing_files_and_unknown_extension() {
    let dir = temp_dir("missing");
    for name in ["nothing.gltf", "nothing.glb", "nothing.obj", "nothing.toml"] {
        let msg = err_of(load(&dir.join(name), &opts()));
        assert!(msg.contains(name) && msg.contains("cannot read"), "{msg}");
    }
    let p = dir.join("scene.fbx");
    std::fs::write(&p, "x").unwrap();
    assert_err_names(load(&p, &opts()), "scene.fbx", "unknown scene format");
}

#[test]
fn bad_json_and_missing_buffer() {
    let dir = temp_dir("json");
    let p = dir.join("bad.gltf");
    std::fs::write(&p, "{ \"asset\": { \"version\": \"2.0\" }, \"nodes\": [ ").unwrap();
    assert_err_names(load(&p, &opts()), "bad.gltf", "invalid glTF");
    let mut root = one_box_gltf();
    root["buffers"][0]["uri"] = json!("gone.bin");
    let p = dir.join("extbuf.gltf");
    std::fs::write(&p, serde_json::to_string(&root).unwrap()).unwrap();
    assert_err_names(load(&p, &opts()), "extbuf.gltf", "gone.bin");
    // An accessor index out of range of the JSON.
    let mut root = one_box_gltf();
    root["meshes"][0]["primitives"][0]["indices"] = json!(42);
    let p = dir.join("badref.gltf");
    std::fs::write(&p, serde_json::to_string(&root).unwrap()).unwrap();
    assert_err_names(
        load(&p, &opts()),
        "badref.gltf",
        "meshes[0].primitives[0].indices: accessor 42 does not exist",
    );
}

#[test]
fn external_buffer_loads() {
    let dir = temp_dir("extbuf_ok");
    let path = dir.join("c.glb");
    write_gltf(&cornell_box(), &path).unwrap();
    // Turn the GLB into a .gltf + .bin pair.
    let bytes = std::fs::read(&path).unwrap();
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let mut root: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin = &bytes[20 + json_len + 8..];
    std::fs::write(dir.join("data file.bin"), bin).unwrap();
    root["buffers"][0]["uri"] = json!("data%20file.bin");
    let p = dir.join("c.gltf");
    std::fs::write(&p, serde_json::to_string(&root).unwrap()).unwrap();
    assert_same_objects(&cornell_box(), &load(&p, &opts()).unwrap());
}

fn tri_scene(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Scene {
    let mut light = Material::diffuse(Vec3::splat(0.5));
    light.emitted_radiance = Vec3::ONE;
    let mut s = Scene {
        source: "test".into(),
        ..Default::default()
    };
    s.objects.push(Object::new(
        "panel",
        Mesh {
            positions,
            triangles,
            ..Default::default()
        },
        light,
    ));
    s
}

fn square() -> Vec<Vec3> {
    vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y]
}

#[test]
fn index_out_of_range() {
    let dir = temp_dir("index");
    let s = tri_scene(square(), vec![[0, 1, 2], [0, 2, 9]]);
    let p = dir.join("index.gltf");
    write_gltf(&s, &p).unwrap();
    let msg = err_of(load(&p, &opts()));
    assert!(
        msg.contains("index.gltf") && msg.contains("out of range") && msg.contains("panel"),
        "{msg}"
    );
    let p = dir.join("index.obj");
    std::fs::write(&p, "o panel\nv 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 3 7\n").unwrap();
    assert_err_names(load(&p, &opts()), "index.obj", "out of bounds");
    // A face of two vertices (tobj dropped it: "the scene has no objects") and one word
    // that is no index (tobj: "face parse error", no line): both name their line.
    for (name, face, fault) in [
        (
            "two.obj",
            "f 1 2",
            "line 5: a face needs at least 3 vertices, this one has 2",
        ),
        (
            "word.obj",
            "f 1 2 x",
            "line 5: face vertex 'x' does not start with a vertex index",
        ),
    ] {
        let p = dir.join(name);
        let text = format!("o panel\nv 0 0 0\nv 1 0 0\nv 1 1 0\n{face}\n");
        std::fs::write(&p, text).unwrap();
        assert_err_names(load(&p, &opts()), name, fault);
    }
    // Elements short of numbers, or with a word for one, and bytes that are not UTF-8 (tobj:
    // "position parse error", "read error", no line): each names its line.
    for (name, line, fault) in [
        (
            "short.obj",
            &b"v 1 1"[..],
            "line 4: a vertex needs 3 coordinates, this one has 2",
        ),
        (
            "word-v.obj",
            b"v 1 1 x",
            "line 4: 'v' number 3 is 'x', not a number",
        ),
        (
            "short-vt.obj",
            b"vt 0.5",
            "line 4: a texture coordinate needs u and v, this one has 1",
        ),
        ("latin1.obj", b"o caf\xe9", "line 4: not UTF-8 text"),
    ] {
        let p = dir.join(name);
        let text = [&b"o panel\nv 0 0 0\nv 1 0 0\n"[..], line, b"\nf 1 2 3\n"].concat();
        std::fs::write(&p, text).unwrap();
        assert_err_names(load(&p, &opts()), name, fault);
    }
    // Faces of three or more, with texture and normal indices, negative ones, still load.
    let p = dir.join("fine.obj");
    let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\nf 1/1/1 2/1/1 3//1 -1\n";
    std::fs::write(&p, text).unwrap();
    assert_eq!(
        load(&p, &opts()).unwrap().objects[0].mesh.triangles.len(),
        2
    );
}

#[test]
fn nan_vertex_names_object_and_vertex() {
    let dir = temp_dir("nan");
    let mut pos = square();
    pos[2].y = f32::NAN;
    let s = tri_scene(pos, vec![[0, 1, 2], [0, 2, 3]]);
    let p = dir.join("nan.gltf");
    write_gltf(&s, &p).unwrap();
    let msg = err_of(load(&p, &opts()));
    assert!(
        msg.contains("nan.gltf") && msg.contains("'panel'") && msg.contains("vertex 2"),
        "{msg}"
    );
    let p = dir.join("nan.obj");
    std::fs::write(&p, "o panel\nv 0 0 0\nv 1 0 0\nv 1 nan 0\nf 1 2 3\n").unwrap();
    let msg = err_of(load(&p, &opts()));
    assert!(
        msg.contains("nan.obj") && msg.contains("'panel'") && msg.contains("vertex 2"),
        "{msg}"
    );
}

#[test]
fn zero_area_triangles_dropped_in_gltf_an_error_or_dropped_in_obj() {
    let dir = temp_dir("degenerate");
    let s = tri_scene(square(), vec![[0, 1, 2], [0, 2, 3], [0, 1, 1]]);
    let p = dir.join("flat.gltf");
    write_gltf(&s, &p).unwrap();
    // glTF allows degenerate triangles (the validator reports them as information only):
    // the reader drops them with a warning naming the primitive, with or without the flag.
    for drop_degenerate in [false, true] {
        let dropped = load(
            &p,
            &LoadOptions {
                drop_degenerate,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(
            dropped.objects[0].mesh.triangles,
            vec![[0, 1, 2], [0, 2, 3]]
        );
        assert!(
            dropped.warnings.iter().any(|w| w.contains(
                "meshes[0].primitives[0] (nodes[0] 'panel'): 1 of 3 triangle(s) have zero area"
            )),
            "{:?}",
            dropped.warnings
        );
    }
    // Only zero-area triangles: nothing to light, said so.
    let s = tri_scene(square(), vec![[0, 1, 1], [2, 2, 3]]);
    let p = dir.join("all-flat.gltf");
    write_gltf(&s, &p).unwrap();
    // A valid file: it loads empty, as a viewer opens it, saying why.
    let empty = load(&p, &opts()).unwrap();
    assert!(empty.objects.is_empty());
    assert!(
        empty.warnings.iter().any(|w| w.contains(
            "nothing to light: every triangle the scene draws has zero area (2 triangle(s) in 1 primitive(s), dropped); the scene is empty"
        )),
        "{:?}",
        empty.warnings
    );
    let p = dir.join("flat.obj");
    std::fs::write(
        &p,
        "o panel\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 2 2 0\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    assert_err_names(load(&p, &opts()), "flat.obj", "zero-area");
    let ok = load(
        &p,
        &LoadOptions {
            drop_degenerate: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(ok.objects[0].mesh.triangles.len(), 1);
}

#[test]
fn obj_materials_missing_mtl_and_malformed_lines() {
    let dir = temp_dir("obj");
    std::fs::write(
        dir.join("m.mtl"),
        "newmtl lamp\nKd 1 1 1\nKe 5 4 3\nnewmtl grey\nKd 0.3 0.3 0.3\n",
    )
    .unwrap();
    let p = dir.join("m.obj");
    std::fs::write(
        &p,
        "mtllib m.mtl\no lamp\nv 0 1 0\nv 1 1 0\nv 1 1 1\nv 0 1 1\nusemtl lamp\nf 1 4 3 2\no floor\nv 0 0 0\nv 0 0 1\nv 1 0 1\nv 1 0 0\nusemtl grey\nf 5 6 7 8\n",
    )
    .unwrap();
    let s = load(&p, &opts()).unwrap();
    assert_eq!(s.objects.len(), 2);
    let lamp = &s.objects[0];
    assert_eq!(lamp.mesh.triangles.len(), 2, "quad triangulated");
    assert_eq!(lamp.material.emitted_radiance, Vec3::new(5.0, 4.0, 3.0));
    assert_eq!(lamp.role, Some(Role::Light));
    assert!(
        s.warnings.iter().any(|w| w.contains("clamped")),
        "Kd 1 clamped: {:?}",
        s.warnings
    );
    assert_eq!(s.objects[1].material.reflectance, Vec3::splat(0.3));
    assert!(
        !s.warnings.iter().any(|w| w.contains("usemtl")),
        "{:?}",
        s.warnings
    );
    // Missing MTL: warning and default material (then no emitter: a warning too).
    std::fs::remove_file(dir.join("m.mtl")).unwrap();
    let s = load(&p, &opts()).unwrap();
    assert!(
        s.warnings.iter().any(|w| w.contains("material library")),
        "{:?}",
        s.warnings
    );
    assert_eq!(s.objects[0].material, Material::default());
    // A one-value colour is grey (MTL allows it); a malformed one is an error naming the MTL.
    std::fs::write(dir.join("m.mtl"), "newmtl lamp\nKd 0.5\nKe 2\n").unwrap();
    let s = load(&p, &opts()).unwrap();
    assert_eq!(s.objects[0].material.reflectance, Vec3::splat(0.5));
    assert_eq!(s.objects[0].material.emitted_radiance, Vec3::splat(2.0));
    // A bare `usemtl` is an error with its line (tobj said "material parse error").
    let bare = dir.join("bare.obj");
    std::fs::write(&bare, "v 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl\nf 1 2 3\n").unwrap();
    let msg = err_of(load(&bare, &opts()));
    assert!(
        msg.contains("line 4: usemtl without a material name"),
        "{msg}"
    );
    // A library that is a folder (or a device: /dev/zero was read until memory ran out) is
    // named as such, and the default material taken.
    std::fs::create_dir_all(dir.join("folder.mtl")).unwrap();
    let odd = dir.join("odd.obj");
    std::fs::write(
        &odd,
        "mtllib folder.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let o = load(&odd, &opts()).unwrap();
    assert!(
        o.warnings.iter().any(|w| w.contains("it is a folder")),
        "{:?}",
        o.warnings
    );
    #[cfg(target_os = "linux")]
    {
        std::fs::write(
            &odd,
            "mtllib /dev/zero\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        )
        .unwrap();
        let o = load(&odd, &opts()).unwrap();
        let said = |w: &String| w.contains("/dev/zero") && w.contains("not a regular file");
        assert!(o.warnings.iter().any(said), "{:?}", o.warnings);
    }
    // That library has no `grey`: its faces take the default material, with a word.
    assert_eq!(s.objects[1].material, Material::default());
    assert!(
        s.warnings.iter().any(|w| w.contains(
            "line 14: usemtl 'grey' names no material of the libraries read (1 defined)"
        )),
        "{:?}",
        s.warnings
    );
    std::fs::write(dir.join("m.mtl"), "newmtl lamp\nKd 0.5 0.5\n").unwrap();
    let msg = err_of(load(&p, &opts()));
    assert!(
        msg.contains("m.mtl") && msg.contains("line 2") && msg.contains("m.obj"),
        "{msg}"
    );
}

#[test]
fn gltf_unknown_role_in_extras() {
    let mut root = one_box_gltf();
    root["nodes"][0]["extras"] = json!({"shrad_role": "wall"});
    let dir = temp_dir("extras");
    let p = dir.join("role.gltf");
    std::fs::write(&p, serde_json::to_string(&root).unwrap()).unwrap();
    assert_err_names(load(&p, &opts()), "role.gltf", "unknown shrad_role 'wall'");
    root["nodes"][0]["extras"] = json!({"shrad_role": "light", "shrad_patch_size": 0.25});
    std::fs::write(&p, serde_json::to_string(&root).unwrap()).unwrap();
    let s = load(&p, &opts()).unwrap();
    assert_eq!(s.objects[0].role, Some(Role::Light));
    assert_eq!(s.objects[0].patch_size, Some(0.25));
    // A patch size that is no positive length is an error, on the node or the mesh (it gave
    // one patch a triangle, or was ignored).
    for (at, bad) in [
        ("nodes", json!(-1)),
        ("nodes", json!(0)),
        ("meshes", json!("big")),
    ] {
        let mut root = one_box_gltf();
        root[at][0]["extras"] = json!({ "shrad_patch_size": bad });
        std::fs::write(&p, serde_json::to_string(&root).unwrap()).unwrap();
        assert_err_names(
            load(&p, &opts()),
            "role.gltf",
            &format!("shrad_patch_size must be a positive number (a length in the file's units), not {bad}"),
        );
    }
}

/// A glTF whose corners lie beyond the coordinates a solve holds is refused by its reach:
/// one unit apart 1e15 away, in 32-bit floats, its triangles read as of no area and were
/// dropped with a warning that said so (false), and the file loaded empty.
#[test]
fn gltf_beyond_the_coordinates_a_solve_holds_is_refused_not_dropped() {
    let dir = temp_dir("far-gltf");
    let far = square().into_iter().map(|v| v + Vec3::X * 1e15).collect();
    let s = tri_scene(far, vec![[0, 1, 2], [0, 2, 3]]);
    let p = dir.join("far.gltf");
    write_gltf(&s, &p).unwrap();
    assert_err_names(
        load(&p, &opts()),
        "far.gltf",
        "world coordinates reach 1.0e15",
    );
}

#[test]
fn repeated_triangles_are_dropped_with_a_warning_in_every_format() {
    let dir = temp_dir("repeated");
    // Triangle 2 repeats 0 from another corner; 3 is 0 mirrored (the back of the same
    // sheet: kept).
    let s = tri_scene(square(), vec![[0, 1, 2], [0, 2, 3], [1, 2, 0], [0, 2, 1]]);
    for name in ["twice.gltf", "twice.obj"] {
        let p = dir.join(name);
        match name.ends_with(".obj") {
            true => write_obj(&s, &p).unwrap(),
            false => write_gltf(&s, &p).unwrap(),
        }
        let loaded = load(&p, &LoadOptions::default()).unwrap();
        assert_eq!(loaded.objects[0].mesh.triangles.len(), 3, "{name}");
        let said = "dropped 1 repeated triangle(s)";
        assert!(
            loaded.warnings.iter().any(|w| w.contains(said)),
            "{name}: {:?}",
            loaded.warnings
        );
    }
}
