//! Looks for the system Embree 3 (`libembree-dev`). When found, enables `cfg(shrad_embree)`
//! and links `libembree3`; `SHRAD_NO_EMBREE=1` at build time turns it off. Extra search
//! roots can be given with `EMBREE_DIR` (containing `include/embree3` and `lib`).

use std::path::{Path, PathBuf};

fn main() {
    println!("cargo::rustc-check-cfg=cfg(shrad_embree)");
    println!("cargo::rerun-if-changed=build.rs");
    println!("cargo::rerun-if-env-changed=SHRAD_NO_EMBREE");
    println!("cargo::rerun-if-env-changed=EMBREE_DIR");

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
    let mut roots: Vec<PathBuf> = Vec::new();
    if let Ok(d) = std::env::var("EMBREE_DIR") {
        roots.push(d.into());
    }
    roots.push("/usr".into());
    roots.push("/usr/local".into());
    for root in roots {
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
