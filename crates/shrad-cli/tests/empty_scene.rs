//! A valid glTF with nothing to light (every triangle of zero area: its POSITION accessor
//! has no bufferView, so it is all zeros, glTF 2.0 "Accessors") loads empty, as a viewer
//! opens it: `shrad render` writes the background with a warning saying why and exits 0;
//! `shrad bake` refuses it saying there is nothing to bake, and writes nothing.

use crate::common;

use std::path::{Path, PathBuf};

use common::{files_in, shrad, temp_dir};

/// One triangle whose three positions are zeros (an accessor without bufferView).
fn zero_positions(dir: &Path) -> PathBuf {
    let json = r#"{
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"name": "placeholder", "mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
        "accessors": [{"componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [0, 0, 0]}]
    }"#;
    let p = dir.join("zeros.gltf");
    std::fs::write(&p, json).unwrap();
    p
}

#[test]
fn render_of_a_scene_with_nothing_to_light_writes_the_background() {
    let dir = temp_dir("empty-render");
    let scene = zero_positions(&dir);
    for solver in ["reference", "dispersive", "grid"] {
        let png = dir.join(format!("{solver}.png"));
        let exr = dir.join(format!("{solver}.exr"));
        let o = shrad(&[
            "render",
            scene.to_str().unwrap(),
            "--solver",
            solver,
            "--width",
            "24",
            "--height",
            "16",
            "-o",
            png.to_str().unwrap(),
            "--hdr",
            exr.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(0), "{solver}: {stderr}");
        assert!(!stderr.contains("panicked"), "{solver}: {stderr}");
        assert!(
            stderr.contains(
                "warning: nothing to light: every triangle the scene draws has zero area (1 triangle(s) in 1 primitive(s), dropped); the scene is empty"
            ),
            "{solver}: {stderr}"
        );
        let picture =
            shrad_scene::TextureImage::decode(&std::fs::read(&png).unwrap(), "png".into()).unwrap();
        assert_eq!((picture.width(), picture.height()), (24, 16));
        for y in 0..16 {
            for x in 0..24 {
                assert_eq!(
                    picture.texel(x, y),
                    glam::Vec3::ZERO,
                    "{solver}: pixel {x} {y}"
                );
            }
        }
        let radiance = shrad::image_io::read_exr(&exr).unwrap();
        assert!(
            radiance.pixels.iter().all(|p| *p == glam::Vec3::ZERO),
            "{solver}"
        );
    }
}

#[test]
fn bake_of_a_scene_with_nothing_to_light_is_refused() {
    let dir = temp_dir("empty-bake");
    let scene = zero_positions(&dir);
    let out = dir.join("out.glb");
    for extra in [&[][..], &["--lightmap"][..]] {
        let mut args = vec!["bake", scene.to_str().unwrap(), "-o", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        let o = shrad(&args);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{extra:?}: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(
            stderr.contains("zeros.gltf") && stderr.contains("nothing to bake"),
            "{extra:?}: {stderr}"
        );
        assert_eq!(files_in(&dir), std::slice::from_ref(&scene), "{extra:?}");
    }
}
