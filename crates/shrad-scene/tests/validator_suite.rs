//! The Khronos glTF-Validator's own test files (its `test/` folder, Apache-2.0, with each
//! file's expected `.report.json`), read from `../shared/gltf-validator-suite/` beside the
//! repository and never copied into it: every file is loaded, and
//!
//! - nothing panics (a panic hook counts panics inside the readers' `catch_unwind` guards);
//! - every file the validator finds valid (no error in its report) in which a node instances
//!   a mesh loads,
//!   except those listed in [`VALID_REFUSED`] with the reason;
//! - a valid file without a mesh, or whose meshes no node instances, is refused with a
//!   message that says so;
//! - every invalid file is refused, or loads with at least one warning, except those listed
//!   in [`INVALID_LOADED`] with why shrad may read them as it does.
//!
//! The counts (valid / invalid x loaded / refused / crashed) are printed as the table of
//! `docs/results.md` ("glTF conformance"); run with `--nocapture` to see it.

use std::cell::Cell;
use std::path::{Path, PathBuf};
use std::sync::Once;

use serde_json::Value;
use shrad_scene::{load, LoadOptions};

thread_local! {
    static PANICS: Cell<usize> = const { Cell::new(0) };
}

fn count_panics() {
    static HOOK: Once = Once::new();
    HOOK.call_once(|| {
        let default = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            PANICS.with(|p| p.set(p.get() + 1));
            default(info);
        }));
    });
}

/// Valid files (by the validator) that shrad refuses all the same: (suite-relative path, a
/// fragment of the message it must give, why that is right). The validator does not look
/// into data it cannot see (an accessor without bufferView is zeros, a buffer without uri in
/// a .gltf has none), so its placeholder geometry has zero area and its key times are equal.
const VALID_REFUSED: &[(&str, &str, &str)] = &[
    (
        "base/data/accessor/unknown_type.gltf",
        "'NotaVEC3' is not a glTF accessor type",
        "the validator reports an unknown accessor type as a warning; shrad cannot size the accessor",
    ),
    (
        "base/data/asset/min_version_valid.gltf",
        "the file needs glTF 2.1",
        "asset.minVersion 2.1: the file says a glTF 2.0 reader must not load it",
    ),
    (
        "base/data/node/node_skinned_mesh_without_skin.gltf",
        "zero-area triangle",
        "its positions are an accessor without bufferView, so all zeros: one zero-area triangle",
    ),
    (
        "base/data/node/node_weights_override.gltf",
        "zero-area triangle",
        "positions all zeros (accessor without bufferView)",
    ),
    (
        "base/data/node/valid.gltf",
        "zero-area triangle",
        "positions all zeros (accessor without bufferView)",
    ),
    (
        "base/data/skin/ignored_local_transform.gltf",
        "zero-area triangle",
        "positions all zeros (accessor without bufferView)",
    ),
    (
        "base/data/skin/ignored_parent_transform.gltf",
        "zero-area triangle",
        "positions all zeros (accessor without bufferView)",
    ),
    (
        "base/data/skin/ignored_animated_transform.gltf",
        "must be strictly increasing",
        "its animation's key times are zeros (accessor without bufferView); the specification requires them strictly increasing",
    ),
    (
        "base/data/root/named_objects.gltf",
        "which has no data",
        "the mesh reads a buffer that has neither uri nor a GLB BIN chunk: its data is not in the file",
    ),
    (
        "base/data/root/unused_objects.gltf",
        "which has no data",
        "the mesh reads a buffer that has neither uri nor a GLB BIN chunk",
    ),
];

/// Invalid files that load without a warning, and why that is right for shrad.
const INVALID_LOADED: &[(&str, &str)] = &[];

fn suite_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/gltf-validator-suite")
}

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    let mut entries: Vec<PathBuf> = entries.filter_map(|e| Some(e.ok()?.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            files(&p, out);
        } else if matches!(p.extension().and_then(|e| e.to_str()), Some("gltf" | "glb"))
            && report_path(&p).exists()
        {
            out.push(p);
        }
    }
}

fn report_path(p: &Path) -> PathBuf {
    let mut s = p.as_os_str().to_owned();
    s.push(".report.json");
    PathBuf::from(s)
}

/// The JSON of a .gltf or of a GLB's first chunk (None when unreadable).
fn json_of(p: &Path) -> Option<Value> {
    let bytes = std::fs::read(p).ok()?;
    let json = if bytes.starts_with(b"glTF") {
        let len = u32::from_le_bytes(bytes.get(12..16)?.try_into().ok()?) as usize;
        bytes.get(20..20 + len)?.to_vec()
    } else {
        bytes
    };
    serde_json::from_slice(&json).ok()
}

/// A node of the file instances a mesh (a mesh no node draws has nothing to light).
fn has_mesh(p: &Path) -> bool {
    json_of(p)
        .and_then(|v| {
            let nodes = v.get("nodes")?.as_array()?;
            let meshes = v.get("meshes")?.as_array()?;
            // A primitive without positions is skipped, as the specification says.
            let drawable = |m: &Value| {
                m["primitives"]
                    .as_array()
                    .is_some_and(|p| p.iter().any(|p| p["attributes"].get("POSITION").is_some()))
            };
            Some(nodes.iter().any(|n| {
                n["mesh"]
                    .as_u64()
                    .and_then(|m| meshes.get(m as usize))
                    .is_some_and(drawable)
            }))
        })
        .unwrap_or(false)
}

#[derive(Default)]
struct Row {
    loaded: usize,
    refused: usize,
    crashed: usize,
}

#[test]
fn validator_suite_loads_the_valid_and_refuses_the_invalid() {
    let dir = suite_dir();
    let mut all = Vec::new();
    files(&dir, &mut all);
    if all.is_empty() {
        println!(
            "skipped: the validator's test files are not at {}",
            dir.display()
        );
        return;
    }
    count_panics();
    let (mut valid, mut invalid) = (Row::default(), Row::default());
    let mut failures = Vec::new();
    let mut refused_valid_no_mesh = 0;
    let mut refused_valid_listed = 0;
    let mut refused_valid_not_instanced = 0;
    for p in &all {
        let rel = p.strip_prefix(&dir).unwrap().display().to_string();
        let report: Value =
            serde_json::from_slice(&std::fs::read(report_path(p)).unwrap()).unwrap();
        let is_valid = report["issues"]["numErrors"].as_u64() == Some(0);
        let before = PANICS.with(Cell::get);
        let r = std::panic::catch_unwind(|| load(p, &LoadOptions::default()));
        let panicked = PANICS.with(Cell::get) != before || r.is_err();
        let row = if is_valid { &mut valid } else { &mut invalid };
        let outcome = match r {
            Ok(r) if !panicked => Some(r),
            _ => None,
        };
        match outcome {
            None => {
                row.crashed += 1;
                failures.push(format!("{rel}: panicked"));
            }
            Some(Ok(scene)) => {
                row.loaded += 1;
                if !is_valid
                    && scene.warnings.is_empty()
                    && !INVALID_LOADED.iter().any(|(f, _)| *f == rel)
                {
                    let codes: Vec<&str> = report["issues"]["messages"]
                        .as_array()
                        .into_iter()
                        .flatten()
                        .filter(|m| m["severity"] == 0)
                        .filter_map(|m| m["code"].as_str())
                        .collect();
                    failures.push(format!(
                        "{rel}: invalid ({}) but loaded without a warning",
                        codes.join(", ")
                    ));
                }
            }
            Some(Err(e)) => {
                row.refused += 1;
                let msg = e.to_string();
                if !msg.starts_with(&p.display().to_string()) {
                    failures.push(format!("{rel}: the message does not name the file: {msg}"));
                }
                if msg.contains("invalid glTF: invalid glTF") {
                    failures.push(format!("{rel}: doubled prefix: {msg}"));
                }
                let listed = VALID_REFUSED.iter().find(|(f, _, _)| *f == rel);
                if let Some((_, fragment, _)) = listed {
                    refused_valid_listed += 1;
                    if !is_valid || !msg.contains(fragment) {
                        failures.push(format!(
                            "{rel}: listed as a valid file refused with '{fragment}', but: {msg}"
                        ));
                    }
                } else if is_valid && has_mesh(p) {
                    failures.push(format!("{rel}: valid, has a mesh, refused: {msg}"));
                } else if is_valid {
                    if msg.contains("has no mesh") {
                        refused_valid_no_mesh += 1;
                    } else if msg.contains("instances a triangle mesh") {
                        // Read to the end (buffers, decoding, animations) before this.
                        refused_valid_not_instanced += 1;
                    } else {
                        failures.push(format!(
                            "{rel}: valid without a mesh, refused with an unclear message: {msg}"
                        ));
                    }
                }
            }
        }
    }
    println!(
        "glTF-Validator test files: {} (in {})",
        all.len(),
        dir.display()
    );
    println!("| validator says | loaded | refused | crashed |");
    println!("| --- | ---: | ---: | ---: |");
    for (name, r) in [("valid", &valid), ("invalid", &invalid)] {
        println!("| {name} | {} | {} | {} |", r.loaded, r.refused, r.crashed);
    }
    println!("valid files refused for having no mesh: {refused_valid_no_mesh}");
    println!(
        "valid files read to the end and refused because no node instances a mesh: {refused_valid_not_instanced}"
    );
    println!(
        "valid files refused for a listed reason: {refused_valid_listed} (of {})",
        VALID_REFUSED.len()
    );
    for f in &failures {
        println!("FAIL {f}");
    }
    assert!(
        failures.is_empty(),
        "{} failure(s), listed above",
        failures.len()
    );
}
