//! Blender's fixtures (`tests/data/blender`): the matrices it recorded, and running its
//! scripts again where Blender is installed as the bpy module.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use glam::Mat4;
use serde_json::Value;

/// The folder of Blender's fixtures.
pub fn data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/blender")
}

/// The matrix Blender recorded in `pose["matrix"]` (a list of rows).
pub fn matrix(pose: &Value) -> Mat4 {
    let rows: Vec<f32> = pose["matrix"]
        .as_array()
        .unwrap()
        .iter()
        .flat_map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap() as f32)
        })
        .collect();
    Mat4::from_cols_slice(&rows).transpose() // rows -> columns
}

/// Run the Blender script `script` with `out` and `args` after it, under /tmp/bpyenv (a
/// Python with Blender as the bpy module), asserting that it succeeds. Returns false, and
/// says it skipped, when there is no such Python.
pub fn run_script(script: &Path, out: &Path, args: &[&str]) -> bool {
    let python = Path::new("/tmp/bpyenv/bin/python");
    if !python.exists() {
        eprintln!("skipped: no /tmp/bpyenv (a Python with Blender as the bpy module)");
        return false;
    }
    let status = Command::new(python)
        .arg(script)
        .arg(out)
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .unwrap();
    assert!(status.success(), "{} failed", script.display());
    true
}

/// Blender's fixture script `name.py` run again into a fresh folder, and `check` given the
/// `name.glb` and `name.json` it wrote; nothing (it says it skipped) without Blender.
pub fn check_fresh_export(name: &str, check: impl FnOnce(&Path, &Path)) {
    let out = std::env::temp_dir().join(format!("shrad-blender-{name}-{}", std::process::id()));
    if !run_script(&data().join(format!("{name}.py")), &out, &[]) {
        return;
    }
    check(
        &out.join(format!("{name}.glb")),
        &out.join(format!("{name}.json")),
    );
    let _ = std::fs::remove_dir_all(&out);
}
