//! What this crate's integration tests share: a hook that counts panics, fresh temporary
//! folders, Blender's recorded matrices, and an error as a user reads it.
#![allow(dead_code)]

pub mod blender;
pub mod gltf_bin;
pub mod panics;

use std::path::PathBuf;

/// A fresh empty folder `name` in the temporary directory (emptied if it was there).
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Write glTF JSON `root` as `NAME.gltf` in a fresh folder of its own (named after the test
/// file's `suite`, this process and `name`, so that tests never share one) and return its
/// path.
pub fn gltf_json_file(suite: &str, name: &str, root: &serde_json::Value) -> PathBuf {
    let dir = temp_dir(&format!("shrad-{suite}-{}-{name}", std::process::id()));
    let p = dir.join(format!("{name}.gltf"));
    std::fs::write(&p, serde_json::to_string_pretty(root).unwrap()).unwrap();
    p
}

/// Load glTF JSON `root` written by [`gltf_json_file`]; a refusal fails the test.
pub fn load_gltf_json(suite: &str, name: &str, root: &serde_json::Value) -> shrad_scene::Scene {
    let p = gltf_json_file(suite, name, root);
    shrad_scene::load(&p, &shrad_scene::LoadOptions::default())
        .unwrap_or_else(|e| panic!("{name}: refused: {e}"))
}

/// The error of a load that should have failed, as a user reads it (the CLI prints the
/// error and its causes); a scene loaded instead is a failure of the test.
pub fn err_of(r: Result<shrad_scene::Scene, shrad_scene::SceneError>) -> String {
    match r {
        Ok(s) => panic!(
            "expected an error, got a scene of {} objects (warnings {:?})",
            s.objects.len(),
            s.warnings
        ),
        Err(e) => {
            let mut msg = e.to_string();
            let mut cause = std::error::Error::source(&e);
            while let Some(c) = cause {
                msg = format!("{msg}: {c}");
                cause = c.source();
            }
            msg
        }
    }
}

/// A `w x h` RGBA PNG of colour `rgb` whose alpha at texel `(x, y)` is `alpha(x, y)`, as a
/// data URI.
pub fn rgba_png_uri(w: u32, h: u32, rgb: [u8; 3], alpha: impl Fn(u32, u32) -> u8) -> String {
    let mut img = image::RgbaImage::new(w, h);
    for (x, y, p) in img.enumerate_pixels_mut() {
        *p = image::Rgba([rgb[0], rgb[1], rgb[2], alpha(x, y)]);
    }
    let mut bytes = Vec::new();
    image::DynamicImage::ImageRgba8(img)
        .write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .unwrap();
    format!("data:image/png;base64,{}", base64::encode(&bytes))
}
