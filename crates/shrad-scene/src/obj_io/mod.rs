//! Wavefront OBJ + MTL import and export.
//!
//! Import: each model (`o` / `g`, split further by `usemtl`) becomes one object in world
//! space (identity transform), faces triangulated; `Kd` is the reflectance, `Ke` the emitted
//! radiance, `map_Kd` the base colour texture; `map_d` cuts the surface and `d` / `Tr` may
//! leave it out (`maps`). OBJ has no roles: they are inferred. Export: world-space
//! vertices, one `o` per object, one material per object with `Kd` and `Ke`.

mod maps;

use std::cell::RefCell;
use std::collections::{HashMap, HashSet};
use std::fmt::Write as _;
use std::panic::AssertUnwindSafe;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};

use crate::{Material, Mesh, Object, Scene, SceneError};
use maps::{Alpha, Cutouts, Maps};

/// Read an OBJ file (and the MTL files it names) into a scene, no role inference or validation.
pub(crate) fn read(path: &Path) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    // tobj reads lines of text: a byte that is not UTF-8 was "read error", with no line.
    let text = std::str::from_utf8(&bytes).map_err(|e| {
        let line = 1 + bytes[..e.valid_up_to()]
            .iter()
            .filter(|&&b| b == b'\n')
            .count();
        SceneError::invalid(path, format!("invalid OBJ: line {line}: not UTF-8 text"))
    })?;
    check_face_indices(text).map_err(|m| SceneError::invalid(path, format!("invalid OBJ: {m}")))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    let parsed = parse(path, dir, &bytes)?;
    let mut scene = Scene {
        source: path.display().to_string(),
        ..Default::default()
    };
    let materials = materials_or_default(path, parsed.materials, &parsed.problems, &mut scene)?;
    if parsed.problems.is_empty() {
        warn_unknown_materials(path, text, &materials, &mut scene.warnings);
    }
    let lib_dirs = parsed
        .libraries
        .into_iter()
        .filter_map(|k| k.parent().map(Path::to_path_buf))
        .chain([dir.to_path_buf()])
        .collect();
    let mut maps = Maps::new(path, lib_dirs);
    let mut seen = HashMap::<String, usize>::new();
    let (mut cutouts, mut partly_warned) = (Cutouts::default(), HashSet::new());
    for (mi, model) in parsed.models.iter().enumerate() {
        if model.mesh.indices.is_empty() {
            continue;
        }
        let (material, alpha) = model_material(model, &materials, &mut maps, &mut scene.warnings);
        let base = if model.name.is_empty() {
            format!("object{mi}")
        } else {
            model.name.clone()
        };
        let name = unique_name(&mut seen, base);
        let mat_name = model
            .mesh
            .material_id
            .and_then(|i| materials.get(i))
            .map_or("", |m| m.name.as_str());
        match &alpha.dissolve {
            Some(d) if d.d <= 0.0 => {
                scene.warnings.push(format!(
                    "{}: object '{name}' skipped (it neither reflects nor blocks light): material '{mat_name}' is fully transparent ({})",
                    path.display(),
                    d.said
                ));
                continue;
            }
            Some(d) if d.d < 1.0 && partly_warned.insert(mat_name.to_string()) => {
                scene.warnings.push(format!(
                    "{}: material '{mat_name}' is partly transparent ({}): transparency is not represented, the surface is treated as opaque",
                    path.display(),
                    d.said
                ));
            }
            _ => {}
        }
        let textured = material.base_color_texture.is_some();
        let mut object = model_object(path, model, name, material, &alpha, &mut scene.warnings);
        if let Some(map) = alpha.map.as_ref().filter(|_| !object.mesh.uvs.is_empty()) {
            if !cutouts.apply(path, &mut object, mat_name, map, &mut scene.warnings) {
                continue;
            }
        }
        if !textured {
            // Texture coordinates read for `map_d` alone.
            object.mesh.uvs.clear();
        }
        scene.objects.push(object);
    }
    Ok(scene)
}

/// What tobj made of the file.
struct Parsed {
    models: Vec<tobj::Model>,
    materials: Result<Vec<tobj::Material>, tobj::LoadError>,
    problems: Vec<MtlProblem>,
    /// The material libraries read.
    libraries: Vec<PathBuf>,
}

fn parse(path: &Path, dir: &Path, bytes: &[u8]) -> Result<Parsed, SceneError> {
    let opts = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let problems = RefCell::new(Vec::<MtlProblem>::new());
    let seen_libs = RefCell::new(HashMap::<PathBuf, Result<(), tobj::LoadError>>::new());
    let loaded = std::panic::catch_unwind(AssertUnwindSafe(|| {
        tobj::load_obj_buf(&mut &bytes[..], &opts, |mtl| {
            load_mtl_once(dir, mtl, &problems, &seen_libs)
        })
    }))
    .map_err(|_| SceneError::invalid(path, "malformed OBJ or MTL (the reader gave up on it)"))?;
    let (models, materials) =
        loaded.map_err(|e| SceneError::invalid(path, format!("invalid OBJ: {e}")))?;
    Ok(Parsed {
        models,
        materials,
        problems: problems.into_inner(),
        libraries: seen_libs.into_inner().into_keys().collect(),
    })
}

/// The materials, or none with a warning when the libraries could not be loaded; an
/// invalid library is an error naming it.
fn materials_or_default(
    path: &Path,
    materials: Result<Vec<tobj::Material>, tobj::LoadError>,
    problems: &[MtlProblem],
    scene: &mut Scene,
) -> Result<Vec<tobj::Material>, SceneError> {
    if let Some(MtlProblem::Invalid(file, m)) = problems
        .iter()
        .find(|p| matches!(p, MtlProblem::Invalid(..)))
    {
        return Err(SceneError::invalid(
            file,
            format!("{m} (material library of {})", path.display()),
        ));
    }
    match materials {
        Ok(m) => Ok(m),
        Err(e) => {
            let why: Vec<String> = problems
                .iter()
                .map(|p| match p {
                    MtlProblem::Missing(m) | MtlProblem::Invalid(_, m) => m.clone(),
                })
                .collect();
            let why = if why.is_empty() {
                e.to_string()
            } else {
                why.join("; ")
            };
            scene.warnings.push(format!(
                "{}: material library not loaded ({why}); using the default material",
                path.display()
            ));
            Ok(Vec::new())
        }
    }
}

/// A warning for each material a `usemtl` names that no library read defines (tobj gives
/// its faces no material, silently): a misspelt name, or a library that is not one.
fn warn_unknown_materials(
    path: &Path,
    text: &str,
    materials: &[tobj::Material],
    warnings: &mut Vec<String>,
) {
    let known: HashSet<&str> = materials.iter().map(|m| m.name.as_str()).collect();
    let mut warned = HashSet::new();
    for (ln, line) in text.lines().enumerate() {
        // As tobj reads it: the rest of the line, trimmed; an empty name changes nothing.
        let line = line.trim();
        if line.split_whitespace().next() != Some("usemtl") {
            continue;
        }
        let name = line.split_once(' ').map_or("", |(_, rest)| rest.trim());
        if !name.is_empty() && !known.contains(name) && warned.insert(name) {
            warnings.push(format!(
                "{}: line {}: usemtl '{name}' names no material of the libraries read ({} defined); its faces take the default material",
                path.display(),
                ln + 1,
                materials.len()
            ));
        }
    }
}

/// A model's material: its `Kd`, `Ke` and `map_Kd`, or the default; and its transparency
/// (`map_d`, `d` / `Tr`).
fn model_material(
    model: &tobj::Model,
    materials: &[tobj::Material],
    maps: &mut Maps,
    warnings: &mut Vec<String>,
) -> (Material, Alpha) {
    match model.mesh.material_id {
        Some(id) => match materials.get(id) {
            Some(mat) => (
                Material {
                    reflectance: mat
                        .diffuse
                        .map_or(Material::default().reflectance, Vec3::from),
                    emitted_radiance: mat.emissive.map_or(Vec3::ZERO, Vec3::from),
                    double_sided: false,
                    base_color_texture: mat
                        .diffuse_texture
                        .as_deref()
                        .and_then(|t| maps.colour(t, warnings)),
                    emissive_texture: None,
                },
                Alpha {
                    map: mat
                        .dissolve_texture
                        .as_deref()
                        .and_then(|t| maps.alpha(t, warnings)),
                    dissolve: maps::dissolve(mat),
                },
            ),
            None => (Material::default(), Alpha::default()),
        },
        None => {
            if !materials.is_empty() {
                warnings.push(format!(
                    "{}: object '{}' has no material; using the default",
                    maps.obj.display(),
                    model.name
                ));
            }
            (Material::default(), Alpha::default())
        }
    }
}

/// `base`, or `base.N` for its N-th repeat: `usemtl` inside one `o` splits it into several
/// models of the same name.
fn unique_name(seen: &mut HashMap<String, usize>, base: String) -> String {
    let count = seen.entry(base.clone()).or_insert(0);
    let name = if *count == 0 {
        base.clone()
    } else {
        format!("{base}.{count}")
    };
    *count += 1;
    name
}

/// One model as an object: its mesh, with texture coordinates when it has a texture or a
/// `map_d` (without them, the texture is averaged into the reflectance and `map_d` is not
/// read, with a warning).
fn model_object(
    path: &Path,
    model: &tobj::Model,
    name: String,
    mut material: Material,
    alpha: &Alpha,
    warnings: &mut Vec<String>,
) -> Object {
    let m = &model.mesh;
    let positions: Vec<Vec3> = m
        .positions
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    let triangles: Vec<[u32; 3]> = m
        .indices
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let mut mesh = Mesh::new(positions, triangles);
    let has_uvs = m.texcoords.len() == 2 * mesh.positions.len();
    if has_uvs && (material.base_color_texture.is_some() || alpha.map.is_some()) {
        // OBJ's v grows upwards from the image's bottom; glTF's (shrad's) downwards.
        mesh.uvs = vec![m
            .texcoords
            .chunks_exact(2)
            .map(|c| Vec2::new(c[0], 1.0 - c[1]))
            .collect()];
    }
    if let Some(t) = material.base_color_texture.as_ref().filter(|_| !has_uvs) {
        warnings.push(format!(
            "{}: object '{name}' has no texture coordinates: map_Kd averaged to one colour",
            path.display()
        ));
        material.reflectance *= t.image.mean();
        material.base_color_texture = None;
    }
    if let Some(t) = alpha.map.as_ref().filter(|_| !has_uvs) {
        warnings.push(format!(
            "{}: object '{name}' has no texture coordinates: map_d '{}' not read (the surface stays opaque)",
            path.display(),
            t.image.name
        ));
    }
    Object::new(name, mesh, material)
}

/// Check the face indices before tobj sees them: tobj turns a relative index reaching before
/// the first element, or a huge one, into a huge `usize` and then overflows on it
/// (`vt * 2 + 1`, `vn * 3 + 2`; found by fuzzing: `f 1/1/1 2/1/1 3/-11/1` with one `vt`
/// panics in debug builds). Rejects, naming the line, an index of a kind the file has (tobj
/// ignores texture and normal indices when there are no `vt` / `vn`) in a face of three or
/// more vertices (`f` or `l`: tobj goes by the count; points and lines are ignored) that is
/// relative beyond the elements so far or beyond the file's elements, or a vertex index 0.
/// A texture or normal index 0 stays allowed: tobj reads it as absent.
fn check_face_indices(text: &str) -> Result<(), String> {
    const KINDS: [(&str, &str); 3] = [("v", "vertex"), ("vt", "texture"), ("vn", "normal")];
    let mut total = [0usize; 3];
    for line in text.lines() {
        if let Some(k) = line
            .split_whitespace()
            .next()
            .and_then(|w| KINDS.iter().position(|(key, _)| *key == w))
        {
            total[k] += 1;
        }
    }
    let mut so_far = [0usize; 3];
    for (ln, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        if let Some(k) = KINDS.iter().position(|(w, _)| *w == key) {
            check_element_numbers(ln, key, words)?;
            so_far[k] += 1;
            continue;
        }
        if key == "f" && !line.trim_end().ends_with('\\') {
            check_face_shape(ln, words.clone())?;
        }
        // tobj refuses it as "material parse error", with no line.
        if key == "usemtl" && words.clone().next().is_none() {
            return Err(format!("line {}: usemtl without a material name", ln + 1));
        }
        if !matches!(key, "f" | "l") || words.clone().count() < 3 {
            continue;
        }
        for vertex in words {
            for (k, part) in vertex.split('/').take(3).enumerate() {
                let Ok(i) = part.parse::<isize>() else {
                    continue;
                };
                if total[k] == 0 {
                    continue;
                }
                let ok = if i < 0 {
                    i.unsigned_abs() <= so_far[k]
                } else {
                    (i >= 1 || k > 0) && i.unsigned_abs() <= total[k]
                };
                if !ok {
                    return Err(format!(
                        "line {}: face {} index {i} out of bounds ({} in the file{})",
                        ln + 1,
                        KINDS[k].1,
                        total[k],
                        if i < 0 {
                            format!(", {} before this line", so_far[k])
                        } else {
                            String::new()
                        }
                    ));
                }
            }
        }
    }
    Ok(())
}

/// A `v`, `vt` or `vn` line (line `ln`, 0-based, its numbers `words`) starts with as many
/// numbers as its kind needs: tobj said "position parse error" of `v 0 0` or `v 0 0 x`,
/// with no line.
fn check_element_numbers<'a>(
    ln: usize,
    key: &str,
    mut words: impl Iterator<Item = &'a str>,
) -> Result<(), String> {
    let (needs, what) = match key {
        "v" => (3, "a vertex needs 3 coordinates"),
        "vn" => (3, "a normal needs 3 components"),
        _ => (2, "a texture coordinate needs u and v"),
    };
    for k in 0..needs {
        match words.next() {
            Some(w) if w.parse::<f64>().is_ok() => {}
            Some(w) => {
                return Err(format!(
                    "line {}: '{key}' number {} is '{w}', not a number",
                    ln + 1,
                    k + 1
                ))
            }
            None => return Err(format!("line {}: {what}, this one has {k}", ln + 1)),
        }
    }
    Ok(())
}

/// A face (line `ln`, 0-based, its vertices `words`) of at least 3 vertices, each starting
/// with an index: tobj dropped a face of two silently (a file of such faces was "a scene with
/// no objects") and said "face parse error" of a word that is not one, with no line. (A line
/// continued with `\` is left to tobj.)
fn check_face_shape<'a>(
    ln: usize,
    words: impl Iterator<Item = &'a str> + Clone,
) -> Result<(), String> {
    let n = words.clone().count();
    if n < 3 {
        return Err(format!(
            "line {}: a face needs at least 3 vertices, this one has {n}",
            ln + 1
        ));
    }
    for w in words {
        let index = w.split('/').next().unwrap_or("");
        if index.parse::<isize>().is_err() {
            return Err(format!(
                "line {}: face vertex '{w}' does not start with a vertex index",
                ln + 1
            ));
        }
    }
    Ok(())
}

enum MtlProblem {
    /// The library cannot be read: a warning, default materials.
    Missing(String),
    /// The library is malformed: an error naming it.
    Invalid(PathBuf, String),
}

/// [`load_mtl`], but a library named again (`mtllib` repeated, or another spelling of the
/// same file) is not read again: it adds nothing (tobj would append a second copy of every
/// material), and re-reading it made a small OBJ with thousands of `mtllib` lines cost time
/// and memory quadratic in its size (found by fuzzing: 65 KB took > 30 s and ~1 GB).
fn load_mtl_once(
    dir: &Path,
    name: &Path,
    problems: &RefCell<Vec<MtlProblem>>,
    seen: &RefCell<HashMap<PathBuf, Result<(), tobj::LoadError>>>,
) -> tobj::MTLLoadResult {
    let joined = dir.join(name);
    let key = std::fs::canonicalize(&joined).unwrap_or(joined);
    if let Some(first) = seen.borrow().get(&key) {
        return first.map(|()| Default::default());
    }
    let r = load_mtl(dir, name, problems);
    seen.borrow_mut()
        .insert(key, r.as_ref().map(|_| ()).map_err(|e| *e));
    r
}

/// Load one MTL library named by the OBJ. Colour lines with a single value (`Kd 0.5`, which
/// the MTL format allows and means grey) are expanded to three values first; malformed ones
/// are recorded as errors with their line.
fn load_mtl(dir: &Path, name: &Path, problems: &RefCell<Vec<MtlProblem>>) -> tobj::MTLLoadResult {
    let file = dir.join(name);
    // Only a regular file is read: `mtllib /dev/zero` read until memory ran out, and a
    // pipe never ended.
    if let Some(m) = std::fs::metadata(&file).ok().filter(|m| !m.is_file()) {
        let what = if m.is_dir() {
            "a folder"
        } else {
            "not a regular file (a device or a pipe)"
        };
        problems.borrow_mut().push(MtlProblem::Missing(format!(
            "cannot read '{}': it is {what}",
            file.display()
        )));
        return Err(tobj::LoadError::OpenFileFailed);
    }
    let text = match std::fs::read_to_string(&file) {
        Ok(t) => t,
        Err(e) => {
            problems.borrow_mut().push(MtlProblem::Missing(format!(
                "cannot read '{}': {e}",
                file.display()
            )));
            return Err(tobj::LoadError::OpenFileFailed);
        }
    };
    let mut fixed = String::with_capacity(text.len() + 64);
    for (ln, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            let values: Option<Vec<f32>> = words.map(|w| w.parse().ok()).collect();
            match values.as_deref() {
                Some([v]) => {
                    let _ = writeln!(fixed, "{key} {v} {v} {v}");
                    continue;
                }
                Some([_, _, _]) => {}
                _ => {
                    problems.borrow_mut().push(MtlProblem::Invalid(
                        file.clone(),
                        format!("line {}: '{}' needs 1 or 3 numbers", ln + 1, line.trim()),
                    ));
                    return Err(tobj::LoadError::MaterialParseError);
                }
            }
        }
        fixed.push_str(line);
        fixed.push('\n');
    }
    tobj::load_mtl_buf(&mut fixed.as_bytes()).inspect_err(|e| {
        problems.borrow_mut().push(MtlProblem::Invalid(
            file.clone(),
            format!("invalid MTL: {e}"),
        ));
    })
}

fn clean_name(s: &str) -> String {
    let s: String = s
        .chars()
        .map(|c| if c.is_whitespace() { '_' } else { c })
        .collect();
    if s.is_empty() {
        "unnamed".into()
    } else {
        s
    }
}

/// Write the scene as OBJ with an MTL file beside it (same name, `.mtl`): world-space
/// vertices at rest, one `o` per object, one material per object with `Kd` (reflectance) and
/// `Ke` (emitted radiance). Roles, double-sidedness, animation and the camera are not
/// written (OBJ has no place for them; roles are inferred again on load); neither are
/// textures, texture coordinates and vertex colours: `Kd` is the material's factor alone.
pub fn write_obj(scene: &Scene, obj_path: &Path) -> Result<(), SceneError> {
    let mtl_path = obj_path.with_extension("mtl");
    let mtl_name = mtl_path
        .file_name()
        .ok_or_else(|| SceneError::invalid(obj_path, "not a file path"))?
        .to_string_lossy()
        .into_owned();
    let mut obj = String::new();
    let mut mtl = String::new();
    let _ = writeln!(obj, "# written by shrad from {}", scene.source);
    let _ = writeln!(obj, "mtllib {mtl_name}");
    let _ = writeln!(mtl, "# written by shrad from {}", scene.source);
    let mut base = 1usize;
    for (i, o) in scene.objects.iter().enumerate() {
        let name = clean_name(&o.name);
        let mat_name = format!("m{i}_{name}");
        let m = &o.material;
        let (r, e) = (m.reflectance, m.emitted_radiance);
        let _ = writeln!(mtl, "\nnewmtl {mat_name}");
        let _ = writeln!(mtl, "Kd {} {} {}", r.x, r.y, r.z);
        let _ = writeln!(mtl, "Ke {} {} {}", e.x, e.y, e.z);
        let _ = writeln!(mtl, "Ka 0 0 0\nKs 0 0 0\nillum 1");
        let _ = writeln!(obj, "\no {name}");
        if let Some(role) = o.role {
            let _ = writeln!(obj, "# shrad role: {role}");
        }
        let _ = writeln!(obj, "usemtl {mat_name}");
        for p in &o.mesh.positions {
            let p = o.world_from_object.transform_point3(*p);
            let _ = writeln!(obj, "v {} {} {}", p.x, p.y, p.z);
        }
        // Baked into world space, a mirrored object's (negative determinant) triangles would
        // be clockwise from their front: flip them so the front stays front.
        let mirrored = o.world_from_object.matrix3.determinant() < 0.0;
        for t in &o.mesh.triangles {
            let [a, b, c] = t.map(|v| v as usize + base);
            let (b, c) = if mirrored { (c, b) } else { (b, c) };
            let _ = writeln!(obj, "f {a} {b} {c}");
        }
        base += o.mesh.positions.len();
    }
    let write = |path: &Path, text: &str| {
        crate::write_atomic(path, |tmp| {
            std::fs::write(tmp, text).map_err(|e| e.to_string())
        })
    };
    write(&mtl_path, &mtl)?;
    write(obj_path, &obj)?;
    Ok(())
}
