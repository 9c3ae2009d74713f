//! What this crate's integration tests share: a hook that counts panics, fresh temporary
//! folders, Blender's recorded matrices, and an error as a user reads it.
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
