//! [`load`]: read any scene shrad knows (glTF, GLB, OBJ, TOML scene file, built-in name),
//! infer missing roles and validate.

use std::path::Path;

use crate::gltf_io::PartNames;
use crate::{builtin, builtin_names, infer_roles, Scene, SceneError};

/// Options of [`load`].
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Drop zero-area triangles with a warning instead of failing. The glTF reader drops
    /// them whatever this says (glTF allows degenerate triangles); OBJ and scene files
    /// follow it.
    pub drop_degenerate: bool,
    /// Play only this glTF animation (its name, else its index); `None`: every animation of
    /// the file at once on one timeline. An unknown one is an error listing those there are.
    pub animation: Option<String>,
}

/// Read a scene: `.gltf` / `.glb` (glTF 2.0), `.obj` (+ MTL), `.toml` (shrad scene file, see
/// docs/scene-format.md), or, when `path` does not exist and has no extension, a built-in
/// scene by name (`cornell`, `room`). Then infer the roles the input did not give, clamp
/// reflectances >= 1 to 0.999 (with a warning) and [`Scene::validate`]. Every error names
/// the file and what is wrong with it.
pub fn load(path: &Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
    if !path.exists() && path.extension().is_none() {
        let name = path.to_string_lossy();
        if !builtin_names().contains(&name.as_ref()) {
            return Err(SceneError::Io {
                path: path.to_path_buf(),
                source: std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    format!(
                        "no such file, and not a built-in scene (built-ins: {})",
                        builtin_names().join(", ")
                    ),
                ),
            });
        }
        if opts.animation.is_some() {
            return Err(SceneError::invalid(
                path,
                "an animation can be selected in a glTF file only (a built-in scene has none)",
            ));
        }
        let mut scene = builtin(&name)?;
        let source = std::path::PathBuf::from(&scene.source);
        finish(&mut scene, &source, opts)?;
        return Ok(scene);
    }
    let animation = opts.animation.as_deref();
    if animation.is_some() && format_of(path)? != Format::Gltf {
        return Err(SceneError::invalid(
            path,
            "an animation can be selected in a glTF file only (in a scene file: `animation = ...` on the mesh object)",
        ));
    }
    let mut scene = read_any(path, animation)?.0;
    if format_of(path)? == Format::Gltf && scene.objects.is_empty() {
        // A valid glTF whose scene has nothing to light loads empty (its reader said why).
        clamp_reflectance(&mut scene);
        scene.validate_may_be_empty(path, opts.drop_degenerate)?;
        return Ok(scene);
    }
    finish(&mut scene, path, opts)?;
    Ok(scene)
}

/// Role inference, reflectance clamping and validation.
fn finish(scene: &mut Scene, path: &Path, opts: &LoadOptions) -> Result<(), SceneError> {
    infer_roles(scene);
    crate::roles::warn_faces_turned_away(scene);
    clamp_reflectance(scene);
    scene.validate(path, opts.drop_degenerate)
}

/// Clamp reflectance components >= 1 (common in exported files) to 0.999 with a warning.
/// (A scene file's or a dict's own `reflectance` is at most 1: `scene_def`.)
pub fn clamp_reflectance(scene: &mut Scene) {
    for (i, o) in scene.objects.iter_mut().enumerate() {
        let r = o.material.reflectance;
        if r.is_finite() && r.max_element() >= 1.0 {
            o.material.reflectance = r.min(glam::Vec3::splat(crate::MAX_REFLECTANCE));
            scene.warnings.push(format!(
                "object {i} '{}': reflectance {r} clamped to {} (must be < 1)",
                o.name, o.material.reflectance
            ));
        }
    }
}

/// The file's format from its extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Format {
    Gltf,
    Obj,
    Toml,
}

pub(crate) fn format_of(path: &Path) -> Result<Format, SceneError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("gltf" | "glb") => Ok(Format::Gltf),
        Some("obj") => Ok(Format::Obj),
        Some("toml") => Ok(Format::Toml),
        _ => Err(SceneError::UnknownFormat {
            path: path.to_path_buf(),
            builtins: builtin_names().join(", "),
        }),
    }
}

/// Read a file of any format without inference or validation; also returns, per object,
/// the node and mesh names it came from (for the scene file's filters).
pub(crate) fn read_any(
    path: &Path,
    animation: Option<&str>,
) -> Result<(Scene, Vec<PartNames>), SceneError> {
    match format_of(path)? {
        Format::Gltf => crate::gltf_io::read(path, animation),
        Format::Obj => {
            let scene = crate::obj_io::read(path)?;
            let names = scene
                .objects
                .iter()
                .map(|o| PartNames {
                    node: Some(o.name.clone()),
                    mesh: Some(o.name.clone()),
                })
                .collect();
            Ok((scene, names))
        }
        Format::Toml => {
            let scene = crate::scene_file::read(path)?;
            let names = vec![PartNames::default(); scene.objects.len()];
            Ok((scene, names))
        }
    }
}
