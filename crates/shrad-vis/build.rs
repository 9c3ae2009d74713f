//! Looks for the system Embree 3 (`libembree-dev`). When found, enables `cfg(shrad_embree)`
//! and links `libembree3`; `SHRAD_NO_EMBREE=1` at build time turns it off. Extra search
//! roots can be given with `EMBREE_DIR` (containing `include/embree3` and `lib`).
//!
//! The script reruns when Embree appears or disappears (say `scripts/setup` installs it after
//! a first build), so the cfg follows the system. Cargo treats a `rerun-if-changed` path that
//! does not exist as changed on *every* build (the crate and its dependents would recompile
//! each time), so for each candidate header we watch the header when it exists, else the
//! nearest existing directory of `ROOT/include/embree3`, `ROOT/include` (and `EMBREE_DIR`
//! itself); cargo scans a watched directory recursively, so a file created below it counts.

use std::path::{Path, PathBuf};

fn main() {
    println!("cargo::rustc-check-cfg=cfg(shrad_embree)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=SHRAD_NO_EMBREE");
    println!("cargo::rerun-if-env-changed=EMBREE_DIR");
    for (root, watch_root) in roots() {
        if let Some(path) = watch_path(&root, watch_root) {
            println!("cargo::rerun-if-changed={}", path.display());
        }
    }

    if std::env::var("SHRAD_NO_EMBREE").is_ok_and(|v| !v.is_empty() && v != "0") {
        return;
    }
    if let Some(lib_dir) = find_embree() {
        println!("cargo::rustc-link-search=native={}", lib_dir.display());
        println!("cargo::rustc-link-lib=dylib=embree3");
        println!("cargo::rustc-cfg=shrad_embree");
    } else {
        println!("cargo::warning=Embree 3 not found (install libembree-dev); shrad-vis uses its pure-Rust BVH only");
    }
}

fn find_embree() -> Option<PathBuf> {
    // pkg-config first (some distributions ship embree3.pc).
    if let Ok(out) = std::process::Command::new("pkg-config")
        .args(["--libs-only-L", "embree3"])
        .output()
    {
        if out.status.success() {
            let s = String::from_utf8_lossy(&out.stdout);
            for tok in s.split_whitespace() {
                if let Some(dir) = tok.strip_prefix("-L") {
                    if has_lib(Path::new(dir)) {
                        return Some(dir.into());
                    }
                }
            }
            // Found by pkg-config but in a default linker path.
            for dir in lib_dirs(None) {
                if has_lib(&dir) {
                    return Some(dir);
                }
            }
        }
    }
    for (root, _) in roots() {
        if !root.join("include/embree3/rtcore.h").is_file() {
            continue;
        }
        for dir in lib_dirs(Some(&root)) {
            if has_lib(&dir) {
                return Some(dir);
            }
        }
    }
    None
}

/// Search roots, each holding `include/embree3/rtcore.h` and a lib directory, and whether
/// the root itself may be watched (`EMBREE_DIR` is an Embree prefix, small; `/usr/local` may
/// hold a whole Cargo home, and a watched directory is scanned recursively).
fn roots() -> Vec<(PathBuf, bool)> {
    let mut roots: Vec<(PathBuf, bool)> = Vec::new();
    if let Ok(d) = std::env::var("EMBREE_DIR") {
        if !d.is_empty() {
            roots.push((d.into(), true));
        }
    }
    roots.push(("/usr".into(), false));
    roots.push(("/usr/local".into(), false));
    roots
}

/// What to watch for `root`: its header when present, else the nearest existing directory
/// on the way to it: `include/embree3`, `include`, then the root itself when allowed.
fn watch_path(root: &Path, watch_root: bool) -> Option<PathBuf> {
    let include = root.join("include");
    let dir = include.join("embree3");
    let header = dir.join("rtcore.h");
    let mut candidates = vec![header, dir, include];
    if watch_root {
        candidates.push(root.to_path_buf());
    }
    candidates.into_iter().find(|p| p.exists())
}

fn lib_dirs(root: Option<&Path>) -> Vec<PathBuf> {
    let arch = std::env::var("CARGO_CFG_TARGET_ARCH").unwrap_or_default();
    let multiarch = format!("lib/{arch}-linux-gnu");
    let root = root.unwrap_or(Path::new("/usr"));
    [multiarch.as_str(), "lib64", "lib"]
        .iter()
        .map(|d| root.join(d))
        .collect()
}

fn has_lib(dir: &Path) -> bool {
    ["libembree3.so", "libembree3.dylib", "embree3.lib"]
        .iter()
        .any(|f| dir.join(f).exists())
}
