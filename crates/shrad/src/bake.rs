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
//! sequence is written are they renamed into place; a bake that fails partway (a solve, a
//! full disk, a file that cannot be written) removes the staged files, so no file of the
//! sequence is left on disk, and files of an earlier bake at those names stay as they were.

use std::path::{Path, PathBuf};

use glam::Vec3;
use serde_json::{json, Value};

use crate::engine::Engine;
use crate::solver::SolverChoice;
use crate::{Error, NoProgress, Progress};

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
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
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
}

/// The file of frame `frame` of a sequence: `out.glb` -> `out_0007.glb`.
pub fn frame_path(path: &Path, frame: usize) -> PathBuf {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_default();
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
/// the files of a sequence.
pub fn bake_with_progress(
    engine: &mut Engine,
    path: &Path,
    options: &BakeOptions,
    progress: &dyn Progress,
) -> Result<Vec<Baked>, Error> {
    check_path(path)?;
    if options
        .exposure
        .is_some_and(|e| !(e.is_finite() && e > 0.0))
    {
        return Err(Error::Invalid(format!(
            "exposure must be a positive number, got {}",
            options.exposure.unwrap_or_default()
        )));
    }
    let times: Vec<f32> = match options.frames {
        None => vec![options.time.unwrap_or(engine.world().time)],
        Some(0) => return Err(Error::Invalid("frames must be at least 1".into())),
        Some(n) => {
            if options.time.is_some() {
                return Err(Error::Invalid(
                    "give a time or a number of frames, not both".into(),
                ));
            }
            let duration = engine.world().scene.duration();
            if n > 1 && duration <= 0.0 {
                return Err(Error::Invalid(format!(
                    "{}: the scene is not animated, so {n} frames would all be the same",
                    engine.world().scene.source
                )));
            }
            (0..n)
                .map(|i| duration * i as f32 / (n.max(2) - 1) as f32)
                .collect()
        }
    };
    let reference = matches!(engine.solver_choice(), SolverChoice::Reference(_));
    let (file_bar, step_bar): (&dyn Progress, &dyn Progress) = if reference {
        (&NoProgress, progress)
    } else {
        (progress, &NoProgress)
    };
    let mut exposure = options.exposure;
    let mut out = Vec::with_capacity(times.len());
    // Every file goes to a staged name first; only when all are written are they renamed
    // into place (the sequence is all or nothing, module docs).
    let mut staged = Vec::new();
    file_bar.begin("files", times.len() as u64);
    for (i, &t) in times.iter().enumerate() {
        let file = match options.frames {
            None => path.to_path_buf(),
            Some(_) => frame_path(path, i),
        };
        let written = engine.set_time(t).and_then(|()| {
            // Not `converge(0)`: the reference solves once whatever the passes, so a
            // state just solved would be solved again.
            if options.passes > 0 {
                engine.converge_with_progress(options.passes, step_bar);
            }
            let e = *exposure.get_or_insert_with(|| auto_exposure(engine));
            stage_gltf(engine, &file, Some(e), &mut staged)
        });
        match written {
            Ok(baked) => out.push(baked),
            Err(e) => {
                file_bar.end();
                discard(&staged);
                return Err(e);
            }
        }
        file_bar.advance(1);
    }
    file_bar.end();
    commit(&staged)?;
    Ok(out)
}

fn check_path(path: &Path) -> Result<bool, Error> {
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
            for &v in &patches.corner_vertex[p][..corners(patches, p)] {
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

fn corners(patches: &crate::Patches, p: usize) -> usize {
    if patches.is_quad[p] {
        4
    } else {
        3
    }
}

/// One object's mesh: vertices (world), their normals, light and triangles.
#[derive(Default)]
struct ObjectBake {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    radiosity: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
}

fn object_meshes(engine: &Engine) -> Vec<ObjectBake> {
    let world = engine.world();
    let p = &world.patches;
    let light = engine.vertex_colors();
    let mut local = vec![u32::MAX; p.shading_vertex_count];
    (0..p.object_ranges.len())
        .map(|o| {
            let mut m = ObjectBake::default();
            let to_world = p.world_from_local[o];
            let flip = to_world.matrix3.determinant() < 0.0;
            for i in p.range(o) {
                let n = corners(p, i);
                let mut ids = [0u32; 4];
                for k in 0..n {
                    let v = p.corner_vertex[i][k] as usize;
                    if local[v] == u32::MAX {
                        local[v] = m.positions.len() as u32;
                        m.positions.push(to_world.transform_point3(p.corners[i][k]));
                        m.normals.push(p.normal[i]);
                        m.radiosity.push(light[v]);
                    }
                    ids[k] = local[v];
                }
                let mut push = |a: u32, b: u32, c: u32| {
                    m.triangles.push(if flip { [a, c, b] } else { [a, b, c] });
                };
                push(ids[0], ids[1], ids[2]);
                if n == 4 {
                    push(ids[0], ids[2], ids[3]);
                }
            }
            m
        })
        .collect()
}

/// The glTF JSON and binary buffer of the engine's current state.
fn build(engine: &Engine, exposure: f32, bin_uri: Option<&str>) -> (Value, Vec<u8>, Baked) {
    let world = engine.world();
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut meshes = Vec::new();
    let mut nodes = Vec::new();
    let mut baked = Baked {
        path: PathBuf::new(),
        time: world.time,
        exposure,
        meshes: 0,
        vertices: 0,
        triangles: 0,
    };
    // A buffer view of `bytes` (4-byte aligned, as every element here is 4 bytes).
    let mut view = |bytes: &[u8], target: u32| -> usize {
        let offset = bin.len();
        bin.extend_from_slice(bytes);
        views.push(
            json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len(), "target": target}),
        );
        views.len() - 1
    };
    let vec3s = |v: &[Vec3]| -> Vec<u8> {
        v.iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .collect()
    };
    const ARRAY_BUFFER: u32 = 34962;
    const ELEMENT_ARRAY_BUFFER: u32 = 34963;
    const FLOAT: u32 = 5126;
    const UNSIGNED_INT: u32 = 5125;
    for (o, m) in object_meshes(engine).into_iter().enumerate() {
        if m.triangles.is_empty() {
            continue;
        }
        let obj = &world.scene.objects[o];
        let (lo, hi) = m
            .positions
            .iter()
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| {
                (a.min(*p), b.max(*p))
            });
        let colours: Vec<Vec3> = m
            .radiosity
            .iter()
            .map(|b| (*b * (exposure / std::f32::consts::PI)).clamp(Vec3::ZERO, Vec3::ONE))
            .collect();
        let n = m.positions.len();
        let mut accessor = |view: usize, count: usize, kind: &str, component: u32, extra: Value| {
            let mut a = json!({"bufferView": view, "componentType": component, "count": count, "type": kind});
            if let (Value::Object(a), Value::Object(extra)) = (&mut a, extra) {
                a.extend(extra);
            }
            accessors.push(a);
            accessors.len() - 1
        };
        let position = accessor(
            view(&vec3s(&m.positions), ARRAY_BUFFER),
            n,
            "VEC3",
            FLOAT,
            json!({"min": lo.to_array(), "max": hi.to_array()}),
        );
        let normal = accessor(
            view(&vec3s(&m.normals), ARRAY_BUFFER),
            n,
            "VEC3",
            FLOAT,
            json!({}),
        );
        let colour = accessor(
            view(&vec3s(&colours), ARRAY_BUFFER),
            n,
            "VEC3",
            FLOAT,
            json!({}),
        );
        let radiosity = accessor(
            view(&vec3s(&m.radiosity), ARRAY_BUFFER),
            n,
            "VEC3",
            FLOAT,
            json!({}),
        );
        let index_bytes: Vec<u8> = m
            .triangles
            .iter()
            .flatten()
            .flat_map(|i| i.to_le_bytes())
            .collect();
        let indices = accessor(
            view(&index_bytes, ELEMENT_ARRAY_BUFFER),
            3 * m.triangles.len(),
            "SCALAR",
            UNSIGNED_INT,
            json!({}),
        );
        meshes.push(json!({
            "name": obj.name,
            "primitives": [{
                "attributes": {"POSITION": position, "NORMAL": normal, "COLOR_0": colour, "_RADIOSITY": radiosity},
                "indices": indices,
                "material": 0,
                "mode": 4,
            }],
        }));
        nodes.push(json!({
            "name": obj.name,
            "mesh": meshes.len() - 1,
            "extras": {"shrad_role": world.patches.object_role[o].name(), "shrad_object": o},
        }));
        baked.meshes += 1;
        baked.vertices += n;
        baked.triangles += m.triangles.len();
    }
    let mut buffer = json!({"byteLength": bin.len()});
    if let Some(uri) = bin_uri {
        buffer["uri"] = json!(uri);
    }
    let root = json!({
        "asset": {
            "version": "2.0",
            "generator": concat!("shrad ", env!("CARGO_PKG_VERSION"), " bake"),
            "extras": {"shrad": {
                "source": world.scene.source,
                "time": world.time,
                "solver": engine.solver_choice().name(),
                "exposure": exposure,
                "COLOR_0": "clamp(exposure * B / pi, 0, 1), linear RGB",
                "_RADIOSITY": "B, W/m^2, linear RGB, unclamped",
            }},
        },
        "extensionsUsed": ["KHR_materials_unlit"],
        "materials": [{
            "name": "shrad baked light (unlit)",
            "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_unlit": {}},
        }],
        "scene": 0,
        "scenes": [{"name": world.scene.source, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [buffer],
    });
    (root, bin, baked)
}

/// Write the engine's current state (no stepping) to `path`: `.glb`, or `.gltf` with its
/// buffer in a `.bin` of the same name beside it. `exposure` scales `COLOR_0` (`None`:
/// [`auto_exposure`]). The file (and its `.bin`) is written whole or not at all.
pub fn write_gltf(engine: &Engine, path: &Path, exposure: Option<f32>) -> Result<Baked, Error> {
    let mut staged = Vec::new();
    let baked =
        stage_gltf(engine, path, exposure, &mut staged).inspect_err(|_| discard(&staged))?;
    commit(&staged)?;
    Ok(baked)
}

/// A file written under a staged name beside its destination, not yet renamed into place.
struct Staged {
    staged: PathBuf,
    dest: PathBuf,
}

/// The staged name of `dest`: hidden, in the same folder (so the final rename is atomic).
fn staged_path(dest: &Path) -> PathBuf {
    let name = dest
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    dest.with_file_name(format!(".{name}.staged-{}", std::process::id()))
}

/// Write `bytes` (each file whole, [`shrad_scene::write_atomic`]) to the staged name of
/// `dest` and add it to `staged`.
fn stage(dest: &Path, bytes: &[u8], staged: &mut Vec<Staged>) -> Result<(), Error> {
    let tmp = staged_path(dest);
    shrad_scene::write_atomic(&tmp, |t| {
        std::fs::write(t, bytes).map_err(|e| e.to_string())
    })
    .map_err(|e| Error::Output(dest.into(), e.message))?;
    staged.push(Staged {
        staged: tmp,
        dest: dest.to_path_buf(),
    });
    Ok(())
}

/// Remove every staged file (a bake that failed leaves nothing behind).
fn discard(staged: &[Staged]) {
    for s in staged {
        let _ = std::fs::remove_file(&s.staged);
    }
}

/// Rename every staged file into place, in order. When a rename fails (rare: each is in
/// its destination's folder), the files not yet renamed are removed, and so are those
/// already renamed: what was at their names before is gone, but no part of the sequence
/// stays.
fn commit(staged: &[Staged]) -> Result<(), Error> {
    for (i, s) in staged.iter().enumerate() {
        if let Err(e) = std::fs::rename(&s.staged, &s.dest) {
            discard(&staged[i..]);
            for done in &staged[..i] {
                let _ = std::fs::remove_file(&done.dest);
            }
            return Err(Error::Output(s.dest.clone(), e.to_string()));
        }
    }
    Ok(())
}

/// [`write_gltf`] to staged names (added to `staged`, the `.bin` before the `.gltf` that
/// names it), renamed into place by [`commit`].
fn stage_gltf(
    engine: &Engine,
    path: &Path,
    exposure: Option<f32>,
    staged: &mut Vec<Staged>,
) -> Result<Baked, Error> {
    let glb = check_path(path)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            return Err(Error::Output(
                path.into(),
                format!("directory {} does not exist", dir.display()),
            ));
        }
    }
    let exposure = match exposure {
        Some(e) if e.is_finite() && e > 0.0 => e,
        Some(e) => {
            return Err(Error::Invalid(format!(
                "exposure must be a positive number, got {e}"
            )))
        }
        None => auto_exposure(engine),
    };
    let bin_path = path.with_extension("bin");
    let bin_name = bin_path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let (root, bin, mut baked) = build(engine, exposure, (!glb).then_some(bin_name.as_str()));
    let json = serde_json::to_vec(&root).map_err(|e| Error::Output(path.into(), e.to_string()))?;
    if glb {
        let total = 28 + json.len().next_multiple_of(4) + bin.len();
        if u32::try_from(total).is_err() {
            return Err(Error::Output(
                path.into(),
                format!("{total} bytes is more than a GLB can hold (4 GiB)"),
            ));
        }
        let container = gltf::Glb {
            header: gltf::binary::Header {
                magic: *b"glTF",
                version: 2,
                length: 0, // computed by to_vec
            },
            json: json.into(),
            bin: Some(bin.into()),
        };
        let bytes = container
            .to_vec()
            .map_err(|e| Error::Output(path.into(), e.to_string()))?;
        stage(path, &bytes, staged)?;
    } else {
        stage(&bin_path, &bin, staged)?;
        stage(path, &json, staged)?;
    }
    baked.path = path.to_path_buf();
    Ok(baked)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::PatchSizing;

    fn engine() -> Engine {
        let mut e = Engine::new(
            shrad_scene::cornell_box(),
            PatchSizing::Count(600),
            shrad_vis::Backend::Auto,
            SolverChoice::preset("reference", "fast").unwrap(),
        )
        .unwrap();
        e.step();
        e
    }

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("shrad-bake-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn the_glb_holds_the_light_per_vertex() {
        let e = engine();
        let d = dir("glb");
        let path = d.join("cornell.glb");
        let baked = write_gltf(&e, &path, Some(2.0)).unwrap();
        assert_eq!(baked.meshes, e.world().scene.objects.len());
        let (doc, buffers, _) = gltf::import(&path).unwrap();
        assert_eq!(
            doc.extensions_used().collect::<Vec<_>>(),
            ["KHR_materials_unlit"]
        );
        let mut vertices = 0;
        let mut sum_b = Vec3::ZERO;
        for mesh in doc.meshes() {
            for prim in mesh.primitives() {
                let r = prim.reader(|b| Some(&buffers[b.index()]));
                let pos: Vec<[f32; 3]> = r.read_positions().unwrap().collect();
                let colours: Vec<[f32; 3]> = r.read_colors(0).unwrap().into_rgb_f32().collect();
                assert_eq!(pos.len(), colours.len());
                assert!(colours.iter().flatten().all(|c| (0.0..=1.0).contains(c)));
                let radiosity = prim
                    .attributes()
                    .find(|(s, _)| *s == gltf::Semantic::Extras("RADIOSITY".into()))
                    .map(|(_, a)| a)
                    .expect("_RADIOSITY");
                assert_eq!(radiosity.count(), pos.len());
                let idx: Vec<u32> = r.read_indices().unwrap().into_u32().collect();
                assert!(idx.iter().all(|&i| (i as usize) < pos.len()));
                vertices += pos.len();
                let view = radiosity.view().unwrap();
                let bytes =
                    &buffers[view.buffer().index()][view.offset()..view.offset() + view.length()];
                for c in bytes.chunks_exact(12) {
                    let f = |k: usize| f32::from_le_bytes(c[4 * k..4 * k + 4].try_into().unwrap());
                    sum_b += Vec3::new(f(0), f(1), f(2));
                }
            }
        }
        assert_eq!(vertices, baked.vertices);
        // Every shading vertex once, with the engine's radiosity there.
        assert_eq!(vertices, e.world().patches.shading_vertex_count);
        let want: Vec3 = e.vertex_colors().iter().sum();
        assert!(
            (sum_b - want).length() <= 1e-4 * want.length(),
            "{sum_b} vs {want}"
        );
    }

    /// The Cornell box with its short block sliding along +x over one second.
    fn animated_engine() -> Engine {
        use shrad_scene::{Animation, Keyframe};
        let mut scene = shrad_scene::cornell_box();
        let block = scene
            .objects
            .iter_mut()
            .find(|o| o.name == "short_block")
            .unwrap();
        let key = |time, x| Keyframe {
            time,
            translation: Vec3::new(x, 0.0, 0.0),
            rotation: glam::Quat::IDENTITY,
        };
        block.animation = Some(Animation {
            keys: vec![key(0.0, 0.0), key(1.0, 60.0)],
            ..Default::default()
        });
        Engine::new(
            scene,
            PatchSizing::Count(400),
            shrad_vis::Backend::Auto,
            SolverChoice::preset("reference", "fast").unwrap(),
        )
        .unwrap()
    }

    fn entries(d: &Path) -> Vec<String> {
        let mut v: Vec<String> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_sequence_that_fails_partway_leaves_no_file_of_it() {
        let mut e = animated_engine();
        assert!(e.world().scene.duration() > 0.0);
        let d = dir("partway");
        let path = d.join("out.glb");
        let options = BakeOptions {
            frames: Some(3),
            passes: 1,
            ..Default::default()
        };
        // Frame 1 cannot be written: a folder holds its staged name.
        let blocker = staged_path(&frame_path(&path, 1));
        std::fs::create_dir(&blocker).unwrap();
        let err = bake(&mut e, &path, &options).unwrap_err().to_string();
        assert!(err.contains("out_0001.glb"), "{err}");
        let blocker_name = blocker.file_name().unwrap().to_string_lossy().into_owned();
        assert_eq!(entries(&d), [blocker_name], "frame 0 was left behind");
        std::fs::remove_dir(&blocker).unwrap();

        // Frame 2 cannot be renamed into place (a folder has its name): frames 0 and 1,
        // renamed already, are removed again.
        let last = frame_path(&path, 2);
        std::fs::create_dir(&last).unwrap();
        let err = bake(&mut e, &path, &options).unwrap_err().to_string();
        assert!(err.contains("out_0002.glb"), "{err}");
        assert_eq!(entries(&d), ["out_0002.glb"], "part of the sequence stayed");
        std::fs::remove_dir(&last).unwrap();

        // Nothing in the way: the whole sequence, and no staged file.
        let baked = bake(&mut e, &path, &options).unwrap();
        assert_eq!(baked.len(), 3);
        assert_eq!(
            entries(&d),
            ["out_0000.glb", "out_0001.glb", "out_0002.glb"]
        );
        assert!(gltf::import(frame_path(&path, 2)).is_ok());
    }

    #[test]
    fn gltf_with_bin_and_bad_paths() {
        let mut e = engine();
        let d = dir("gltf");
        let path = d.join("c.gltf");
        let frames = e.frames();
        let baked = bake(
            &mut e,
            &path,
            &BakeOptions {
                passes: 0,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(
            e.frames(),
            frames,
            "0 passes: the state as it is, not solved again"
        );
        assert!(d.join("c.bin").is_file() && baked[0].exposure > 0.0);
        assert!(gltf::import(&path).is_ok());
        let err = write_gltf(&e, &d.join("c.png"), None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("c.png") && err.contains(".glb"), "{err}");
        let err = write_gltf(&e, &d.join("no/such/dir/c.glb"), None)
            .unwrap_err()
            .to_string();
        assert!(err.contains("does not exist"), "{err}");
        let static_frames = BakeOptions {
            frames: Some(3),
            ..Default::default()
        };
        assert!(bake(&mut e, &path, &static_frames)
            .unwrap_err()
            .to_string()
            .contains("not animated"));
        assert!(write_gltf(&e, &path, Some(f32::NAN)).is_err());
        assert_eq!(
            frame_path(Path::new("a/out.glb"), 7),
            Path::new("a/out_0007.glb")
        );
    }
}
