//! `shrad bake --lightmap` as a user meets it: the glTF and its EXR are written, the glTF
//! passes the Khronos glTF-Validator with no error and loads in three.js's GLTFLoader
//! (validation/bake/validate.mjs, node; `npm ci` there is done by scripts/setup-python);
//! bad lightmap options exit non-zero naming the option and leave no file.

use crate::common;

use std::process::Command;

use common::{bake_cornell, files_in, shrad, temp_dir};

#[test]
fn bake_lightmap_passes_the_validator_and_loads_in_three() {
    let (dir, out, o) = bake_cornell("lightmap", &["-q", "--lightmap", "--lightmap-res", "256"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names = file_names(&dir);
    assert_eq!(names, ["c.glb", "c.lightmap.exr"]);
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../validation/bake");
    assert!(
        root.join("node_modules/gltf-validator").is_dir(),
        "validation/bake/node_modules is missing: run scripts/setup-bake-validators (npm ci there)"
    );
    let v = Command::new("node")
        .arg(root.join("validate.mjs"))
        .arg(&out)
        .output()
        .expect("node runs (the validators run in node)");
    let report = String::from_utf8_lossy(&v.stdout);
    assert!(
        v.status.success(),
        "{report}{}",
        String::from_utf8_lossy(&v.stderr)
    );
    // One JSON line (validate.mjs): the validator's counts, then three.js's meshes.
    assert!(report.contains(r#""errors":0,"warnings":0"#), "{report}");
    assert_eq!(report.matches(r#""vertexColors""#).count(), 8, "{report}");
    // Every mesh has uv1 and its map (the lit surface) reads it.
    assert_eq!(
        report.matches(r#""uv1":2,"mapChannel":1"#).count(),
        8,
        "{report}"
    );
}

/// `--lightmap-format rgbm` writes the RGBM PNG instead of the EXR and says its multiplier
/// (its decoding against the EXR: shrad's tests/lightmap_rgbm.rs).
#[test]
fn bake_lightmap_rgbm_writes_the_png_and_states_its_multiplier() {
    let dir = temp_dir("lightmap-rgbm");
    let out = dir.join("c.glb");
    let o = shrad(&[
        "bake",
        "cornell",
        "--patches",
        "200",
        "--lightmap",
        "--lightmap-res",
        "64",
        "--lightmap-format",
        "rgbm",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let names = file_names(&dir);
    assert_eq!(names, ["c.glb", "c.lightmap.png"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("c.lightmap.png (RGBM PNG: E / pi = rgb * a * "),
        "{stdout}"
    );
}

#[test]
fn bad_lightmap_options_fail_cleanly_and_write_nothing() {
    let dir = temp_dir("lightmap-bad");
    let out = dir.join("c.glb");
    let out = out.to_str().unwrap();
    for (args, needle) in [
        (vec!["--lightmap", "--texel-size", "-1"], "--texel-size"),
        (
            vec!["--lightmap", "--texel-size", "0.001"],
            "larger texel size",
        ),
        (vec!["--lightmap", "--lightmap-res", "4"], "--lightmap-res"),
        (
            vec!["--lightmap", "--lightmap-res", "64", "--texel-size", "1"],
            "cannot be used with",
        ),
        (vec!["--texel-size", "1"], "--lightmap"),
        (vec!["--lightmap-format", "rgbm"], "--lightmap"),
        (
            vec!["--lightmap", "--lightmap-format", "rgbe"],
            "possible values: exr, rgbm",
        ),
    ] {
        let mut all = vec!["bake", "-q", "--patches", "200", "cornell", "-o", out];
        all.extend_from_slice(&args);
        let o = shrad(&all);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_ne!(o.status.code(), Some(0), "{args:?} succeeded");
        assert!(stderr.contains(needle), "expected '{needle}' in: {stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(files_in(&dir).is_empty(), "left: {:?}", files_in(&dir));
    }
}

/// The names of the files in `dir`, sorted.
fn file_names(dir: &std::path::Path) -> Vec<String> {
    let mut names: Vec<String> = files_in(dir)
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}
