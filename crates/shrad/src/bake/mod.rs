//! Baked light for other engines: the engine's patched meshes as glTF 2.0, with the light
//! per vertex, so that three.js, Blender or Godot show the lit result as it is.
//!
//! Each object is one node and one mesh (world positions of the current pose, so no node
//! transform), its triangles the patches' (a cell is two triangles), its vertices the
//! engine's shading vertices (patch corners welded by position and normal, per object):
//!
//! - `COLOR_0` (float VEC3): the display colour `clamp(exposure * B / pi, 0, 1)`, linear,
//!   drawn as it is by one shared unlit material (`KHR_materials_unlit`, white base colour);
//!   a viewer's sRGB output gives the same picture as shrad's PNG at that exposure;
//! - `_RADIOSITY` (float VEC3): the unclamped radiosity `B` (W/m^2) at the vertex, the
//!   area-weighted mean of its patches' (what [`Engine::vertex_colors`] returns);
//! - `NORMAL`, and `POSITION` with its bounds.
//!
//! Textures and vertex colours are in the light already (a patch's reflectance is their
//! average over it), so none is written. `asset.extras.shrad` records the exposure, time,
//! solver and what the attributes hold.
//!
//! **An animation is a sequence of files** (`out_0000.glb`, `out_0001.glb`, ...), one per
//! frame, each a whole scene at its pose ([`bake`] with `frames`). glTF has no standard way
//! to animate vertex colours: per-frame colours in one file would ride on morph targets,
//! whose `COLOR_0` is optional for viewers (three.js reads it, Blender's importer does not)
//! and which cannot carry the motion of the patches themselves; a file per frame shows
//! everywhere as it is, and each can be loaded alone.
//!
//! **A sequence is all or nothing.** Each file is written under a hidden staged name in its
//! destination's folder (`.out_0003.glb.staged-PID`), and only once every file of the
//! sequence is written are they renamed into place ([`shrad_scene::StagedFiles`]); a bake
//! that fails partway (a solve, a full disk, a file that cannot be written) removes the
//! staged files, so no file of the sequence is left on disk, and files of an earlier bake at
//! those names stay as they were.
//!
//! The accessors, the buffer and the GLB container are written by `write_gltf`'s
//! ([`shrad_scene::gltf_builder`]); the meshes are the viewer's
//! ([`crate::view_data::DisplayMesh`]); `per_vertex.rs` builds one file from them.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::{json, Value};
use shrad_scene::gltf_builder::TRIANGLES;
use shrad_scene::StagedFiles;

use crate::engine::Engine;
use crate::progress::check;
use crate::solver::SolverChoice;
use crate::{Error, NoProgress, Progress, World};

mod per_vertex;
use per_vertex::stage_gltf;

/// What [`bake`] writes.
#[derive(Clone, Debug, PartialEq)]
pub struct BakeOptions {
    /// The time to bake (seconds on the scene's animation); `None`: where the engine is.
    pub time: Option<f32>,
    /// Bake an animation as this many files, evenly over `[0, duration]` (`None`: one file
    /// at `time`).
    pub frames: Option<usize>,
    /// Before each file, step until every object has been updated this many times
    /// ([`Engine::converge`]); 0 writes the state as it is (no step, the reference's solve
    /// included).
    pub passes: usize,
    /// Display scale of `COLOR_0`; `None`: from the first file, as a PNG's automatic
    /// exposure (the 99th percentile of non-light luminance at 0.9), kept for the others.
    pub exposure: Option<f32>,
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions {
            time: None,
            frames: None,
            passes: 2,
            exposure: None,
        }
    }
}

/// One file written.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Baked {
    /// The file.
    pub path: PathBuf,
    /// The time it shows.
    pub time: f32,
    /// The exposure of its `COLOR_0`.
    pub exposure: f32,
    /// Meshes (objects with patches).
    pub meshes: usize,
    /// Vertices over all meshes.
    pub vertices: usize,
    /// Triangles over all meshes.
    pub triangles: usize,
    /// What the user should know about this file (a lightmap: an object's own UVs that
    /// could not be used).
    pub warnings: Vec<String>,
    /// A lightmap's file beside it (`c.lightmap.exr`, in the folder of `path`).
    pub lightmap_file: Option<PathBuf>,
    /// What the lightmap's texels hold (`linear OpenEXR, E / pi`, or RGBM with its
    /// multiplier).
    pub lightmap_encoding: Option<String>,
}

/// The file of frame `frame` of a sequence: `out.glb` -> `out_0007.glb`.
pub fn frame_path(path: &Path, frame: usize) -> PathBuf {
    let text = |part: Option<&std::ffi::OsStr>| {
        part.map_or(String::new(), |p| p.to_string_lossy().into_owned())
    };
    let (stem, ext) = (text(path.file_stem()), text(path.extension()));
    path.with_file_name(format!("{stem}_{frame:04}.{ext}"))
}

/// Bake the engine's scene (what `shrad bake` and Python's `Engine.bake` do): go to
/// `time`, converge and write `path`; with `frames`, a sequence over the animation (see
/// the module docs), `path` naming it (`out.glb` -> `out_0000.glb`, ...).
pub fn bake(engine: &mut Engine, path: &Path, options: &BakeOptions) -> Result<Vec<Baked>, Error> {
    bake_with_progress(engine, path, options, &NoProgress)
}

/// [`bake`], reporting progress: with the reference, its steps in each file's solve (form
/// factors, iterations: minutes); with the other solvers, whose frames take milliseconds,
/// the files of a sequence. When `progress` asks to stop, [`Error::Interrupted`]: no file
/// is written (the staged ones are removed), the engine is whole at the frame it reached.
pub fn bake_with_progress(
    engine: &mut Engine,
    path: &Path,
    options: &BakeOptions,
    progress: &dyn Progress,
) -> Result<Vec<Baked>, Error> {
    bake_files(
        engine,
        path,
        options,
        progress,
        &|engine, file, e, staged| stage_gltf(engine, file, Some(e), staged),
    )
}

/// An empty scene (a valid glTF with nothing to light loads empty) is refused before any
/// file is written: a bake is light on surfaces, and a file without a mesh would be one
/// that shrad itself, and most importers, refuse or show as nothing; in a pipeline, an
/// error says where the light went, an empty file does not.
fn nothing_to_bake(engine: &Engine) -> Result<(), Error> {
    if engine.world().patches.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: nothing to bake: the scene has no surface to light (see its load warnings)",
            engine.world().scene.source
        )));
    }
    Ok(())
}

/// Refuse to write `path` over the file the engine's scene was read from (a built-in scene
/// or one built in memory is no file): `bake("room.gltf")` on the engine that loaded
/// `room.gltf` replaced the user's scene with its bake. Every front end's writer of the
/// engine's state calls it (the CLI's own check, before the solve, names its flag).
pub fn refuse_overwriting_scene(engine: &Engine, path: &Path) -> Result<(), Error> {
    let source = Path::new(&engine.world().scene.source);
    if source.is_file() && shrad_scene::same_file(path, source) {
        return Err(Error::Output(
            path.into(),
            "that is the scene file being read; write to another name".into(),
        ));
    }
    Ok(())
}

/// Writes one file of a bake (the engine's state at `exposure`) to staged names.
pub type StageFile<'a> = dyn Fn(&Engine, &Path, f32, &mut StagedFiles) -> Result<Baked, Error> + 'a;

/// The files of a bake, each written by `stage` (see [`bake_with_progress`]; a lightmap's
/// are [`crate::lightmap::bake_with_progress`]'s).
pub fn bake_files(
    engine: &mut Engine,
    path: &Path,
    options: &BakeOptions,
    progress: &dyn Progress,
    stage: &StageFile<'_>,
) -> Result<Vec<Baked>, Error> {
    is_glb_output(path)?;
    if let Some(e) = options.exposure {
        check_exposure(e)?;
    }
    nothing_to_bake(engine)?;
    let times = times(engine, options)?;
    let file = |i: usize| match options.frames {
        None => path.to_path_buf(),
        Some(_) => frame_path(path, i),
    };
    (0..times.len()).try_for_each(|i| refuse_overwriting_scene(engine, &file(i)))?;
    let reference = matches!(engine.solver_choice(), SolverChoice::Reference(_));
    let (file_bar, step_bar): (&dyn Progress, &dyn Progress) = if reference {
        (&NoProgress, progress)
    } else {
        (progress, &NoProgress)
    };
    let mut exposure = options.exposure;
    let mut out = Vec::with_capacity(times.len());
    // Every file goes to a staged name first; only when all are written are they renamed
    // into place (the sequence is all or nothing, module docs): dropped on an error, the
    // staged files are removed.
    let mut staged = StagedFiles::new();
    file_bar.begin("files", times.len() as u64);
    for (i, &t) in times.iter().enumerate() {
        let file = file(i);
        let written = engine.set_time(t).and_then(|()| {
            // Not `converge(0)`: the reference solves once whatever the passes, so a
            // state just solved would be solved again. A stop asked for ends the bake
            // between frames (or within a reference frame), before any file is in place.
            if options.passes > 0 {
                engine.converge_by(options.passes, |e| {
                    check(progress)?;
                    e.try_step_with_progress(step_bar)
                })?;
            }
            check(progress)?;
            let e = *exposure.get_or_insert_with(|| auto_exposure(engine));
            stage(engine, &file, e, &mut staged)
        });
        out.push(written.inspect_err(|_| file_bar.end())?);
        file_bar.advance(1);
    }
    file_bar.end();
    check(progress)?;
    staged.commit()?;
    Ok(out)
}

/// The times of the files `options` asks for.
fn times(engine: &Engine, options: &BakeOptions) -> Result<Vec<f32>, Error> {
    let n = match options.frames {
        None => return Ok(vec![options.time.unwrap_or(engine.world().time)]),
        Some(n) if !(1..=crate::limits::MAX_FRAMES).contains(&n) => {
            return Err(Error::Invalid(format!(
                "frames must be between 1 and {}, got {n}",
                crate::limits::MAX_FRAMES
            )))
        }
        Some(_) if options.time.is_some() => {
            return Err(Error::Invalid(
                "give a time or a number of frames, not both".into(),
            ))
        }
        Some(n) => n,
    };
    let duration = engine.world().scene.duration();
    if n > 1 && duration <= 0.0 {
        return Err(Error::Invalid(format!(
            "{}: the scene is not animated, so {n} frames would all be the same",
            engine.world().scene.source
        )));
    }
    Ok((0..n)
        // The fraction first: `duration * i` overflowed for an animation near f32's end.
        .map(|i| duration * (i as f32 / (n.max(2) - 1) as f32))
        .collect())
}

/// Whether `path` names a GLB (`.glb`) rather than a `.gltf`; any other name is an error.
fn is_glb_output(path: &Path) -> Result<bool, Error> {
    match path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .as_deref()
    {
        Some("glb") => Ok(true),
        Some("gltf") => Ok(false),
        _ => Err(Error::Output(
            path.into(),
            "a bake is written as .glb (binary) or .gltf (JSON and a .bin beside it)".into(),
        )),
    }
}

/// `e` if it is a valid exposure (finite, positive).
fn check_exposure(e: f32) -> Result<f32, Error> {
    if e.is_finite() && e > 0.0 {
        Ok(e)
    } else {
        Err(Error::Invalid(format!(
            "exposure must be a positive number, got {e}"
        )))
    }
}

/// The automatic exposure of the engine's current light: that of a PNG of its vertices.
pub fn auto_exposure(engine: &Engine) -> f32 {
    let patches = &engine.world().patches;
    let radiance: Vec<Vec3> = engine
        .vertex_colors()
        .iter()
        .map(|b| *b / std::f32::consts::PI)
        .collect();
    let mut light = vec![false; radiance.len()];
    for p in 0..patches.len() {
        if patches.role(p) == shrad_scene::Role::Light {
            let corners = if patches.is_quad[p] { 4 } else { 3 };
            for &v in &patches.corner_vertex[p][..corners] {
                light[v as usize] = true;
            }
        }
    }
    crate::image_io::auto_exposure(&crate::render::Image {
        width: radiance.len() as u32,
        height: 1,
        pixels: radiance,
        emitter: light,
    })
}

/// Write the engine's current state (no stepping) to `path`: `.glb`, or `.gltf` with its
/// buffer in a `.bin` of the same name beside it. `exposure` scales `COLOR_0` (`None`:
/// [`auto_exposure`]). The file (and its `.bin`) is written whole or not at all.
pub fn write_gltf(engine: &Engine, path: &Path, exposure: Option<f32>) -> Result<Baked, Error> {
    nothing_to_bake(engine)?;
    refuse_overwriting_scene(engine, path)?;
    let mut staged = StagedFiles::new();
    let baked = stage_gltf(engine, path, exposure, &mut staged)?;
    staged.commit()?;
    Ok(baked)
}

/// Object `object`'s glTF mesh, the `mesh`-th of the file (one triangle list of
/// `attributes` and `indices`, with the file's one material), and the node that shows it,
/// whose `extras` name the object's role and index with `extras` (an object) added: what a
/// per-vertex bake and a lightmap bake write alike.
pub(crate) fn object_mesh_node(
    world: &World,
    object: usize,
    mesh: usize,
    (attributes, indices): (Value, usize),
    extras: Value,
) -> (Value, Value) {
    let name = &world.scene.objects[object].name;
    let mut all =
        json!({"shrad_role": world.patches.object_role[object].name(), "shrad_object": object});
    if let (Some(all), Value::Object(more)) = (all.as_object_mut(), extras) {
        all.extend(more);
    }
    (
        json!({
            "name": name,
            "primitives": [{"attributes": attributes, "indices": indices, "material": 0, "mode": TRIANGLES}],
        }),
        json!({"name": name, "mesh": mesh, "extras": all}),
    )
}
