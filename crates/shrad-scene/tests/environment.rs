//! The scene file's `[environment]` and the maps it reads: a uniform radiance, an OpenEXR
//! and a Radiance `.hdr` map read back texel for texel (row 0 the top), and bad values as
//! errors naming the file: a negative radiance, a missing or malformed map, a NaN or a
//! negative texel.

use std::path::{Path, PathBuf};

use glam::Vec3;
use shrad_scene::{load, EnvMap, LoadOptions, SceneError};

const FLOOR: &str = r#"
[[object]]
shape = "quad"
corners = [[-1, 0, -1], [-1, 0, 1], [1, 0, 1], [1, 0, -1]]
"#;

fn dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("shrad-toml-env-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn write(name: &str, environment: &str) -> PathBuf {
    let p = dir().join(name);
    std::fs::write(&p, format!("{FLOOR}\n[environment]\n{environment}")).unwrap();
    p
}

fn load_err(p: &Path) -> String {
    load(p, &LoadOptions::default()).unwrap_err().to_string()
}

/// A 4x2 map, its texels distinct and the top row bright.
fn texels() -> Vec<[f32; 3]> {
    (0..8)
        .map(|k| {
            let top = if k < 4 { 10.0 } else { 0.0 };
            [top + k as f32, 0.5 * k as f32, 0.25]
        })
        .collect()
}

fn save(name: &str, texels: &[[f32; 3]]) -> PathBuf {
    let p = dir().join(name);
    let flat: Vec<f32> = texels.iter().flatten().copied().collect();
    image::Rgb32FImage::from_raw(4, 2, flat)
        .unwrap()
        .save(&p)
        .unwrap();
    p
}

#[test]
fn a_uniform_sky_and_maps_load() {
    let p = write("uniform.toml", "radiance = [0.5, 0.6, 0.8]\nscale = 2");
    let env = load(&p, &LoadOptions::default())
        .unwrap()
        .environment
        .unwrap();
    assert_eq!(env.radiance, Vec3::new(0.5, 0.6, 0.8));
    assert_eq!((env.scale, env.rotate_deg), (2.0, 0.0));
    assert!(env.map.is_none());
    for name in ["map.exr", "map.hdr"] {
        save(name, &texels());
        let p = write(
            &format!("{name}.toml"),
            &format!("file = \"{name}\"\nrotate_deg = 90"),
        );
        let env = load(&p, &LoadOptions::default())
            .unwrap()
            .environment
            .unwrap();
        assert_eq!(env.rotate_deg, 90.0);
        let m = env.map.unwrap();
        assert_eq!((m.width, m.height), (4, 2));
        // OpenEXR keeps f32 exactly; RGBE keeps about 1 % (8-bit mantissas).
        let tol = if name.ends_with("exr") { 0.0 } else { 0.01 };
        for (got, want) in m.texels.iter().zip(texels()) {
            let want = Vec3::from_array(want);
            assert!(
                (*got - want).abs().max_element() <= tol * want.max_element() + 1e-6,
                "{name}: {got} vs {want}"
            );
        }
    }
}

#[test]
fn bad_values_are_errors_naming_the_file() {
    let p = write("negative.toml", "radiance = [-1, 0, 0]");
    let e = load_err(&p);
    assert!(
        e.contains("negative.toml") && e.contains("[environment]") && e.contains(">= 0"),
        "{e}"
    );
    let p = write("both.toml", "radiance = [1, 1, 1]\nfile = \"x.exr\"");
    assert!(load_err(&p).contains("not both"));
    let p = write("neither.toml", "scale = 2");
    assert!(load_err(&p).contains("needs 'radiance'"));
    let p = write("scale.toml", "radiance = [1, 1, 1]\nscale = -2");
    assert!(load_err(&p).contains("scale -2"));
    // Finite, but beyond what a solve's sums hold (the picture was black, every value reset).
    let p = write("bright.toml", "radiance = [1e38, 1, 1]");
    assert!(load_err(&p).contains("beyond the 1e20"), "{}", load_err(&p));
    let p = write("scaled.toml", "radiance = [1e15, 1, 1]\nscale = 1e10");
    assert!(load_err(&p).contains("1.000e25"), "{}", load_err(&p));
    let p = write("missing.toml", "file = \"nowhere.exr\"");
    let e = load_err(&p);
    assert!(
        e.contains("missing.toml") && e.contains("nowhere.exr") && e.contains("cannot read"),
        "{e}"
    );
    let junk = dir().join("junk.exr");
    std::fs::write(&junk, "not an image").unwrap();
    let e = EnvMap::load(&junk).unwrap_err().to_string();
    assert!(
        e.contains("junk.exr") && e.contains("not a readable map"),
        "{e}"
    );
    // A header that declares more texels than a map may have is refused by its size, from
    // the header (the decoder said "Memory limit exceeded").
    let huge = dir().join("huge.hdr");
    std::fs::write(
        &huge,
        "#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 100000 +X 100000\njunk",
    )
    .unwrap();
    let e = EnvMap::load(&huge).unwrap_err().to_string();
    assert!(
        e.contains("huge.hdr") && e.contains("100000x100000") && e.contains("1..=16384"),
        "{e}"
    );
    let png = dir().join("sky.png");
    std::fs::write(&png, "").unwrap();
    let e = EnvMap::load(&png).unwrap_err().to_string();
    assert!(e.contains("sky.png") && e.contains(".exr"), "{e}");
    let mut t = texels();
    t[5][1] = f32::NAN;
    let e = EnvMap::load(&save("nan.exr", &t)).unwrap_err().to_string();
    assert!(
        e.contains("nan.exr") && e.contains("texel (1, 1)") && e.contains("finite"),
        "{e}"
    );
    t[5][1] = -3.0;
    let e = EnvMap::load(&save("neg.exr", &t)).unwrap_err().to_string();
    assert!(
        e.contains("neg.exr") && e.contains("texel (1, 1)") && e.contains("negative"),
        "{e}"
    );
    assert!(matches!(
        EnvMap::load(&dir().join("absent.hdr")),
        Err(SceneError::Io { .. })
    ));
}
