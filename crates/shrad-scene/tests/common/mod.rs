//! What this crate's integration tests share: a hook that counts panics, fresh temporary
//! folders, and Blender's recorded matrices.
#![allow(dead_code)]

pub mod blender;
pub mod panics;

use std::path::PathBuf;

/// A fresh empty folder `name` in the temporary directory (emptied if it was there).
pub fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}
