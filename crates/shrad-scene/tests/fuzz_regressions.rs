//! Replays the fuzz seed corpus (`fuzz/seeds/<target>/*`) and every minimised crash input
//! that was fixed (`fuzz/regressions/<target>/*`) through `shrad_scene::load`, the way the
//! fuzz targets in `fuzz/fuzz_targets/` feed them, and asserts that nothing panics: neither
//! out of `load` nor inside it (the readers' own `catch_unwind` guards would hide a panic,
//! so a panic hook counts every panic on this thread, except those inside
//! draco-oxide-decoder, which the Draco step catches on purpose). An `Err` is fine. See fuzz/README.md.

use std::path::{Path, PathBuf};

use shrad_scene::{load, LoadOptions};

mod common;

use common::panics::{count_panics, panics};

fn fuzz_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz")
}

fn inputs(target: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for set in ["seeds", "regressions"] {
        let Ok(rd) = std::fs::read_dir(fuzz_dir().join(set).join(target)) else {
            continue;
        };
        out.extend(rd.flatten().map(|e| e.path()).filter(|p| p.is_file()));
    }
    out.sort();
    out
}

/// The files a target writes for one input, as in `fuzz/fuzz_targets/*.rs`.
fn files(target: &str, data: &[u8]) -> Vec<(&'static str, Vec<u8>)> {
    match target {
        "gltf" => vec![("s.gltf", data.to_vec())],
        "glb" => vec![("s.glb", data.to_vec())],
        "toml" => vec![("s.toml", data.to_vec())],
        "obj" => match data.iter().position(|&b| b == 0) {
            Some(i) => vec![
                ("s.obj", data[..i].to_vec()),
                ("m.mtl", data[i + 1..].to_vec()),
            ],
            None => vec![("s.obj", data.to_vec())],
        },
        _ => unreachable!(),
    }
}

fn replay(target: &str) {
    count_panics();
    let inputs = inputs(target);
    assert!(!inputs.is_empty(), "no seeds for fuzz target {target}");
    let mut failures = Vec::new();
    for (k, input) in inputs.iter().enumerate() {
        let data = std::fs::read(input).unwrap();
        let dir = std::env::temp_dir().join(format!(
            "shrad-fuzz-replay-{}-{target}-{k}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let files = files(target, &data);
        for (name, bytes) in &files {
            std::fs::write(dir.join(name), bytes).unwrap();
        }
        let path = dir.join(files[0].0);
        let before = panics().outside_draco;
        for drop_degenerate in [false, true] {
            let opts = LoadOptions {
                drop_degenerate,
                ..Default::default()
            };
            let r = std::panic::catch_unwind(|| load(&path, &opts).map(|_| ()));
            if r.is_err() {
                failures.push(format!("{}: load panicked", input.display()));
            }
        }
        if panics().outside_draco != before {
            failures.push(format!("{}: panicked inside load", input.display()));
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn gltf_inputs_never_panic() {
    replay("gltf");
}

#[test]
fn glb_inputs_never_panic() {
    replay("glb");
}

#[test]
fn obj_inputs_never_panic() {
    replay("obj");
}

#[test]
fn toml_inputs_never_panic() {
    replay("toml");
}

/// The seeds are meant to be valid: they should load, so the fuzzer starts from the paths
/// that matter (a typo in a seed would make it start from an error path).
#[test]
fn hand_written_seeds_load() {
    for (target, name) in [
        ("gltf", "tri.gltf"),
        ("gltf", "strip.gltf"),
        ("gltf", "cornell.gltf"),
        ("gltf", "texture.gltf"),
        ("gltf", "cornell-quant.gltf"),
        ("gltf", "cornell-meshopt.gltf"),
        ("gltf", "cornell-meshopt-cc.gltf"),
        ("gltf", "cornell-draco.gltf"),
        ("gltf", "library_sparse_zeros.gltf"),
        ("glb", "cornell-draco.glb"),
        ("glb", "tri.glb"),
        ("glb", "texture.glb"),
        ("glb", "cornell.glb"),
        ("obj", "tri"),
        ("obj", "cornell"),
        ("toml", "minimal.toml"),
        ("toml", "example_primitives.toml"),
    ] {
        let data = std::fs::read(fuzz_dir().join("seeds").join(target).join(name)).unwrap();
        let dir = std::env::temp_dir().join(format!(
            "shrad-fuzz-seed-{}-{target}-{name}",
            std::process::id()
        ));
        std::fs::create_dir_all(&dir).unwrap();
        let files = files(target, &data);
        for (f, bytes) in &files {
            std::fs::write(dir.join(f), bytes).unwrap();
        }
        let r = load(&dir.join(files[0].0), &LoadOptions::default());
        let _ = std::fs::remove_dir_all(&dir);
        let scene = r.unwrap_or_else(|e| panic!("seed {target}/{name}: {e}"));
        assert!(
            !scene.objects.is_empty(),
            "seed {target}/{name}: no objects"
        );
        if name.starts_with("texture") {
            assert!(
                scene.warnings.iter().any(|w| w.contains("texture")),
                "seed {target}/{name}: texture not read: {:?}",
                scene.warnings
            );
        }
    }
}

/// A library named again (`mtllib` repeated, or spelt `./m.mtl`) is read once and gives the
/// same materials as naming it once (fuzzing found thousands of repeats costing quadratic
/// time and memory: `fuzz/regressions/obj/repeated-mtllib`).
#[test]
fn repeated_mtllib_is_read_once_with_the_same_materials() {
    let dir = std::env::temp_dir().join(format!("shrad-fuzz-mtllib-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("m.mtl"),
        "newmtl a\nKd 0.25 0.5 0.75\nKe 1 2 3\nnewmtl b\nKd 0.1\n",
    )
    .unwrap();
    let mut obj = "mtllib m.mtl\n".repeat(5000);
    obj += "mtllib ./m.mtl\nmtllib missing.mtl\n";
    obj += "o t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl a\nf 1 2 3\nusemtl b\nf 1 2 3\n";
    std::fs::write(dir.join("s.obj"), obj).unwrap();
    let scene = load(&dir.join("s.obj"), &LoadOptions::default());
    let _ = std::fs::remove_dir_all(&dir);
    let scene = scene.unwrap();
    assert_eq!(scene.objects.len(), 2);
    let (a, b) = (&scene.objects[0].material, &scene.objects[1].material);
    assert_eq!(a.reflectance, glam::Vec3::new(0.25, 0.5, 0.75));
    assert_eq!(a.emitted_radiance, glam::Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(b.reflectance, glam::Vec3::splat(0.1));
}

/// Face indices that tobj would overflow on (fuzz finding: a relative texture index before
/// the first `vt`) are errors naming the line; a texture index 0 still reads as absent.
#[test]
fn obj_face_indices_out_of_bounds_name_the_line() {
    let dir = std::env::temp_dir().join(format!("shrad-fuzz-faceidx-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
    let load_face = |name: &str, face: &str| {
        let p = dir.join(name);
        std::fs::write(&p, format!("{head}{face}\n")).unwrap();
        load(&p, &LoadOptions::default()).map(|s| s.objects.len())
    };
    for (name, face) in [
        ("rel_vt.obj", "f 1/1/1 2/1/1 3/-2/1"),
        ("huge_vn.obj", "f 1/1/1 2/1/9223372036854775807 3/1/1"),
        ("rel_vn_line.obj", "l 1/1/-2 2/1/1 3/1/1"),
        ("zero_v.obj", "f 0 2 3"),
        ("far_v.obj", "f 1 2 4"),
        ("rel_v.obj", "f -4 -2 -1"),
    ] {
        let msg = load_face(name, face).unwrap_err().to_string();
        assert!(
            msg.contains(name) && msg.contains("line 6") && msg.contains("out of bounds"),
            "{face}: {msg}"
        );
    }
    assert_eq!(load_face("ok.obj", "f -3/-1/-1 2/1/1 3/0/0").unwrap(), 1);
    // A face of two vertices is not one (tobj read it as a line, and the file as one of no
    // objects): an error naming the line, before its indices are looked at.
    let msg = load_face("two.obj", "f 1/9/-7 2/9/9")
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("line 6: a face needs at least 3 vertices"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The two resource findings of fuzz/README.md end bounded: the 10 KB GLB whose seven images
/// share one buffer view of an 8192 x 8192 PNG decodes it once (every material holds the
/// same image), and a scene file of seventeen 512-segment spheres is refused by the file's
/// triangle budget before it builds them all.
#[test]
fn resource_findings_are_bounded() {
    let glb = fuzz_dir().join("regressions/glb/slow-seven-8192px-textures.glb");
    let s = load(&glb, &LoadOptions::default()).unwrap();
    // Seven images of 64 Mi texels each against a budget of 128 Mi: decoded apart, five
    // would be refused. The mesh has no TEXCOORD_0, so each material's texture is averaged.
    let refused: Vec<_> = s
        .warnings
        .iter()
        .filter(|w| w.contains("cannot be loaded"))
        .collect();
    assert!(
        refused.is_empty(),
        "the shared PNG was decoded more than once: {refused:?}"
    );
    let averaged = s
        .warnings
        .iter()
        .filter(|w| w.contains("base colour texture averaged"))
        .count();
    assert_eq!(averaged, s.objects.len(), "{:?}", s.warnings);
    assert_eq!(s.objects.len(), 14);

    let toml = fuzz_dir().join("regressions/toml/many-spheres-512-segments.toml");
    let msg = load(&toml, &LoadOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        msg.contains("many-spheres-512-segments.toml")
            && msg.contains("object 16")
            && msg.contains("more than the 4177920 a scene file may build"),
        "{msg}"
    );
}

/// Distinct huge images in one file stop at the file's texel budget: the textures past it
/// are refused with a warning (the factor alone), the file still loads.
#[test]
fn textures_past_the_file_texel_budget_are_refused_with_a_warning() {
    let glb =
        std::fs::read(fuzz_dir().join("regressions/glb/slow-seven-8192px-textures.glb")).unwrap();
    // The same GLB as glTF JSON, its images on three copies of the PNG's buffer view (three
    // sources, each decoded): 3 x 64 Mi texels pass the budget of 128 Mi.
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut root: serde_json::Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    let bin = &glb[20 + json_len + 8..];
    let png_view = root["images"][0]["bufferView"].as_u64().unwrap() as usize;
    let copy = root["bufferViews"][png_view].clone();
    let views = root["bufferViews"].as_array_mut().unwrap();
    let first = views.len();
    views.extend([copy.clone(), copy]);
    for (k, img) in root["images"]
        .as_array_mut()
        .unwrap()
        .iter_mut()
        .enumerate()
    {
        img["bufferView"] = serde_json::json!([png_view, first, first + 1][k % 3]);
    }
    root["buffers"][0]["uri"] = serde_json::json!(format!(
        "data:application/octet-stream;base64,{}",
        base64::encode(bin)
    ));
    let dir = std::env::temp_dir().join(format!("shrad-texel-budget-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("three.gltf");
    std::fs::write(&path, serde_json::to_vec(&root).unwrap()).unwrap();
    let s = load(&path, &LoadOptions::default()).unwrap();
    let refused = s
        .warnings
        .iter()
        .filter(|w| w.contains("texels all textures of a file may decode to"))
        .count();
    // Images 0 and 1 decode (the budget), image 2 and its material are refused; images
    // 3..6 share the three sources already tried.
    let decoded = s
        .warnings
        .iter()
        .filter(|w| w.contains("base colour texture averaged"))
        .count();
    assert_eq!(refused, 1, "{:?}", s.warnings);
    assert!(s.warnings.iter().any(|w| w.starts_with(
        "materials[2]: base colour image 2 cannot be loaded (its 8192 x 8192 texels pass"
    )));
    // Materials 0, 1, 3, 4, 6 have a texture (image k % 3 != 2), on each of the two nodes.
    assert_eq!(decoded, 10, "{:?}", s.warnings);
    let _ = std::fs::remove_dir_all(&dir);
}
