//! Helpers shared by the command-line tests (`cli.rs`, `bake_view.rs`, `bake_lightmap.rs`):
//! run the binary, bake the Cornell box, make a fresh folder, list one. Each test binary uses a part of them.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Run `shrad` with `args` and wait for it.
pub fn shrad(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shrad"))
        .args(args)
        .output()
        .expect("run shrad")
}

/// Bake the Cornell box (400 patches, the dispersive solver, and `extra`) into `c.glb` in
/// a fresh folder for test `name`: (the folder, the file, the run).
pub fn bake_cornell(name: &str, extra: &[&str]) -> (PathBuf, PathBuf, Output) {
    let dir = temp_dir(name);
    let out = dir.join("c.glb");
    let mut args = vec![
        "bake",
        "cornell",
        "--patches",
        "400",
        "--solver",
        "dispersive",
    ];
    args.extend_from_slice(extra);
    args.extend(["-o", out.to_str().unwrap()]);
    let o = shrad(&args);
    (dir, out, o)
}

/// An empty folder for test `name`, unique to this test process.
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("shrad-cli-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The repository's root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The entries of `dir`.
pub fn files_in(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect()
}
