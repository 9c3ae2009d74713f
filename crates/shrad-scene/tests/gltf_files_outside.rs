//! glTF files that name files outside their folder (an absolute path, a `file:` or other
//! URL, `..` leading out, a symbolic link out): refused, naming the URI and why, where the
//! same layout with the file inside the folder loads. And the other rules on what a glTF's
//! references may be: a buffer's file at least its byteLength, a scene's root nodes unique.

use std::path::{Path, PathBuf};

use serde_json::{json, Value};
use shrad_scene::{load, LoadOptions, Scene};

use crate::common::err_of;

/// A fresh empty temporary directory for one test.
fn temp_dir(name: &str) -> PathBuf {
    crate::common::temp_dir(&format!(
        "shrad-scene-{}-outside-{name}",
        std::process::id()
    ))
}

/// The 44 bytes of one triangle: indices 0 1 2 (u16, padded to 8 bytes), then the
/// positions (0, 0, 0), (1, 0, 0), (0, 1, 0).
fn triangle_bytes() -> Vec<u8> {
    let mut b: Vec<u8> = [0u16, 1, 2, 0]
        .iter()
        .flat_map(|i| i.to_le_bytes())
        .collect();
    for p in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
        b.extend(p.iter().flat_map(|c| c.to_le_bytes()));
    }
    b
}

/// A one-triangle glTF whose buffer is `uri`.
fn triangle_gltf(uri: &str) -> Value {
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 1}, "indices": 0, "material": 0}]}],
        "materials": [{
            "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.6, 0.4, 1.0]},
            "emissiveFactor": [1.0, 1.0, 1.0]
        }],
        "buffers": [{"uri": uri, "byteLength": 44}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 6, "target": 34963},
            {"buffer": 0, "byteOffset": 8, "byteLength": 36, "target": 34962}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5123, "count": 3, "type": "SCALAR"},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3",
             "max": [1.0, 1.0, 0.0], "min": [0.0, 0.0, 0.0]}
        ]
    })
}

fn write_gltf(path: &Path, v: &Value) {
    std::fs::write(path, serde_json::to_vec(v).unwrap()).unwrap();
}

fn loads_one_object(path: &Path) -> Scene {
    let s = load(path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{} should load: {e}", path.display()));
    assert_eq!(s.objects.len(), 1, "{:?}", s.warnings);
    s
}

/// The folder `root/model` with `scene.gltf` to come, and beside it (outside) `secret.bin`
/// holding a valid triangle: read, the file would load.
fn model_beside_a_secret(name: &str) -> (PathBuf, PathBuf) {
    let root = temp_dir(name);
    let dir = root.join("model");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(root.join("secret.bin"), triangle_bytes()).unwrap();
    (root, dir)
}

#[test]
fn buffer_uris_outside_the_folder_are_refused() {
    let (root, dir) = model_beside_a_secret("buffers");
    let secret = root.join("secret.bin");
    let gltf = dir.join("scene.gltf");
    let outside = "refers to a file outside the folder of the glTF file";
    let only = "shrad reads only files in that folder and below";
    let mut cases: Vec<(String, &str)> = vec![
        (secret.display().to_string(), "it is an absolute path"),
        (format!("file://{}", secret.display()), "a file: URL"),
        (
            "../secret.bin".into(),
            "'..' components lead out of the folder",
        ),
        (
            "./sub/../../secret.bin".into(),
            "'..' components lead out of the folder",
        ),
        (
            "..%2Fsecret.bin".into(),
            "'..' components lead out of the folder",
        ),
        (
            "../../../../../../../../../../../..".to_string() + &secret.display().to_string(),
            "'..' components lead out of the folder",
        ),
    ];
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("../secret.bin", dir.join("link.bin")).unwrap();
        cases.push(("link.bin".into(), "through a symbolic link"));
    }
    for (uri, why) in &cases {
        write_gltf(&gltf, &triangle_gltf(uri));
        let msg = err_of(load(&gltf, &LoadOptions::default()));
        for part in [
            gltf.display().to_string().as_str(),
            "buffers[0].uri",
            &format!("'{uri}' {outside}"),
            why,
            only,
        ] {
            assert!(msg.contains(part), "{uri}: does not say '{part}': {msg}");
        }
    }
    // A URL of another scheme: refused as no file of the folder.
    write_gltf(&gltf, &triangle_gltf("http://127.0.0.1:1/secret.bin"));
    let msg = err_of(load(&gltf, &LoadOptions::default()));
    assert!(
        msg.contains("'http://127.0.0.1:1/secret.bin' is a URL (http:)") && msg.contains(only),
        "{msg}"
    );

    // The same layout with the file in the folder or below (spaces, unicode, percent-encoding,
    // `..` that stays inside, a link that stays inside): loads.
    std::fs::create_dir_all(dir.join("sub dir/ünï")).unwrap();
    std::fs::write(dir.join("tri.bin"), triangle_bytes()).unwrap();
    std::fs::write(dir.join("sub dir/ünï/tri 2.bin"), triangle_bytes()).unwrap();
    let mut inside = vec![
        "tri.bin",
        "./tri.bin",
        "sub%20dir/../tri.bin",
        "sub%20dir/%C3%BCn%C3%AF/tri%202.bin",
        "sub dir/ünï/tri 2.bin",
    ];
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink("sub dir/ünï/tri 2.bin", dir.join("in.bin")).unwrap();
        inside.push("in.bin");
    }
    for uri in inside {
        write_gltf(&gltf, &triangle_gltf(uri));
        loads_one_object(&gltf);
    }
    // And the secret itself, from a glTF file beside it.
    let beside = root.join("beside.gltf");
    write_gltf(&beside, &triangle_gltf("secret.bin"));
    loads_one_object(&beside);
}

#[test]
fn image_uris_outside_the_folder_are_not_read() {
    let (root, dir) = model_beside_a_secret("images");
    std::fs::write(dir.join("tri.bin"), triangle_bytes()).unwrap();
    // A grey image: read, it would darken the material's reflectance.
    image::RgbImage::from_pixel(2, 2, image::Rgb([128, 128, 128]))
        .save(root.join("grey.png"))
        .unwrap();
    let with_image = |uri: &str| {
        let mut v = triangle_gltf("tri.bin");
        v["images"] = json!([{"uri": uri}]);
        v["textures"] = json!([{"source": 0}]);
        v["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
        v
    };
    let gltf = dir.join("scene.gltf");
    let factor = glam::Vec3::new(0.8, 0.6, 0.4);
    let grey = root.join("grey.png").display().to_string();
    for (uri, why) in [
        (
            "../grey.png".to_string(),
            "'..' components lead out of the folder",
        ),
        (grey.clone(), "it is an absolute path"),
        (format!("file://{grey}"), "a file: URL"),
    ] {
        write_gltf(&gltf, &with_image(&uri));
        let s = loads_one_object(&gltf);
        let warned = s.warnings.iter().find(|w| w.contains("cannot be loaded"));
        let w = warned.unwrap_or_else(|| panic!("{uri}: no warning: {:?}", s.warnings));
        for part in [
            format!("'{uri}' refers to a file outside the folder of the glTF file"),
            why.to_string(),
            "shrad reads only files in that folder and below".to_string(),
        ] {
            assert!(w.contains(&part), "{uri}: does not say '{part}': {w}");
        }
        let got = s.objects[0].material.reflectance;
        assert!(
            got.abs_diff_eq(factor, 1e-6),
            "{uri}: the image was read: {got}"
        );
    }
    // The image in the folder: read (grey times the factor).
    std::fs::copy(root.join("grey.png"), dir.join("grey.png")).unwrap();
    write_gltf(&gltf, &with_image("grey.png"));
    let s = loads_one_object(&gltf);
    assert!(
        !s.warnings.iter().any(|w| w.contains("cannot be loaded")),
        "{:?}",
        s.warnings
    );
    let got = s.objects[0].material.reflectance;
    assert!(
        !got.abs_diff_eq(factor, 1e-3),
        "the image was not read: {got}"
    );
}

#[test]
fn a_buffer_file_shorter_than_its_byte_length_is_refused_naming_it() {
    let dir = temp_dir("length");
    let gltf = dir.join("scene.gltf");
    write_gltf(&gltf, &triangle_gltf("short%20one.bin"));
    std::fs::write(dir.join("short one.bin"), &triangle_bytes()[..40]).unwrap();
    let msg = err_of(load(&gltf, &LoadOptions::default()));
    let file = dir.join("short one.bin").display().to_string();
    for part in [
        gltf.display().to_string(),
        "buffers[0].uri".into(),
        format!("'{file}' has 40 bytes, fewer than the buffer's byteLength 44"),
    ] {
        assert!(msg.contains(&part), "does not say '{part}': {msg}");
    }
    // Its full 44 bytes: loads; with more behind them (not read), too.
    std::fs::write(dir.join("short one.bin"), triangle_bytes()).unwrap();
    loads_one_object(&gltf);
    let mut long = triangle_bytes();
    long.resize(1 << 20, 0xff);
    std::fs::write(dir.join("short one.bin"), long).unwrap();
    loads_one_object(&gltf);
}

#[test]
fn a_node_listed_twice_in_a_scene_is_refused() {
    let dir = temp_dir("scene_nodes");
    std::fs::write(dir.join("tri.bin"), triangle_bytes()).unwrap();
    let gltf = dir.join("twice.gltf");
    let mut v = triangle_gltf("tri.bin");
    v["scenes"][0]["nodes"] = json!([0, 0]);
    write_gltf(&gltf, &v);
    let msg = err_of(load(&gltf, &LoadOptions::default()));
    for part in [
        gltf.display().to_string().as_str(),
        "scenes[0].nodes: node 0 is listed twice (at 0 and 1",
        "a scene's root nodes must be unique",
    ] {
        assert!(msg.contains(part), "does not say '{part}': {msg}");
    }
    // Among others, in a second scene.
    v["nodes"] = json!([{"mesh": 0}, {"mesh": 0, "translation": [2.0, 0.0, 0.0]}]);
    v["scenes"] = json!([{"nodes": [0, 1]}, {"nodes": [1, 0, 1]}]);
    write_gltf(&gltf, &v);
    let msg = err_of(load(&gltf, &LoadOptions::default()));
    assert!(
        msg.contains("scenes[1].nodes: node 1 is listed twice (at 0 and 2"),
        "{msg}"
    );
    // Each node once (two nodes may share a mesh): loads, one object each.
    v["scenes"] = json!([{"nodes": [0, 1]}]);
    write_gltf(&gltf, &v);
    let s = load(&gltf, &LoadOptions::default()).unwrap();
    assert_eq!(s.objects.len(), 2, "{:?}", s.warnings);
    v["scenes"][0]["nodes"] = json!([0]);
    write_gltf(&gltf, &v);
    loads_one_object(&gltf);
}
